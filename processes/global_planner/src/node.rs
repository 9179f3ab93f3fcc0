//! The global planner process: answers `PlanRequest`s on the newest global map (the
//! mapper's newest full map with its newest changes, each history 1) with a
//! `PlanResponse` of the same request id, written in place.
//!
//! `use_detections = 0` plans on the static cells only (the map's detected cells are
//! read as free), as the seed does for the first path of a leg. Every request is bounded
//! twice: by its expansion budget (deterministic) and by its wall-clock timeout, checked
//! here through the planner's stop callback, so no request hangs.
//!
//! Adapter only: the search is [`crate::Planner`]; the loop around it is the node
//! runtime's (`aisle_node::run`).

use crate::{DockKind, DockSite, Placed, PlanErrorKind, PlanRequest, Planner, PlannerConfig};
use aisle_bus::{NodeArgs, NodeError, Stamp, clock};
use aisle_geometry::{Footprint, OCCUPIED_DETECTED, Pose2};
use aisle_messages::{
    DockMove, GlobalGrid, GlobalMapCopy, GridCopy, MAX_PATH_POSES, MapChanges, NodeKind,
    PlanRequest as PlanRequestMsg, PlanResponse, PlanStatus, RectMsg, StageStatus, Topic, topics,
};
use aisle_node::{Cycle, Io, RunContext, Stage};
use std::time::Duration;

/// Budget when a request leaves `max_expansions` at 0; the planner raises it with the
/// reachable area (`expansions_per_reachable_cell`).
pub const DEFAULT_MAX_EXPANSIONS: u32 = 100_000;
/// Wall-clock bound when a request leaves `timeout_ms` at 0.
pub const DEFAULT_TIMEOUT_MS: u32 = 5_000;

/// The static layer of a cell (detections read as free).
fn static_cell(c: u8) -> u8 {
    if c == OCCUPIED_DETECTED { 0 } else { c }
}

/// Brings `map` to the newest full map and changes (either `None` when nothing new came),
/// and `static_map` with it; returns whether `map` holds a valid map. A full map that
/// is not a valid grid, or changes that do not fit the held map, are left out (logged)
/// and what was held is kept.
fn update(
    map: &mut GlobalMapCopy,
    static_map: &mut GridCopy,
    full: Option<&GlobalGrid>,
    changes: Option<&MapChanges>,
) -> bool {
    match map.update(full, changes) {
        Ok(u) => {
            if let (Some(e), Some(f)) = (&u.refused, full) {
                tracing::warn!(
                    "global_planner: global map version {} refused: {e}",
                    f.version
                );
            }
            if u.full {
                static_map.copy_mapped(map.grid(), static_cell);
            } else if let (Some(n), Some(c)) = (u.changes, changes) {
                let cells = static_map.cells_mut();
                for e in &c.changes[..n] {
                    cells[e.index as usize] = static_cell(e.value);
                }
            }
        }
        Err(e) => tracing::warn!("global_planner: global map changes refused: {e}"),
    }
    map.view().is_ok()
}

fn status_of(kind: &PlanErrorKind) -> PlanStatus {
    match kind {
        PlanErrorKind::InvalidInput(_) => PlanStatus::InvalidRequest,
        PlanErrorKind::StartOccupied => PlanStatus::StartOccupied,
        PlanErrorKind::GoalOccupied => PlanStatus::GoalOccupied,
        PlanErrorKind::StartOutsideMap => PlanStatus::StartOutsideMap,
        PlanErrorKind::GoalOutsideMap => PlanStatus::GoalOutsideMap,
        // `AboveBound` stays inside a docked plan (a side that lost); listed for totality.
        PlanErrorKind::NoPath | PlanErrorKind::ValidationFailed | PlanErrorKind::AboveBound => {
            PlanStatus::NoPath
        }
        PlanErrorKind::BudgetExhausted | PlanErrorKind::Stopped => PlanStatus::Timeout,
        PlanErrorKind::NoOpenSide => PlanStatus::NoOpenSide,
    }
}

/// The planner as a stage: one cycle per request, in arrival order, on the newest map.
pub struct PlannerStage {
    planner: Planner,
    /// The newest global map, and its static layer (detections cleared).
    map: GlobalMapCopy,
    static_map: GridCopy,
    /// A docking request's parts (reused).
    parts: Vec<Placed>,
}

impl PlannerStage {
    /// Loads `planner.toml` from `config_dir`.
    pub fn new(config_dir: &std::path::Path) -> Result<PlannerStage, NodeError> {
        let path = config_dir.join("planner.toml");
        let cfg = aisle_config::load::<PlannerConfig>(&path)
            .map_err(|e| NodeError::setup("global_planner", e))?;
        let planner = Planner::new(cfg).map_err(|e| NodeError::setup("global_planner", e))?;
        Ok(PlannerStage {
            planner,
            map: GlobalMapCopy::default(),
            static_map: GridCopy::default(),
            parts: Vec::with_capacity(aisle_messages::MAX_DOCK_PARTS),
        })
    }

    /// The request as the library takes it, with the defaults for unset bounds.
    fn request_of(req: &PlanRequestMsg) -> PlanRequest {
        PlanRequest {
            start: Pose2::from(req.start),
            goal: Pose2::from(req.goal),
            footprint: Footprint::new(req.footprint_length, req.footprint_width),
            margin: req.margin,
            max_expansions: if req.max_expansions == 0 {
                DEFAULT_MAX_EXPANSIONS
            } else {
                req.max_expansions
            },
            fixed_budget: req.fixed_budget != 0,
        }
    }
}

/// The body and parts of a docking request, in `parts` (reused); `None` for a plain one.
fn site_of<'p>(req: &PlanRequestMsg, parts: &'p mut Vec<Placed>) -> Option<DockSite<'p>> {
    let kind = match DockMove::from_u32(req.dock)? {
        DockMove::None => return None,
        DockMove::Dock => DockKind::Dock,
        DockMove::Undock => DockKind::Undock,
    };
    let placed = |r: &RectMsg| Placed {
        pose: Pose2::from(r.pose),
        footprint: Footprint::new(r.length, r.width),
    };
    parts.clear();
    parts.extend(req.parts.iter().take_while(|r| r.valid != 0).map(placed));
    Some(DockSite {
        kind,
        body: placed(&req.body),
        parts,
        free_heading: req.free_heading != 0,
    })
}

fn fill_response(m: &mut PlanResponse, req: &PlanRequestMsg, result: &PlanResult, solve_ns: u64) {
    m.request_id = req.request_id;
    m.solve_ns = solve_ns;
    match result {
        Ok(plan) if plan.path.len() <= MAX_PATH_POSES => {
            m.status = PlanStatus::Ok as u32;
            m.straight = plan.straight as u32;
            m.split = plan.split as u32;
            m.expansions = plan.stats.expansions;
            m.path_length = plan.stats.path_length;
            m.len = plan.path.len() as u32;
            for (dst, p) in m.poses.iter_mut().zip(&plan.path) {
                *dst = (*p).into();
            }
        }
        Ok(plan) => {
            // Longer than a message holds: report it rather than truncate it.
            m.status = PlanStatus::InvalidRequest as u32;
            m.expansions = plan.stats.expansions;
        }
        Err(e) => {
            m.status = status_of(&e.kind) as u32;
            m.expansions = e.stats.expansions;
        }
    }
}

/// A plan as the response carries it: the path, its straight part, the search's stats.
struct Answer {
    path: Vec<aisle_geometry::PathPose>,
    straight: DockMove,
    split: usize,
    stats: crate::PlanStats,
}

type PlanResult = Result<Answer, crate::PlanError>;

impl Stage for PlannerStage {
    const KIND: NodeKind = NodeKind::GlobalPlanner;
    type Trigger = PlanRequestMsg;
    const TRIGGER: Topic<PlanRequestMsg> = topics::PLAN_REQUEST;
    const NEWEST_ONLY: bool = false;
    const ANNOUNCES_START: bool = true;

    /// Ready once there is a map to plan on.
    fn start(&mut self, io: &impl Io, _ctx: &RunContext) -> Result<(), NodeError> {
        loop {
            if let Some(m) =
                io.wait_for(topics::GLOBAL_MAP, Duration::from_millis(200), |_| true)?
                && update(
                    &mut self.map,
                    &mut self.static_map,
                    Some(&*m),
                    io.latest(topics::GLOBAL_MAP_CHANGES)?.as_deref(),
                )
            {
                // The static layer (first plans of a leg use it; replans ask for the
                // detections too) taken in before the first request (its distance tiles
                // are computed as searches read them), and the search's buffers made
                // resident (a fresh process faults them in).
                if let Ok(view) = self.static_map.view() {
                    self.planner.prepare(&view);
                    self.planner.warm_up(&view);
                }
                return Ok(());
            }
        }
    }

    fn process(&mut self, req: &PlanRequestMsg, io: &impl Io) -> Result<Cycle, NodeError> {
        let req = *req;
        update(
            &mut self.map,
            &mut self.static_map,
            io.latest(topics::GLOBAL_MAP)?.as_deref(),
            io.latest(topics::GLOBAL_MAP_CHANGES)?.as_deref(),
        );
        let started = clock::monotonic_ns();
        let timeout_ms = if req.timeout_ms == 0 {
            DEFAULT_TIMEOUT_MS
        } else {
            req.timeout_ms
        };
        let deadline = started + timeout_ms as u64 * 1_000_000;
        let request = Self::request_of(&req);
        let layer = if req.use_detections != 0 {
            self.map.grid()
        } else {
            &self.static_map
        };
        // Only valid grids are taken (`update`), so this holds from the first map on.
        let view = layer
            .view()
            .map_err(|e| NodeError::Protocol(format!("global_planner: map: {e}")))?;
        let mut stop = || {
            // Asked every few hundred expansions: a long search is not a hang.
            io.keep_alive();
            clock::monotonic_ns() > deadline
        };
        let result = match site_of(&req, &mut self.parts) {
            None => self
                .planner
                .plan_with_stop(&request, &view, &mut stop)
                .map(|p| Answer {
                    path: p.path,
                    straight: DockMove::None,
                    split: 0,
                    stats: p.stats,
                }),
            Some(site) => self
                .planner
                .plan_docked(&request, &site, &view, &mut stop)
                .map(|p| Answer {
                    path: p.path,
                    straight: match p.kind {
                        DockKind::Dock => DockMove::Dock,
                        DockKind::Undock => DockMove::Undock,
                    },
                    split: p.split,
                    stats: p.stats,
                }),
        };
        let solve_ns = clock::monotonic_ns() - started;
        io.publish(topics::PLAN_RESPONSE, Stamp::of(&req.header), |m| {
            fill_response(m, &req, &result, solve_ns)
        })?;
        match &result {
            Ok(plan) => tracing::info!(
                "global_planner: request {}: {:.2} m in {} poses, {} expansions, {:.1} ms{}{}{}",
                req.request_id,
                plan.stats.path_length,
                plan.path.len(),
                plan.stats.expansions,
                solve_ns as f64 / 1e6,
                match (plan.stats.from_goal, plan.stats.met) {
                    (true, true) => "; found from the goal's end, joining the start's search",
                    (true, false) => "; found from the goal's end",
                    (false, true) => "; joining the goal's search",
                    (false, false) => "",
                },
                match (plan.stats.start_relief, plan.stats.escaped) {
                    (Some(m), true) => format!("; the start is boxed in: {m:.3} m kept near it"),
                    (Some(m), false) => {
                        format!("; the start is inside the margin: {m:.3} m kept near it")
                    }
                    (None, _) => String::new(),
                },
                match plan.stats.goal_relief {
                    Some(m) => format!("; the goal is beside an obstacle: {m:.3} m kept near it"),
                    None => String::new(),
                }
            ),
            Err(e) => tracing::warn!("global_planner: request {}: {e}", req.request_id),
        }
        Ok(Cycle {
            status: StageStatus::Done,
            compute_ns: Some(solve_ns),
        })
    }
}

pub fn run(args: &NodeArgs) -> Result<(), NodeError> {
    let mut stage = PlannerStage::new(&args.config_dir)?;
    aisle_node::run(&mut stage, args)
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::OCCUPIED_STATIC;
    use aisle_messages::{CellChangeMsg, zeroed_box};

    #[test]
    fn the_map_and_its_static_layer_follow_the_full_map_and_its_changes() {
        let mut full = zeroed_box::<GlobalGrid>();
        (full.width, full.height, full.resolution, full.version) = (4, 2, 0.1, 3);
        full.cells[..8].copy_from_slice(&[1, 0, 2, 0, 0, 0, 0, 0]);
        let mut changes = zeroed_box::<MapChanges>();
        (changes.base_version, changes.version) = (3, 5);
        (changes.width, changes.height, changes.len) = (4, 2, 3);
        for (e, (index, value)) in
            changes
                .changes
                .iter_mut()
                .zip([(2, 0), (5, OCCUPIED_DETECTED), (7, OCCUPIED_STATIC)])
        {
            *e = CellChangeMsg {
                index,
                value,
                _pad: [0; 7],
            };
        }
        let (mut map, mut static_map) = (GlobalMapCopy::default(), GridCopy::default());
        assert!(!update(&mut map, &mut static_map, None, Some(&changes)));
        assert!(update(&mut map, &mut static_map, Some(&full), None));
        assert_eq!(static_map.view().unwrap().cells, &[1, 0, 0, 0, 0, 0, 0, 0]);
        assert!(update(&mut map, &mut static_map, None, Some(&changes)));
        assert_eq!(map.view().unwrap().cells, &[1, 0, 0, 0, 0, 2, 0, 1]);
        assert_eq!(static_map.view().unwrap().cells, &[1, 0, 0, 0, 0, 0, 0, 1]);
        // An invalid full map is left out; the held one stays.
        let mut bad = zeroed_box::<GlobalGrid>();
        bad.version = 9;
        assert!(update(&mut map, &mut static_map, Some(&bad), None));
        assert_eq!(map.version(), 5);
    }

    #[test]
    fn a_request_s_budget_is_the_default_and_grows_unless_it_says_otherwise() {
        let mut msg = zeroed_box::<PlanRequestMsg>();
        let req = PlannerStage::request_of(&msg);
        assert_eq!(req.max_expansions, DEFAULT_MAX_EXPANSIONS);
        assert!(!req.fixed_budget);
        (msg.max_expansions, msg.fixed_budget) = (5_000, 1);
        let req = PlannerStage::request_of(&msg);
        assert_eq!((req.max_expansions, req.fixed_budget), (5_000, true));
    }
}

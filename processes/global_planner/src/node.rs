//! The global planner process: answers `PlanRequest`s on the newest global map (history
//! 1, from the mapper) with a `PlanResponse` of the same request id, written in place.
//!
//! `use_detections = 0` plans on the static cells only (the map's detected cells are
//! read as free), as the seed does for the first path of a leg. Every request is bounded
//! twice: by its expansion budget (deterministic) and by its wall-clock timeout, checked
//! here through the planner's stop callback, so no request hangs.
//!
//! Adapter only: the search is [`crate::Planner`].

use crate::{PlanErrorKind, PlanRequest, Planner, PlannerConfig};
use aisle_bus::{Bus, NodeArgs, NodeError, Stamp, WaitOutcome, clock};
use aisle_geometry::{Footprint, OCCUPIED_DETECTED, Pose2};
use aisle_messages::{
    GridCopy, MAX_PATH_POSES, NodeKind, NodeState, OccupancyGrid, PlanRequest as PlanRequestMsg,
    PlanResponse, PlanStatus, services,
};
use std::time::Duration;

/// Budget when a request leaves `max_expansions` at 0.
pub const DEFAULT_MAX_EXPANSIONS: u32 = 100_000;
/// Wall-clock bound when a request leaves `timeout_ms` at 0.
pub const DEFAULT_TIMEOUT_MS: u32 = 5_000;

/// Takes `m` as the newest global map, with its static layer (detections cleared);
/// a grid that is not a valid map is ignored and the previous one kept.
fn update(map: &mut GridCopy, static_map: &mut GridCopy, m: &OccupancyGrid) -> bool {
    if m.view().is_err() {
        return false;
    }
    map.copy_from(m);
    static_map.copy_mapped(map, |c| if c == OCCUPIED_DETECTED { 0 } else { c });
    true
}

fn status_of(kind: &PlanErrorKind) -> PlanStatus {
    match kind {
        PlanErrorKind::InvalidInput(_) => PlanStatus::InvalidRequest,
        PlanErrorKind::StartOccupied => PlanStatus::StartOccupied,
        PlanErrorKind::GoalOccupied => PlanStatus::GoalOccupied,
        PlanErrorKind::NoPath | PlanErrorKind::ValidationFailed => PlanStatus::NoPath,
        PlanErrorKind::BudgetExhausted | PlanErrorKind::Stopped => PlanStatus::Timeout,
    }
}

pub fn run(args: &NodeArgs) -> Result<(), NodeError> {
    let path = args.config_dir.join("planner.toml");
    let cfg = aisle_config::load::<PlannerConfig>(&path)
        .map_err(|e| NodeError::setup("global_planner", e))?;
    let mut planner = Planner::new(cfg).map_err(|e| NodeError::setup("global_planner", e))?;

    let (bus, _) = Bus::join(
        &args.instance,
        NodeKind::GlobalPlanner,
        NodeArgs::JOIN_TIMEOUT,
    )?;
    let maps = bus.subscriber::<OccupancyGrid>(services::GLOBAL_MAP)?;
    let requests = bus.subscriber::<PlanRequestMsg>(services::PLAN_REQUEST)?;
    let mut responses = bus.publisher::<PlanResponse>(services::PLAN_RESPONSE)?;
    let mut heartbeat = bus.heartbeat()?;
    heartbeat.send(NodeState::Starting, "waiting for the global map")?;

    let (mut map, mut static_map) = (GridCopy::default(), GridCopy::default());
    // Ready once there is a map to plan on.
    loop {
        let hb = &mut heartbeat;
        let (outcome, sample) = maps.wait_for(
            Duration::from_millis(200),
            |_| true,
            || {
                let _ = hb.tick(NodeState::Starting);
            },
        )?;
        if let (WaitOutcome::Matched, Some(m)) = (outcome, sample)
            && update(&mut map, &mut static_map, &m)
        {
            break;
        }
    }
    heartbeat.send(NodeState::Ready, "")?;

    loop {
        let hb = &mut heartbeat;
        let (outcome, sample) = requests.wait_for(
            Duration::from_millis(500),
            |_| true,
            || {
                let _ = hb.tick(NodeState::Running);
            },
        )?;
        let (WaitOutcome::Matched, Some(req)) = (outcome, sample) else {
            continue;
        };
        let req = *req;
        if let Some(m) = maps.latest()? {
            update(&mut map, &mut static_map, &m);
        }
        let started = clock::monotonic_ns();
        let timeout_ms = if req.timeout_ms == 0 {
            DEFAULT_TIMEOUT_MS
        } else {
            req.timeout_ms
        };
        let deadline = started + timeout_ms as u64 * 1_000_000;
        let request = PlanRequest {
            start: Pose2::from(req.start),
            goal: Pose2::from(req.goal),
            footprint: Footprint::new(req.footprint_length, req.footprint_width),
            margin: req.margin,
            max_expansions: if req.max_expansions == 0 {
                DEFAULT_MAX_EXPANSIONS
            } else {
                req.max_expansions
            },
        };
        let layer = if req.use_detections != 0 {
            &map
        } else {
            &static_map
        };
        // Only valid grids are taken (`update`), so this holds from the first map on.
        let view = layer
            .view()
            .map_err(|e| NodeError::Protocol(format!("global_planner: map: {e}")))?;
        let result =
            planner.plan_with_stop(&request, &view, &mut || clock::monotonic_ns() > deadline);
        let solve_ns = clock::monotonic_ns() - started;
        responses.publish(Stamp::of(&req.header), |m| {
            m.request_id = req.request_id;
            m.solve_ns = solve_ns;
            match &result {
                Ok(plan) if plan.path.len() <= MAX_PATH_POSES => {
                    m.status = PlanStatus::Ok as u32;
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
        })?;
        match &result {
            Ok(plan) => tracing::info!(
                "global_planner: request {}: {:.2} m in {} poses, {} expansions, {:.1} ms",
                req.request_id,
                plan.stats.path_length,
                plan.path.len(),
                plan.stats.expansions,
                solve_ns as f64 / 1e6
            ),
            Err(e) => tracing::warn!("global_planner: request {}: {e}", req.request_id),
        }
    }
}

//! [`Planner::plan_docked`]: a plan that ends with a straight move under a body or
//! starts with one out of it (`dock.rs` lays the moves out and checks them), the search
//! running on a copy of the map in which the body is an obstacle.
//!
//! Every open candidate is searched and the cheapest total wins (search cost plus the
//! straight move at the forward or reverse cost), so the side is chosen from where the
//! robot comes from, and the way out from where it goes next.

use crate::dock::{self, DockKind, DockParams, DockSite, Straight};
use crate::error::{PlanError, PlanErrorKind, PlanStats};
use crate::search::{PlanRequest, Planner};
use aisle_geometry::{Direction, GridView, PathPose, Pose2, wrap_angle};

/// A plan with its straight move: `path[split..]` is the docking move, or
/// `path[..=split]` the undocking move.
#[derive(Debug, Clone, PartialEq)]
pub struct DockedPlan {
    pub path: Vec<PathPose>,
    pub split: usize,
    pub kind: DockKind,
    pub stats: PlanStats,
}

impl Planner {
    /// Plans `req` with the straight move `site` asks for. Fails with
    /// [`PlanErrorKind::NoOpenSide`] when no straight move is clear, else with the
    /// failure of the candidate whose search went farthest.
    pub fn plan_docked(
        &mut self,
        req: &PlanRequest,
        site: &DockSite,
        map: &GridView,
        should_stop: &mut dyn FnMut() -> bool,
    ) -> Result<DockedPlan, PlanError> {
        let params = DockParams {
            run_in: self.config().dock_run_in,
            clearance: self.config().dock_clearance,
            step: self.config().validation_distance,
        };
        let moves = match site.kind {
            DockKind::Dock => dock::entries(site, &req.goal, req.footprint, &params),
            DockKind::Undock => dock::exits(site, &req.start, req.footprint, &params),
        };
        let mut stats = PlanStats::default();
        let open: Vec<Straight> = moves
            .into_iter()
            .filter(|mv| dock::corridor_clear(site, mv, req.footprint, &params, map))
            .collect();
        if open.is_empty() {
            return Err(PlanError {
                kind: PlanErrorKind::NoOpenSide,
                stats,
            });
        }
        let mut scratch = std::mem::take(&mut self.dock_scratch);
        let blocked = dock::with_body_blocked(map, &site.body, &mut scratch);
        let mut best: Option<(f64, DockedPlan)> = None;
        let mut failure: Option<PlanError> = None;
        for mv in &open {
            let leg = match site.kind {
                DockKind::Dock => PlanRequest {
                    goal: mv.from,
                    ..*req
                },
                DockKind::Undock => PlanRequest {
                    start: mv.to,
                    ..*req
                },
            };
            match self.plan_with_stop(&leg, &blocked, should_stop) {
                Ok(plan) => {
                    stats.expansions += plan.stats.expansions;
                    let cost = plan.stats.path_cost + self.straight_cost(mv);
                    if best.as_ref().is_none_or(|(c, _)| cost < *c) {
                        let joined = join(site.kind, mv, plan.path, params.step);
                        best = Some((cost, joined_plan(joined, site.kind, plan.stats)));
                    }
                }
                Err(e) => {
                    stats.expansions += e.stats.expansions;
                    if failure.is_none_or(|f| e.stats.expansions > f.stats.expansions) {
                        failure = Some(e);
                    }
                    if e.kind == PlanErrorKind::Stopped {
                        break;
                    }
                }
            }
        }
        self.dock_scratch = scratch;
        match (best, failure) {
            (Some((_, mut plan)), _) => {
                plan.stats.expansions = stats.expansions;
                Ok(plan)
            }
            (None, Some(e)) => Err(PlanError {
                kind: e.kind,
                stats: PlanStats {
                    expansions: stats.expansions,
                    ..e.stats
                },
            }),
            (None, None) => Err(PlanError {
                kind: PlanErrorKind::NoOpenSide,
                stats,
            }),
        }
    }

    fn straight_cost(&self, mv: &Straight) -> f64 {
        let per_metre = match mv.direction {
            Direction::Reverse => self.config().reverse_cost,
            _ => self.config().forward_cost,
        };
        per_metre * mv.length()
    }
}

/// The searched path and the straight move as one path; the index where they meet.
fn join(
    kind: DockKind,
    mv: &Straight,
    searched: Vec<PathPose>,
    step: f64,
) -> (Vec<PathPose>, usize) {
    let straight: Vec<PathPose> = mv.poses(step).collect();
    match kind {
        DockKind::Dock => {
            let mut path = searched;
            let split = path.len() - 1;
            // The searched path ends exactly at the move's start: continue from it.
            if let Some(last) = path.last_mut() {
                last.direction = Direction::Forward;
            }
            path.extend(straight.into_iter().skip(1));
            (path, split)
        }
        DockKind::Undock => {
            let split = straight.len() - 1;
            let mut path = straight;
            // The move's end is the search's start, which says how the path leaves it.
            path.pop();
            path.extend(searched);
            (path, split)
        }
    }
}

fn joined_plan(
    (path, split): (Vec<PathPose>, usize),
    kind: DockKind,
    mut stats: PlanStats,
) -> DockedPlan {
    stats.path_length = aisle_geometry::path_length(&path);
    let path = path
        .into_iter()
        .map(|p| {
            PathPose::new(
                Pose2::new(p.pose.x, p.pose.y, wrap_angle(p.pose.theta)),
                p.direction,
            )
        })
        .collect();
    DockedPlan {
        path,
        split,
        kind,
        stats,
    }
}

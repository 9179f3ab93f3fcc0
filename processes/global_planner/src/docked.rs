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

/// Fractions of `dock_run_in` tried in turn while every open side's pose outside is
/// blocked.
const RUN_IN_FRACTIONS: [f64; 3] = [1.0, 0.6, 0.3];

/// What the searches of one request did so far: their expansions, and the failure of
/// the one that went farthest.
#[derive(Default)]
struct Tally {
    expansions: u32,
    failure: Option<PlanError>,
}

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
        self.request_expansions = 0;
        let mut scratch = std::mem::take(&mut self.dock_scratch);
        let blocked = dock::with_body_blocked(map, &site.body, &mut scratch);
        let mut tally = Tally::default();
        let mut result = None;
        // Moves out through a side, which turn in place under the body first, only when
        // neither end along the robot's heading leads anywhere.
        let tiers: &[bool] = match site.kind {
            DockKind::Dock => &[false],
            DockKind::Undock => &[false, true],
        };
        'tiers: for &turning in tiers {
            // A shorter run-in when the pose outside is blocked (a neighbouring rack):
            // less room to line up, but the straight move still corrects what the path
            // leaves.
            for fraction in RUN_IN_FRACTIONS {
                let params = self.dock_params(fraction);
                let moves = match site.kind {
                    DockKind::Dock => dock::entries(site, &req.goal, req.footprint, &params),
                    DockKind::Undock => dock::exits(site, &req.start, req.footprint, &params),
                };
                let open: Vec<Straight> = moves
                    .into_iter()
                    .filter(|mv| mv.turn_from.is_some() == turning)
                    .filter(|mv| dock::corridor_clear(site, mv, req.footprint, &params, map))
                    .collect();
                let (best, ends_blocked) =
                    self.cheapest(req, site, &open, &blocked, &params, should_stop, &mut tally);
                let stopped = tally
                    .failure
                    .is_some_and(|f| f.kind == PlanErrorKind::Stopped);
                if best.is_some() || stopped {
                    result = best;
                    break 'tiers;
                }
                if !ends_blocked {
                    break;
                }
            }
        }
        let (expansions, failure) = (tally.expansions, tally.failure);
        // The goal is under something (the next body the leg approaches, whose legs the
        // lidar has seen): no search reaches it from outside this body, so the plan is
        // the move out alone, and the caller plans on from where it ends.
        let goal_occupied = failure.is_some_and(|e| e.kind == PlanErrorKind::GoalOccupied);
        if result.is_none() && site.kind == DockKind::Undock && goal_occupied {
            result = self.move_out_only(req, site, &blocked, map, should_stop);
        }
        self.dock_scratch = scratch;
        match (result, failure) {
            (Some(mut plan), _) => {
                plan.stats.expansions = expansions;
                Ok(plan)
            }
            (None, Some(e)) => Err(PlanError {
                kind: e.kind,
                stats: PlanStats {
                    expansions,
                    ..e.stats
                },
            }),
            (None, None) => Err(PlanError {
                kind: PlanErrorKind::NoOpenSide,
                stats: PlanStats {
                    expansions,
                    ..PlanStats::default()
                },
            }),
        }
    }

    /// The cheapest of the searches to (or from) each of `open`'s moves, joined with
    /// its move (ties to the first in `open`); and whether every search failed at its
    /// own end pose (so a shorter run-in may help).
    ///
    /// Sides are searched in the order of an estimate of their cost (the free-space
    /// connection plus the move), and each search is bounded by the cheapest total found
    /// so far: a side that cannot win stops as soon as that is certain (`search_core.rs`
    /// `all_above_bound`; a weighted search sets such nodes aside), instead of finding
    /// its own best path. The order only decides how early the bound is tight: the free-space cost is no lower bound when the robot
    /// may turn on the spot, so it never rules a side out. On a large map the losing
    /// sides' searches were 95 % of a docking request's time.
    #[allow(clippy::too_many_arguments)]
    fn cheapest(
        &mut self,
        req: &PlanRequest,
        site: &DockSite,
        open: &[Straight],
        blocked: &GridView,
        params: &DockParams,
        should_stop: &mut dyn FnMut() -> bool,
        tally: &mut Tally,
    ) -> (Option<DockedPlan>, bool) {
        // (estimate, index in `open`, the move's own cost)
        let mut order: Vec<(f64, usize, f64)> = Vec::with_capacity(open.len());
        for (i, mv) in open.iter().enumerate() {
            let free = match site.kind {
                DockKind::Dock => self.free_space_cost(&req.start, &mv.from),
                DockKind::Undock => self.free_space_cost(&mv.to, &req.goal),
            };
            let straight = self.straight_cost(mv);
            order.push((free + straight, i, straight));
        }
        order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut best: Option<(f64, usize, DockedPlan)> = None;
        let mut ends_blocked = true;
        for (_, i, straight) in order {
            let mv = &open[i];
            let best_cost = best.as_ref().map_or(f64::INFINITY, |b| b.0);
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
            match self.plan_below(&leg, blocked, best_cost - straight, should_stop) {
                Ok(plan) => {
                    tally.expansions += plan.stats.expansions;
                    let cost = plan.stats.path_cost + straight;
                    let wins = best
                        .as_ref()
                        .is_none_or(|(c, j, _)| cost < *c || (cost == *c && i < *j));
                    if wins {
                        let joined = join(site.kind, mv, plan.path, params.step);
                        best = Some((cost, i, joined_plan(joined, site.kind, plan.stats)));
                    }
                }
                Err(e) if e.kind == PlanErrorKind::AboveBound => {
                    tally.expansions += e.stats.expansions;
                    ends_blocked = false;
                }
                Err(e) => {
                    tally.expansions += e.stats.expansions;
                    ends_blocked &= matches!(
                        e.kind,
                        PlanErrorKind::GoalOccupied | PlanErrorKind::StartOccupied
                    );
                    if tally
                        .failure
                        .is_none_or(|f| e.stats.expansions >= f.stats.expansions)
                    {
                        tally.failure = Some(e);
                    }
                    if e.kind == PlanErrorKind::Stopped {
                        break;
                    }
                }
            }
        }
        (best.map(|(_, _, plan)| plan), ends_blocked)
    }

    /// The straight move out of `site` alone, through the open side whose end is free
    /// (on `blocked`) and nearest to the goal; `None` when no side qualifies.
    fn move_out_only(
        &mut self,
        req: &PlanRequest,
        site: &DockSite,
        blocked: &GridView,
        map: &GridView,
        should_stop: &mut dyn FnMut() -> bool,
    ) -> Option<DockedPlan> {
        let params = self.dock_params(1.0);
        let mut best: Option<(f64, Straight, PlanStats)> = None;
        for mv in dock::exits(site, &req.start, req.footprint, &params) {
            if !dock::corridor_clear(site, &mv, req.footprint, &params, map) {
                continue;
            }
            // Planning from the end to itself checks that the end is free.
            let here = PlanRequest {
                start: mv.to,
                goal: mv.to,
                ..*req
            };
            let Ok(plan) = self.plan_below(&here, blocked, f64::INFINITY, should_stop) else {
                continue;
            };
            let cost = self.straight_cost(&mv) + mv.to.distance(&req.goal);
            if best.as_ref().is_none_or(|(c, _, _)| cost < *c) {
                best = Some((cost, mv, plan.stats));
            }
        }
        let (_, mv, stats) = best?;
        let (mut path, _) = join(DockKind::Undock, &mv, Vec::new(), params.step);
        // `join` leaves the move's end to the search that would follow: put it back.
        path.extend(mv.poses(params.step).last());
        let split = path.len() - 1;
        Some(joined_plan((path, split), DockKind::Undock, stats))
    }

    /// The straight moves' layout with `fraction` of the configured run-in.
    fn dock_params(&self, fraction: f64) -> DockParams {
        DockParams {
            run_in: self.config().dock_run_in * fraction,
            clearance: self.config().dock_clearance,
            step: self.config().validation_distance,
        }
    }

    fn straight_cost(&self, mv: &Straight) -> f64 {
        let per_metre = match mv.direction {
            Direction::Reverse => self.config().reverse_cost,
            _ => self.config().forward_cost,
        };
        let turn = mv
            .turn_from
            .map_or(0.0, |h| wrap_angle(mv.from.theta - h).abs());
        per_metre * mv.length() + self.config().rotation_cost * turn
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
            // A side exit turns in place first: the pose it turns from leads.
            let turn = mv
                .turn_from
                .map(|h| PathPose::new(Pose2::new(mv.from.x, mv.from.y, h), Direction::Rotate));
            let mut path: Vec<PathPose> = turn.into_iter().chain(straight).collect();
            let split = path.len() - 1;
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

#[cfg(test)]
mod tests;

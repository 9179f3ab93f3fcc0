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
    /// `above_bound`), instead of finding its own best path. The order only decides how
    /// early the bound is tight: the free-space cost is no lower bound when the robot
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
        let mut order: Vec<(f64, usize)> = Vec::with_capacity(open.len());
        for (i, mv) in open.iter().enumerate() {
            let free = match site.kind {
                DockKind::Dock => self.free_space_cost(&req.start, &mv.from),
                DockKind::Undock => self.free_space_cost(&mv.to, &req.goal),
            };
            order.push((free + self.straight_cost(mv), i));
        }
        order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut best: Option<(f64, usize, DockedPlan)> = None;
        let mut ends_blocked = true;
        for (_, i) in order {
            let mv = &open[i];
            let straight = self.straight_cost(mv);
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
            let Ok(plan) = self.plan_with_stop(&here, blocked, should_stop) else {
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
mod tests {
    use super::*;
    use crate::PlannerConfig;
    use aisle_geometry::{Footprint, GridMap};
    use std::f64::consts::FRAC_PI_2;

    use crate::dock::seed_rack as rack;

    /// Twenty occupied cells from `at`, `step` apart in each direction.
    fn wall(map: &mut GridMap, at: (f64, f64), step: (f64, f64)) {
        for k in -10..10 {
            let (x, y) = (at.0 + step.0 * f64::from(k), at.1 + step.1 * f64::from(k));
            let c = map.view().cell_of(x, y);
            map.set(c, aisle_geometry::OCCUPIED_STATIC);
        }
    }

    fn request(start: Pose2, goal: Pose2) -> PlanRequest {
        PlanRequest {
            start,
            goal,
            footprint: Footprint::new(0.508, 0.43),
            margin: 0.1,
            max_expansions: 100_000,
        }
    }

    #[test]
    fn a_free_heading_dock_enters_the_side_facing_the_robot_straight() {
        let map = GridMap::new_free(-5.0, -5.0, 0.1, 10.0, 10.0).unwrap();
        let (body, legs) = rack(Pose2::new(0.0, 2.0, FRAC_PI_2));
        let site = DockSite {
            kind: DockKind::Dock,
            body,
            parts: &legs,
            free_heading: true,
        };
        let mut planner = Planner::new(PlannerConfig::default()).unwrap();
        let req = request(Pose2::new(0.0, -3.0, FRAC_PI_2), body.pose);
        let plan = planner
            .plan_docked(&req, &site, &map.view(), &mut || false)
            .unwrap();
        // From the south: the straight part runs north along x = 0 into the centre.
        let last = plan.path.last().unwrap().pose;
        assert!((last.x, last.y) == (0.0, 2.0) && (last.theta - FRAC_PI_2).abs() < 1e-9);
        for p in &plan.path[plan.split..] {
            assert!(p.pose.x.abs() < 1e-9 && (p.pose.theta - FRAC_PI_2).abs() < 1e-9);
        }
        // Nothing before the straight part comes near the rack.
        let robot = Footprint::new(0.508, 0.43);
        for p in &plan.path[..=plan.split] {
            assert!(
                !robot.overlaps(&p.pose, &body.footprint, &body.pose),
                "{p:?}"
            );
        }
    }

    #[test]
    fn an_undock_leaves_backwards_when_the_goal_is_behind_else_through_a_side_and_blocked_sides_are_refused()
     {
        let map = GridMap::new_free(-5.0, -5.0, 0.1, 10.0, 10.0).unwrap();
        let (body, legs) = rack(Pose2::new(0.0, 0.0, 0.0));
        let site = DockSite {
            kind: DockKind::Undock,
            body,
            parts: &legs,
            free_heading: false,
        };
        let mut planner = Planner::new(PlannerConfig::default()).unwrap();
        let req = request(body.pose, Pose2::new(-3.5, 0.0, 0.0));
        let plan = planner
            .plan_docked(&req, &site, &map.view(), &mut || false)
            .unwrap();
        assert_eq!(plan.path[0].direction, Direction::Reverse);
        assert!(plan.path[plan.split].pose.x < -1.0);
        // Walled in at both ends: out through a side after a quarter turn in place.
        let mut walled = map.clone();
        wall(&mut walled, (-1.0, 0.0), (0.0, 0.05));
        wall(&mut walled, (1.0, 0.0), (0.0, 0.05));
        let plan = planner
            .plan_docked(&req, &site, &walled.view(), &mut || false)
            .unwrap();
        assert_eq!(plan.path[0].direction, Direction::Rotate);
        let out = plan.path[plan.split].pose;
        assert!(out.x.abs() < 1e-9 && out.y.abs() > 1.0, "{out:?}");
        // Walled in on every side: no way out.
        wall(&mut walled, (0.0, -1.0), (0.05, 0.0));
        wall(&mut walled, (0.0, 1.0), (0.05, 0.0));
        let e = planner
            .plan_docked(&req, &site, &walled.view(), &mut || false)
            .unwrap_err();
        assert_eq!(e.kind, PlanErrorKind::NoOpenSide);
    }

    /// A rack in the open with every side free: the sides searched after the cheapest
    /// so far stop early, and the plan is the one searching every side to its end
    /// gives.
    #[test]
    fn the_cheapest_side_wins_as_if_every_side_were_searched_in_full() {
        let map = GridMap::new_free(-8.0, -8.0, 0.1, 16.0, 16.0).unwrap();
        let (body, legs) = rack(Pose2::new(1.0, 2.0, 0.4));
        let site = DockSite {
            kind: DockKind::Dock,
            body,
            parts: &legs,
            free_heading: true,
        };
        let mut planner = Planner::new(PlannerConfig::default()).unwrap();
        let req = request(Pose2::new(-5.0, -5.0, 0.3), body.pose);
        let plan = planner
            .plan_docked(&req, &site, &map.view(), &mut || false)
            .unwrap();
        // Every open side searched in full, in order, the first of the cheapest kept.
        let params = planner.dock_params(1.0);
        let mut scratch = Vec::new();
        let blocked = dock::with_body_blocked(&map.view(), &site.body, &mut scratch);
        let (mut best, mut expansions, mut sides) = (None::<(f64, Pose2)>, 0, 0);
        for mv in dock::entries(&site, &req.goal, req.footprint, &params) {
            if !dock::corridor_clear(&site, &mv, req.footprint, &params, &map.view()) {
                continue;
            }
            let leg = PlanRequest {
                goal: mv.from,
                ..req
            };
            let searched = planner.plan(&leg, &blocked).unwrap();
            sides += 1;
            expansions += searched.stats.expansions;
            let cost = searched.stats.path_cost + planner.straight_cost(&mv);
            if best.is_none_or(|(c, _)| cost < c) {
                best = Some((cost, mv.from));
            }
        }
        assert_eq!(sides, 4);
        let (_, entry) = best.unwrap();
        let split = plan.path[plan.split].pose;
        assert!(split.distance(&entry) < 1e-9, "{split:?} vs {entry:?}");
        assert!(
            plan.stats.expansions < expansions,
            "{} vs {expansions}",
            plan.stats.expansions
        );
    }

    /// The next rack of the leg stands 3 m east; its legs are on the map, so its centre
    /// (the leg's goal) is occupied: the plan is the move out alone, east, towards it.
    #[test]
    fn an_undock_towards_a_goal_under_another_body_is_the_move_out_alone() {
        let mut map = GridMap::new_free(-5.0, -5.0, 0.05, 10.0, 10.0).unwrap();
        let (body, legs) = rack(Pose2::new(0.0, 0.0, 0.0));
        let (next, next_legs) = rack(Pose2::new(3.0, 0.0, 0.0));
        // Each leg seen as a 3 x 3 block of cells, as noisy returns spread it.
        for leg in &next_legs {
            for (dx, dy) in (-1..=1).flat_map(|i| (-1..=1).map(move |j| (i, j))) {
                let (x, y) = (
                    leg.pose.x + 0.05 * f64::from(dx),
                    leg.pose.y + 0.05 * f64::from(dy),
                );
                let c = map.view().cell_of(x, y);
                map.set(c, aisle_geometry::OCCUPIED_STATIC);
            }
        }
        let site = DockSite {
            kind: DockKind::Undock,
            body,
            parts: &legs,
            free_heading: false,
        };
        let mut planner = Planner::new(PlannerConfig::default()).unwrap();
        let req = request(body.pose, next.pose);
        let plan = planner
            .plan_docked(&req, &site, &map.view(), &mut || false)
            .unwrap();
        assert_eq!(plan.split, plan.path.len() - 1, "only the straight move");
        let end = plan.path[plan.split].pose;
        assert!(end.x > 0.8 && end.y.abs() < 1e-9, "{end:?}");
        assert!(plan.path.iter().all(|p| p.direction == Direction::Forward));
        // A goal occupied by anything gets the same answer: the robot leaves the body
        // first, and the plan from outside says why it cannot go on.
        let walled_goal = request(body.pose, Pose2::new(3.0, 4.0, 0.0));
        let mut boxed = map.clone();
        for k in -10..=10 {
            let c = boxed.view().cell_of(3.0 + 0.05 * f64::from(k), 4.0);
            boxed.set(c, aisle_geometry::OCCUPIED_STATIC);
        }
        let e = planner.plan_docked(&walled_goal, &site, &boxed.view(), &mut || false);
        assert!(
            e.is_ok_and(|p| p.split == p.path.len() - 1),
            "occupied goal: out first"
        );
    }
}

//! [`Planner::plan_below`]: a request searched from its start and, once that proves
//! costly, from its goal's end too, the two taking turns (`goal_end_after`).
//!
//! The search from the goal's end solves the mirrored request: start and goal swapped,
//! both headings turned half round. A motion driven forward from A to B, run backwards
//! in time with the heading turned half round, is a forward motion from B to A: the
//! robot moves along its heading again. Reverse stays reverse, a rotation stays a
//! rotation, arcs keep their radius, so every path of the mirrored request is a path of
//! the request read backwards at the same cost. The footprint is a rectangle centred on
//! the pose, so turned half round it covers the same cells. The one asymmetry is the
//! relief near a start or goal inside the margin (`relief.rs` treats the two ends
//! differently): a request with either relief is searched from its start alone.
//!
//! A search from the start pays for what the heuristic does not see where it pays it:
//! a turn on the spot at the goal, which the 2D heuristic ignores, leaves the whole
//! path's length of slack to the search from the start and none to the one from the
//! goal, which pays it first. Which end is the hard one is not known before searching,
//! hence the turns: each search goes on from where its last turn stopped (the one from
//! the goal with buffers and a heuristic of its own), so what the search from the start
//! expands, turns and all, is what it expands alone, and the turns cost only the other
//! search's work. When both ends are hard, neither search alone is cheap: a node either
//! search closes where the other has closed one joins them (`meet.rs`), and each pays
//! only for its own end. Deterministic: turns are counted in expansions.

use crate::error::{PlanError, PlanErrorKind, PlanStats};
use crate::heuristic::GridHeuristic;
use crate::meet::turned;
use crate::search::{Plan, PlanRequest, Planner};
use crate::search_buffers::Buffers;
use crate::search_core::RunState;
use aisle_geometry::{Direction, GridView, PathPose, Pose2, wrap_angle};

/// How far a search of a request has come: what it did so far, its loop's state, and
/// whether it has started (a turn after the first goes on from the open list).
#[derive(Debug, Default)]
pub(crate) struct Progress {
    pub(crate) stats: PlanStats,
    pub(crate) run: RunState,
    pub(crate) started: bool,
}

/// The search from a request's goal's end: its own buffers and
/// heuristic, kept from turn to turn while the search from the start keeps the
/// planner's.
#[derive(Debug, Default)]
pub(crate) struct Mirror {
    pub(crate) buf: Buffers,
    pub(crate) heur: GridHeuristic,
    pub(crate) progress: Progress,
}

/// Which search a turn runs.
pub(crate) enum Side<'a> {
    /// The search from the start, and the one from the goal once it has started (whose
    /// closed nodes the start's may join, `meet.rs`).
    Start(&'a mut Progress, Option<&'a Buffers>),
    Goal(&'a mut Mirror),
}

impl Side<'_> {
    pub(crate) fn progress(&mut self) -> &mut Progress {
        match self {
            Side::Start(p, _) => p,
            Side::Goal(m) => &mut m.progress,
        }
    }
}

/// Each turn's expansion limit over the last one's.
const GROWTH: u32 = 4;

impl Planner {
    /// Plans `req` with a search cost the path must stay below:
    /// [`PlanErrorKind::AboveBound`] as soon as no cheaper path can be left. Each search
    /// goes on from where its last turn stopped, so the search from the start, turns
    /// and all, expands what it would have alone; the stats count both searches' work.
    pub(crate) fn plan_below(
        &mut self,
        req: &PlanRequest,
        map: &GridView,
        bound: f64,
        should_stop: &mut dyn FnMut() -> bool,
    ) -> Result<Plan, PlanError> {
        // The mirror's buffers and heuristic are kept from request to request: made
        // anew, a hard request paid their page faults (on a large map its heuristic's
        // table is the map's size, allocated only once a request has needed it).
        let mut from_goal = self.mirror.take().unwrap_or_default();
        from_goal.progress = Progress::default();
        let mut outcome = self.alternate(req, map, bound, &mut from_goal, should_stop);
        if let Err(first) = outcome
            && boxed_in(&first)
            && self.config().boxed_in_margin < 1.0
        {
            // Once more, with less of the margin near the start (`relief.rs`).
            self.escaping = true;
            outcome = self.alternate(req, map, bound, &mut from_goal, should_stop);
            self.escaping = false;
            outcome = escaped(outcome, &first.stats);
        }
        self.mirror = Some(from_goal);
        outcome
    }

    /// The turns of [`Planner::plan_below`].
    fn alternate(
        &mut self,
        req: &PlanRequest,
        map: &GridView,
        bound: f64,
        from_goal: &mut Mirror,
        should_stop: &mut dyn FnMut() -> bool,
    ) -> Result<Plan, PlanError> {
        let mut from_start = Progress::default();
        let mut cap = self.config().goal_end_after;
        let mut goal_end = cap > 0;
        let mirrored = mirror(req);
        while goal_end && cap.saturating_mul(GROWTH) <= req.max_expansions {
            let other = from_goal.progress.started.then_some(&from_goal.buf);
            let start_side = Side::Start(&mut from_start, other);
            match self.turn(req, map, bound, Some(cap), start_side, should_stop) {
                Err(e) if e.kind == PlanErrorKind::BudgetExhausted && !relieved(&e.stats) => {}
                // A relieved end took its whole budget in this turn.
                outcome => return with_other(outcome, &from_goal.progress, false),
            }
            let goal_side = Side::Goal(&mut *from_goal);
            match self.turn(&mirrored, map, bound, Some(cap), goal_side, should_stop) {
                Ok(plan) => {
                    let plan = Plan {
                        path: read_backwards(&plan.path, req),
                        stats: plan.stats,
                    };
                    return with_other(Ok(plan), &from_start, true);
                }
                Err(e) if e.kind == PlanErrorKind::BudgetExhausted => {}
                // No path, or none within the bound, holds for both ends.
                Err(e) if answers_both(e.kind) => return with_other(Err(e), &from_start, true),
                // Anything else (a check of the ends that differs) leaves the request
                // to the search from the start.
                Err(_) => goal_end = false,
            }
            cap = cap.saturating_mul(GROWTH);
        }
        let other = from_goal.progress.started.then_some(&from_goal.buf);
        let start_side = Side::Start(&mut from_start, other);
        let last = self.turn(req, map, bound, None, start_side, should_stop);
        with_other(last, &from_goal.progress, false)
    }
}

/// Whether `e` says the search from the start was boxed in (`relief.rs`).
fn boxed_in(e: &PlanError) -> bool {
    e.kind == PlanErrorKind::NoPath && e.stats.boxed_in && !e.stats.from_goal
}

/// The second search's outcome from a boxed-in start, counting the first's work.
fn escaped(outcome: Result<Plan, PlanError>, first: &PlanStats) -> Result<Plan, PlanError> {
    with_stats(outcome, |s| PlanStats {
        escaped: true,
        ..plus_work(s, first)
    })
}

fn relieved(stats: &PlanStats) -> bool {
    stats.start_relief.is_some() || stats.goal_relief.is_some()
}

/// Failures of the mirrored search that answer the request itself.
fn answers_both(kind: PlanErrorKind) -> bool {
    matches!(
        kind,
        PlanErrorKind::NoPath | PlanErrorKind::AboveBound | PlanErrorKind::Stopped
    )
}

/// The request with its ends swapped and both headings turned half round.
fn mirror(req: &PlanRequest) -> PlanRequest {
    PlanRequest {
        start: turned(&req.goal),
        goal: turned(&req.start),
        ..*req
    }
}

/// A path of the mirrored request as a path of `req`: the poses in reverse order,
/// turned back, each with the direction of the motion that now leaves it (the one that
/// reached it in the mirrored path), and the request's own end poses exactly.
fn read_backwards(mirrored: &[PathPose], req: &PlanRequest) -> Vec<PathPose> {
    let n = mirrored.len();
    let mut path: Vec<PathPose> = (0..n)
        .map(|k| {
            let from = &mirrored[n - 1 - k];
            let leaving = if k + 1 < n {
                mirrored[n - 2 - k].direction
            } else {
                Direction::Forward
            };
            PathPose::new(turned(&from.pose), leaving)
        })
        .collect();
    if n >= 2 {
        path[n - 1].direction = path[n - 2].direction;
        path[0].pose = Pose2::new(req.start.x, req.start.y, wrap_angle(req.start.theta));
        path[n - 1].pose = Pose2::new(req.goal.x, req.goal.y, wrap_angle(req.goal.theta));
    }
    path
}

/// The work of the other search added to `outcome`'s stats, which say from which end
/// the path (or failure) came.
fn with_other(
    outcome: Result<Plan, PlanError>,
    other: &Progress,
    from_goal: bool,
) -> Result<Plan, PlanError> {
    with_stats(outcome, |s| PlanStats {
        from_goal,
        ..plus_work(s, &other.stats)
    })
}

/// `s` with the work counted in `o` added.
fn plus_work(s: &PlanStats, o: &PlanStats) -> PlanStats {
    PlanStats {
        expansions: s.expansions + o.expansions,
        nodes: s.nodes + o.nodes,
        analytic_checks: s.analytic_checks + o.analytic_checks,
        collision_probes: s.collision_probes + o.collision_probes,
        map_rebuilt: s.map_rebuilt || o.map_rebuilt,
        ..*s
    }
}

/// `outcome` with its stats replaced by `f` of them.
fn with_stats(
    outcome: Result<Plan, PlanError>,
    f: impl Fn(&PlanStats) -> PlanStats,
) -> Result<Plan, PlanError> {
    match outcome {
        Ok(plan) => Ok(Plan {
            stats: f(&plan.stats),
            path: plan.path,
        }),
        Err(e) => Err(PlanError {
            kind: e.kind,
            stats: f(&e.stats),
        }),
    }
}

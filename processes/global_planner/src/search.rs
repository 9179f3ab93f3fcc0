//! The Hybrid A* search and the reusable [`Planner`] that runs it.
//!
//! Nodes keep continuous poses; the closed set is a sparse table of (search cell, heading
//! bin) states (`states.rs`). Each expansion applies the primitives of
//! [`crate::model::Model`] and checks them continuously against the footprint. The
//! heuristic is the larger of the 2D obstacle-aware grid distance (a backward search
//! from the goal, run as far as the queries need; an unreachable start proves that there
//! is no path before any search) and the free-space Reeds-Shepp / rotate-drive-rotate
//! cost; the latter is evaluated lazily, when a node is first popped. The map's distance
//! tables are computed tile by tile as the search reads them (`distance_map.rs`), so a
//! request costs what it searches, not the map's size.
//! Every few expansions an analytic connection to the goal is tried; the first valid one
//! ends the search. The result is sampled, smoothed and validated again.
//!
//! A request runs in phases ([`Planner::plan_with_stop`]): inputs, end poses and the 2D
//! heuristic, then the search core (`search_core.rs`, `Search`: `next_node` pops the open list, `close`
//! counts the expansion against the budget and the stop callback, `shot_due` and
//! `analytic_expansion` attempt the connection that is also the goal test, `expand`
//! opens the children), then the path (`Buffers::trace` walks the parents back,
//! `output_path` smooths and validates).
//!
//! Reads no clock: the request carries an expansion budget, and the caller may pass a
//! stop callback (for a wall deadline) that is asked every few hundred expansions.

use crate::both_ends::{Mirror, Side};
use crate::budget::{Budget, Spent};
use crate::config::PlannerConfig;
use crate::distance_map::{DistanceMap, EAGER_CELLS};
use crate::error::{InvalidInput, PlanError, PlanErrorKind, PlanStats, check_input};
use crate::heuristic::{GRID_OVERESTIMATE, GridHeuristic};
use crate::model::Model;
use crate::motion::Motion;
use crate::relief::{self, Clearance, GoalRelief};
use crate::search_buffers::Buffers;
use crate::search_core::Search;
use crate::smooth::{SmoothParams, smooth_path};
use crate::states::SearchGrid;
use aisle_config::{InvalidKey, Validate};
use aisle_geometry::{Footprint, GridView, PathPose, Pose2, path_length, wrap_angle};

/// One planning request.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanRequest {
    pub start: Pose2,
    pub goal: Pose2,
    /// The body to keep free (the robot, or the robot with its rack).
    pub footprint: Footprint,
    /// Clearance added on every side of the footprint (m).
    pub margin: f64,
    /// Maximum number of node expansions before giving up (deterministic bound); more
    /// where the reachable area calls for it (`expansions_per_reachable_cell`), unless
    /// `fixed_budget`.
    pub max_expansions: u32,
    /// `max_expansions` is the most the whole request expands: it does not grow with the
    /// reachable area, and it counts every search the request makes (both ends, a second
    /// search from a boxed-in start, every docking candidate). For a try the caller has
    /// a fallback for, whose worst case must stay short.
    pub fixed_budget: bool,
}

/// A planned path: poses about `validation_distance` apart from exactly the start to
/// exactly the goal (headings wrapped to (-pi, pi]); each pose carries the direction of
/// the motion that leaves it (the last one repeats the one before).
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub path: Vec<PathPose>,
    pub stats: PlanStats,
}

/// A Hybrid A* planner. Keep one and call [`Planner::plan`] for every request: it reuses
/// its buffers, and the distance tables of the map while the map does not change.
#[derive(Debug)]
pub struct Planner {
    cfg: PlannerConfig,
    model: Model,
    dm: DistanceMap,
    /// Two heuristics, so that requests alternating between two bodies (the robot
    /// alone, carrying a rack) keep the blocked cells of both.
    heur: [GridHeuristic; 2],
    /// The one the last request used.
    heur_last: usize,
    buf: Buffers,
    /// The search from a request's goal's end (`both_ends.rs`), once one has run.
    pub(crate) mirror: Option<Box<Mirror>>,
    /// The map with a docking body marked occupied (`docked.rs`), reused.
    pub(crate) dock_scratch: Vec<u8>,
    /// Fill a small map's tables whole (the distances on a rebuild, the heuristic's
    /// flood before the search) instead of as the search reads them, as small maps
    /// were before: the reference the lazy tables are tested against (`tests/lazy.rs`).
    /// Off: on the seed map the whole-map flood was most of a request (the park leg's
    /// 6.0 ms at 20 cells/m, 2.5 ms as read; 2.4 and 1.5 ms at 10 cells/m), for the same
    /// paths bit for bit. Takes effect on the next map.
    pub(crate) eager_small_maps: bool,
    /// The second search of a boxed-in start is under way (`both_ends.rs`).
    pub(crate) escaping: bool,
    /// Expansions of the current request's searches so far, all of them (what a
    /// `fixed_budget` holds).
    pub(crate) request_expansions: u32,
}

impl Planner {
    pub fn new(cfg: PlannerConfig) -> Result<Self, InvalidKey> {
        cfg.validate()?;
        Ok(Self {
            model: Model::new(&cfg),
            cfg,
            dm: DistanceMap::default(),
            heur: Default::default(),
            heur_last: 0,
            buf: Buffers::default(),
            mirror: None,
            dock_scratch: Vec::new(),
            eager_small_maps: false,
            escaping: false,
            request_expansions: 0,
        })
    }

    pub fn config(&self) -> &PlannerConfig {
        &self.cfg
    }

    /// Brings the map tables to `map` ahead of a request (its cells taken in; the
    /// distance tiles are computed as requests read them). Returns whether anything
    /// changed.
    pub fn prepare(&mut self, map: &GridView) -> bool {
        self.ensure_tables(map)
    }

    /// [`DistanceMap::ensure`], filling a small map whole only for the eager reference.
    fn ensure_tables(&mut self, map: &GridView) -> bool {
        self.dm.force_lazy = !self.eager_small_maps;
        self.dm.ensure(map)
    }

    /// Makes the memory a long search uses resident ahead of the first request on `map`
    /// (the node calls it at its start): in a fresh process the first search carrying a
    /// rack across the seed hall faulted in its node, open and state tables page by page
    /// and copied them as they grew. Changes no result: capacity only.
    pub fn warm_up(&mut self, map: &GridView) {
        let Some(grid) = SearchGrid::new(map, self.cfg.search_resolution, self.model.bins) else {
            return;
        };
        self.ensure_tables(map);
        self.buf.warm(&grid, WARM_NODES, WARM_TILES);
        for h in &mut self.heur {
            h.warm(&self.dm, self.cfg.heuristic_resolution);
        }
    }

    /// The search's free-space estimate from `from` to `to`: the cheapest Reeds-Shepp or
    /// rotate-drive-rotate connection under its cost model, ignoring obstacles. Not a
    /// lower bound when the robot may turn on the spot (a path mixing turns on the spot
    /// with arcs can be cheaper): an estimate to order candidates by.
    pub(crate) fn free_space_cost(&mut self, from: &Pose2, to: &Pose2) -> f64 {
        let wrapped = |p: &Pose2| Pose2::new(p.x, p.y, wrap_angle(p.theta));
        // The candidates buffer no longer holds the ones a search cached.
        self.buf.rs_from = None;
        self.model
            .free_space_cost(&wrapped(from), &wrapped(to), &mut self.buf.rs)
    }

    /// Plans with the expansion budget as the only bound.
    pub fn plan(&mut self, req: &PlanRequest, map: &GridView) -> Result<Plan, PlanError> {
        self.plan_with_stop(req, map, &mut || false)
    }

    /// Plans, asking `should_stop` every `stop_check_interval` expansions; when it
    /// returns true the search ends with [`PlanErrorKind::Stopped`].
    pub fn plan_with_stop(
        &mut self,
        req: &PlanRequest,
        map: &GridView,
        should_stop: &mut dyn FnMut() -> bool,
    ) -> Result<Plan, PlanError> {
        self.request_expansions = 0;
        self.plan_below(req, map, f64::INFINITY, should_stop)
    }

    /// A turn of a search of `req`: its first, or on from where `side`'s progress
    /// stopped, up to `cap` expansions in all (none: the request's growing budget).
    /// `Side::Goal` searches with the mirror's own buffers and heuristic, so that the
    /// search from the start keeps its own. The stats are the search's so far.
    pub(crate) fn turn(
        &mut self,
        req: &PlanRequest,
        map: &GridView,
        bound: f64,
        cap: Option<u32>,
        mut side: Side<'_>,
        should_stop: &mut dyn FnMut() -> bool,
    ) -> Result<Plan, PlanError> {
        let before = side.progress().stats.expansions;
        let outcome = self.plan_phases(req, map, bound, cap, &mut side, should_stop);
        let stats = side.progress().stats;
        let spent = stats.expansions.saturating_sub(before);
        self.request_expansions = self.request_expansions.saturating_add(spent);
        match outcome {
            Ok(path) => Ok(Plan { path, stats }),
            Err(kind) => Err(PlanError { kind, stats }),
        }
    }

    /// The phases of one request: inputs, end poses, heuristic, search, path. The
    /// progress's stats keep what they did, also when one of them fails; a search that
    /// has started goes on from where it stopped.
    fn plan_phases(
        &mut self,
        req: &PlanRequest,
        map: &GridView,
        bound: f64,
        cap: Option<u32>,
        side: &mut Side<'_>,
        should_stop: &mut dyn FnMut() -> bool,
    ) -> Result<Vec<PathPose>, PlanErrorKind> {
        check_input(req, map).map_err(PlanErrorKind::InvalidInput)?;
        let grid = SearchGrid::new(map, self.cfg.search_resolution, self.model.bins)
            .ok_or(PlanErrorKind::InvalidInput(InvalidInput::TooManyStates))?;
        let start = Pose2::new(req.start.x, req.start.y, wrap_angle(req.start.theta));
        let goal = Pose2::new(req.goal.x, req.goal.y, wrap_angle(req.goal.theta));
        // Once a request, in its first turn: the map's comparison with the kept copy
        // reads every cell (about 1 ms on a 100 x 200 m map at 20 cells/m).
        let first_turn = matches!(side, Side::Start(p, _) if !p.started);
        let rebuilt = first_turn && self.ensure_tables(map);
        if first_turn {
            self.dm.motions.get_mut().begin_request();
        }

        let cfg = &self.cfg;
        let model = &self.model;
        let escaping = self.escaping && matches!(side, Side::Start(..));
        let sizes = end_sizes(cfg, model, req, map, (&start, &goal), escaping)?;
        let progress = side.progress();
        progress.stats.map_rebuilt |= rebuilt;
        let (checker, output, radius) =
            request_checks(&self.dm, &sizes, &start, &goal, &mut progress.stats)?;
        // The other end's search, to join (`meet.rs`): the start's goes first.
        let (heur, buf, progress, other) = match side {
            Side::Start(progress, other) => {
                let k = heuristic_for(&self.heur, &mut self.heur_last, radius);
                (&mut self.heur[k], &mut self.buf, &mut **progress, *other)
            }
            Side::Goal(m) => (&mut m.heur, &mut m.buf, &mut m.progress, Some(&self.buf)),
        };
        let stats = &mut progress.stats;
        // A relieved end is searched from the start alone (`both_ends.rs`): no turns.
        let cap = cap.filter(|_| stats.start_relief.is_none() && stats.goal_relief.is_none());
        // The heuristic's backward search runs as far as the queries need (and on to
        // its end to count the cells the goal can be reached from once the request's
        // own budget is spent); the reference fills a small map whole up front.
        let eager = map.width * map.height <= EAGER_CELLS && self.eager_small_maps;
        let ends = ((goal.x, goal.y), (start.x, start.y));
        let reached = heur.begin(&self.dm, radius, cfg.heuristic_resolution, ends, eager);
        let h_start = reached.then(|| heur.metres(&self.dm, start.x, start.y));
        stats.heuristic_cells = heur.settled;
        let h_start = h_start.flatten().ok_or(PlanErrorKind::NoPath)?;

        let spent = Spent::new(self.request_expansions, stats.expansions);
        let budget = Budget::of_turn(req, cap, spent, cfg, eager.then_some(heur.settled));
        let bound = search_bound(cfg, model, heur, bound);
        let mut search = Search {
            cfg,
            model,
            grid,
            dm: &self.dm,
            heur: &mut *heur,
            budget,
            checker,
            goal,
            bound,
            buf: &mut *buf,
            other,
            stats: &mut *stats,
        };
        if !progress.started {
            search.open_start(start, h_start);
            progress.started = true;
        }
        let outcome = search.run(&mut progress.run, should_stop);
        let stats = &mut progress.stats;
        stats.heuristic_cells = heur.settled;
        let reached = outcome?;
        let joined = reached.other.zip(other).map(|(k, o)| (o, k));
        let rest = joined.map_or(0.0, |(o, k)| o.nodes[k as usize].g);
        stats.path_cost = buf.nodes[reached.last].g + reached.shot.cost + rest;
        stats.met = joined.is_some();
        let rotate_step =
            (cfg.validation_distance / output.full_checker().circumscribed_radius()).min(0.2);
        let to_goal = (&reached.shot, joined);
        buf.trace(
            reached.last,
            model,
            to_goal,
            cfg.validation_distance,
            rotate_step,
        );
        // Land exactly on the goal (the integrated end is within round-off of it).
        let end = buf.raw.len() - 1;
        buf.raw[end].pose = goal;
        buf.raw[0].pose = start;
        output_path(cfg, model.radius, &output, buf, stats)
    }
}

/// The poses' clearances for a request whose ends lie on the map; `escaping`: the
/// second search of a boxed-in start.
fn end_sizes(
    cfg: &PlannerConfig,
    model: &Model,
    req: &PlanRequest,
    map: &GridView,
    (start, goal): (&Pose2, &Pose2),
    escaping: bool,
) -> Result<relief::Sizes, PlanErrorKind> {
    // The search keeps a little more clearance than the output needs: output poses are
    // joined by straight interpolation, which leaves the arcs by at most the sagitta.
    let sagitta = cfg.validation_distance.powi(2) / (8.0 * model.radius) + 1e-3;
    let (x0, y0, x1, y1) = map.bounds();
    let on_map = |p: &Pose2| p.x >= x0 && p.x <= x1 && p.y >= y0 && p.y <= y1;
    if !on_map(start) {
        return Err(PlanErrorKind::StartOutsideMap);
    }
    if !on_map(goal) {
        return Err(PlanErrorKind::GoalOutsideMap);
    }
    Ok(relief::Sizes {
        footprint: req.footprint,
        margin: req.margin,
        sagitta,
        cover: cfg.sweep_cover,
        radius: cfg.start_relief_radius,
        escape: escaping.then_some(cfg.boxed_in_margin * req.margin),
    })
}

/// The search's bound on `g + h_grid` for a caller's `bound` on the path's cost.
fn search_bound(cfg: &PlannerConfig, model: &Model, heur: &GridHeuristic, bound: f64) -> f64 {
    // A node is past the bound when its `g + h_grid` is. The grid distance may exceed a
    // real path's length by its cells' quantisation, and then by up to
    // GRID_OVERESTIMATE off the axes and diagonals: plain A*, whose path is the
    // cheapest, widens the bound by both, so that what it cuts costs more. A weighted
    // search's paths are only within its weight of the cheapest, and the factor would
    // leave its bound nearly nothing to cut (a side below 0.8 x the cheapest cost 2.4 x
    // the expansions of an unbounded search): it widens by the quantisation alone, and
    // may cut a side up to 7.7 % cheaper than the best so far, the order of its weight's
    // own loss.
    let overestimate = if cfg.heuristic_weight == 1.0 {
        GRID_OVERESTIMATE
    } else {
        1.0
    };
    overestimate * (bound + heur.quantisation() * model.min_cost_per_metre)
}

/// The search's and the output's checks for a request (relieved near a start or a goal
/// inside the search's allowance, `relief.rs`), noted in `stats`, and the inscribed
/// radius its heuristic uses.
fn request_checks<'a>(
    dm: &'a DistanceMap,
    sizes: &relief::Sizes,
    start: &Pose2,
    goal: &Pose2,
    stats: &mut PlanStats,
) -> Result<(Clearance<'a>, Clearance<'a>, f64), PlanErrorKind> {
    let Some(mut checks) = relief::checks(dm, sizes, start) else {
        return Err(PlanErrorKind::StartOccupied);
    };
    stats.start_relief = checks.kept;
    if !checks.output.full_checker().pose_free(goal) {
        return Err(PlanErrorKind::GoalOccupied);
    }
    stats.goal_relief = match checks.relieve_goal(dm, sizes, goal) {
        GoalRelief::None => None,
        GoalRelief::Kept(m) => Some(m),
        GoalRelief::Unreachable => return Err(PlanErrorKind::GoalOccupied),
    };
    // A relieved start (or poses near a relieved goal) may lie where the full margin's
    // inscribed circle does not fit: the heuristic then uses the least margin kept (a
    // lower bound still).
    let margin = sizes.margin;
    let least = stats
        .start_relief
        .unwrap_or(margin)
        .min(stats.goal_relief.unwrap_or(margin));
    let radius = sizes.footprint.inflated(least).inscribed_radius();
    Ok((checks.search, checks.output, radius))
}

/// The returned path: the traced `buf.raw`, smoothed if configured, and checked again by
/// the output checker; the unsmoothed path if only the smoothed one fails.
fn output_path(
    cfg: &PlannerConfig,
    radius: f64,
    output: &Clearance,
    buf: &mut Buffers,
    stats: &mut PlanStats,
) -> Result<Vec<PathPose>, PlanErrorKind> {
    let sweep_ok = |poses: &[PathPose], probes: &mut u64| {
        poses
            .windows(2)
            .all(|w| output.motion_free(&w[0].pose, &Motion::Lerp { to: w[1].pose }, probes))
    };
    // The traced poses lie on the search's motions, which it swept with the sagitta to
    // spare: that holds the straight joins between them to the margin. Sweeping the joins
    // again demanded `sweep_cover` of clearance beyond the margin at the output's own
    // samples, more than the search proves between its samples, and refused paths it had
    // found (request 4 of config/large, `ValidationFailed`). So the traced poses are
    // checked exactly, each under the margin its motion was held to (a relieved motion
    // may reach beyond its relief).
    let poses_ok = |poses: &[PathPose], first: usize| {
        poses.iter().enumerate().all(|(i, p)| {
            let (from, motion) = &buf.traced[buf.raw_motion[first + i] as usize];
            output.pose_free_on(from, motion, &p.pose)
        })
    };
    let mut path = buf.raw.clone();
    let mut checked = std::mem::take(&mut buf.checked);
    if cfg.smoothing {
        let params = SmoothParams {
            weight_data: cfg.smoothing_weight_data,
            weight_smooth: cfg.smoothing_weight_smooth,
            iterations: cfg.smoothing_iterations,
            radius,
        };
        let probes = &mut stats.collision_probes;
        let scratch = &mut buf.smooth_scratch;
        stats.smoothed = smooth_path(&mut path, &params, scratch, &mut checked, |s| {
            sweep_ok(s, probes)
        });
    } else {
        checked.clear();
    }
    // Every stretch the smoothing kept passed the sweep as it stands; the rest holds traced
    // poses. Stretches share their end poses: each gap runs from the last pose of one
    // checked stretch to the first of the next.
    let mut from = 0;
    let mut rest_ok = true;
    for r in checked.iter() {
        rest_ok = rest_ok && poses_ok(&path[from..=r.start], from);
        from = r.end - 1;
    }
    rest_ok = rest_ok && poses_ok(&path[from..], from);
    let raw_ok = rest_ok || (stats.smoothed && poses_ok(&buf.raw, 0));
    buf.checked = checked;
    if !raw_ok {
        return Err(PlanErrorKind::ValidationFailed);
    }
    if !rest_ok {
        path.clone_from(&buf.raw);
        stats.smoothed = false;
    }
    stats.path_length = path_length(&path);
    Ok(path)
}

/// Search nodes the buffers are sized for at the start: the seed mission's longest
/// request (4929 expansions carrying a rack) opens 10,648 nodes.
const WARM_NODES: usize = 1 << 14;
/// State tiles (0.8 x 0.8 m at 0.1 m, every heading bin: 18 KB) made at the start; that
/// request takes 56.
const WARM_TILES: usize = 128;

/// The most cells a map may have (2^25: 200 x 200 m at 0.035 m); the tables a request
/// builds are proportional to what it searches, but the planner keeps a copy of the
/// cells and flags per heuristic cell.
pub const MAX_MAP_CELLS: u64 = 1 << 25;

/// Which of the two heuristics serves a body of inscribed radius `r_in`: the one that
/// did, else the one not used `last`.
fn heuristic_for(heur: &[GridHeuristic; 2], last: &mut usize, r_in: f64) -> usize {
    let k = match heur.iter().position(|h| h.serves(r_in)) {
        Some(k) => k,
        None => 1 - *last,
    };
    *last = k;
    k
}

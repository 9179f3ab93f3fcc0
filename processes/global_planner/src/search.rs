//! The Hybrid A* search and the reusable [`Planner`] that runs it.
//!
//! Nodes keep continuous poses; the closed set is a dense grid of (search cell, heading
//! bin) states. Each expansion applies the primitives of [`crate::model::Model`] and
//! checks them continuously against the footprint. The heuristic is the larger of the
//! 2D obstacle-aware grid distance (computed once per request; an unreachable start
//! proves that there is no path before any search) and the free-space Reeds-Shepp /
//! rotate-drive-rotate cost; the latter is evaluated lazily, when a node is first popped.
//! Every few expansions an analytic connection to the goal is tried; the first valid one
//! ends the search. The result is sampled, smoothed and validated again.
//!
//! A request runs in phases ([`Planner::plan_with_stop`]): inputs, end poses and the 2D
//! heuristic, then the search core (`Search`: `next_node` pops the open list, `close`
//! counts the expansion against the budget and the stop callback, `shot_due` and
//! `analytic_expansion` attempt the connection that is also the goal test, `expand`
//! opens the children), then the path (`Buffers::trace` walks the parents back,
//! `output_path` smooths and validates).
//!
//! Reads no clock: the request carries an expansion budget, and the caller may pass a
//! stop callback (for a wall deadline) that is asked every few hundred expansions.

use crate::collision::FootprintChecker;
use crate::config::PlannerConfig;
use crate::distance_map::DistanceMap;
use crate::error::{InvalidInput, PlanError, PlanErrorKind, PlanStats};
use crate::heuristic::GridHeuristic;
use crate::model::{DIR_NONE, Model, Shot};
use crate::motion::Motion;
use crate::reeds_shepp::Candidates;
use crate::sampling::{append_motion, finish};
use crate::smooth::{SmoothParams, smooth_path};
use aisle_config::{InvalidKey, Validate};
use aisle_geometry::{Footprint, GridView, PathPose, Pose2, path_length, wrap_angle};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// One planning request.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanRequest {
    pub start: Pose2,
    pub goal: Pose2,
    /// The body to keep free (the robot, or the robot with its rack).
    pub footprint: Footprint,
    /// Clearance added on every side of the footprint (m).
    pub margin: f64,
    /// Maximum number of node expansions before giving up (deterministic bound).
    pub max_expansions: u32,
}

/// A planned path: poses about `validation_distance` apart from exactly the start to
/// exactly the goal (headings wrapped to (-pi, pi]); each pose carries the direction of
/// the motion that leaves it (the last one repeats the one before).
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub path: Vec<PathPose>,
    pub stats: PlanStats,
}

const NONE: u32 = u32::MAX;

#[derive(Debug, Clone, Copy)]
struct Node {
    pose: Pose2,
    g: f64,
    h: f64,
    parent: u32,
    state: u32,
    prim: u8,
    dir: i8,
    closed: bool,
    h_full: bool,
}

#[derive(Debug, Clone, Copy)]
struct OpenEntry {
    f: f64,
    g: f64,
    node: u32,
}

impl PartialEq for OpenEntry {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for OpenEntry {}
impl PartialOrd for OpenEntry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for OpenEntry {
    /// Max-heap order: lowest f first, then the deeper node, then the older node.
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .f
            .total_cmp(&self.f)
            .then(self.g.total_cmp(&other.g))
            .then(other.node.cmp(&self.node))
    }
}

/// Buffers kept between requests so that planning does not allocate in steady state.
#[derive(Debug, Default)]
struct Buffers {
    nodes: Vec<Node>,
    state_node: Vec<u32>,
    open: BinaryHeap<OpenEntry>,
    rs: Candidates,
    shots: Vec<Shot>,
    chain: Vec<u32>,
    smooth_scratch: Vec<PathPose>,
    raw: Vec<PathPose>,
}

/// A Hybrid A* planner. Keep one and call [`Planner::plan`] for every request: it reuses
/// its buffers, and the distance tables of the map while the map does not change.
#[derive(Debug)]
pub struct Planner {
    cfg: PlannerConfig,
    model: Model,
    dm: DistanceMap,
    heur: GridHeuristic,
    buf: Buffers,
}

impl Planner {
    pub fn new(cfg: PlannerConfig) -> Result<Self, InvalidKey> {
        cfg.validate()?;
        Ok(Self {
            model: Model::new(&cfg),
            cfg,
            dm: DistanceMap::default(),
            heur: GridHeuristic::default(),
            buf: Buffers::default(),
        })
    }

    pub fn config(&self) -> &PlannerConfig {
        &self.cfg
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
        let mut stats = PlanStats::default();
        match self.plan_phases(req, map, should_stop, &mut stats) {
            Ok(path) => Ok(Plan { path, stats }),
            Err(kind) => Err(PlanError { kind, stats }),
        }
    }

    /// The phases of one request: inputs, end poses, heuristic, search, path. `stats`
    /// keeps what they did, also when one of them fails.
    fn plan_phases(
        &mut self,
        req: &PlanRequest,
        map: &GridView,
        should_stop: &mut dyn FnMut() -> bool,
        stats: &mut PlanStats,
    ) -> Result<Vec<PathPose>, PlanErrorKind> {
        check_input(req, map).map_err(PlanErrorKind::InvalidInput)?;
        let start = Pose2::new(req.start.x, req.start.y, wrap_angle(req.start.theta));
        let goal = Pose2::new(req.goal.x, req.goal.y, wrap_angle(req.goal.theta));
        stats.map_rebuilt = self.dm.ensure(map);

        let cfg = &self.cfg;
        let model = &self.model;
        let body = req.footprint.inflated(req.margin);
        // The search keeps a little more clearance than the output needs: output poses are
        // joined by straight interpolation, which leaves the arcs by at most the sagitta.
        let sagitta = cfg.validation_distance.powi(2) / (8.0 * model.radius) + 1e-3;
        let checker = FootprintChecker::new(&self.dm, body.inflated(sagitta), cfg.sweep_cover);
        let output = FootprintChecker::new(&self.dm, body, cfg.sweep_cover);
        if !output.pose_free(&start) {
            return Err(PlanErrorKind::StartOccupied);
        }
        if !output.pose_free(&goal) {
            return Err(PlanErrorKind::GoalOccupied);
        }
        let reached = self.heur.compute(
            &self.dm,
            body.inscribed_radius(),
            cfg.heuristic_resolution,
            (goal.x, goal.y),
        );
        stats.heuristic_cells = self.heur.settled;
        let h_start = self
            .heur
            .metres(start.x, start.y)
            .filter(|_| reached)
            .ok_or(PlanErrorKind::NoPath)?;

        let mut search = Search {
            cfg,
            model,
            grid: SearchGrid::new(map, cfg.search_resolution, model.bins),
            heur: &self.heur,
            checker,
            goal,
            buf: &mut self.buf,
            stats: &mut *stats,
        };
        search.open_start(start, h_start);
        let (last, shot) = search.run(req.max_expansions, should_stop)?;

        let buf = &mut self.buf;
        stats.path_cost = buf.nodes[last].g + shot.cost;
        let rotate_step = (cfg.validation_distance / output.circumscribed_radius()).min(0.2);
        buf.trace(last, model, &shot, cfg.validation_distance, rotate_step);
        // Land exactly on the goal (the integrated end is within round-off of it).
        let end = buf.raw.len() - 1;
        buf.raw[end].pose = goal;
        buf.raw[0].pose = start;
        output_path(cfg, model.radius, &output, buf, stats)
    }
}

/// One request's search: what it reads (configuration, model, closed-set grid,
/// heuristic, the search's collision checker, goal) and what it writes (the planner's
/// buffers and the request's counters).
struct Search<'a> {
    cfg: &'a PlannerConfig,
    model: &'a Model,
    grid: SearchGrid,
    heur: &'a GridHeuristic,
    checker: FootprintChecker<'a>,
    goal: Pose2,
    buf: &'a mut Buffers,
    stats: &'a mut PlanStats,
}

impl Search<'_> {
    /// Clears the buffers and puts the start node on the open list.
    fn open_start(&mut self, start: Pose2, h_start: f64) {
        self.buf.reset(self.grid.states());
        self.buf.push_node(Node {
            pose: start,
            g: 0.0,
            h: h_start * self.model.min_cost_per_metre,
            parent: NONE,
            state: self.grid.state(&start, self.model).unwrap_or(0),
            prim: 0,
            dir: DIR_NONE,
            closed: false,
            h_full: false,
        });
        self.stats.nodes = 1;
    }

    /// Expands nodes in order of f until an analytic expansion reaches the goal; returns
    /// the node it left from and the shot.
    fn run(
        &mut self,
        budget: u32,
        should_stop: &mut dyn FnMut() -> bool,
    ) -> Result<(usize, Shot), PlanErrorKind> {
        let mut since_shot = 0u32;
        loop {
            let ni = self.next_node().ok_or(PlanErrorKind::NoPath)?;
            self.close(ni, budget, should_stop)?;
            let node = self.buf.nodes[ni];
            if self.shot_due(&node, &mut since_shot)
                && let Some(shot) = self.analytic_expansion(&node)
            {
                return Ok((ni, shot));
            }
            self.expand(ni, &node);
        }
    }

    /// Pops the open node with the lowest f that is still current (not closed, not
    /// superseded by a cheaper g). A node popped for the first time gets the free-space
    /// part of its heuristic; if that raises it, it goes back on the list and the next
    /// one is popped. `None` when the open list is empty.
    #[inline]
    fn next_node(&mut self) -> Option<usize> {
        loop {
            let entry = self.buf.open.pop()?;
            let ni = entry.node as usize;
            let node = self.buf.nodes[ni];
            if node.closed || node.g.to_bits() != entry.g.to_bits() {
                continue;
            }
            if !node.h_full {
                let h_free = self
                    .model
                    .free_space_cost(&node.pose, &self.goal, &mut self.buf.rs);
                let n = &mut self.buf.nodes[ni];
                n.h_full = true;
                if h_free > n.h + 1e-9 {
                    n.h = h_free;
                    self.buf.open.push(OpenEntry {
                        f: n.g + n.h,
                        g: n.g,
                        node: entry.node,
                    });
                    continue;
                }
            }
            return Some(ni);
        }
    }

    /// Counts the expansion of node `ni` and closes it, unless the budget is spent or
    /// the caller (asked every `stop_check_interval` expansions) wants to stop.
    #[inline]
    fn close(
        &mut self,
        ni: usize,
        budget: u32,
        should_stop: &mut dyn FnMut() -> bool,
    ) -> Result<(), PlanErrorKind> {
        let stats = &mut *self.stats;
        let interval = self.cfg.stop_check_interval;
        if stats.expansions >= budget {
            return Err(PlanErrorKind::BudgetExhausted);
        }
        if stats.expansions > 0 && stats.expansions.is_multiple_of(interval) && should_stop() {
            return Err(PlanErrorKind::Stopped);
        }
        stats.expansions += 1;
        self.buf.nodes[ni].closed = true;
        Ok(())
    }

    /// Whether this expansion tries an analytic connection: the first one does, then
    /// one in every interval, which grows with the remaining cost.
    #[inline]
    fn shot_due(&self, node: &Node, since_shot: &mut u32) -> bool {
        // Far from the goal a shot almost always fails after a long collision check,
        // so shots are spaced by the remaining cost as well (Nav2 does the same).
        *since_shot += 1;
        let remaining = node.h / self.model.min_cost_per_metre;
        let interval = (self.cfg.analytic_interval_per_metre * remaining)
            .min(f64::from(u32::MAX))
            .max(f64::from(self.cfg.analytic_expansion_interval)) as u32;
        if self.stats.expansions == 1 || *since_shot >= interval {
            *since_shot = 0;
            return true;
        }
        false
    }

    /// Tries the cheapest analytic connections from `node` to the goal; the first that
    /// is collision free and lands on the goal ends the search.
    fn analytic_expansion(&mut self, node: &Node) -> Option<Shot> {
        let (model, buf) = (self.model, &mut *self.buf);
        crate::reeds_shepp::solve(&node.pose, &self.goal, model.radius, &mut buf.rs);
        buf.shots.clear();
        for p in buf.rs.as_slice() {
            buf.shots.push(model.rs_shot(p, node.dir));
        }
        if model.allow_rotation {
            buf.shots
                .extend(model.rtr_shots(&node.pose, &self.goal, node.dir));
        }
        // Stable sort: ties keep the solver's fixed order, so the choice is deterministic.
        buf.shots.sort_by(|a, b| a.cost.total_cmp(&b.cost));
        let tries = self.cfg.analytic_candidates as usize;
        for shot in buf.shots.iter().take(tries) {
            self.stats.analytic_checks += 1;
            if shot_reaches_goal(&self.checker, &node.pose, shot, &self.goal, self.stats) {
                return Some(*shot);
            }
        }
        None
    }

    /// Opens (or reopens with a lower g) the child of `node` (index `ni`) at the end of
    /// every primitive that lands on the grid, in a state not closed, is collision free
    /// and has a heuristic (its cell is reachable from the goal).
    #[inline]
    fn expand(&mut self, ni: usize, node: &Node) {
        let model = self.model;
        for (pi, prim) in model.prims.iter().enumerate() {
            let pose = prim.end(&node.pose);
            let Some(state) = self.grid.state(&pose, model) else {
                continue;
            };
            let buf = &mut *self.buf;
            let existing = buf.state_node[state as usize];
            if existing != NONE && buf.nodes[existing as usize].closed {
                continue;
            }
            let dir = model.prim_dir[pi];
            let g = node.g + model.prim_cost[pi] + model.switch(node.dir, dir);
            if existing != NONE && buf.nodes[existing as usize].g <= g {
                continue;
            }
            let probes = &mut self.stats.collision_probes;
            if !self.checker.motion_free(&node.pose, prim, probes) {
                continue;
            }
            let Some(h2d) = self.heur.metres(pose.x, pose.y) else {
                continue;
            };
            let child = Node {
                pose,
                g,
                h: h2d * model.min_cost_per_metre,
                parent: ni as u32,
                state,
                prim: pi as u8,
                dir,
                closed: false,
                h_full: false,
            };
            if existing == NONE {
                buf.push_node(child);
                self.stats.nodes += 1;
            } else {
                buf.reopen(existing, child);
            }
        }
    }
}

/// The goal test of an analytic expansion: every motion of `shot` from `from` is
/// collision free and the chain ends on the goal.
#[inline]
fn shot_reaches_goal(
    checker: &FootprintChecker,
    from: &Pose2,
    shot: &Shot,
    goal: &Pose2,
    stats: &mut PlanStats,
) -> bool {
    let mut pose = *from;
    for m in shot.motions() {
        if !checker.motion_free(&pose, m, &mut stats.collision_probes) {
            return false;
        }
        pose = m.end(&pose);
    }
    pose.distance(goal) < 1e-6 && pose.heading_error(goal) < 1e-6
}

/// The returned path: the traced `buf.raw`, smoothed if configured, and swept again by
/// the output checker; the unsmoothed path if only the smoothed one fails.
fn output_path(
    cfg: &PlannerConfig,
    radius: f64,
    output: &FootprintChecker,
    buf: &mut Buffers,
    stats: &mut PlanStats,
) -> Result<Vec<PathPose>, PlanErrorKind> {
    let sweep_ok = |poses: &[PathPose], probes: &mut u64| {
        poses
            .windows(2)
            .all(|w| output.motion_free(&w[0].pose, &Motion::Lerp { to: w[1].pose }, probes))
    };
    let mut path = buf.raw.clone();
    if cfg.smoothing {
        let params = SmoothParams {
            weight_data: cfg.smoothing_weight_data,
            weight_smooth: cfg.smoothing_weight_smooth,
            iterations: cfg.smoothing_iterations,
            radius,
        };
        let probes = &mut stats.collision_probes;
        stats.smoothed = smooth_path(&mut path, &params, &mut buf.smooth_scratch, |s| {
            sweep_ok(s, probes)
        });
    }
    if !sweep_ok(&path, &mut stats.collision_probes) {
        if !stats.smoothed || !sweep_ok(&buf.raw, &mut stats.collision_probes) {
            return Err(PlanErrorKind::ValidationFailed);
        }
        path.clone_from(&buf.raw);
        stats.smoothed = false;
    }
    stats.path_length = path_length(&path);
    Ok(path)
}

impl Buffers {
    fn reset(&mut self, states: usize) {
        for n in &self.nodes {
            if let Some(s) = self.state_node.get_mut(n.state as usize) {
                *s = NONE;
            }
        }
        if self.state_node.len() < states {
            self.state_node.resize(states, NONE);
        }
        self.nodes.clear();
        self.open.clear();
    }

    fn push_node(&mut self, n: Node) {
        let idx = self.nodes.len() as u32;
        self.state_node[n.state as usize] = idx;
        self.open.push(OpenEntry {
            f: n.g + n.h,
            g: n.g,
            node: idx,
        });
        self.nodes.push(n);
    }

    /// Replaces node `existing` by `child` (same state, lower g) and queues it again;
    /// its old open entry goes stale (its g no longer matches).
    #[inline]
    fn reopen(&mut self, existing: u32, child: Node) {
        self.nodes[existing as usize] = child;
        self.open.push(OpenEntry {
            f: child.g + child.h,
            g: child.g,
            node: existing,
        });
    }

    /// Samples the motions from the start to `last` and then `shot` into `raw`.
    fn trace(&mut self, last: usize, model: &Model, shot: &Shot, spacing: f64, rot: f64) {
        self.chain.clear();
        let mut i = last as u32;
        while i != NONE {
            self.chain.push(i);
            i = self.nodes[i as usize].parent;
        }
        self.raw.clear();
        for w in self.chain.windows(2).rev() {
            let (child, parent) = (&self.nodes[w[0] as usize], &self.nodes[w[1] as usize]);
            let m = model.prims[child.prim as usize];
            append_motion(&mut self.raw, &parent.pose, &m, spacing, rot);
        }
        let mut pose = self.nodes[last].pose;
        for m in shot.motions() {
            append_motion(&mut self.raw, &pose, m, spacing, rot);
            pose = m.end(&pose);
        }
        if self.raw.is_empty() {
            self.raw
                .push(PathPose::new(pose, aisle_geometry::Direction::Forward));
        }
        finish(&mut self.raw, pose);
    }
}

/// Geometry of the dense closed-set grid over the map's extent.
struct SearchGrid {
    origin_x: f64,
    origin_y: f64,
    cell: f64,
    nx: usize,
    ny: usize,
    bins: usize,
}

impl SearchGrid {
    fn new(map: &GridView, cell: f64, bins: u32) -> Self {
        let (x0, y0, x1, y1) = map.bounds();
        Self {
            origin_x: x0,
            origin_y: y0,
            cell,
            nx: ((x1 - x0) / cell).ceil() as usize,
            ny: ((y1 - y0) / cell).ceil() as usize,
            bins: bins as usize,
        }
    }

    fn states(&self) -> usize {
        self.nx * self.ny * self.bins
    }

    #[inline]
    fn state(&self, p: &Pose2, model: &Model) -> Option<u32> {
        let fx = ((p.x - self.origin_x) / self.cell).floor();
        let fy = ((p.y - self.origin_y) / self.cell).floor();
        if fx < 0.0 || fy < 0.0 || fx >= self.nx as f64 || fy >= self.ny as f64 {
            return None;
        }
        let cell = fy as usize * self.nx + fx as usize;
        Some((cell * self.bins + model.bin(p.theta) as usize) as u32)
    }
}

fn check_input(req: &PlanRequest, map: &GridView) -> Result<(), InvalidInput> {
    if !req.start.is_finite() {
        return Err(InvalidInput::StartNotFinite);
    }
    if !req.goal.is_finite() {
        return Err(InvalidInput::GoalNotFinite);
    }
    let f = req.footprint;
    if !(f.length.is_finite() && f.width.is_finite() && f.length > 0.0 && f.width > 0.0) {
        return Err(InvalidInput::Footprint);
    }
    if !(req.margin.is_finite() && req.margin >= 0.0) {
        return Err(InvalidInput::Margin);
    }
    let geometry_ok = map.resolution.is_finite()
        && map.resolution > 0.0
        && map.origin_x.is_finite()
        && map.origin_y.is_finite();
    if !geometry_ok
        || map.width == 0
        || map.height == 0
        || map.cells.len() != map.width * map.height
        || (map.width as u64 * map.height as u64) > u64::from(u32::MAX / 1024)
    {
        return Err(InvalidInput::Map);
    }
    if req.max_expansions == 0 {
        return Err(InvalidInput::ZeroBudget);
    }
    Ok(())
}

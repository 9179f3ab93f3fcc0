//! The search core of Hybrid A*, apart from its planner (in the manner of Nav2 smac's
//! `a_star.hpp` beside `smac_planner_hybrid.hpp`): the search node, the expansion
//! budget, and one request's [`Search`] (`next_node`, `close`, `shot_due`,
//! `analytic_expansion`, `join`, `expand`) with its goal test and its cost bound. The open
//! list's order and the buffers kept between requests are `search_buffers.rs`.
//!
//! Knows the motion model, the collision checks (`Clearance`) and the heuristic it is handed; knows
//! nothing of requests, configuration files or the bus.

use crate::budget::Budget;
use crate::config::PlannerConfig;
use crate::distance_map::DistanceMap;
use crate::error::{PlanErrorKind, PlanStats};
use crate::heuristic::GridHeuristic;
use crate::meet;
use crate::model::{DIR_NONE, Model, Shot};
use crate::motion::pose_bits;
use crate::relief::Clearance;
use crate::search_buffers::{Buffers, OpenEntry};
use crate::states::{NONE, SearchGrid};
use aisle_geometry::Pose2;

#[derive(Debug, Clone, Copy)]
pub(crate) struct Node {
    pub(crate) pose: Pose2,
    pub(crate) g: f64,
    pub(crate) h: f64,
    /// The obstacle-aware part of `h` (the 2D grid distance, in cost): unlike the
    /// free-space part, at most `GRID_OVERESTIMATE` times any path's cost to the goal
    /// (up to the grid's quantisation), so the one a cost bound is tested with.
    pub(crate) h_grid: f64,
    pub(crate) parent: u32,
    pub(crate) state: u32,
    pub(crate) prim: u8,
    pub(crate) dir: i8,
    pub(crate) closed: bool,
    pub(crate) h_full: bool,
}

/// One request's search: what it reads (configuration, model, state numbering, distance
/// map, the search's collision checker, goal) and what it writes (the heuristic's
/// backward search, the planner's buffers and the request's counters).
pub(crate) struct Search<'a> {
    pub(crate) cfg: &'a PlannerConfig,
    pub(crate) model: &'a Model,
    pub(crate) grid: SearchGrid,
    pub(crate) dm: &'a DistanceMap,
    pub(crate) heur: &'a mut GridHeuristic,
    pub(crate) budget: Budget,
    pub(crate) checker: Clearance<'a>,
    pub(crate) goal: Pose2,
    /// No path matters whose cost exceeds this: the search ends once every open node's
    /// `g + h_grid` does (infinite: no bound; `search.rs` widens the caller's bound by
    /// the grid's quantisation and its overestimate).
    pub(crate) bound: f64,
    pub(crate) buf: &'a mut Buffers,
    /// The search from the request's other end, once it has started: a node this
    /// search closes in the state of one it has closed joins the two (`meet.rs`).
    pub(crate) other: Option<&'a Buffers>,
    pub(crate) stats: &'a mut PlanStats,
}

/// How a search reached its goal: from node `last` by `shot`, and then, if the shot
/// joined the other end's search, along that search's path from its node `other`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Reached {
    pub(crate) last: usize,
    pub(crate) shot: Shot,
    pub(crate) other: Option<u32>,
}

/// What the search's loop carries from one run to the next (`both_ends.rs` resumes a
/// search that ran out of its turn's budget).
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct RunState {
    /// Expansions since the last analytic connection was tried.
    since_shot: u32,
    /// Whether a node was set aside for the bound: an empty open list then means that
    /// no path within the bound is left, not that there is none.
    beyond: bool,
}

impl Search<'_> {
    /// Clears the buffers and puts the start node on the open list.
    pub(crate) fn open_start(&mut self, start: Pose2, h_start: f64) {
        self.buf.reset(&self.grid);
        self.buf.push_node(Node {
            pose: start,
            g: 0.0,
            h: self.cfg.heuristic_weight * h_start * self.model.min_cost_per_metre,
            h_grid: h_start * self.model.min_cost_per_metre,
            parent: NONE,
            state: self
                .grid
                .state(&start, self.model.bin(start.theta))
                .unwrap_or(0),
            prim: 0,
            dir: DIR_NONE,
            closed: false,
            h_full: false,
        });
        self.stats.nodes = 1;
    }

    /// Expands nodes in order of f until an analytic expansion reaches the goal or joins
    /// the other end's search; returns how. A search that ran out of budget may be run
    /// again with a larger one and the same `state`: it goes on where it stopped.
    pub(crate) fn run(
        &mut self,
        state: &mut RunState,
        should_stop: &mut dyn FnMut() -> bool,
    ) -> Result<Reached, PlanErrorKind> {
        loop {
            // Judged before a node is popped, so that nothing is lost when the search
            // is resumed.
            if self.stats.expansions >= self.budget.limit && !self.grow_budget() {
                return Err(PlanErrorKind::BudgetExhausted);
            }
            let Some(ni) = self.next_node() else {
                if state.beyond {
                    return Err(PlanErrorKind::AboveBound);
                }
                self.stats.boxed_in = self.closed_near_start();
                return Err(PlanErrorKind::NoPath);
            };
            let n = &self.buf.nodes[ni];
            if n.g + n.h_grid > self.bound {
                if self.cfg.heuristic_weight != 1.0 {
                    state.beyond = true;
                    continue;
                }
                if self.all_above_bound() {
                    return Err(PlanErrorKind::AboveBound);
                }
            }
            self.close(ni, should_stop)?;
            let node = self.buf.nodes[ni];
            if self.shot_due(&node, &mut state.since_shot)
                && let Some(shot) = self.analytic_expansion(&node)
            {
                return Ok(Reached {
                    last: ni,
                    shot,
                    other: None,
                });
            }
            if let Some((shot, other)) = self.join(&node) {
                return Ok(Reached {
                    last: ni,
                    shot,
                    other: Some(other),
                });
            }
            self.expand(ni, &node);
        }
    }

    /// Whether every node this search closed lies within `start_relief_radius` of its
    /// start (read once, when the search has failed).
    #[cold]
    fn closed_near_start(&self) -> bool {
        let nodes = &self.buf.nodes;
        let Some(start) = nodes.first() else {
            return false;
        };
        let reach = self.cfg.start_relief_radius + 1e-9;
        nodes
            .iter()
            .filter(|n| n.closed)
            .all(|n| n.pose.distance(&start.pose) <= reach)
    }

    /// Pops the open node with the lowest f that is still current (not closed, not
    /// superseded by a cheaper g). A node popped for the first time gets the free-space
    /// part of its heuristic; if that raises it, it goes back on the list and the next
    /// one is popped. `None` when the open list is empty.
    #[inline]
    pub(crate) fn next_node(&mut self) -> Option<usize> {
        loop {
            let entry = self.buf.open.pop()?;
            let ni = entry.node as usize;
            let node = self.buf.nodes[ni];
            if node.closed || node.g.to_bits() != entry.g.to_bits() {
                continue;
            }
            if !node.h_full {
                let h_free = self.cfg.heuristic_weight
                    * self
                        .model
                        .free_space_cost(&node.pose, &self.goal, &mut self.buf.rs);
                self.buf.rs_from = Some(pose_bits(&node.pose));
                let n = &mut self.buf.nodes[ni];
                n.h_full = true;
                if h_free > n.h + 1e-9 {
                    n.h = h_free;
                    self.buf.open.push(OpenEntry {
                        f: n.g + n.h,
                        g: n.g,
                        node: entry.node,
                    });
                    if self.bound < f64::INFINITY && self.cfg.heuristic_weight == 1.0 {
                        self.buf.raised.push(OpenEntry {
                            f: n.g + n.h_grid,
                            g: n.g,
                            node: entry.node,
                        });
                    }
                    continue;
                }
            }
            return Some(ni);
        }
    }

    /// Whether no open node can lead to a path within the bound, once the popped one
    /// (above it) cannot. Every path still to be found passes an open node and costs at
    /// least its `g + h_grid`. In plain A* nodes whose `h` is still the grid part come
    /// off the open list in that order, so the popped one stands for them; those raised
    /// by the free-space part (which, with turns on the spot, is no lower bound) are
    /// kept apart by `g + h_grid` in `raised`. A weighted search orders by
    /// `g + w h_grid`, which says nothing of `g + h_grid`: `run` sets each node above
    /// the bound aside instead, until the open list is empty.
    #[inline]
    fn all_above_bound(&mut self) -> bool {
        let nodes = &self.buf.nodes;
        while let Some(e) = self.buf.raised.peek() {
            let o = &nodes[e.node as usize];
            if o.closed || o.g.to_bits() != e.g.to_bits() {
                self.buf.raised.pop();
                continue;
            }
            return e.f > self.bound;
        }
        true
    }

    /// Counts the expansion of node `ni` and closes it, unless the caller (asked every
    /// `stop_check_interval` expansions) wants to stop.
    #[inline]
    pub(crate) fn close(
        &mut self,
        ni: usize,
        should_stop: &mut dyn FnMut() -> bool,
    ) -> Result<(), PlanErrorKind> {
        let stats = &mut *self.stats;
        let interval = self.cfg.stop_check_interval;
        if stats.expansions > 0 && stats.expansions.is_multiple_of(interval) && should_stop() {
            return Err(PlanErrorKind::Stopped);
        }
        stats.expansions += 1;
        self.buf.nodes[ni].closed = true;
        Ok(())
    }

    /// Raises the spent budget to the one the reachable area calls for, if not done yet;
    /// whether it is still open.
    #[cold]
    fn grow_budget(&mut self) -> bool {
        let Some(per_cell) = self.budget.per_cell.take() else {
            return false;
        };
        self.heur.complete(self.dm);
        let scaled = per_cell * f64::from(self.heur.settled);
        let limit = self
            .budget
            .limit
            .max(scaled.min(f64::from(u32::MAX)) as u32);
        self.budget.limit = limit;
        self.stats.expansions < limit
    }

    /// Whether this expansion tries an analytic connection: the first one does, then
    /// one in every interval, which grows with the remaining cost.
    #[inline]
    pub(crate) fn shot_due(&self, node: &Node, since_shot: &mut u32) -> bool {
        // Far from the goal a shot almost always fails after a long collision check,
        // so shots are spaced by the remaining cost as well (Nav2 does the same).
        *since_shot += 1;
        let remaining = node.h / (self.cfg.heuristic_weight * self.model.min_cost_per_metre);
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
    pub(crate) fn analytic_expansion(&mut self, node: &Node) -> Option<Shot> {
        let from = Some(pose_bits(&node.pose));
        if self.buf.rs_from != from {
            let radius = self.model.radius;
            crate::reeds_shepp::solve(&node.pose, &self.goal, radius, &mut self.buf.rs);
            self.buf.rs_from = from;
        }
        let goal = self.goal;
        self.first_free_shot(node, &goal, node.g)
    }

    /// Joins `node` to the other end's search where that search has closed the state
    /// of `node` turned half round (`meet.rs`): the cheapest collision-free analytic
    /// connection, counting what the other search's path costs from where it lands, to
    /// that node or to one of its ancestors a little further on (a connection between
    /// two poses a few centimetres apart is a jog on the spot; one that ends a metre or
    /// two on can be a gentle curve).
    #[inline]
    fn join(&mut self, node: &Node) -> Option<(Shot, u32)> {
        let other = self.other?;
        let mut k = meet::closed_in_other(other, &self.grid, self.model, &node.pose)?;
        let mut best: Option<(f64, Shot, u32)> = None;
        for step in 0..=meet::JOIN_STEPS {
            if step > 0 {
                k = other.nodes[k as usize].parent;
                if k == NONE {
                    break;
                }
            }
            if step % meet::JOIN_EVERY != 0 {
                continue;
            }
            let met = &other.nodes[k as usize];
            let target = meet::turned(&met.pose);
            crate::reeds_shepp::solve(&node.pose, &target, self.model.radius, &mut self.buf.rs);
            // The candidates are to another pose than the goal.
            self.buf.rs_from = None;
            let spent = node.g + met.g;
            if let Some(shot) = self.first_free_shot(node, &target, spent)
                && best.is_none_or(|(c, ..)| spent + shot.cost < c)
            {
                best = Some((spent + shot.cost, shot, k));
            }
        }
        best.map(|(_, shot, k)| (shot, k))
    }

    /// The first of the cheapest analytic connections from `node` to `target` (the
    /// Reeds-Shepp candidates in the buffers, and rotate-translate-rotate ones) that is
    /// collision free and lands on it, within the bound once `spent` is added.
    fn first_free_shot(&mut self, node: &Node, target: &Pose2, spent: f64) -> Option<Shot> {
        let (model, buf) = (self.model, &mut *self.buf);
        buf.shots.clear();
        for p in buf.rs.as_slice() {
            buf.shots.push(model.rs_shot(p, node.dir));
        }
        if model.allow_rotation {
            buf.shots
                .extend(model.rtr_shots(&node.pose, target, node.dir));
        }
        // Stable sort: ties keep the solver's fixed order, so the choice is deterministic.
        buf.shots.sort_by(|a, b| a.cost.total_cmp(&b.cost));
        let tries = self.cfg.analytic_candidates as usize;
        for shot in buf.shots.iter().take(tries) {
            // A weighted search can reach the goal through nodes within the bound on a
            // path above it; such a path is no use to the caller, a cheaper one may be.
            if spent + shot.cost > self.bound {
                break;
            }
            self.stats.analytic_checks += 1;
            if shot_reaches_goal(&self.checker, &node.pose, shot, target, self.stats) {
                return Some(*shot);
            }
        }
        None
    }

    /// Opens (or reopens with a lower g) the child of `node` (index `ni`) at the end of
    /// every primitive that lands on the grid, in a state not closed, is collision free
    /// and has a heuristic (its cell is reachable from the goal).
    #[inline]
    pub(crate) fn expand(&mut self, ni: usize, node: &Node) {
        let model = self.model;
        let turn = node.pose.theta.sin_cos();
        let prims = if node.parent == NONE && self.checker.start_relieved() {
            &model.prims[..]
        } else {
            &model.prims[..model.regular]
        };
        for (pi, prim) in prims.iter().enumerate() {
            let pose = prim.end_turned(&node.pose, turn);
            let Some(state) = self.grid.state(&pose, model.bin(pose.theta)) else {
                continue;
            };
            let buf = &mut *self.buf;
            let existing = buf.state_node.get(state);
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
            let Some(h2d) = self.heur.metres(self.dm, pose.x, pose.y) else {
                continue;
            };
            let child = Node {
                pose,
                g,
                h: self.cfg.heuristic_weight * h2d * model.min_cost_per_metre,
                h_grid: h2d * model.min_cost_per_metre,
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
pub(crate) fn shot_reaches_goal(
    checker: &Clearance,
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

//! The open list's order and the buffers the search keeps from request to request, so
//! that planning does not allocate in steady state: nodes, the (sparse) state table,
//! the open list, analytic candidates and the output path's scratch; `trace` walks a
//! found node's parents back to the motions of the path.
//!
//! Knows the search's node and what a motion samples to; nothing of the search's order
//! of work (`search_core.rs`).

use crate::meet;
use crate::model::{DIR_NONE, Model, Shot};
use crate::motion::Motion;
use crate::reeds_shepp::Candidates;
use crate::sampling::{append_motion, finish};
use crate::search_core::Node;
use crate::states::{NONE, SearchGrid, StateTable};
use aisle_geometry::{PathPose, Pose2};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

#[derive(Debug, Clone, Copy)]
pub(crate) struct OpenEntry {
    pub(crate) f: f64,
    pub(crate) g: f64,
    pub(crate) node: u32,
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
pub(crate) struct Buffers {
    pub(crate) nodes: Vec<Node>,
    pub(crate) state_node: StateTable,
    pub(crate) open: BinaryHeap<OpenEntry>,
    /// Under a cost bound: the open nodes whose heuristic the free-space part raised,
    /// by `g + h_grid` (`Search::all_above_bound`).
    pub(crate) raised: BinaryHeap<OpenEntry>,
    pub(crate) rs: Candidates,
    /// The pose (bits) `rs` holds the candidates from, to this request's goal: a node's
    /// analytic expansion usually follows its free-space heuristic, which solved them.
    pub(crate) rs_from: Option<[u64; 3]>,
    pub(crate) shots: Vec<Shot>,
    pub(crate) chain: Vec<u32>,
    pub(crate) smooth_scratch: Vec<PathPose>,
    /// The output path's stretches the smoothing kept, collision-checked already.
    pub(crate) checked: Vec<std::ops::Range<usize>>,
    pub(crate) raw: Vec<PathPose>,
    /// For every pose of `raw`, the index in `traced` of the motion it lies on.
    pub(crate) raw_motion: Vec<u32>,
    /// The motions `raw` was sampled from, each with the pose it leaves from.
    pub(crate) traced: Vec<(Pose2, Motion)>,
}

impl Buffers {
    pub(crate) fn reset(&mut self, grid: &SearchGrid) {
        for n in &self.nodes {
            self.state_node.set(n.state, NONE);
        }
        self.state_node.reset(grid);
        self.nodes.clear();
        self.open.clear();
        self.raised.clear();
        self.rs_from = None;
    }

    /// Sizes and touches the buffers for a search of `nodes` nodes on `grid` (`tiles`
    /// state tiles), so that a fresh process's first long search does not fault them in
    /// page by page nor copy them as they grow. Capacity only: the buffers stay empty.
    pub(crate) fn warm(&mut self, grid: &SearchGrid, nodes: usize, tiles: usize) {
        self.reset(grid);
        self.state_node.warm(grid, tiles);
        let blank = Node {
            pose: Pose2::default(),
            g: 0.0,
            h: 0.0,
            h_grid: 0.0,
            parent: NONE,
            state: 0,
            prim: 0,
            dir: DIR_NONE,
            closed: false,
            h_full: false,
        };
        self.nodes.resize(nodes, blank);
        self.nodes.clear();
        // Open entries: a node's first and its raised heuristic, and reopenings.
        let mut open = std::mem::take(&mut self.open).into_vec();
        let entry = OpenEntry {
            f: 0.0,
            g: 0.0,
            node: 0,
        };
        open.resize(2 * nodes, entry);
        open.clear();
        self.open = BinaryHeap::from(open);
    }

    pub(crate) fn push_node(&mut self, n: Node) {
        let idx = self.nodes.len() as u32;
        self.state_node.set(n.state, idx);
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
    pub(crate) fn reopen(&mut self, existing: u32, child: Node) {
        self.nodes[existing as usize] = child;
        self.open.push(OpenEntry {
            f: child.g + child.h,
            g: child.g,
            node: existing,
        });
    }

    /// Samples the motions from the start to `last`, then `shot`, then (when the shot
    /// joined the other end's search) that search's path from its node back to its start
    /// (`meet.rs`) into `raw`.
    pub(crate) fn trace(
        &mut self,
        last: usize,
        model: &Model,
        (shot, other): (&Shot, Option<(&Buffers, u32)>),
        spacing: f64,
        rot: f64,
    ) {
        self.chain.clear();
        let mut i = last as u32;
        while i != NONE {
            self.chain.push(i);
            i = self.nodes[i as usize].parent;
        }
        self.raw.clear();
        self.traced.clear();
        for w in self.chain.windows(2).rev() {
            let (child, parent) = (&self.nodes[w[0] as usize], &self.nodes[w[1] as usize]);
            self.traced
                .push((parent.pose, model.prims[child.prim as usize]));
        }
        let mut pose = self.nodes[last].pose;
        for m in shot.motions() {
            self.traced.push((pose, *m));
            pose = m.end(&pose);
        }
        if let Some((other, from)) = other {
            pose = meet::append_other_half(&mut self.traced, other, model, from);
        }
        if self.traced.is_empty() {
            self.traced.push((pose, Motion::Rotate { angle: 0.0 }));
        }
        self.raw_motion.clear();
        for (k, (from, m)) in self.traced.iter().enumerate() {
            append_motion(&mut self.raw, from, m, spacing, rot);
            self.raw_motion.resize(self.raw.len(), k as u32);
        }
        finish(&mut self.raw, pose);
        self.raw_motion.push(self.traced.len() as u32 - 1);
    }
}

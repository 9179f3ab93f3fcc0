//! Where the searches from a request's two ends meet (`both_ends.rs`): a node one
//! search closes, in the state of a node the other search has closed, joined to it by
//! an analytic connection, makes a whole path. Each search then pays only for its own
//! end: an ending that neither heuristic sees (a goal in a cross aisle reached only by
//! a turn past it and a stretch in reverse, where every state of the aisles before it
//! looks up to 1.9 cheaper than it is) costs the search from that end alone, instead of
//! the other search's flooding every state whose estimate the slack leaves open.
//!
//! The other search's path runs backwards in time: a node `c` it reached from `p` by a
//! motion `m` is, in this search's frame, the motion from `c` turned half round to `p`
//! turned half round that drives the same length with the opposite curvature (the same
//! curve, driven the other way round, along the heading turned half round) or turns on
//! the spot by the opposite angle. Reverse stays reverse.
//!
//! Knows the search's nodes, states and motions; nothing of turns or requests.

use crate::model::Model;
use crate::motion::Motion;
use crate::search_buffers::Buffers;
use crate::states::{NONE, SearchGrid};
use aisle_geometry::{Pose2, wrap_angle};
use std::f64::consts::PI;

/// How far up the other search's path a join may land, in its nodes, and every how
/// many nodes it is tried: 0, 3 and 6 nodes on (about 0, 1 and 2 m with the shipped
/// primitives).
pub(crate) const JOIN_STEPS: u32 = 6;
pub(crate) const JOIN_EVERY: u32 = 3;

/// `p` turned half round: the pose the other search knows it by.
pub(crate) fn turned(p: &Pose2) -> Pose2 {
    Pose2::new(p.x, p.y, wrap_angle(p.theta + PI))
}

/// The other search's closed node in the state of `pose` turned half round, if any.
#[inline]
pub(crate) fn closed_in_other(
    other: &Buffers,
    grid: &SearchGrid,
    model: &Model,
    pose: &Pose2,
) -> Option<u32> {
    let mirrored = turned(pose);
    let bin = model.bin(mirrored.theta);
    let bins = model.bins;
    [bin, (bin + 1) % bins, (bin + bins - 1) % bins]
        .into_iter()
        .find_map(|b| {
            let k = other.state_node.get(grid.state(&mirrored, b)?);
            (k != NONE && other.nodes[k as usize].closed).then_some(k)
        })
}

/// The motion of the other search that reached one of its nodes, as this search's
/// motion from that node (turned) to its parent (turned).
pub(crate) fn backwards(m: &Motion) -> Motion {
    match *m {
        Motion::Drive { length, curvature } => Motion::Drive {
            length,
            curvature: -curvature,
        },
        Motion::Rotate { angle } => Motion::Rotate { angle: -angle },
        Motion::Lerp { to } => Motion::Lerp { to: turned(&to) },
    }
}

/// Appends to `traced` the other search's path from its node `from` back to where it
/// started, as this search's motions (each with the pose it leaves from); returns the
/// pose they end at (the other search's start, turned: this search's goal).
pub(crate) fn append_other_half(
    traced: &mut Vec<(Pose2, Motion)>,
    other: &Buffers,
    model: &Model,
    from: u32,
) -> Pose2 {
    let mut k = from;
    loop {
        let node = &other.nodes[k as usize];
        if node.parent == NONE {
            return turned(&node.pose);
        }
        traced.push((
            turned(&node.pose),
            backwards(&model.prims[node.prim as usize]),
        ));
        k = node.parent;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &Pose2, b: &Pose2) -> bool {
        a.distance(b) < 1e-9 && a.heading_error(b) < 1e-9
    }

    /// Every kind of motion, driven from `p` to `c`, driven backwards from `c` turned
    /// ends at `p` turned, in the same direction of travel.
    #[test]
    fn a_motion_read_backwards_ends_where_the_original_started() {
        let p = Pose2::new(1.5, -2.0, 0.7);
        let motions = [
            Motion::Drive {
                length: 0.8,
                curvature: 0.0,
            },
            Motion::Drive {
                length: 0.6,
                curvature: 1.3,
            },
            Motion::Drive {
                length: -0.5,
                curvature: -0.9,
            },
            Motion::Rotate { angle: 0.4 },
            Motion::Rotate { angle: -1.1 },
        ];
        for m in &motions {
            let c = m.end(&p);
            let back = backwards(m);
            assert!(close(&back.end(&turned(&c)), &turned(&p)), "{m:?}");
            assert_eq!(back.direction(&turned(&c)), m.direction(&p), "{m:?}");
        }
    }
}

//! Docking and undocking: the straight moves under and out of a body the robot drives
//! under (a pallet rack), which side to use, and the body as an obstacle meanwhile.
//!
//! A body the robot drives under is entered only straight, through a side whose
//! corridor (the robot's footprint grown by `clearance`, swept from outside to the
//! goal) misses every part the robot can hit (the rack's legs) and every occupied cell
//! outside the body. The search itself keeps away from the whole body (its footprint is
//! marked occupied in a copy of the map), so a path never clips a leg on the way in or
//! cuts back under the body on the way out: it ends at the pose outside from which the
//! straight move starts, or starts at the pose outside where the move out ends.
//! Candidates are the four sides (or the one the mission's heading enters driving
//! forwards), and forwards or backwards out along the robot's heading or, after a
//! quarter turn in place under the body (checked swept like the move), forwards through
//! either side; the cheapest total cost wins.
//!
//! Knows nothing of the bus, of missions or of the controller that drives the moves.

use aisle_geometry::{Direction, Footprint, GridView, OCCUPIED_STATIC, PathPose, Pose2};
use std::f64::consts::FRAC_PI_2;

/// A rectangle placed in the map frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placed {
    pub pose: Pose2,
    pub footprint: Footprint,
}

/// Which straight move a request asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DockKind {
    /// The path ends under the body (at the request's goal position).
    Dock,
    /// The path starts under the body (at the request's start).
    Undock,
}

/// The body to drive under or out of, with the parts of it the robot can hit.
#[derive(Debug, Clone, Copy)]
pub struct DockSite<'a> {
    pub kind: DockKind,
    pub body: Placed,
    pub parts: &'a [Placed],
    /// Docking only: the goal's heading is free (any open side will do).
    pub free_heading: bool,
}

/// How the straight moves are laid out (`planner.toml [dock]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DockParams {
    /// Straight run, m, between the body's side and the robot's front (docking) or back
    /// (undocking) at the pose outside: room to line up before the legs.
    pub run_in: f64,
    /// Clearance, m, the swept footprint keeps from the parts and from occupied cells.
    pub clearance: f64,
    /// Spacing, m, of the poses of the straight move (and of its checks).
    pub step: f64,
}

/// One straight move: from `from` to `to` with a fixed heading, forwards or backwards;
/// an undocking move through a side of the body may first turn in place under it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Straight {
    pub from: Pose2,
    pub to: Pose2,
    pub direction: Direction,
    /// The heading the robot turns from, in place at `from`, before the move (a side
    /// exit); `None`: no turn.
    pub turn_from: Option<f64>,
}

impl Straight {
    pub fn length(&self) -> f64 {
        (self.to.x - self.from.x).hypot(self.to.y - self.from.y)
    }

    /// Poses about `step` apart from `from` to `to` inclusive, each labelled with the
    /// move's direction.
    pub fn poses(&self, step: f64) -> impl Iterator<Item = PathPose> + '_ {
        let n = (self.length() / step).ceil().max(1.0) as usize;
        (0..=n).map(move |i| {
            let f = i as f64 / n as f64;
            let pose = Pose2::new(
                self.from.x + f * (self.to.x - self.from.x),
                self.from.y + f * (self.to.y - self.from.y),
                self.from.theta,
            );
            PathPose::new(pose, self.direction)
        })
    }
}

/// How far, m, the body reaches from `at` along the unit direction `(ux, uy)`.
fn reach(body: &Placed, at: &Pose2, ux: f64, uy: f64) -> f64 {
    body.footprint
        .corners(&body.pose)
        .iter()
        .map(|&(x, y)| (x - at.x) * ux + (y - at.y) * uy)
        .fold(f64::NEG_INFINITY, f64::max)
}

/// The docking moves to consider: one per side of the body, entering forwards with the
/// side's inward heading, ending at `goal`'s position; only the one entering with
/// `goal.theta` when the heading is not free.
pub fn entries(site: &DockSite, goal: &Pose2, robot: Footprint, p: &DockParams) -> Vec<Straight> {
    let headings: Vec<f64> = if site.free_heading {
        (0..4)
            .map(|k| site.body.pose.theta + k as f64 * FRAC_PI_2)
            .collect()
    } else {
        vec![goal.theta]
    };
    headings
        .into_iter()
        .map(|h| {
            let (ux, uy) = (h.cos(), h.sin());
            let to = Pose2::new(goal.x, goal.y, aisle_geometry::wrap_angle(h));
            // Back along the heading until the robot's front is `run_in` clear of the body.
            let back = reach(&site.body, &to, -ux, -uy) + 0.5 * robot.length + p.run_in;
            let from = Pose2::new(goal.x - back * ux, goal.y - back * uy, to.theta);
            Straight {
                from,
                to,
                direction: Direction::Forward,
                turn_from: None,
            }
        })
        .collect()
}

/// The undocking moves to consider from `start` under the body: forwards and backwards
/// along the robot's heading, and forwards through either side after a quarter turn in
/// place, each until the robot is `run_in` clear of the body.
pub fn exits(site: &DockSite, start: &Pose2, robot: Footprint, p: &DockParams) -> Vec<Straight> {
    // (turn in place first, sign along the heading then, direction)
    let candidates = [
        (0.0, 1.0, Direction::Forward),
        (0.0, -1.0, Direction::Reverse),
        (FRAC_PI_2, 1.0, Direction::Forward),
        (-FRAC_PI_2, 1.0, Direction::Forward),
    ];
    candidates
        .into_iter()
        .map(|(turn, sign, direction)| {
            let h = aisle_geometry::wrap_angle(start.theta + turn);
            let (ux, uy) = (sign * h.cos(), sign * h.sin());
            let out = reach(&site.body, start, ux, uy) + 0.5 * robot.length + p.run_in;
            Straight {
                from: Pose2::new(start.x, start.y, h),
                to: Pose2::new(start.x + out * ux, start.y + out * uy, h),
                direction,
                turn_from: (turn != 0.0).then_some(start.theta),
            }
        })
        .collect()
}

/// Whether the move's swept footprint (grown by `clearance`) misses every part of the
/// body and every occupied cell of `map` outside the body.
pub fn corridor_clear(
    site: &DockSite,
    mv: &Straight,
    robot: Footprint,
    p: &DockParams,
    map: &GridView,
) -> bool {
    let swept = robot.inflated(p.clearance);
    // Cells under the body are the body's own (deck, load): only its parts count there.
    let body_zone = site.body.footprint.inflated(map.resolution);
    let clear = |at: &Pose2| {
        if site
            .parts
            .iter()
            .any(|part| swept.overlaps(at, &part.footprint, &part.pose))
        {
            return false;
        }
        !cells_under(map, &swept, at).any(|(c, cx, cy)| {
            !body_zone.contains(&site.body.pose, cx, cy) && map.occupied_or_outside(c)
        })
    };
    turn_poses(mv).all(|at| clear(&at)) && mv.poses(p.step).all(|pp| clear(&pp.pose))
}

/// Headings no more than 3 degrees apart through the turn in place before `mv` (none
/// without one): the swept check of the turn.
fn turn_poses(mv: &Straight) -> impl Iterator<Item = Pose2> + '_ {
    const STEP_RAD: f64 = 3.0 * std::f64::consts::PI / 180.0;
    let turn = mv
        .turn_from
        .map_or(0.0, |h| aisle_geometry::wrap_angle(mv.from.theta - h));
    let n = (turn.abs() / STEP_RAD).ceil() as usize;
    let from = mv.turn_from.unwrap_or(mv.from.theta);
    (0..n).map(move |i| {
        let h = from + turn * i as f64 / n as f64;
        Pose2::new(mv.from.x, mv.from.y, h)
    })
}

/// The cells (with their centres) whose centre lies in `rect` placed at `at`; cells
/// beyond the grid included (the caller decides what they mean).
fn cells_under<'m>(
    map: &'m GridView,
    rect: &'m Footprint,
    at: &'m Pose2,
) -> impl Iterator<Item = (aisle_geometry::CellIndex, f64, f64)> + 'm {
    let r = rect.circumscribed_radius();
    let lo = map.cell_of(at.x - r, at.y - r);
    let hi = map.cell_of(at.x + r, at.y + r);
    (lo.iy..=hi.iy)
        .flat_map(move |iy| (lo.ix..=hi.ix).map(move |ix| aisle_geometry::CellIndex { ix, iy }))
        .filter_map(move |c| {
            let (cx, cy) = map.cell_center(c);
            rect.contains(at, cx, cy).then_some((c, cx, cy))
        })
}

/// `map` with every cell whose centre lies within the body's footprint (grown by half a
/// cell, so that a cell the body only partly covers counts) marked occupied, in
/// `scratch`.
pub fn with_body_blocked<'s>(
    map: &GridView,
    body: &Placed,
    scratch: &'s mut Vec<u8>,
) -> GridView<'s> {
    scratch.clear();
    scratch.extend_from_slice(map.cells);
    let grown = body.footprint.inflated(0.5 * map.resolution);
    for (c, _, _) in cells_under(map, &grown, &body.pose) {
        if map.contains_cell(c) {
            scratch[c.iy as usize * map.width + c.ix as usize] = OCCUPIED_STATIC;
        }
    }
    GridView {
        cells: scratch,
        ..*map
    }
}

/// The seed's pallet rack (0.88 x 0.8 m, legs 0.05 m at +-0.415, +-0.375) at `pose`:
/// its footprint and legs, for tests.
#[cfg(test)]
pub(crate) fn seed_rack(pose: Pose2) -> (Placed, Vec<Placed>) {
    let legs = [
        (0.415, 0.375),
        (-0.415, 0.375),
        (-0.415, -0.375),
        (0.415, -0.375),
    ]
    .iter()
    .map(|&(x, y)| {
        let (wx, wy) = pose.transform_point(x, y);
        Placed {
            pose: Pose2::new(wx, wy, pose.theta),
            footprint: Footprint::new(0.05, 0.05),
        }
    })
    .collect();
    let body = Placed {
        pose,
        footprint: Footprint::new(0.88, 0.8),
    };
    (body, legs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::GridMap;

    use super::seed_rack as rack;

    const ROBOT: Footprint = Footprint::new(0.508, 0.43);
    const P: DockParams = DockParams {
        run_in: 0.5,
        clearance: 0.03,
        step: 0.05,
    };

    fn free_map() -> GridMap {
        GridMap::new_free(-5.0, -5.0, 0.1, 10.0, 10.0).unwrap()
    }

    #[test]
    fn every_side_of_the_seed_rack_is_open_and_each_entry_starts_clear_of_it() {
        let (body, legs) = rack(Pose2::new(1.0, 2.0, FRAC_PI_2));
        let site = DockSite {
            kind: DockKind::Dock,
            body,
            parts: &legs,
            free_heading: true,
        };
        let map = free_map();
        let goal = body.pose;
        let moves = entries(&site, &goal, ROBOT, &P);
        assert_eq!(moves.len(), 4);
        for mv in &moves {
            assert!(corridor_clear(&site, mv, ROBOT, &P, &map.view()), "{mv:?}");
            // The robot outside is run_in clear of the body.
            assert!(!ROBOT.inflated(P.run_in - 1e-6).overlaps(
                &mv.from,
                &body.footprint,
                &body.pose
            ));
        }
    }

    #[test]
    fn an_entry_at_an_angle_hits_a_leg_and_a_box_in_the_corridor_closes_a_side() {
        let (body, legs) = rack(Pose2::new(0.0, 0.0, 0.0));
        let stated = DockSite {
            kind: DockKind::Dock,
            body,
            parts: &legs,
            free_heading: false,
        };
        let map = free_map();
        let skew = entries(&stated, &Pose2::new(0.0, 0.0, 0.6), ROBOT, &P);
        assert_eq!(skew.len(), 1);
        assert!(!corridor_clear(&stated, &skew[0], ROBOT, &P, &map.view()));
        // A box just outside the +x side blocks the entry from +x (heading pi).
        let mut blocked = free_map();
        let c = blocked.view().cell_of(1.0, 0.0);
        blocked.set(c, OCCUPIED_STATIC);
        let from_east = entries(
            &stated,
            &Pose2::new(0.0, 0.0, std::f64::consts::PI),
            ROBOT,
            &P,
        );
        assert!(!corridor_clear(
            &stated,
            &from_east[0],
            ROBOT,
            &P,
            &blocked.view()
        ));
        let from_west = entries(&stated, &Pose2::new(0.0, 0.0, 0.0), ROBOT, &P);
        assert!(corridor_clear(
            &stated,
            &from_west[0],
            ROBOT,
            &P,
            &blocked.view()
        ));
    }

    #[test]
    fn exits_leave_forwards_and_backwards_clear_of_the_body() {
        let (body, legs) = rack(Pose2::new(0.0, 0.0, 0.0));
        let site = DockSite {
            kind: DockKind::Undock,
            body,
            parts: &legs,
            free_heading: false,
        };
        let start = Pose2::new(0.0, 0.0, FRAC_PI_2);
        let moves = exits(&site, &start, ROBOT, &P);
        assert_eq!(moves[0].direction, Direction::Forward);
        assert!((moves[0].to.y - (0.4 + 0.254 + 0.5)).abs() < 1e-9);
        assert!((moves[1].to.y + (0.4 + 0.254 + 0.5)).abs() < 1e-9);
        for mv in &moves {
            assert!(corridor_clear(&site, mv, ROBOT, &P, &free_map().view()));
        }
    }

    #[test]
    fn the_blocked_copy_covers_the_body_and_nothing_else() {
        let (body, _) = rack(Pose2::new(0.0, 0.0, 0.3));
        let map = free_map();
        let mut scratch = Vec::new();
        let blocked = with_body_blocked(&map.view(), &body, &mut scratch);
        assert!(blocked.occupied_at(0.0, 0.0));
        assert!(blocked.occupied_at(0.4, 0.1));
        assert!(!blocked.occupied_at(0.8, 0.8));
        assert_eq!(map.view().cells.iter().filter(|&&c| c != 0).count(), 0);
    }
}

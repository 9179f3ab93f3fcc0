//! Straight moves (docking): into the gap between a rack's four legs on a 0.1 m grid
//! and out of it backwards, a blocked line, determinism, and the optimiser reaching a
//! pre-dock pose within a tight goal tolerance.
//!
//! The step loop is the node's and the simulator's: a step, its timeline driven open
//! loop for one 0.5 s period with the exact unicycle arc every 10 ms, the next step.

use aisle_geometry::{CellIndex, Footprint, GridMap, OCCUPIED_DETECTED, Pose2, wrap_angle};

use super::{PERIOD, RES, ROBOT, follow, straight_path, unicycle};
use crate::clearance::overlaps_occupied;
use crate::{ExitFlag, Goal, Mode, StepOutput, TebConfig, TebController};

/// The rack's centre (its legs at +-0.415 along x, +-0.375 along y, 0.05 m square:
/// openings of 0.78 m between them across x and 0.70 m across y).
const RACK_CENTRE: Pose2 = Pose2::new(3.0, 1.0, 0.0);
const PRE_DOCK_TOLERANCE: [f64; 3] = [0.08, 0.04, 0.06];

/// The four legs of a rack centred at `c` (axis-aligned), as squares.
fn legs(c: &Pose2) -> Vec<[f64; 4]> {
    let mut out = Vec::new();
    for (sx, sy) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
        let (x, y) = (c.x + sx * 0.415, c.y + sy * 0.375);
        out.push([x - 0.025, y - 0.025, x + 0.025, y + 0.025]);
    }
    out
}

/// A 15 x 15 m local map centred on the robot with every cell that any part of a box
/// covers occupied (a 0.05 m leg fills one to four cells).
fn map_of(robot: &Pose2, boxes: &[[f64; 4]]) -> GridMap {
    let ox = ((robot.x - 7.5) / RES).round() * RES;
    let oy = ((robot.y - 7.5) / RES).round() * RES;
    let mut g = GridMap::new_free(ox, oy, RES, 15.0, 15.0).unwrap();
    for b in boxes {
        let lo = g.view().cell_of(b[0], b[1]);
        let hi = g.view().cell_of(b[2] - 1e-9, b[3] - 1e-9);
        for iy in lo.iy..=hi.iy {
            for ix in lo.ix..=hi.ix {
                g.set(CellIndex { ix, iy }, OCCUPIED_DETECTED);
            }
        }
    }
    g
}

/// Exact clearance from the footprint at `p` to the boxes themselves (not their cells).
fn true_clearance(fp: &Footprint, p: &Pose2, boxes: &[[f64; 4]]) -> f64 {
    let mut best = f64::INFINITY;
    for b in boxes {
        for (x, y) in [(b[0], b[1]), (b[2], b[1]), (b[2], b[3]), (b[0], b[3])] {
            best = best.min(fp.signed_distance(p, x, y));
        }
        for (x, y) in fp.corners(p) {
            let dx = (b[0] - x).max(x - b[2]).max(0.0);
            let dy = (b[1] - y).max(y - b[3]).max(0.0);
            best = best.min(if dx == 0.0 && dy == 0.0 {
                -1.0
            } else {
                dx.hypot(dy)
            });
        }
    }
    best
}

fn straight(target: Pose2, tolerance: Option<[f64; 3]>) -> Goal {
    Goal {
        reference: Vec::new(),
        footprint: ROBOT,
        margin: 0.1,
        mode: Mode::Straight { target },
        tolerance,
    }
}

struct Docked {
    reached: bool,
    pose: Pose2,
    steps: usize,
    flags: Vec<u8>,
    /// Smallest exact clearance of the driven footprint to the legs, m.
    clearance: f64,
    outputs: Vec<StepOutput>,
}

/// The step loop; every rolled-out pose is checked against the grid with the footprint
/// grown by the docking margin, every driven pose against the true boxes.
fn dock(goal: &Goal, boxes: &[[f64; 4]], start: Pose2, max_steps: usize) -> Docked {
    let cfg = TebConfig::default();
    let inflated = goal.footprint.inflated(cfg.straight.margin);
    let mut teb = TebController::new(cfg.clone()).unwrap();
    teb.set_goal(goal).unwrap();
    let (mut pose, mut v, mut w, mut t) = (start, 0.0, 0.0, 0.0);
    let mut run = Docked {
        reached: false,
        pose,
        steps: 0,
        flags: Vec::new(),
        clearance: f64::INFINITY,
        outputs: Vec::new(),
    };
    for _ in 0..max_steps {
        let map = map_of(&pose, boxes);
        let out = teb.step(pose, (v, w), t, &map.view()).unwrap();
        run.steps += 1;
        run.flags.push(out.exit_flag.code());
        run.outputs.push(out.clone());
        if out.reached_goal {
            run.reached = true;
            break;
        }
        for p in &out.poses {
            assert!(
                !overlaps_occupied(&map.view(), &inflated, &p.pose),
                "rolled-out pose {p:?} overlaps the map"
            );
        }
        for pair in out.commands.windows(2) {
            assert!(pair[1].t > pair[0].t, "{:?}", out.commands);
            let dt = pair[1].t - pair[0].t;
            assert!((pair[1].v - pair[0].v).abs() <= cfg.limits.max_acceleration * dt + 1e-9);
            assert!(
                (pair[1].w - pair[0].w).abs() <= cfg.limits.max_angular_acceleration * dt + 1e-9
            );
        }
        let commands = out.commands.clone();
        let sub = 0.01;
        for k in 0..(PERIOD / sub).round() as usize {
            let (cv, cw) = crate::command_at(&commands, t + k as f64 * sub + 1e-9);
            assert!(cv.abs() <= cfg.straight.speed + 1e-9, "{cv}");
            assert!(cw.abs() <= cfg.limits.max_angular_velocity + 1e-9, "{cw}");
            pose = unicycle(&pose, cv, cw, sub);
            (v, w) = (cv, cw);
            run.clearance = run
                .clearance
                .min(true_clearance(&goal.footprint, &pose, boxes));
        }
        t += PERIOD;
    }
    run.pose = pose;
    run
}

/// Along, across (m) and heading (rad) errors of `p` in the frame of `target`.
fn errors(p: &Pose2, target: &Pose2) -> (f64, f64, f64) {
    let (lx, ly) = target.inverse_transform_point(p.x, p.y);
    (lx, ly, wrap_angle(p.theta - target.theta))
}

#[test]
fn docking_threads_the_legs_from_an_offset_start() {
    let boxes = legs(&RACK_CENTRE);
    // 1.5 m before the centre (the robot's front 0.33 m before the legs), 0.15 m off
    // the line and turned 0.15 rad further away from it.
    let start = Pose2::new(1.5, 1.15, 0.15);
    let tol = [0.02, 0.02, 0.02];
    let run = dock(&straight(RACK_CENTRE, Some(tol)), &boxes, start, 20);
    let (ex, ey, eh) = errors(&run.pose, &RACK_CENTRE);
    println!(
        "docking: {} steps, flags {:?}, final error along {ex:.4} m, across {ey:.4} m, \
         heading {eh:.4} rad, least clearance to a leg {:.3} m",
        run.steps, run.flags, run.clearance
    );
    assert!(run.reached, "{:?} flags {:?}", run.pose, run.flags);
    assert!(ex.abs() <= tol[0] && ey.abs() <= tol[1] && eh.abs() <= tol[2]);
    assert!(run.clearance > 0.0, "clearance {}", run.clearance);
    assert!(run.flags.iter().all(|&f| f == 0), "{:?}", run.flags);
    // It drove forwards only.
    for out in &run.outputs {
        assert!(
            out.commands.iter().all(|c| c.v >= 0.0),
            "{:?}",
            out.commands
        );
    }
}

#[test]
fn docking_through_the_other_side_turns_on_the_spot_first() {
    // Into the 0.78 m opening along y from the south, starting 0.6 rad off the line.
    let boxes = legs(&RACK_CENTRE);
    let target = Pose2::new(3.0, 1.0, std::f64::consts::FRAC_PI_2);
    let start = Pose2::new(3.05, -0.3, std::f64::consts::FRAC_PI_2 + 0.6);
    let run = dock(&straight(target, None), &boxes, start, 20);
    let first = &run.outputs[0].commands;
    assert_eq!(first[0].v, 0.0);
    assert!(first[0].w < 0.0, "{:?}", &first[..3]);
    let (ex, ey, eh) = errors(&run.pose, &target);
    println!(
        "other side: {} steps, error {ex:.4} {ey:.4} {eh:.4}",
        run.steps
    );
    assert!(run.reached, "{:?} flags {:?}", run.pose, run.flags);
    assert!(run.clearance > 0.0, "clearance {}", run.clearance);
}

#[test]
fn undocking_backs_out_of_the_gap() {
    let boxes = legs(&RACK_CENTRE);
    // Under the rack, a little off its centre, leaving backwards to the west.
    let start = Pose2::new(3.02, 0.99, 0.03);
    let target = Pose2::new(1.7, 1.0, 0.0);
    let tol = [0.02, 0.02, 0.02];
    let run = dock(&straight(target, Some(tol)), &boxes, start, 20);
    let (ex, ey, eh) = errors(&run.pose, &target);
    println!(
        "undocking: {} steps, final error along {ex:.4} m, across {ey:.4} m, heading \
         {eh:.4} rad, least clearance {:.3} m",
        run.steps, run.clearance
    );
    assert!(run.reached, "{:?} flags {:?}", run.pose, run.flags);
    assert!(run.clearance > 0.0);
    for out in &run.outputs {
        assert!(
            out.commands.iter().all(|c| c.v <= 0.0),
            "{:?}",
            out.commands
        );
    }
    assert!(run.outputs[0].commands.iter().any(|c| c.v < -0.1));
}

#[test]
fn a_blocked_line_stops_short_then_reports_a_collision() {
    // A box across the line 0.6 m before the rack's legs.
    let mut boxes = legs(&RACK_CENTRE);
    boxes.push([1.9, 0.7, 2.0, 1.3]);
    let start = Pose2::new(0.6, 1.0, 0.0);
    let run = dock(&straight(RACK_CENTRE, None), &boxes, start, 12);
    assert!(!run.reached);
    let last = run.outputs.last().unwrap();
    assert_eq!(last.exit_flag, ExitFlag::Collision, "{:?}", run.flags);
    assert_eq!(last.commands.len(), 1);
    assert_eq!(last.command_at(last.t0 + 0.2), (0.0, 0.0));
    // It drove up to the box (its front within a few centimetres) without touching it.
    let front = run.pose.x + 0.5 * ROBOT.length;
    assert!(front > 1.8 && front < 1.9, "front at {front}");
    assert!(run.clearance > 0.0);
    // Standing right before it: the first step already stops.
    let mut teb = TebController::new(TebConfig::default()).unwrap();
    teb.set_goal(&straight(RACK_CENTRE, None)).unwrap();
    let p = Pose2::new(1.9 - 0.5 * ROBOT.length - 0.01, 1.0, 0.0);
    let map = map_of(&p, &boxes);
    let out = teb.step(p, (0.0, 0.0), 4.0, &map.view()).unwrap();
    assert_eq!(out.exit_flag.code(), 1);
    assert_eq!(out.commands.len(), 1);
    assert_eq!(out.command_at(4.1), (0.0, 0.0));
}

#[test]
fn straight_moves_are_bitwise_repeatable_and_restorable() {
    let boxes = legs(&RACK_CENTRE);
    let goal = straight(RACK_CENTRE, Some(PRE_DOCK_TOLERANCE));
    let start = Pose2::new(1.5, 1.1, -0.1);
    let a = dock(&goal, &boxes, start, 20);
    let b = dock(&goal, &boxes, start, 20);
    assert_eq!(a.outputs, b.outputs);
    assert!(a.reached);
    // No band: the snapshot is empty and restores as such.
    let mut teb = TebController::new(TebConfig::default()).unwrap();
    teb.set_goal(&goal).unwrap();
    let map = map_of(&start, &boxes);
    teb.step(start, (0.0, 0.0), 0.0, &map.view()).unwrap();
    let snap = teb.snapshot();
    assert!(snap.band.is_empty());
    let mut c = TebController::new(TebConfig::default()).unwrap();
    c.set_goal(&goal).unwrap();
    c.restore(&snap).unwrap();
    let got = c.step(start, (0.0, 0.0), 0.0, &map.view()).unwrap();
    assert_eq!(got, &a.outputs[0]);
}

#[test]
fn the_optimiser_reaches_a_pre_dock_pose_within_the_tight_tolerance() {
    // Straight references to the pre-dock pose (2, 0, 0), the robot 0.15 m to their
    // side, at times also turned.
    let end = Pose2::new(2.0, 0.0, 0.0);
    let t = PRE_DOCK_TOLERANCE;
    for (x0, start) in [
        (0.0, Pose2::new(0.0, 0.15, 0.0)),
        (0.0, Pose2::new(0.0, -0.15, 0.2)),
        (0.8, Pose2::new(0.8, 0.15, -0.1)),
    ] {
        let mut goal = follow(straight_path(x0, 2.0, 0.0), ROBOT, 0.1);
        goal.tolerance = Some(PRE_DOCK_TOLERANCE);
        let run = super::drive(&goal, &vec![], start, 30);
        let (ex, ey, eh) = errors(&run.final_pose, &end);
        println!(
            "TEB to a pre-dock pose from {start:?}: {} steps, error along {ex:.4} m, \
             across {ey:.4} m, heading {eh:.4} rad, flags {:?}",
            run.steps, run.flags
        );
        assert!(run.reached, "{:?} flags {:?}", run.final_pose, run.flags);
        assert!(ex.abs() <= t[0] && ey.abs() <= t[1] && eh.abs() <= t[2]);
        assert!(run.steps <= 12, "{} steps", run.steps);
    }
}

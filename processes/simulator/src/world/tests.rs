use super::*;
use aisle_config::testing::shipped;
use aisle_robot::{RobotConfig, RobotModel};
use std::f64::consts::FRAC_PI_2;
use std::path::Path;

const DT: u64 = DEFAULT_DT_NS;

fn robot() -> (RobotConfig, RobotModel) {
    aisle_robot::load_robot(&shipped("robot.toml")).unwrap()
}

fn warehouse() -> Scene {
    Scene::load(&shipped("warehouse.toml")).unwrap()
}

fn warehouse_at(start: Pose2) -> World {
    let (cfg, model) = robot();
    World::new_at(&warehouse(), &model, &cfg, start).unwrap()
}

/// One 1 x 1 x 1 box at (3, 0) and nothing else.
fn one_box_world(start: Pose2) -> World {
    let text = r#"
[[body]]
name = "crate"
kind = "box"
static = false
pose = [3.0, 0.0, 0.0]
size = [1.0, 1.0, 1.0]
"#;
    let scene = Scene::parse(Path::new("one.toml"), text).unwrap();
    let (cfg, model) = robot();
    World::new_at(&scene, &model, &cfg, start).unwrap()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

/// Straight at `v` for `secs`, in 0.1 s entries so the watchdog never cuts in early,
/// then a stop command.
fn straight(v: f64, secs: f64) -> Vec<(f64, f64, f64)> {
    let n = (secs * 10.0).round() as usize;
    let mut c: Vec<_> = (0..n).map(|k| (k as f64 * 0.1, v, 0.0)).collect();
    c.push((secs, 0.0, 0.0));
    c
}

fn run(world: &mut World, steps: usize) -> Vec<StepReport> {
    (0..steps).map(|_| world.step(DT)).collect()
}

#[test]
fn the_shipped_start_is_free_and_a_start_inside_a_body_is_refused() {
    let (cfg, model) = robot();
    let w = World::new(&warehouse(), &model, &cfg).unwrap();
    assert_eq!(w.robot_state().pose, Pose2::new(0.0, 0.0, 0.0));
    assert!(w.min_clearance() > 0.3, "{}", w.min_clearance());
    let e = World::new_at(&warehouse(), &model, &cfg, Pose2::new(2.6, 1.2, 0.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("pallet_leg2"), "{e}");
    let e = World::new_at(&warehouse(), &model, &cfg, Pose2::new(5.0, 10.0, 0.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("rack_row_2"), "{e}");
    assert!(matches!(
        World::new_at(&warehouse(), &model, &cfg, Pose2::new(f64::NAN, 0.0, 0.0)),
        Err(SimError::StartNotFinite { .. })
    ));
}

#[test]
fn zero_order_hold_inside_one_step_and_the_watchdog_stop() {
    let mut w = one_box_world(Pose2::default());
    // Nothing in force before 50 ms, 1 m/s until 80 ms, then 2 m/s.
    w.set_timeline(50_000_000, &[(0.0, 1.0, 0.0), (0.03, 2.0, 0.0)])
        .unwrap();
    let r = w.step(DT);
    assert!(close(r.robot.pose.x, 0.03 + 0.04), "{:?}", r.robot.pose);
    assert_eq!(r.robot.twist.v, 2.0);
    assert!(!r.robot.watchdog_stopped);
    // The last command holds 0.3 s from its stamp (80 ms): until 380 ms.
    run(&mut w, 2);
    assert!(!w.robot_state().watchdog_stopped);
    let r = w.step(DT);
    assert_eq!(r.time_ns, 400_000_000);
    assert!(
        close(r.robot.pose.x, 0.07 + 2.0 * 0.28),
        "{:?}",
        r.robot.pose
    );
    assert!(r.robot.watchdog_stopped);
    assert_eq!(r.robot.twist, Twist::default());
    let x = r.robot.pose.x;
    run(&mut w, 10);
    assert_eq!(w.robot_state().pose.x, x, "stopped robot stays put");
}

#[test]
fn explicit_stop_and_no_timeline_keep_the_robot_still() {
    let mut w = one_box_world(Pose2::new(0.0, 0.0, 0.3));
    run(&mut w, 3);
    assert_eq!(w.robot_state().pose, Pose2::new(0.0, 0.0, 0.3));
    w.set_timeline(w.time_ns(), &straight(0.5, 2.0)).unwrap();
    w.step(DT);
    w.stop();
    let p = w.robot_state().pose;
    w.step(DT);
    assert_eq!(w.robot_state().pose, p);
    assert!(w.robot_state().watchdog_stopped);
}

#[test]
fn wheel_limits_apply_in_the_world() {
    let mut w = one_box_world(Pose2::new(0.0, -2.0, 0.0));
    w.set_timeline(0, &[(0.0, 5.0, 0.0)]).unwrap();
    let r = w.step(DT);
    assert!(r.robot.wheels_clamped);
    assert_eq!(r.robot.wheels.left, 34.0);
    assert!(close(r.robot.pose.x, 34.0 * 0.065 * 0.1));
}

#[test]
fn clearance_and_collision_events_against_a_box() {
    // Robot front edge at 0.254; the box's near face at 2.5.
    let mut w = one_box_world(Pose2::default());
    assert!(close(w.min_clearance(), 2.5 - 0.254));
    w.set_timeline(0, &straight(1.0, 2.5)).unwrap();
    let reports = run(&mut w, 30);
    let first = reports.iter().position(|r| r.contacts > 0).unwrap();
    // Contact once the front passes 2.5: x >= 2.246, i.e. after 2.3 s (step 23).
    assert_eq!(first, 22);
    assert_eq!(reports[first].first_contact, Some(0));
    assert_eq!(reports[first].new_collisions, 1);
    assert!(reports[first + 1..].iter().all(|r| r.new_collisions == 0));
    assert_eq!(w.collisions(), 1, "staying in contact is one event");
    assert_eq!(w.min_clearance(), 0.0);
    assert!(
        close(reports[10].clearance, 2.5 - 0.254 - 1.1),
        "{}",
        reports[10].clearance
    );
    // Back out and in again: a second event.
    w.set_timeline(w.time_ns(), &straight(-1.0, 1.0)).unwrap();
    run(&mut w, 12);
    assert!(!w.in_contact(0));
    w.set_timeline(w.time_ns(), &straight(1.0, 1.0)).unwrap();
    run(&mut w, 12);
    assert_eq!(w.collisions(), 2);
}

#[test]
fn under_a_rack_deck_is_free_but_a_leg_is_hit() {
    // rack2b stands at (2, 13) turned by pi/2: legs at x = 2 +- 0.375, y = 13 +- 0.415.
    let mut w = warehouse_at(Pose2::new(2.0, 11.5, FRAC_PI_2));
    w.set_timeline(0, &straight(1.0, 1.5)).unwrap();
    let reports = run(&mut w, 20);
    assert!(reports.iter().all(|r| r.contacts == 0));
    assert!(close(w.robot_state().pose.y, 13.0));
    assert!(close(w.robot_state().pose.x, 2.0));
    assert_eq!(w.collisions(), 0);
    // The legs (heights 0 to 0.30) are the nearest thing under the deck: robot corner
    // (2.215, 13.254) to leg corner (2.35, 13.39), diagonally.
    let rack = w.body_index("rack2b").unwrap();
    assert_eq!(reports[19].nearest_body, Some(rack));
    let leg_gap = (0.375 - 0.025 - 0.215f64).hypot(0.415 - 0.025 - 0.254);
    assert!(
        close(reports[19].clearance, leg_gap),
        "{}",
        reports[19].clearance
    );

    // Offset by 0.3 m the robot's side (x up to 2.515) meets the legs at x = 2.35..2.40.
    let mut w = warehouse_at(Pose2::new(2.3, 11.5, FRAC_PI_2));
    w.set_timeline(0, &straight(1.0, 1.5)).unwrap();
    let reports = run(&mut w, 20);
    let hit = reports.iter().find(|r| r.contacts > 0).unwrap();
    assert_eq!(hit.first_contact, Some(rack));
    assert_eq!(w.collisions(), 1);
}

#[test]
fn a_carried_rack_moves_with_the_robot_and_stays_at_the_drop() {
    let mut w = warehouse_at(Pose2::new(2.0, 13.0, 0.0));
    let rack = w.body_index("rack2b").unwrap();
    w.attach_by_name("rack2b").unwrap();
    assert_eq!(w.carried().map(|c| c.body), Some(rack));
    // Turn in place by +pi/2 (rigid grasp: the rack turns too), then drive 1 m.
    let w_rate = FRAC_PI_2 / 1.0;
    let mut cmds = vec![(0.0, 0.0, w_rate), (0.5, 0.0, w_rate)];
    cmds.extend(straight(1.0, 1.0).iter().map(|&(t, v, r)| (t + 1.0, v, r)));
    w.set_timeline(0, &cmds).unwrap();
    let reports = run(&mut w, 25);
    assert!(
        reports.iter().all(|r| r.contacts == 0),
        "{:?}",
        reports.last()
    );
    let p = w.robot_state().pose;
    assert!(
        close(p.x, 2.0) && close(p.y, 14.0) && close(p.theta, FRAC_PI_2),
        "{p:?}"
    );
    let b = w.bodies()[rack].pose;
    assert!(
        close(b.x, 2.0) && close(b.y, 14.0) && close(b.theta.abs(), std::f64::consts::PI),
        "{b:?}"
    );
    assert_eq!(w.detach().unwrap(), rack);
    // Back out 1 m: the rack stays at the drop pose and the robot passes between its legs.
    w.set_timeline(w.time_ns(), &straight(-1.0, 1.0)).unwrap();
    let reports = run(&mut w, 12);
    assert!(reports.iter().all(|r| r.contacts == 0));
    assert!(close(w.robot_state().pose.y, 13.0));
    assert_eq!(w.bodies()[rack].pose, b);
    assert!(matches!(w.detach(), Err(SimError::NotCarrying)));
}

#[test]
fn a_carried_rack_collides_by_its_parts() {
    // Carry rack2b east towards rack_row_2 (x from 4.5): the robot's front stops
    // short of it (4.454) while the rack's legs and cartons reach into it.
    let mut w = warehouse_at(Pose2::new(2.0, 13.0, 0.0));
    w.attach_by_name("rack2b").unwrap();
    w.set_timeline(0, &straight(1.0, 2.2)).unwrap();
    run(&mut w, 25);
    let p = w.robot_state().pose;
    assert!(close(p.x, 4.2) && p.x + 0.254 < 4.5, "{p:?}");
    let row = w.body_index("rack_row_2").unwrap();
    assert!(w.in_contact(row));
    assert_eq!(w.collisions(), 1);
    assert_eq!(w.min_clearance(), 0.0);
}

#[test]
fn attach_refuses_what_cannot_be_carried() {
    let mut w = warehouse_at(Pose2::new(2.0, 13.0, 0.0));
    assert!(matches!(
        w.attach_by_name("wall_north"),
        Err(SimError::StaticBody { .. })
    ));
    let e = w.attach_by_name("rack2a").unwrap_err().to_string();
    assert!(e.contains("rack2a") && e.contains("not under"), "{e}");
    assert!(matches!(
        w.attach_by_name("nope"),
        Err(SimError::UnknownBody { .. })
    ));
    assert!(matches!(
        w.attach(999),
        Err(SimError::BodyIndex { index: 999, .. })
    ));
    w.attach_by_name("rack2b").unwrap();
    let e = w.attach_by_name("rack2b").unwrap_err().to_string();
    assert!(e.contains("already carrying `rack2b`"), "{e}");
}

/// A mission-like drive: pick, turn, carry, with collisions along the way.
fn scripted(w: &mut World, from: usize, to: usize, log: &mut Vec<String>) {
    for k in from..to {
        match k {
            0 => w
                .set_timeline(0, &[(0.0, 0.8, 0.3), (0.7, 1.2, -0.2), (1.9, 2.5, 0.9)])
                .unwrap(),
            14 => w
                .set_timeline(w.time_ns() + 30_000_000, &straight(0.7, 1.3))
                .unwrap(),
            30 => w
                .set_timeline(w.time_ns(), &[(0.0, 0.0, 1.0), (0.45, 0.3, 0.0)])
                .unwrap(),
            _ => {}
        }
        let r = w.step(DT);
        log.push(format!("{r:?}"));
    }
}

#[test]
fn snapshot_and_restore_continue_bit_for_bit() {
    let start = Pose2::new(2.0, 12.0, FRAC_PI_2);
    let mut a = warehouse_at(start);
    let mut log_a = Vec::new();
    scripted(&mut a, 0, 10, &mut log_a);
    a.set_timeline(a.time_ns(), &straight(1.0, 1.0)).unwrap();
    log_a.push(format!("{:?}", a.step(DT)));
    for _ in 0..9 {
        log_a.push(format!("{:?}", a.step(DT)));
    }
    a.attach_by_name("rack2b").ok();
    scripted(&mut a, 20, 25, &mut log_a);
    let snap = a.snapshot();
    let cut = log_a.len();
    scripted(&mut a, 25, 60, &mut log_a);

    // A fresh simulator restarted from the snapshot.
    let mut b = warehouse_at(Pose2::new(0.0, 0.0, 0.0));
    b.restore(&snap).unwrap();
    assert_eq!(format!("{:?}", b.snapshot()), format!("{snap:?}"));
    let mut log_b = log_a[..cut].to_vec();
    scripted(&mut b, 25, 60, &mut log_b);
    assert_eq!(log_a, log_b);
    assert_eq!(format!("{:?}", a.snapshot()), format!("{:?}", b.snapshot()));
    assert!(
        b.collisions() > 0 || b.carried().is_some(),
        "the script exercises state"
    );

    // Snapshots from another scene are refused.
    let mut other = one_box_world(Pose2::default());
    assert!(matches!(
        other.restore(&snap),
        Err(SimError::Snapshot { .. })
    ));
}

#[test]
fn same_inputs_give_identical_runs() {
    let go = || {
        let mut w = warehouse_at(Pose2::new(0.0, 0.0, 0.0));
        let mut log = Vec::new();
        scripted(&mut w, 0, 60, &mut log);
        (log, format!("{:?}", w.snapshot()))
    };
    assert_eq!(go(), go());
}

#[test]
fn the_nearest_body_hint_changes_no_report() {
    // Drive past racks and into a shelf row while carrying, and compare every step
    // with a copy that sweeps without the hint.
    let mut w = warehouse_at(Pose2::new(2.0, 13.0, 0.0));
    w.attach_by_name("rack2b").unwrap();
    w.set_timeline(
        0,
        &[
            (0.0, 0.0, 1.0),
            (1.0, 0.8, 0.0),
            (3.0, 0.6, -0.7),
            (5.0, 1.0, 0.2),
        ],
    )
    .unwrap();
    let mut contacts = 0;
    for _ in 0..80 {
        let mut cold = w.clone();
        cold.last_nearest = None;
        let hot = w.step(DT);
        assert_eq!(format!("{hot:?}"), format!("{:?}", cold.step(DT)));
        assert_eq!(w.in_contact, cold.in_contact);
        contacts += hot.contacts;
    }
    assert!(contacts > 0, "the drive should touch something");
}

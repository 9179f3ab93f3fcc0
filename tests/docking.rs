//! System tests of docking as a capability (issue 15): every movable rack picked from
//! each of its sides, a rack set down at four headings and left again, and a start
//! inside the storage area; no mission here says `depart`. Each run is the real group in
//! lockstep; a collision would fail the run (exit 1).

mod support;

use aisle_config::scene::Scene;
use std::f64::consts::{FRAC_PI_2, PI};
use support::*;

/// The rack's centre and yaw, from the shipped scene.
fn rack(name: &str) -> [f64; 3] {
    let scene = Scene::load(&config_dir().join("warehouse.toml")).unwrap();
    let (_, b) = scene.body(name).unwrap();
    [b.pose.x, b.pose.y, b.pose.theta]
}

/// Runs `legs` from `start` in lockstep and asserts success with no collision.
fn succeeds(name: &str, start: [f64; 3], legs: &str) {
    assert!(!legs.contains("depart"));
    let dir = TestDir::new(name);
    let text = format!(
        "start = {start:?}\nleg_timeout_s = 90.0\nmax_replans_per_leg = 12\nreplan_cooldown_steps = 2\n{legs}"
    );
    let mission = dir.path("mission.toml");
    std::fs::write(&mission, text).unwrap();
    let report = dir.path("report.json");
    let out = run(
        &dir.run_dir(),
        &[
            "run",
            "--quiet",
            "--mission",
            mission.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ],
    );
    let r: aisle_supervisor::report::RunReport =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert!(
        out.status.success() && r.success && r.collisions == 0,
        "{name}: {:?} collisions {}\n{}",
        r.failure,
        r.collisions,
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Picks `name` entering with heading `h` (driving forwards), carries it to the seed's
/// drop pose and parks: the park leg starts under the rack and must leave it.
fn pick_from_each_side(name: &str) {
    let [x, y, yaw] = rack(name);
    for k in 0..4 {
        let h = yaw + k as f64 * FRAC_PI_2;
        let legs = format!(
            "[[leg]]\nname = \"to pick\"\ngoal = [{x}, {y}, {h}]\napproach = \"{name}\"\n\
             [[leg]]\nname = \"carry\"\ngoal = [6.0, -7.0, 0.0]\ncarry = \"{name}\"\n\
             [[leg]]\nname = \"park\"\ngoal = [6.0, 8.0, {FRAC_PI_2}]\n"
        );
        succeeds(&format!("dock-{name}-{k}"), [0.0, 0.0, 0.0], &legs);
    }
}

#[test]
fn rack2b_is_picked_from_each_of_its_sides() {
    pick_from_each_side("rack2b");
}

#[test]
fn rack2a_is_picked_from_each_of_its_sides() {
    pick_from_each_side("rack2a");
}

#[test]
fn rack1b_is_picked_from_each_of_its_sides() {
    pick_from_each_side("rack1b");
}

/// The side left to the planner, the rack set down at four headings, left again.
#[test]
fn a_rack_is_set_down_at_four_headings_and_left_again() {
    for (k, h) in [0.0, FRAC_PI_2, PI, -FRAC_PI_2].iter().enumerate() {
        let legs = format!(
            "[[leg]]\nname = \"to pick\"\napproach = \"rack2b\"\n\
             [[leg]]\nname = \"carry\"\ngoal = [6.0, -6.5, {h}]\ncarry = \"rack2b\"\n\
             [[leg]]\nname = \"park\"\ngoal = [2.0, -3.0, 0.0]\n"
        );
        succeeds(&format!("drop-{k}"), [0.0, 0.0, 0.0], &legs);
    }
}

/// The robot starts between the rack rows and picks the rack in front of it.
#[test]
fn a_start_inside_the_storage_area() {
    let legs = "[[leg]]\nname = \"to pick\"\napproach = \"rack2a\"\n\
                [[leg]]\nname = \"carry\"\ngoal = [6.0, -7.0, 0.0]\ncarry = \"rack2a\"\n";
    succeeds("storage-start", [3.3, 10.0, FRAC_PI_2], legs);
}

//! System tests of docking as a capability (issue 15): every movable rack picked from
//! each of its sides, a rack set down at four headings and left again, and a start
//! inside the storage area, two racks in one mission; no mission here says `depart`. Each run is the real group in
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
    let m = mission.to_str().unwrap();
    succeeds_with(name, &dir, &["--mission", m]);
}

/// `aisle run --quiet --report .. <args>` in `dir`: asserts success with no collision and
/// returns the report.
fn succeeds_with(name: &str, dir: &TestDir, args: &[&str]) -> aisle_supervisor::report::RunReport {
    let report = dir.path("report.json");
    let mut all = vec!["run", "--quiet", "--report", report.to_str().unwrap()];
    all.extend_from_slice(args);
    let out = run(&dir.run_dir(), &all);
    let r: aisle_supervisor::report::RunReport =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert!(
        out.status.success() && r.success && r.collisions == 0,
        "{name}: {:?} collisions {}\n{}\n{}",
        r.failure,
        r.collisions,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    r
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

/// Two racks in one mission: the leg to the second starts under the first, just set
/// down, and ends under the second, whose legs the lidar has seen (so its centre is
/// occupied on the map): the move out of the first, then the way in to the second.
#[test]
fn two_racks_are_carried_in_one_mission() {
    let legs = format!(
        "[[leg]]\nname = \"to pick 2b\"\napproach = \"rack2b\"\n\
         [[leg]]\nname = \"carry 2b\"\ngoal = [6.0, -7.0, 0.0]\ncarry = \"rack2b\"\n\
         [[leg]]\nname = \"to pick 1b\"\napproach = \"rack1b\"\n\
         [[leg]]\nname = \"carry 1b\"\ngoal = [4.0, -7.0, {PI}]\ncarry = \"rack1b\"\n\
         [[leg]]\nname = \"park\"\ngoal = [6.0, 8.0, {FRAC_PI_2}]\n"
    );
    succeeds("two-racks", [0.0, 0.0, 0.0], &legs);
}

/// The robot starts between the rack rows and picks the rack in front of it.
#[test]
fn a_start_inside_the_storage_area() {
    let legs = "[[leg]]\nname = \"to pick\"\napproach = \"rack2a\"\n\
                [[leg]]\nname = \"carry\"\ngoal = [6.0, -7.0, 0.0]\ncarry = \"rack2a\"\n";
    succeeds("storage-start", [3.3, 10.0, FRAC_PI_2], legs);
}

/// The seed mission with an unseen barrier across the warehouse at y = 6 m whose only
/// gap, on the carrying leg's way, is 5 cm wider than the carrying footprint (0.8 m)
/// plus its margin (2 x 0.4 m): the leg must find and drive through it.
#[test]
fn a_carrying_leg_through_a_gap_5_cm_wider_than_footprint_and_margin() {
    let dir = TestDir::new("gap");
    let cfg = dir.path("config");
    std::fs::create_dir_all(&cfg).unwrap();
    for e in std::fs::read_dir(config_dir()).unwrap().flatten() {
        if e.path().is_file() {
            std::fs::copy(e.path(), cfg.join(e.file_name())).unwrap();
        }
    }
    let (gap, centre, y) = (0.8 + 2.0 * 0.4 + 0.05, 3.0, 6.0);
    let (west, east) = (-4.8, 14.8);
    let (a_end, b_start) = (centre - gap / 2.0, centre + gap / 2.0);
    let barrier = |name: &str, from: f64, to: f64| {
        format!(
            "\n[[body]]\nname = \"{name}\"\nkind = \"barrier\"\nstatic = false\n\
             pose = [{}, {y}, 0.0]\nsize = [{}, 0.2, 1.0]\n",
            (from + to) / 2.0,
            to - from
        )
    };
    let mut scene = std::fs::read_to_string(cfg.join("warehouse.toml")).unwrap();
    scene += &barrier("barrier_west", west, a_end);
    scene += &barrier("barrier_east", b_start, east);
    std::fs::write(cfg.join("warehouse.toml"), scene).unwrap();
    let r = succeeds_with("gap", &dir, &["--config-dir", cfg.to_str().unwrap()]);
    // The carrying leg crossed y = 6 through the gap.
    let carry = &r.legs[2];
    let crossing = r
        .driven_path
        .windows(2)
        .find(|w| w[0][0] >= carry.start_s && w[0][2] >= y && w[1][2] < y)
        .expect("the carrying leg crosses the barrier's line");
    assert!((crossing[1][1] - centre).abs() < gap / 2.0, "{crossing:?}");
}

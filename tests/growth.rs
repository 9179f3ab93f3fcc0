//! Warehouses larger than the seed's run their missions end to end in lockstep:
//! - four times its area (`config/growth/x4`: 873 bodies, 47 of them movable, a 440 x 660
//!   cell map): ground truth lists only the bodies that can move, so a scene may have any
//!   number of static ones (the v2 messages held 64 bodies in all and the simulator
//!   refused such a scene);
//! - `config/large` (99.2 x 199.4 m, 9,972 bodies, a 2000 x 4000 cell map at 20 cells/m,
//!   two picks and drops over 500 m): the global map's message holds 2^24 cells (the
//!   local map's 2^21; one grid type held 2^20 before, then 2^21, and the config reader
//!   refused a scene over 1 MiB).
//!
//! - `config/narrow` (2.2 m aisles, seven legs): a rack left in an aisle is picked again
//!   where it stands and carried back, a mission written after the code it runs.
//!
//! All run as a user runs them, `--config-dir` naming the overlay directory itself.

mod support;

use aisle_supervisor::report::RunReport;
use support::{config_dir, run_report};

/// Runs the overlay directory `dir` of `config/` as a user does; it must succeed
/// without a collision.
fn run_overlay(name: &str, dir: &str) -> RunReport {
    let config = config_dir().join(dir);
    let (out, report) = run_report(name, &["--config-dir", config.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(report.success, "{:?}", report.failure);
    assert_eq!(report.collisions, 0);
    report
}

/// `body` stood within 0.5 m of `at` at the end of the run.
fn assert_ends_at(report: &RunReport, body: &str, at: (f64, f64)) {
    let b = report.bodies_final.iter().find(|b| b.name == body).unwrap();
    assert!(
        (b.x - at.0).abs() < 0.5 && (b.y - at.1).abs() < 0.5,
        "{body}: {}, {}",
        b.x,
        b.y
    );
}

#[test]
fn a_warehouse_four_times_the_seed_area_carries_its_rack_without_a_collision() {
    // The overlay as a user runs it: its `overlay.toml` lays it over `config/`.
    let scene =
        aisle_config::scene::Scene::load(&config_dir().join("growth/x4/warehouse.toml")).unwrap();
    assert!(scene.bodies.len() > 3 * aisle_messages::MAX_BODIES);

    let report = run_overlay("growth-x4-run", "growth/x4");
    assert_eq!(report.legs.len(), 4);
    // The rack stands where the carry leg set it down (aisle 7, x = 34 m, y = 30 m).
    assert_ends_at(&report, "rack_7", (34.0, 30.0));
    // Ground truth named the movable bodies only: every one is in the final poses.
    assert_eq!(
        report.bodies_final.len(),
        scene.movable_bodies().count(),
        "{:?}",
        report.bodies_final.len()
    );
}

#[test]
fn the_large_warehouse_mission_sets_both_racks_down_without_a_collision() {
    let report = run_overlay("growth-large-run", "large");
    assert_eq!(report.legs.len(), 7);
    assert!(report.path_length_m > 400.0, "{}", report.path_length_m);
    // Each rack stands where its carry leg set it down, 50 m and 140 m from its pick.
    assert_ends_at(&report, "rack_10", (49.6, 60.0));
    assert_ends_at(&report, "rack_24", (86.0, 150.0));
}

#[test]
fn in_2_2_m_aisles_a_rack_left_in_an_aisle_is_picked_again_and_carried_back() {
    let report = run_overlay("narrow-run", "narrow");
    assert_eq!(report.legs.len(), 7);
    // rack_1 where its carry set it down in aisle 2; rack_2 back in the packaging area
    // after a stay in aisle 1.
    assert_ends_at(&report, "rack_1", (6.8, 29.0));
    assert_ends_at(&report, "rack_2", (7.0, 12.0));
}

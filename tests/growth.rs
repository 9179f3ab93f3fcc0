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
//! Both run as a user runs them, `--config-dir` naming the overlay directory itself.

mod support;

use support::{config_dir, run_report};

/// Where `body` stood at the end of the run.
fn final_xy(report: &aisle_supervisor::report::RunReport, body: &str) -> (f64, f64) {
    let b = report.bodies_final.iter().find(|b| b.name == body).unwrap();
    (b.x, b.y)
}

#[test]
fn a_warehouse_four_times_the_seed_area_carries_its_rack_without_a_collision() {
    // The overlay as a user runs it: its `overlay.toml` lays it over `config/`.
    let config = config_dir().join("growth/x4");
    let scene = aisle_config::scene::Scene::load(&config.join("warehouse.toml")).unwrap();
    assert!(scene.bodies.len() > 3 * aisle_messages::MAX_BODIES);

    let (out, report) = run_report("growth-x4-run", &["--config-dir", config.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(report.success, "{:?}", report.failure);
    assert_eq!(report.collisions, 0);
    assert_eq!(report.legs.len(), 4);
    // The rack stands where the carry leg set it down (aisle 7, x = 34 m, y = 30 m).
    let rack = final_xy(&report, "rack_7");
    assert!(
        (rack.0 - 34.0).abs() < 0.5 && (rack.1 - 30.0).abs() < 0.5,
        "{rack:?}"
    );
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
    let config = config_dir().join("large");
    let (out, report) = run_report(
        "growth-large-run",
        &["--config-dir", config.to_str().unwrap()],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(report.success, "{:?}", report.failure);
    assert_eq!(report.collisions, 0);
    assert_eq!(report.legs.len(), 7);
    assert!(report.path_length_m > 400.0, "{}", report.path_length_m);
    // Each rack stands where its carry leg set it down, 50 m and 140 m from its pick.
    for (rack, at) in [("rack_10", (49.6, 60.0)), ("rack_24", (86.0, 150.0))] {
        let (x, y) = final_xy(&report, rack);
        assert!(
            (x - at.0).abs() < 0.5 && (y - at.1).abs() < 0.5,
            "{rack}: {x}, {y}"
        );
    }
}

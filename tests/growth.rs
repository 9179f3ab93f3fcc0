//! A warehouse four times the seed's area (`config/growth/x4`: 873 bodies, 47 of them
//! movable, a 440 x 660 cell map) runs its mission end to end in lockstep: ground truth
//! lists only the bodies that can move, so a scene may have any number of static ones
//! (the v2 messages held 64 bodies in all and the simulator refused such a scene).

mod support;

use support::{TestDir, config_dir, config_with_graph, run_report};

#[test]
fn a_warehouse_four_times_the_seed_area_carries_its_rack_without_a_collision() {
    let dir = TestDir::new("growth-x4");
    // The shipped config (its graph as it is), then the growth files over it.
    let config = config_with_graph(&dir, "");
    for entry in std::fs::read_dir(config_dir().join("growth/x4")).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, config.join(path.file_name().unwrap())).unwrap();
    }
    let scene = aisle_config::scene::Scene::load(&config.join("warehouse.toml")).unwrap();
    assert!(scene.bodies.len() > 3 * aisle_messages::MAX_BODIES);

    let (out, report) = run_report("growth-x4-run", &["--config-dir", config.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(report.success, "{:?}", report.failure);
    assert_eq!(report.collisions, 0);
    assert_eq!(report.legs.len(), 4);
    // The rack stands where the carry leg set it down (aisle 7, x = 34 m, y = 30 m).
    let rack = report
        .bodies_final
        .iter()
        .find(|b| b.name == "rack_7")
        .unwrap();
    assert!(
        (rack.x - 34.0).abs() < 0.5 && (rack.y - 30.0).abs() < 0.5,
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

//! Tests of the mapper: scans of the shipped warehouse, the local window, restarts.
use super::*;
use crate::cloud::{OrganizedCloud, SensorPose};
use crate::obstacle_layer::IgnoreZone;
use crate::synthetic::{WorldBox, boxes_of_scene, cast_cloud};
use aisle_geometry::{Footprint, Pose2};
use std::f64::consts::FRAC_PI_2;

fn shipped() -> (MapConfig, std::path::PathBuf) {
    let path = aisle_config::testing::shipped("warehouse.toml");
    (MapConfig::default(), path)
}

#[test]
fn a_scan_of_the_warehouse_marks_only_movable_bodies() {
    let (cfg, scene_path) = shipped();
    let scene = Scene::load(&scene_path).unwrap();
    let map = load_static_map(&cfg, &scene_path).unwrap();
    let mut m = Mapper::new(map, &cfg, BeamGeometry::default()).unwrap();
    assert_eq!(m.version(), 0);
    let robot = Pose2::new(0.0, 0.0, 0.0);
    let sensor = SensorPose::level(0.25, 0.1, 0.26, 0.0);
    let mut cloud = Vec::new();
    let b = BeamGeometry::default();
    cast_cloud(&boxes_of_scene(&scene, true), &sensor, &b, 12.0, &mut cloud);
    let scan = Scan {
        cloud: OrganizedCloud::new(b.rows, b.cols, &cloud).unwrap(),
        sensor,
        robot,
        robot_footprint: Footprint::new(0.508, 0.43),
        carried: None,
        ignore: &[] as &[IgnoreZone],
    };
    let s = m.integrate(&scan).unwrap();
    assert_eq!(m.version(), 1);
    assert!(s.newly_detected > 0, "{s:?}");
    // The pallet stack ahead at (2.6, 1.0) is detected; static cells are unchanged.
    let g = m.global_map();
    let stack = WorldBox::standing(2.6, 1.0, 0.0, [1.2, 0.8, 0.944]);
    let near = (0..g.cells.len()).filter(|&i| {
        let (x, y) = g.cell_center(aisle_geometry::CellIndex {
            ix: (i % g.width) as i64,
            iy: (i / g.width) as i64,
        });
        g.cells[i] == OCCUPIED_DETECTED && Footprint::new(1.4, 1.0).contains(&stack.pose, x, y)
    });
    assert!(near.count() > 5);
    for (a, b) in m.static_map().cells.iter().zip(g.cells) {
        if *a == OCCUPIED_STATIC {
            assert_eq!(*b, OCCUPIED_STATIC);
        }
    }
    // Every detection comes from a movable body: none where the world is empty.
    let movable = boxes_of_scene(&scene, true);
    for i in 0..g.cells.len() {
        if g.cells[i] != OCCUPIED_DETECTED {
            continue;
        }
        let (x, y) = g.cell_center(aisle_geometry::CellIndex {
            ix: (i % g.width) as i64,
            iy: (i / g.width) as i64,
        });
        let close = movable.iter().any(|b| {
            Footprint::new(2.0 * b.half_x, 2.0 * b.half_y)
                .inflated(0.1)
                .contains(&b.pose, x, y)
        });
        assert!(close, "detection at ({x}, {y}) with nothing there");
    }

    // The local map around the robot carries the detections.
    let mut out = vec![0u8; m.local_side() * m.local_side()];
    let info = m.local_map_into((robot.x, robot.y), &mut out).unwrap();
    assert_eq!((info.width, info.height), (150, 150));
    let lv = GridView::new(
        info.origin_x,
        info.origin_y,
        info.resolution,
        150,
        150,
        &out,
    )
    .unwrap();
    assert_eq!(lv.get(lv.cell_of(2.05, 1.0)), g.get(g.cell_of(2.05, 1.0)));
    assert!(out.contains(&OCCUPIED_DETECTED));

    // State that survives a restart: a fresh mapper takes the detections back.
    let published = m.global_map().cells.to_vec();
    let mut again = Mapper::new(
        load_static_map(&cfg, &scene_path).unwrap(),
        &cfg,
        BeamGeometry::default(),
    )
    .unwrap();
    let view = same_geometry(&g, &published);
    again.restore_detections(&view, 7).unwrap();
    assert_eq!(again.global_map().cells, m.global_map().cells);
    assert_eq!(again.version(), 7);
    let wrong = GridView::new(0.0, 0.0, 0.1, g.width, g.height, &published).unwrap();
    assert!(again.restore_detections(&wrong, 0).is_err());
    again.clear_detections();
    assert_eq!(again.global_map().cells, again.static_map().cells);
    assert_eq!(again.version(), 8);
}

/// `cells` (a published copy) as a grid of `g`'s geometry.
fn same_geometry<'a>(g: &GridView, cells: &'a [u8]) -> GridView<'a> {
    GridView::new(
        g.origin_x,
        g.origin_y,
        g.resolution,
        g.width,
        g.height,
        cells,
    )
    .unwrap()
}

/// A restarted mapper resumes at the published version even with set-down parts in
/// the map: telling it the same parts again changes nothing (the replay of a record
/// taken through a mapper crash compares the maps' versions).
#[test]
fn a_restart_with_set_down_parts_keeps_the_version() {
    let (cfg, scene_path) = shipped();
    let fresh = || {
        Mapper::new(
            load_static_map(&cfg, &scene_path).unwrap(),
            &cfg,
            BeamGeometry::default(),
        )
        .unwrap()
    };
    let parts = [(Pose2::new(2.0, 1.0, 0.3), Footprint::new(0.2, 0.2))];
    let mut m = fresh();
    assert!(m.set_placed(&parts));
    let published = m.global_map().cells.to_vec();
    let view = same_geometry(&m.global_map(), &published);
    let mut again = fresh();
    again.restore_detections(&view, m.version()).unwrap();
    assert_eq!(again.global_map().cells, m.global_map().cells);
    assert!(!again.set_placed(&parts), "the same parts changed the map");
    assert_eq!(again.version(), m.version());
    assert_eq!(again.static_map().cells, m.static_map().cells);
}

/// The scene's movable bodies cast from `robot` with the seed's level lidar.
fn scene_cloud(scene: &Scene, robot: Pose2) -> (SensorPose, Vec<[f32; 3]>) {
    let (x, y) = robot.transform_point(0.25, 0.1);
    let sensor = SensorPose::level(x, y, 0.42, robot.theta);
    let mut cloud = Vec::new();
    cast_cloud(
        &boxes_of_scene(scene, true),
        &sensor,
        &BeamGeometry::default(),
        12.0,
        &mut cloud,
    );
    (sensor, cloud)
}

#[test]
fn integrating_and_copying_out_allocate_nothing() {
    let (_, scene_path) = shipped();
    let cfg_path = aisle_config::testing::shipped("mapper.toml");
    let (mut m, _) = Mapper::from_files(&cfg_path, &scene_path, BeamGeometry::default()).unwrap();
    let scene = Scene::load(&scene_path).unwrap();
    let robot = Pose2::new(0.0, 0.0, 0.3);
    let (sensor, cloud) = scene_cloud(&scene, robot);
    let rack = [IgnoreZone {
        pose: Pose2::new(2.0, 13.0, FRAC_PI_2),
        footprint: Footprint::new(0.88, 0.8),
    }];
    let scan = Scan {
        cloud: OrganizedCloud::new(31, 1201, &cloud).unwrap(),
        sensor,
        robot,
        robot_footprint: Footprint::new(0.508, 0.43),
        carried: Some(IgnoreZone {
            pose: Pose2::default(),
            footprint: Footprint::new(0.88, 0.8),
        }),
        ignore: &rack,
    };
    let mut local = vec![0u8; m.local_side() * m.local_side()];
    let mut global = vec![0u8; m.global_map().cells.len()];
    let (result, n) = crate::alloc_probe::allocations_in(|| {
        let stats = m.integrate(&scan)?;
        m.local_map_into((robot.x, robot.y), &mut local)?;
        m.local_static_map_into((robot.x, robot.y), &mut local)?;
        global.copy_from_slice(m.global_map().cells);
        Ok::<_, MapError>(stats)
    });
    let stats = result.unwrap();
    assert!(stats.changed() && stats.newly_detected > 0, "{stats:?}");
    assert_eq!(n, 0, "allocations during one scan and the copies out");
}

#[test]
fn the_static_only_local_map_has_no_detections() {
    let (cfg, scene_path) = shipped();
    let scene = Scene::load(&scene_path).unwrap();
    let mut m = Mapper::new(
        load_static_map(&cfg, &scene_path).unwrap(),
        &cfg,
        BeamGeometry::default(),
    )
    .unwrap();
    let robot = Pose2::default();
    let (sensor, cloud) = scene_cloud(&scene, robot);
    let scan = Scan {
        cloud: OrganizedCloud::new(31, 1201, &cloud).unwrap(),
        sensor,
        robot,
        robot_footprint: Footprint::new(0.508, 0.43),
        carried: None,
        ignore: &[],
    };
    assert!(m.integrate(&scan).unwrap().changed());
    // Same scan again: nothing new, the version stays.
    let v = m.version();
    assert!(!m.integrate(&scan).unwrap().changed());
    assert_eq!(m.version(), v);
    let side = m.local_side();
    let (mut with, mut without) = (vec![0u8; side * side], vec![0u8; side * side]);
    let a = m.local_map_into((0.0, 0.0), &mut with).unwrap();
    let b = m.local_static_map_into((0.0, 0.0), &mut without).unwrap();
    assert_eq!(a, b);
    assert!(with.contains(&OCCUPIED_DETECTED));
    assert!(!without.contains(&OCCUPIED_DETECTED));
    for (w, s) in with.iter().zip(&without) {
        assert!(*w == *s || (*s == FREE && *w == OCCUPIED_DETECTED));
    }
}

#[test]
fn a_ros_map_can_replace_the_scene() {
    let (mut cfg, scene_path) = shipped();
    let dir = std::env::temp_dir().join(format!("aisle-mapper-src-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene_map = load_static_map(&cfg, &scene_path).unwrap();
    let yaml = dir.join("own.yaml");
    crate::ros_map::write_ros_map(&yaml, &scene_map.view()).unwrap();
    cfg.ros_map = Some(yaml);
    let own = load_static_map(&cfg, Path::new("/nonexistent/scene.toml")).unwrap();
    assert_eq!(own.cells, scene_map.cells);
    let m = Mapper::new(own, &cfg, BeamGeometry::default()).unwrap();
    assert_eq!(m.local_side(), 150);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_config_or_scene_is_an_error() {
    let (cfg, _) = shipped();
    let e = load_static_map(&cfg, Path::new("/nonexistent/scene.toml")).unwrap_err();
    assert!(e.to_string().contains("/nonexistent/scene.toml"), "{e}");
    let bad = MapConfig {
        cells_per_metre: -1.0,
        ..MapConfig::default()
    };
    let g = GridMap::new_free(0.0, 0.0, 0.1, 1.0, 1.0).unwrap();
    let e = Mapper::new(g, &bad, BeamGeometry::default()).unwrap_err();
    assert!(e.to_string().contains("cells_per_metre"), "{e}");
    // A user's ROS map too large for a grid message: more cells than it holds, or a
    // side longer than any grid's; a long narrow one that fits is fine.
    let huge = GridMap::new_free(0.0, 0.0, 0.1, 410.0, 410.0).unwrap();
    let e = Mapper::new(huge, &cfg, BeamGeometry::default()).unwrap_err();
    assert!(
        matches!(
            e,
            MapError::TooMany {
                got: 16_810_000,
                ..
            }
        ),
        "{e}"
    );
    let long = GridMap::new_free(0.0, 0.0, 0.1, 819.3, 2.0).unwrap();
    let e = Mapper::new(long, &cfg, BeamGeometry::default()).unwrap_err();
    assert!(matches!(e, MapError::TooMany { got: 8193, .. }), "{e}");
    let narrow = GridMap::new_free(0.0, 0.0, 0.1, 500.0, 20.0).unwrap();
    assert!(Mapper::new(narrow, &cfg, BeamGeometry::default()).is_ok());
}

#[test]
fn the_changes_listed_bring_the_base_map_to_the_global_map() {
    let (_, scene_path) = shipped();
    let cfg_path = aisle_config::testing::shipped("mapper.toml");
    let (mut m, _) = Mapper::from_files(&cfg_path, &scene_path, BeamGeometry::default()).unwrap();
    let mut scene = Scene::load(&scene_path).unwrap();
    let base = m.global_map().cells.to_vec();
    let check = |m: &Mapper, base: &[u8]| {
        let mut held = base.to_vec();
        for &i in m.changes().touched() {
            held[i as usize] = m.global_map().cells[i as usize];
        }
        assert_eq!(held, m.global_map().cells, "base + changes = the map");
        let differ = base
            .iter()
            .zip(m.global_map().cells)
            .filter(|(a, b)| a != b)
            .count();
        assert!(m.changes().touched().len() >= differ);
    };
    // Drive past the pallets, then take one away: detections come and go.
    let mut cleared = 0;
    for (k, x) in [0.0, 0.8, 1.6, 2.4].into_iter().enumerate() {
        if k == 3 {
            scene.bodies.retain(|b| b.name != "pallet_leg2");
        }
        let robot = Pose2::new(x, 0.0, 0.2);
        let (sensor, cloud) = scene_cloud(&scene, robot);
        let scan = Scan {
            cloud: OrganizedCloud::new(31, 1201, &cloud).unwrap(),
            sensor,
            robot,
            robot_footprint: Footprint::new(0.508, 0.43),
            carried: None,
            ignore: &[],
        };
        let stats = m.integrate(&scan).unwrap();
        assert!(stats.changed() == stats.written.is_some(), "{stats:?}");
        cleared += stats.cleared;
        check(&m, &base);
    }
    assert!(cleared > 0, "the pallet taken away was cleared");
    assert!(!m.changes().touched().is_empty());
    m.set_placed(&[(Pose2::new(5.0, 5.0, 0.0), Footprint::new(0.2, 0.2))]);
    check(&m, &base);
    // A new base: nothing listed, and the changes start from it.
    m.rebase_changes();
    assert_eq!(
        (m.changes().touched().len(), m.changes().base_version()),
        (0, m.version())
    );
    let rebased = m.global_map().cells.to_vec();
    m.clear_detections();
    check(&m, &rebased);
    assert!(!m.changes().touched().is_empty());
}

//! One lidar scan (31 x 1201 = 37,231 points) into the mapper, and the local map copy.
//! Issue target: <= 1 ms per scan. Clouds are cast once, analytically, against the
//! shipped warehouse (static and movable bodies) with the seed's level lidar.

use aisle_config::scene::Scene;
use aisle_geometry::{Footprint, Pose2};
use aisle_mapper::synthetic::{boxes_of_scene, cast_cloud};
use aisle_mapper::{BeamGeometry, IgnoreZone, MapConfig, Mapper, OrganizedCloud, Scan, SensorPose};
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

const ROBOT: Footprint = Footprint::new(0.508, 0.43);
const RACK: Footprint = Footprint::new(0.88, 0.8);

fn config_dir() -> std::path::PathBuf {
    aisle_config::testing::shipped_dir()
}

struct Case {
    name: &'static str,
    robot: Pose2,
    sensor: SensorPose,
    cloud: Vec<[f32; 3]>,
    carrying: bool,
}

fn case(scene: &Scene, name: &'static str, robot: Pose2, carrying: bool) -> Case {
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
    Case {
        name,
        robot,
        sensor,
        cloud,
        carrying,
    }
}

fn scan<'a>(c: &'a Case, ignore: &'a [IgnoreZone]) -> Scan<'a> {
    Scan {
        cloud: OrganizedCloud::new(31, 1201, &c.cloud).expect("seed cloud shape"),
        sensor: c.sensor,
        robot: c.robot,
        robot_footprint: ROBOT,
        carried: c.carrying.then_some(IgnoreZone {
            pose: Pose2::default(),
            footprint: RACK,
        }),
        ignore,
    }
}

fn mapper(cells_per_metre: f64) -> Mapper {
    let scene_path = config_dir().join("warehouse.toml");
    let cfg = MapConfig {
        cells_per_metre,
        ..MapConfig::default()
    };
    let map = aisle_mapper::load_static_map(&cfg, &scene_path).expect("shipped scene");
    Mapper::new(map, &cfg, BeamGeometry::default()).expect("default config")
}

fn bench(c: &mut Criterion) {
    let scene = Scene::load(&config_dir().join("warehouse.toml")).expect("shipped scene");
    let cases = [
        case(&scene, "start", Pose2::new(0.0, 0.0, 0.0), false),
        case(
            &scene,
            "storage_lane",
            Pose2::new(2.0, 10.5, std::f64::consts::FRAC_PI_2),
            false,
        ),
        case(&scene, "carrying", Pose2::new(3.0, 6.0, -1.2), true),
    ];
    let approach = [IgnoreZone {
        pose: Pose2::new(2.0, 13.0, std::f64::consts::FRAC_PI_2),
        footprint: RACK,
    }];
    let mut g = c.benchmark_group("mapper_scan");
    for cpm in [10.0, 20.0] {
        for k in &cases {
            let mut m = mapper(cpm);
            let s = scan(k, &approach);
            g.bench_function(format!("{}_{}cpm", k.name, cpm), |b| {
                b.iter(|| black_box(m.integrate(black_box(&s)).expect("valid scan")))
            });
        }
        // Two poses in turn: every scan clears and marks for real.
        let mut m = mapper(cpm);
        let (a, b2) = (scan(&cases[0], &[]), scan(&cases[2], &[]));
        let mut flip = false;
        g.bench_function(format!("alternating_{cpm}cpm"), |b| {
            b.iter(|| {
                flip = !flip;
                black_box(
                    m.integrate(if flip { &a } else { &b2 })
                        .expect("valid scan"),
                )
            })
        });
    }
    g.finish();

    let m = mapper(10.0);
    let mut out = vec![0u8; m.local_side() * m.local_side()];
    c.bench_function("local_map_150x150", |b| {
        b.iter(|| {
            black_box(
                m.local_map_into(black_box((2.0, 3.0)), &mut out)
                    .expect("buffer size"),
            )
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);

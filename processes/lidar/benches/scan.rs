//! Full-scan timing: the seed pattern (31 x 1201 rays) on the shipped warehouse from the
//! start pose and from inside the storage lane, the parry3d reference for comparison,
//! and the scaling with 10 / 100 / 1000 random boxes (seeded) in the seed's 20 x 30 m
//! (so the density grows with the count).
//!
//! `size`: the storage lane in the seed and in the middle room of the seed repeated 3 x 3
//! and 10 x 10 times (200 x 300 m, 3,000 bodies): the same surroundings in a scene 9 and
//! 100 times the area, level and tilted.
//!
//! `generated`: warehouses from `aisle_config::scene_gen` (the code behind `aisle scene
//! generate`, seeded) of about 1,000 / 5,000 / 20,000 bodies, and the shipped large
//! one's parameters (19 aisles x 172 m, about 100 x 200 m). What is held fixed is the
//! layout (3 m aisles between back-to-back rows of 2.7 m bays, three storage levels
//! filled at 60 %, a cross aisle every 11 bays): the aisles and their length grow with
//! the count, so the density around the sensor stays that of a warehouse. The pose is
//! the same kind in every scene: in the middle picking aisle, 14 m past its start,
//! heading along it, level and tilted (roll 0.05, pitch -0.1 rad, as the seed's tilted
//! case). Scans use one thread as shipped (`scan_threads`); the `two threads` cases
//! sweep half a tilted scan's columns on a second thread.

#[path = "support/cases.rs"]
mod cases;

use aisle_config::scene::{Body, BoxPart, Scene};
use aisle_config::scene_gen::generate_scene;
use aisle_geometry::Pose2;
use aisle_lidar::{LidarConfig, ParryReference, Raycaster, SensorPose};
use cases::{on_robot, robot_in_aisle};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;

fn warehouse() -> Scene {
    let p = aisle_config::testing::shipped("warehouse.toml");
    Scene::load(&p).expect("shipped warehouse")
}

fn sensor_at(x: f64, y: f64, yaw: f64) -> SensorPose {
    let mount = SensorPose::from_xyz_rpy([0.25, 0.1, 0.2], [0.0; 3]);
    SensorPose::on_robot(&Pose2::new(x, y, yaw), &mount)
}

/// `n` boxes of 0.2..1.5 m sides and 0.2..3 m height, any yaw, in the 20 x 30 m map,
/// from a fixed-seed xorshift stream.
fn random_scene(n: usize, seed: u64) -> Scene {
    let mut s = seed;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let bodies = (0..n)
        .map(|i| {
            let size = [0.2 + 1.3 * next(), 0.2 + 1.3 * next(), 0.2 + 2.8 * next()];
            let (mut x, mut y) = (0.0f64, 0.0f64);
            // Keep the sensor (at the origin) outside every box.
            while x.abs() < 1.2 && y.abs() < 1.2 {
                x = -5.0 + 20.0 * next();
                y = -10.0 + 30.0 * next();
            }
            Body {
                name: format!("b{i}"),
                kind: "box".into(),
                is_static: false,
                pose: Pose2::new(x, y, std::f64::consts::PI * next()),
                parts: vec![BoxPart {
                    center: [0.0, 0.0, 0.5 * size[2]],
                    size,
                }],
            }
        })
        .collect();
    Scene { bodies }
}

fn scans(c: &mut Criterion) {
    let scene = warehouse();
    let noisy = LidarConfig::default();
    let mut quiet = LidarConfig::default();
    quiet.noise.enabled = false;
    let poses = [
        ("start (0,0,0)", sensor_at(0.0, 0.0, 0.0)),
        (
            "lane (2,11,pi/2)",
            sensor_at(2.0, 11.0, std::f64::consts::FRAC_PI_2),
        ),
    ];
    let mut g = c.benchmark_group("warehouse");
    g.throughput(Throughput::Elements(37_231));
    for (name, pose) in &poses {
        for (label, cfg) in [("fast+noise", &noisy), ("fast", &quiet)] {
            let mut r = Raycaster::new(cfg, &scene).expect("raycaster");
            let mut out = vec![[0.0f32; 3]; r.len()];
            let mut k = 0u64;
            g.bench_function(format!("{label} {name}"), |b| {
                b.iter(|| {
                    k += 1;
                    r.scan(black_box(pose), k, &mut out).expect("scan");
                    black_box(&out);
                })
            });
        }
        let reference = ParryReference::new(&quiet, &scene).expect("reference");
        let mut out = vec![[0.0f32; 3]; reference.len()];
        g.bench_function(format!("parry reference {name}"), |b| {
            b.iter(|| {
                reference.scan(black_box(pose), &mut out).expect("scan");
                black_box(&out);
            })
        });
    }
    // Carrying rack2b out of the lane: its legs and deck surround the sensor, and the
    // node moves it before every scan.
    let mut r = Raycaster::new(&noisy, &scene).expect("raycaster");
    let rack = r.body_index("rack2b").expect("rack2b in the scene");
    let mut out = vec![[0.0f32; 3]; r.len()];
    let robot = Pose2::new(2.0, 11.0, -std::f64::consts::FRAC_PI_2);
    let mut k = 0u64;
    g.bench_function("fast+noise carrying rack2b (2,11,-pi/2)", |b| {
        b.iter(|| {
            k += 1;
            r.set_body_pose(rack, robot).expect("rack pose");
            r.scan_robot(black_box(&robot), k, &mut out).expect("scan");
            black_box(&out);
        })
    });
    let tilted = SensorPose::on_robot(
        &Pose2::new(2.0, 11.0, std::f64::consts::FRAC_PI_2),
        &SensorPose::from_xyz_rpy([0.25, 0.1, 0.2], [0.05, -0.1, 0.0]),
    );
    let mut r = Raycaster::new(&quiet, &scene).expect("raycaster");
    let mut out = vec![[0.0f32; 3]; r.len()];
    g.bench_function("general path (tilted) lane", |b| {
        b.iter(|| {
            r.scan(black_box(&tilted), 0, &mut out).expect("scan");
            black_box(&out);
        })
    });
    g.finish();

    let mut g = c.benchmark_group("scaling");
    g.throughput(Throughput::Elements(37_231));
    let origin = SensorPose::planar(0.0, 0.0, 0.2, 0.0);
    for n in [10, 100, 1000] {
        let scene = random_scene(n, 0x5EED_0000 + n as u64);
        let mut r = Raycaster::new(&quiet, &scene).expect("raycaster");
        let mut out = vec![[0.0f32; 3]; r.len()];
        g.bench_function(format!("fast {n} boxes"), |b| {
            b.iter(|| {
                r.scan(black_box(&origin), 0, &mut out).expect("scan");
                black_box(&out);
            })
        });
        let reference = ParryReference::new(&quiet, &scene).expect("reference");
        g.bench_function(format!("parry reference {n} boxes"), |b| {
            b.iter(|| {
                reference.scan(black_box(&origin), &mut out).expect("scan");
                black_box(&out);
            })
        });
    }
    g.finish();
}

/// Size alone: the seed's lane, level and tilted, in the seed and in the middle room of
/// the seed repeated 3 x 3 and 10 x 10 times.
fn size(c: &mut Criterion) {
    let mut quiet = LidarConfig::default();
    quiet.noise.enabled = false;
    let seed = warehouse();
    let mut scenes = vec![("seed".to_string(), seed.clone(), (0.0, 0.0))];
    for n in cases::SEED_TILES {
        let (tiled, at) = cases::seed_tiled(&seed, n);
        scenes.push((format!("seed x{}", n * n), tiled, at));
    }
    let mut g = c.benchmark_group("size");
    g.throughput(Throughput::Elements(37_231));
    for (label, scene, (x, y)) in &scenes {
        let mut r = Raycaster::new(&quiet, scene).expect("raycaster");
        let mut out = vec![[0.0f32; 3]; r.len()];
        let robot = Pose2::new(2.0 + x, 11.0 + y, std::f64::consts::FRAC_PI_2);
        for tilted in [false, true] {
            let pose = on_robot(&robot, tilted);
            let kind = if tilted { "tilted" } else { "level" };
            let n = scene.bodies.len();
            g.bench_function(format!("{kind} lane, {label} ({n} bodies)"), |b| {
                b.iter(|| {
                    r.scan(black_box(&pose), 0, &mut out).expect("scan");
                    black_box(&out);
                })
            });
        }
    }
    g.finish();
}

fn generated(c: &mut Criterion) {
    let mut quiet = LidarConfig::default();
    quiet.noise.enabled = false;
    let mut g = c.benchmark_group("generated");
    g.throughput(Throughput::Elements(37_231));
    for (label, p) in cases::generated() {
        let scene = generate_scene(&p);
        let mut r = Raycaster::new(&quiet, &scene).expect("raycaster");
        let two = LidarConfig {
            scan_threads: 2,
            ..quiet.clone()
        };
        let mut r2 = Raycaster::new(&two, &scene).expect("raycaster");
        let mut out = vec![[0.0f32; 3]; r.len()];
        let n = scene.bodies.len();
        for tilted in [false, true] {
            let pose = on_robot(&robot_in_aisle(&p), tilted);
            let kind = if tilted { "tilted" } else { "level" };
            g.bench_function(format!("{kind} {label} ({n} bodies)"), |b| {
                b.iter(|| {
                    r.scan(black_box(&pose), 0, &mut out).expect("scan");
                    black_box(&out);
                })
            });
        }
        let pose = on_robot(&robot_in_aisle(&p), true);
        g.bench_function(format!("tilted {label} ({n} bodies), two threads"), |b| {
            b.iter(|| {
                r2.scan(black_box(&pose), 0, &mut out).expect("scan");
                black_box(&out);
            })
        });
    }
    g.finish();
}

criterion_group!(benches, scans, size, generated);
criterion_main!(benches);

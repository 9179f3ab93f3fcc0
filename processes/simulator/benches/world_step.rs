//! One world step with the full warehouse: motion plus the contact sweep against
//! every body, robot alone and carrying a rack.

use aisle_config::scene::Scene;
use aisle_config::testing::shipped;
use aisle_geometry::Pose2;
use aisle_robot::load_robot;
use aisle_simulator::{DEFAULT_DT_NS, World};
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

fn world_at(start: Pose2) -> World {
    let (cfg, model) = load_robot(&shipped("robot.toml")).expect("robot");
    let scene = Scene::load(&shipped("warehouse.toml")).expect("scene");
    World::new_at(&scene, &model, &cfg, start).expect("world")
}

fn bench(c: &mut Criterion) {
    // A slow circle keeps the robot near its start for any number of iterations.
    let circle: Vec<(f64, f64, f64)> = (0..500).map(|k| (k as f64 * 0.1, 0.5, 0.5)).collect();
    let mut alone = world_at(Pose2::new(0.0, 0.0, 0.0));
    alone.set_timeline(0, &circle).expect("timeline");
    let snap = alone.snapshot();
    c.bench_function("world_step/alone", |b| {
        b.iter(|| {
            if alone.time_ns() > 40_000_000_000 {
                alone.restore(&snap).expect("restore");
            }
            black_box(alone.step(black_box(DEFAULT_DT_NS)))
        })
    });

    let mut carrying = world_at(Pose2::new(2.0, 13.0, 0.0));
    carrying.attach_by_name("rack2b").expect("attach");
    carrying.set_timeline(0, &circle).expect("timeline");
    let snap = carrying.snapshot();
    c.bench_function("world_step/carrying", |b| {
        b.iter(|| {
            if carrying.time_ns() > 40_000_000_000 {
                carrying.restore(&snap).expect("restore");
            }
            black_box(carrying.step(black_box(DEFAULT_DT_NS)))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);

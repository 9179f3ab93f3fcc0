//! CPU time per scan of the bench's cases (the seed's storage lane, the same lane in the
//! middle room of the seed repeated 3 x 3 and 10 x 10 times, and the generated warehouses,
//! level and tilted, one thread), the least of several runs, so that other
//! jobs on the machine do not count: `cargo run --release -p aisle-lidar --example
//! scan_cpu [runs] [scans] [case]` (only the cases whose label starts with `case`).
//! Each case also prints the FNV-1a digest of its cloud's bits, so that two builds can
//! be compared point for point.

#[path = "../benches/support/cases.rs"]
mod cases;

use aisle_config::scene::Scene;
use aisle_config::scene_gen::generate_scene;
use aisle_geometry::Pose2;
use aisle_lidar::{LidarConfig, Raycaster};
use cases::{SEED_TILES, generated, on_robot, robot_in_aisle, seed_tiled};
use std::f64::consts::FRAC_PI_2;

fn digest(out: &[[f32; 3]]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for v in out.iter().flatten() {
        h ^= u64::from(v.to_bits());
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// Least CPU time per scan (ms) over `runs` runs of `scans` scans, and the digest.
fn time(scene: &Scene, robot: &Pose2, tilted: bool, runs: usize, scans: usize) -> (f64, u64) {
    let mut cfg = LidarConfig::default();
    cfg.noise.enabled = false;
    let mut r = Raycaster::new(&cfg, scene).expect("raycaster");
    let sensor = on_robot(robot, tilted);
    let mut out = vec![[0.0f32; 3]; r.len()];
    let mut best = f64::INFINITY;
    for _ in 0..runs {
        let t0 = aisle_bus::clock::thread_cpu_ns();
        for k in 0..scans {
            r.scan(&sensor, k as u64, &mut out).expect("scan");
        }
        let ns = aisle_bus::clock::thread_cpu_ns() - t0;
        best = best.min(ns as f64 / scans as f64 / 1e6);
    }
    (best, digest(&out))
}

fn main() {
    let all: Vec<String> = std::env::args().skip(1).collect();
    let only = all.get(2).cloned().unwrap_or_default();
    let args: Vec<usize> = all
        .iter()
        .take(2)
        .map(|a| a.parse().expect("runs and scans are counts"))
        .collect();
    let runs = args.first().copied().unwrap_or(5);
    let scans = args.get(1).copied().unwrap_or(500);
    let seed = Scene::load(&aisle_config::testing::shipped("warehouse.toml")).expect("seed");
    let mut cases = vec![(
        "seed, lane".to_string(),
        seed.clone(),
        Pose2::new(2.0, 11.0, FRAC_PI_2),
    )];
    for n in SEED_TILES {
        let (tiled, (dx, dy)) = seed_tiled(&seed, n);
        cases.push((
            format!("seed x{} ({})", n * n, tiled.bodies.len()),
            tiled,
            Pose2::new(2.0 + dx, 11.0 + dy, FRAC_PI_2),
        ));
    }
    for (label, p) in generated() {
        let scene = generate_scene(&p);
        cases.push((
            format!("{label} ({})", scene.bodies.len()),
            scene,
            robot_in_aisle(&p),
        ));
    }
    println!("{runs} runs of {scans} scans, least CPU time per scan");
    for (label, scene, robot) in cases.iter().filter(|c| c.0.starts_with(&only)) {
        let (level, dl) = time(scene, robot, false, runs, scans);
        let (tilted, dt) = time(scene, robot, true, runs, scans);
        println!(
            "{label:<16} level {level:.3} ms  tilted {tilted:.3} ms  ratio {:.2}  digests {dl:016x} {dt:016x}",
            tilted / level
        );
    }
}

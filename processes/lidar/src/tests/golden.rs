//! Golden digest of scans: every coordinate (f32 bits) of the organised cloud and the
//! scan's stats, folded into a 64-bit FNV-1a hash per case, from level poses (the planar
//! caster) and tilted ones (the general caster), with and without the floor.
//!
//! The constants were recorded on the code before the casters' `prepare` and `scan` were
//! split into phases; a mismatch means a floating-point operation moved or changed, and
//! the per-case digests printed on failure say where.

use super::{cloud, quiet, warehouse};
use crate::*;
use aisle_geometry::Pose2;
use std::f64::consts::FRAC_PI_2;

/// 64-bit FNV-1a over the bytes of the values folded in.
struct Fnv(u64);

impl Fnv {
    fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    fn u64(&mut self, v: u64) {
        for b in v.to_le_bytes() {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    fn scan(&mut self, stats: ScanStats, out: &[[f32; 3]]) {
        self.u64(stats.returns as u64);
        self.u64(match stats.path {
            ScanPath::Planar => 1,
            ScanPath::General => 2,
        });
        for p in out {
            for v in p {
                self.u64(u64::from(v.to_bits()));
            }
        }
    }
}

fn mount(rpy: [f64; 3]) -> SensorPose {
    SensorPose::from_xyz_rpy([0.25, 0.1, 0.2], rpy)
}

/// Robot poses around the warehouse, the sensor mounted level or tilted.
fn warehouse_case(cfg: &LidarConfig, rpy: [f64; 3]) -> u64 {
    let mut r = Raycaster::new(cfg, &warehouse()).unwrap();
    r.set_mount(mount(rpy)).unwrap();
    let mut out = cloud(&r);
    let mut h = Fnv::new();
    let robots = [
        Pose2::new(0.0, 0.0, 0.0),
        Pose2::new(2.0, 11.0, FRAC_PI_2),
        Pose2::new(-0.5, 15.0, 2.5),
    ];
    for (k, robot) in robots.iter().enumerate() {
        let stats = r.scan_robot(robot, k as u64, &mut out).unwrap();
        h.scan(stats, &out);
    }
    h.0
}

/// Carrying rack2b: its legs and deck surround the sensor.
fn carrying_rack() -> u64 {
    let mut r = Raycaster::new(&quiet(), &warehouse()).unwrap();
    r.set_mount(mount([0.0; 3])).unwrap();
    let rack = r.body_index("rack2b").unwrap();
    let mut out = cloud(&r);
    let mut h = Fnv::new();
    for robot in [
        Pose2::new(2.0, 11.0, -FRAC_PI_2),
        Pose2::new(1.3, 9.0, -2.0),
    ] {
        r.set_body_pose(rack, robot).unwrap();
        let stats = r.scan_robot(&robot, 0, &mut out).unwrap();
        h.scan(stats, &out);
    }
    h.0
}

/// Rays that point down, from 1 m up: the floor, level and tilted.
fn floor() -> u64 {
    let mut cfg = quiet();
    cfg.elevation_min_deg = -30.0;
    let mut r = Raycaster::new(&cfg, &warehouse()).unwrap();
    let mut out = cloud(&r);
    let mut h = Fnv::new();
    for sensor in [
        SensorPose::planar(1.0, 2.0, 1.0, 0.3),
        SensorPose::from_xyz_rpy([1.0, 2.0, 1.0], [0.0, 0.2, 0.3]),
    ] {
        let stats = r.scan(&sensor, 0, &mut out).unwrap();
        h.scan(stats, &out);
    }
    h.0
}

fn digests() -> Vec<(&'static str, u64)> {
    let noisy = LidarConfig::default();
    vec![
        ("level", warehouse_case(&quiet(), [0.0; 3])),
        ("level_noisy", warehouse_case(&noisy, [0.0; 3])),
        ("tilted", warehouse_case(&quiet(), [0.05, -0.1, 0.0])),
        ("pitched_down", warehouse_case(&quiet(), [0.0, 0.3, 0.0])),
        ("carrying_rack", carrying_rack()),
        ("floor", floor()),
    ]
}

/// Recorded on the code before `prepare` and `scan` were split into phases (b4cc126).
const RECORDED: &[(&str, u64)] = &[
    ("level", 0x8cbc9ec970b024e0),
    ("level_noisy", 0x7c768356da939dae),
    ("tilted", 0x597b1db72730fc2a),
    ("pitched_down", 0xe446a128a467c38e),
    ("carrying_rack", 0x5afdc798bce4af66),
    ("floor", 0xdc8a59f869e89802),
];

#[test]
fn scans_are_bit_identical_to_the_recorded_digest() {
    let got = digests();
    for (name, v) in &got {
        println!("    (\"{name}\", 0x{v:016x}),");
    }
    assert_eq!(got, RECORDED, "digests changed (printed above as Rust)");
}

//! The fast paths against the parry3d reference on a generated warehouse of about a
//! thousand bodies (the grid index must not lose a box), with a coarse full-turn pattern
//! so the +-pi seam and downward rays are covered, level and tilted.

use super::*;
use aisle_config::scene_gen::{GenParams, Layout, generate_scene};

fn coarse() -> LidarConfig {
    let mut c = quiet();
    c.azimuth_min_deg = -180.0;
    c.azimuth_max_deg = 179.0;
    c.azimuth_step_deg = 1.0;
    c.elevation_min_deg = -20.0;
    c.elevation_max_deg = 30.0;
    c.elevation_step_deg = 2.0;
    c
}

/// The reference works in f32 world coordinates, here up to 85 m from the origin (a
/// ULP of 8 um), and rays that graze a deck or a wall stretch that along the ray; the
/// shipped 20 x 30 m warehouse is held to 0.1 mm. A lost or extra box would differ by
/// far more.
const TOL: f32 = 5e-4;
/// Rays per scan that may hit in one and miss in the other: a ray through a corner of
/// a box for a few micrometres (seen: 4.7 um through a load's corner at 7.1 m) is a hit
/// in the f64 placement and can be a miss in the reference's f32 world coordinates.
const GRAZES: usize = 2;

/// Hits and misses agree but for at most [`GRAZES`] rays, and common hits are within
/// [`TOL`].
fn assert_mostly_agree(fast: &[[f32; 3]], reference: &[[f32; 3]], what: &str) {
    let differ: Vec<usize> = (0..fast.len())
        .filter(|&i| fast[i][0].is_nan() != reference[i][0].is_nan())
        .collect();
    assert!(differ.len() <= GRAZES, "{what}: rays {differ:?} disagree");
    let mask = |c: &[[f32; 3]]| -> Vec<[f32; 3]> {
        (0..c.len())
            .map(|i| {
                if differ.contains(&i) {
                    [f32::NAN; 3]
                } else {
                    c[i]
                }
            })
            .collect()
    };
    assert_agree_within(&mask(fast), &mask(reference), TOL, what);
}

#[test]
fn fast_paths_match_parry_on_a_generated_thousand_body_warehouse() {
    let p = GenParams::new(4, 80.0, 5);
    let scene = generate_scene(&p);
    assert!(
        (800..2000).contains(&scene.bodies.len()),
        "{} bodies",
        scene.bodies.len()
    );
    let layout = Layout::new(&p);
    let cfg = coarse();
    let mut fast = Raycaster::new(&cfg, &scene).unwrap();
    let reference = ParryReference::new(&cfg, &scene).unwrap();
    let (mut a, mut b) = (cloud(&fast), cloud(&fast));
    // The middle of each picking aisle, a cross aisle and the packaging area.
    let mut robots: Vec<Pose2> = layout.aisles[2..]
        .iter()
        .map(|r| Pose2::new(0.5 * (r[0] + r[2]), 0.5 * (r[1] + r[3]) + 1.3, 1.2))
        .collect();
    robots.push(Pose2::new(7.0, 10.0, -0.4));
    let mut checked = 0;
    for robot in &robots {
        for rpy in [[0.0; 3], [0.08, -0.15, 0.0], [-0.3, 0.2, 0.5]] {
            let mount = SensorPose::from_xyz_rpy([0.25, 0.1, 0.3], rpy);
            let pose = SensorPose::on_robot(robot, &mount);
            let s = fast.scan(&pose, 0, &mut a).unwrap();
            let want = if rpy == [0.0; 3] {
                ScanPath::Planar
            } else {
                ScanPath::General
            };
            assert_eq!(s.path, want);
            let n = reference.scan(&pose, &mut b).unwrap();
            assert_mostly_agree(&a, &b, &format!("{robot:?} {rpy:?}"));
            assert!(s.returns.abs_diff(n) <= GRAZES, "{robot:?} {rpy:?}");
            assert!(n > 1000, "{robot:?} {rpy:?}: only {n} returns");
            checked += 1;
        }
    }
    assert!(checked >= 12);
    // A carried body moved across cells is found where it is now, not where it was.
    let rack = scene
        .body("rack_1")
        .map(|(i, _)| i)
        .expect("a movable rack");
    let robot = robots[0];
    fast.set_body_pose(rack, robot).unwrap();
    let mut reference = reference;
    reference.set_body_pose(rack, robot).unwrap();
    let pose = SensorPose::on_robot(
        &robot,
        &SensorPose::from_xyz_rpy([0.25, 0.1, 0.2], [0.0; 3]),
    );
    fast.scan(&pose, 0, &mut a).unwrap();
    reference.scan(&pose, &mut b).unwrap();
    assert_mostly_agree(&a, &b, "carried rack");
}

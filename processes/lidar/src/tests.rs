//! Scan-level tests: geometry of the organised cloud, noise, moving bodies, and the fast
//! paths against the parry3d reference on the shipped warehouse.

use crate::*;
use aisle_config::scene::{Body, BoxPart, Scene};
use aisle_geometry::Pose2;
use std::f64::consts::{FRAC_PI_2, PI};

fn quiet() -> LidarConfig {
    let mut c = LidarConfig::default();
    c.noise.enabled = false;
    c
}

fn body(name: &str, x: f64, y: f64, yaw: f64, parts: &[([f64; 3], [f64; 3])]) -> Body {
    Body {
        name: name.to_string(),
        kind: "box".to_string(),
        is_static: false,
        pose: Pose2::new(x, y, yaw),
        parts: parts
            .iter()
            .map(|&(center, size)| BoxPart { center, size })
            .collect(),
    }
}

/// A box standing on the floor, like the scene's `size = [...]` bodies.
fn floor_box(name: &str, x: f64, y: f64, size: [f64; 3]) -> Body {
    body(name, x, y, 0.0, &[([0.0, 0.0, 0.5 * size[2]], size)])
}

fn warehouse() -> Scene {
    let p = aisle_config::testing::shipped("warehouse.toml");
    Scene::load(&p).unwrap()
}

fn level(x: f64, y: f64, yaw: f64) -> SensorPose {
    SensorPose::planar(x, y, 0.2, yaw)
}

fn cloud(r: &Raycaster) -> Vec<[f32; 3]> {
    vec![[0.0; 3]; r.len()]
}

fn bits(c: &[[f32; 3]]) -> Vec<u32> {
    c.iter().flatten().map(|v| v.to_bits()).collect()
}

fn range(p: [f32; 3]) -> f32 {
    (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
}

#[test]
fn a_box_at_a_known_range_is_returned_there() {
    // Front face at x = 5, top 0.8 m above the sensor.
    let scene = Scene {
        bodies: vec![floor_box("b", 5.5, 0.0, [1.0, 2.0, 1.0])],
    };
    let mut r = Raycaster::new(&quiet(), &scene).unwrap();
    let mut out = cloud(&r);
    let stats = r.scan(&level(0.0, 0.0, 0.0), 0, &mut out).unwrap();
    assert_eq!(stats.path, ScanPath::Planar);
    let p = out[r.pattern().index(0, 600)];
    assert_eq!(p, [5.0, 0.0, 0.0]);
    // Rows up to 9 deg reach the face below its top (5 tan 9 = 0.79 < 0.8), 10 deg and up
    // pass over the box.
    for row in 0..31 {
        let p = out[r.pattern().index(row, 600)];
        if row <= 9 {
            let want = 5.0 / (row as f64).to_radians().cos();
            assert!(
                (f64::from(range(p)) - want).abs() < 1e-5,
                "row {row}: {p:?}"
            );
            assert!((p[0] - 5.0).abs() < 1e-5);
        } else {
            assert!(p[0].is_nan(), "row {row}: {p:?}");
        }
    }

    let mut noisy = Raycaster::new(&LidarConfig::default(), &scene).unwrap();
    noisy.scan(&level(0.0, 0.0, 0.0), 0, &mut out).unwrap();
    let mut off = 0;
    for row in 0..=9 {
        let p = out[r.pattern().index(row, 600)];
        let want = 5.0 / (row as f64).to_radians().cos();
        let err = f64::from(range(p)) - want;
        assert!(err.abs() < 5.0 * 0.002, "row {row}: error {err}");
        if err.abs() > 1e-6 {
            off += 1;
        }
    }
    assert!(off >= 8, "noise should move almost every return");
}

#[test]
fn nothing_is_returned_past_max_range() {
    let far = Scene {
        bodies: vec![floor_box("far", 13.5, 0.0, [1.0, 30.0, 10.0])],
    };
    let mut r = Raycaster::new(&quiet(), &far).unwrap();
    let mut out = cloud(&r);
    assert_eq!(
        r.scan(&level(0.0, 0.0, 0.0), 0, &mut out).unwrap().returns,
        0
    );
    assert!(out.iter().all(|p| p.iter().all(|v| v.is_nan())));

    // Face at 11.9 m: a ray at elevation e travels 11.9 / cos e to reach it.
    let near = Scene {
        bodies: vec![floor_box("near", 12.2, 0.0, [0.6, 1.0, 10.0])],
    };
    let mut r = Raycaster::new(&quiet(), &near).unwrap();
    r.scan(&level(0.0, 0.0, 0.0), 0, &mut out).unwrap();
    for row in 0..31 {
        let p = out[r.pattern().index(row, 600)];
        let travel = 11.9 / (row as f64).to_radians().cos();
        assert_eq!(p[0].is_nan(), travel > 12.0, "row {row}: {p:?}");
    }
}

#[test]
fn columns_are_azimuths_and_rows_are_elevations() {
    let (s, c) = 60f64.to_radians().sin_cos();
    let scene = Scene {
        bodies: vec![
            // A thin post 4 m away at +60 deg.
            floor_box("post", 4.0 * c, 4.0 * s, [0.1, 0.1, 1.0]),
            // A box floating 1.8..2.8 m above the floor, straight ahead.
            body("high", 5.5, 0.0, 0.0, &[([0.0, 0.0, 2.3], [1.0, 1.0, 1.0])]),
        ],
    };
    let mut r = Raycaster::new(&quiet(), &scene).unwrap();
    let mut out = cloud(&r);
    r.scan(&level(0.0, 0.0, 0.0), 0, &mut out).unwrap();
    let pat = r.pattern().clone();
    // Column 900 is +60 deg (col 0 = -120, 0.2 deg steps).
    let p = out[pat.index(0, 900)];
    assert!((f64::from(p[1]).atan2(f64::from(p[0])) - 60f64.to_radians()).abs() < 1e-3);
    let post_cols: Vec<usize> = (0..pat.columns())
        .filter(|&col| !out[pat.index(0, col)][0].is_nan())
        .collect();
    // The post subtends the angles between its extreme corners (59.0..61.0 deg seen
    // from the origin): exactly the columns whose azimuth falls in there see it.
    let corner_angles: Vec<f64> = [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)]
        .iter()
        .map(|&(sx, sy)| (4.0 * s + 0.05 * sy).atan2(4.0 * c + 0.05 * sx))
        .collect();
    let lo = corner_angles.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = corner_angles
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    let expected: Vec<usize> = (0..pat.columns())
        .filter(|&col| (lo..=hi).contains(&pat.azimuths()[col]))
        .collect();
    assert_eq!(expected, (896..=904).collect::<Vec<_>>());
    assert_eq!(post_cols, expected);
    assert!(out[pat.index(0, 300)][0].is_nan(), "nothing at -60 deg");

    // The floating box: only rows whose ray climbs to 1.6 m above the sensor within
    // 6 m (the far face) can see it; row 0 passes under it.
    let hit_rows: Vec<usize> = (0..pat.rows())
        .filter(|&row| !out[pat.index(row, 600)][0].is_nan())
        .collect();
    assert!(!hit_rows.is_empty());
    let lowest = (1.6f64 / 6.0).atan().to_degrees();
    assert!(
        hit_rows.iter().all(|&row| row as f64 >= lowest),
        "{hit_rows:?}"
    );
    for &row in &hit_rows {
        assert!(out[pat.index(row, 600)][2] >= 1.6 - 1e-5);
    }
}

#[test]
fn noise_is_a_function_of_seed_and_scan_index() {
    let scene = warehouse();
    let pose = SensorPose::on_robot(
        &Pose2::new(0.0, 0.0, 0.0),
        &SensorPose::from_xyz_rpy([0.25, 0.1, 0.2], [0.0; 3]),
    );
    let cfg = LidarConfig::default();
    let mut a = Raycaster::new(&cfg, &scene).unwrap();
    let mut b = Raycaster::new(&cfg, &scene).unwrap();
    let (mut oa, mut ob) = (cloud(&a), cloud(&b));
    // b has run other scans before: the noise of scan 5 must not depend on that.
    b.scan(&pose, 4, &mut ob).unwrap();
    a.scan(&pose, 5, &mut oa).unwrap();
    b.scan(&pose, 5, &mut ob).unwrap();
    assert_eq!(bits(&oa), bits(&ob));

    b.scan(&pose, 6, &mut ob).unwrap();
    assert_ne!(bits(&oa), bits(&ob));
    let mut other = cfg.clone();
    other.noise.seed = 2;
    let mut c = Raycaster::new(&other, &scene).unwrap();
    c.scan(&pose, 5, &mut ob).unwrap();
    assert_ne!(bits(&oa), bits(&ob));
    // Same NaN pattern either way: noise moves points, it does not add or drop them.
    assert!(
        oa.iter()
            .zip(&ob)
            .all(|(p, q)| p[0].is_nan() == q[0].is_nan())
    );
}

fn assert_agree(fast: &[[f32; 3]], reference: &[[f32; 3]], what: &str) {
    assert_agree_within(fast, reference, 1e-4, what);
}

/// Same returns (hit or not, ray by ray), and points within `tol` metres.
fn assert_agree_within(fast: &[[f32; 3]], reference: &[[f32; 3]], tol: f32, what: &str) {
    let mut worst = 0.0f32;
    for (i, (p, q)) in fast.iter().zip(reference).enumerate() {
        assert_eq!(
            p[0].is_nan(),
            q[0].is_nan(),
            "{what}: ray {i}: fast {p:?} reference {q:?}"
        );
        if !p[0].is_nan() {
            for k in 0..3 {
                worst = worst.max((p[k] - q[k]).abs());
            }
        }
    }
    assert!(worst <= tol, "{what}: worst difference {worst} m");
}

#[test]
fn fast_paths_match_parry_on_the_shipped_warehouse() {
    let scene = warehouse();
    let cfg = quiet();
    let mut fast = Raycaster::new(&cfg, &scene).unwrap();
    let reference = ParryReference::new(&cfg, &scene).unwrap();
    let (mut a, mut b) = (cloud(&fast), cloud(&fast));
    let mount = SensorPose::from_xyz_rpy([0.25, 0.1, 0.2], [0.0; 3]);
    let robots = [
        Pose2::new(0.0, 0.0, 0.0),
        Pose2::new(2.0, 11.0, FRAC_PI_2),
        Pose2::new(2.0, 13.0, -FRAC_PI_2),
        Pose2::new(6.0, -7.0, 0.0),
        Pose2::new(6.0, 8.0, FRAC_PI_2),
        Pose2::new(10.3, -4.0, 2.4),
        Pose2::new(-1.7, 17.1, -2.9),
        Pose2::new(3.3, 3.3, PI),
    ];
    for robot in robots {
        let pose = SensorPose::on_robot(&robot, &mount);
        let s = fast.scan(&pose, 0, &mut a).unwrap();
        assert_eq!(s.path, ScanPath::Planar);
        let n = reference.scan(&pose, &mut b).unwrap();
        assert_eq!(s.returns, n, "{robot:?}");
        assert!(n > 1000, "{robot:?}: only {n} returns");
        assert_agree(&a, &b, &format!("level {robot:?}"));
    }
    // Tilted sensors take the general path (and some rays reach the floor).
    for (robot, rpy) in [
        (Pose2::new(0.0, 0.0, 0.0), [0.05, -0.2, 0.0]),
        (Pose2::new(2.0, 11.0, FRAC_PI_2), [-0.1, 0.3, 0.4]),
        (Pose2::new(6.0, -7.0, 0.7), [0.6, 0.0, 0.0]),
    ] {
        let mount = SensorPose::from_xyz_rpy([0.25, 0.1, 0.2], rpy);
        let pose = SensorPose::on_robot(&robot, &mount);
        let s = fast.scan(&pose, 0, &mut a).unwrap();
        assert_eq!(s.path, ScanPath::General);
        let n = reference.scan(&pose, &mut b).unwrap();
        assert_eq!(s.returns, n, "{robot:?} {rpy:?}");
        assert_agree(&a, &b, &format!("tilted {robot:?} {rpy:?}"));
    }
}

#[test]
fn downward_rays_hit_the_floor_only_when_asked() {
    let mut cfg = quiet();
    cfg.elevation_min_deg = -30.0;
    let scene = Scene {
        bodies: vec![floor_box("b", 50.0, 50.0, [1.0, 1.0, 1.0])],
    };
    let mut r = Raycaster::new(&cfg, &scene).unwrap();
    let mut out = cloud(&r);
    r.scan(&SensorPose::planar(0.0, 0.0, 1.0, 0.3), 0, &mut out)
        .unwrap();
    // Row 0 is -30 deg: the floor 1 m below is 2 m away along it.
    let p = out[r.pattern().index(0, 77)];
    assert!(
        (range(p) - 2.0).abs() < 1e-5 && (p[2] + 1.0).abs() < 1e-5,
        "{p:?}"
    );
    assert!(out[r.pattern().index(30, 77)][0].is_nan(), "level ray");
    let reference = ParryReference::new(&cfg, &scene).unwrap();
    let mut b = cloud(&r);
    let tilted = SensorPose::from_xyz_rpy([0.0, 0.0, 1.0], [0.0, 0.2, 0.3]);
    r.scan(&tilted, 0, &mut out).unwrap();
    reference.scan(&tilted, &mut b).unwrap();
    assert_agree(&out, &b, "floor, tilted");

    cfg.hit_floor = false;
    let mut r = Raycaster::new(&cfg, &scene).unwrap();
    assert_eq!(r.scan(&tilted, 0, &mut out).unwrap().returns, 0);
}

#[test]
fn moving_a_body_moves_its_returns() {
    let scene = Scene {
        bodies: vec![floor_box("b", 4.0, 0.0, [0.2, 0.2, 1.0])],
    };
    let mut r = Raycaster::new(&quiet(), &scene).unwrap();
    let mut out = cloud(&r);
    let pose = level(0.0, 0.0, 0.0);
    r.scan(&pose, 0, &mut out).unwrap();
    assert!(!out[r.pattern().index(0, 600)][0].is_nan());
    // To +45 deg at the same distance.
    let (s, c) = 45f64.to_radians().sin_cos();
    r.set_body_pose(0, Pose2::new(4.0 * c, 4.0 * s, 0.3))
        .unwrap();
    r.scan(&pose, 0, &mut out).unwrap();
    assert!(out[r.pattern().index(0, 600)][0].is_nan());
    assert!(!out[r.pattern().index(0, 825)][0].is_nan());

    // The carried rack in the warehouse: the fast path follows it like the reference.
    let scene = warehouse();
    let (rack, _) = scene.body("rack2b").unwrap();
    let cfg = quiet();
    let mut fast = Raycaster::new(&cfg, &scene).unwrap();
    let mut reference = ParryReference::new(&cfg, &scene).unwrap();
    let mut b = cloud(&fast);
    let mount = SensorPose::from_xyz_rpy([0.25, 0.1, 0.2], [0.0; 3]);
    let robot = Pose2::new(2.0, 11.5, FRAC_PI_2);
    let before = {
        fast.scan(&SensorPose::on_robot(&robot, &mount), 0, &mut out)
            .unwrap();
        bits(&out)
    };
    let carried = Pose2::new(2.0, 12.0, 1.2);
    fast.set_body_pose(rack, carried).unwrap();
    reference.set_body_pose(rack, carried).unwrap();
    let pose = SensorPose::on_robot(&robot, &mount);
    fast.scan(&pose, 0, &mut out).unwrap();
    reference.scan(&pose, &mut b).unwrap();
    assert_ne!(before, bits(&out));
    assert_agree(&out, &b, "moved rack");

    // Robot under the carried rack: its deck (0.30..0.35 m) is seen from below.
    let robot = Pose2::new(2.0, 13.0, FRAC_PI_2);
    let under = Pose2::new(2.0 - 0.1, 13.0 + 0.25, FRAC_PI_2);
    fast.set_body_pose(rack, under).unwrap();
    reference.set_body_pose(rack, under).unwrap();
    let pose = SensorPose::on_robot(&robot, &mount);
    fast.scan(&pose, 0, &mut out).unwrap();
    reference.scan(&pose, &mut b).unwrap();
    assert_agree(&out, &b, "under the rack");
    let up = out[fast.pattern().index(30, 600)];
    assert!(
        (up[2] - 0.1).abs() < 1e-5,
        "30 deg ray meets the deck 0.1 m up: {up:?}"
    );
}

#[test]
fn a_disabled_body_such_as_the_robot_is_not_hit() {
    let mut scene = warehouse();
    let without = scene.clone();
    // The robot's own shell, drawn around and in front of the sensor.
    let robot = Pose2::new(0.0, 0.0, 0.0);
    scene.bodies.push(body(
        "robot",
        robot.x,
        robot.y,
        robot.theta,
        &[
            ([0.0, 0.0, 0.092], [0.42, 0.31, 0.184]),
            ([0.33, 0.1, 0.3], [0.05, 0.4, 0.4]),
        ],
    ));
    let idx = scene.bodies.len() - 1;
    let mount = SensorPose::from_xyz_rpy([0.25, 0.1, 0.2], [0.0; 3]);
    let pose = SensorPose::on_robot(&robot, &mount);
    let mut with_robot = Raycaster::new(&quiet(), &scene).unwrap();
    let mut plain = Raycaster::new(&quiet(), &without).unwrap();
    let (mut a, mut b) = (cloud(&plain), cloud(&plain));
    with_robot.scan(&pose, 0, &mut a).unwrap();
    plain.scan(&pose, 0, &mut b).unwrap();
    assert_ne!(bits(&a), bits(&b), "the shell is in the way when enabled");
    with_robot.set_body_enabled(idx, false).unwrap();
    with_robot.scan(&pose, 0, &mut a).unwrap();
    assert_eq!(bits(&a), bits(&b));
}

#[test]
fn a_sensor_inside_a_box_does_not_see_that_box() {
    let scene = Scene {
        bodies: vec![
            floor_box("shell", 0.0, 0.0, [1.0, 1.0, 1.0]),
            floor_box("wall", 6.0, 0.0, [1.0, 20.0, 3.0]),
        ],
    };
    let mut r = Raycaster::new(&quiet(), &scene).unwrap();
    let mut out = cloud(&r);
    r.scan(&level(0.0, 0.0, 0.0), 0, &mut out).unwrap();
    assert!((out[r.pattern().index(0, 600)][0] - 5.5).abs() < 1e-5);
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let mut r = Raycaster::new(&quiet(), &warehouse()).unwrap();
    let mut short = vec![[0.0; 3]; 10];
    assert_eq!(
        r.scan(&level(0.0, 0.0, 0.0), 0, &mut short),
        Err(LidarError::BufferSize {
            expected: 37_231,
            got: 10
        })
    );
    let mut out = cloud(&r);
    let nan = SensorPose::planar(f64::NAN, 0.0, 0.2, 0.0);
    assert_eq!(r.scan(&nan, 0, &mut out), Err(LidarError::BadSensorPose));
    assert!(matches!(
        r.set_body_pose(99, Pose2::new(0.0, 0.0, 0.0)),
        Err(LidarError::BodyIndex { index: 99, .. })
    ));
    assert!(matches!(
        r.set_body_pose(0, Pose2::new(f64::INFINITY, 0.0, 0.0)),
        Err(LidarError::BodyPose { .. })
    ));
    let mut bad = quiet();
    bad.max_range = -1.0;
    let e = Raycaster::new(&bad, &warehouse()).unwrap_err();
    assert!(e.to_string().contains("max_range"), "{e}");
    assert!(r.set_noise(true, f64::NAN, 1).is_err());
}

#[test]
fn scan_robot_uses_the_mount_and_the_floor_frame() {
    let scene = warehouse();
    let mut r = Raycaster::new(&LidarConfig::default(), &scene).unwrap();
    // Until a mount is set the sensor sits at the floor frame's origin.
    assert_eq!(*r.mount(), SensorPose::IDENTITY);
    r.set_mount(SensorPose::from_xyz_rpy([0.25, 0.1, 0.2], [0.0; 3]))
        .unwrap();
    let robot = Pose2::new(2.0, 11.0, FRAC_PI_2);
    let s = r.sensor_pose(&robot);
    assert!((s.position[0] - 1.9).abs() < 1e-12 && (s.position[1] - 11.25).abs() < 1e-12);
    assert!((s.position[2] - 0.2).abs() < 1e-12);

    let (mut a, mut b) = (cloud(&r), cloud(&r));
    r.scan_robot(&robot, 17, &mut a).unwrap();
    r.scan(&SensorPose::on_robot(&robot, r.mount()), 17, &mut b)
        .unwrap();
    assert_eq!(bits(&a), bits(&b));

    // A higher mount changes what is seen, and scan_robot follows it.
    let high = SensorPose::from_xyz_rpy([0.25, 0.1, 0.2635], [0.0; 3]);
    r.set_mount(high).unwrap();
    r.scan_robot(&robot, 17, &mut a).unwrap();
    assert_ne!(bits(&a), bits(&b));
    r.scan(&SensorPose::on_robot(&robot, &high), 17, &mut b)
        .unwrap();
    assert_eq!(bits(&a), bits(&b));

    let mut skew = high;
    skew.rotation[0][1] = 0.5;
    assert_eq!(r.set_mount(skew), Err(LidarError::BadMount));
    assert_eq!(*r.mount(), high, "a refused mount leaves the old one");
    assert_eq!(
        r.scan_robot(&Pose2::new(f64::NAN, 0.0, 0.0), 0, &mut a),
        Err(LidarError::BadSensorPose)
    );
}

#[test]
fn bodies_are_found_by_scene_name() {
    let scene = warehouse();
    let r = Raycaster::new(&quiet(), &scene).unwrap();
    let (want, _) = scene.body("rack2b").unwrap();
    assert_eq!(r.body_index("rack2b"), Some(want));
    assert_eq!(r.body_count(), scene.bodies.len());
    assert_eq!(r.body_index("no such body"), None);
}

#[test]
fn same_seed_and_tick_give_the_same_bits_from_fresh_casters() {
    let scene = warehouse();
    let robot = Pose2::new(0.0, 0.0, 0.0);
    let run = || {
        let mut r = Raycaster::new(&LidarConfig::default(), &scene).unwrap();
        let mut out = cloud(&r);
        r.scan_robot(&robot, 42, &mut out).unwrap();
        bits(&out)
    };
    assert_eq!(run(), run());
}

#[test]
fn compacting_keeps_returns_in_order() {
    let n = f32::NAN;
    let mut c = vec![[n; 3], [1.0, 2.0, 3.0], [n; 3], [4.0, 5.0, 6.0]];
    assert_eq!(compact_returns(&mut c), 2);
    assert_eq!(c[0], [1.0, 2.0, 3.0]);
    assert_eq!(c[1], [4.0, 5.0, 6.0]);
    assert!(c[2][0].is_nan() && c[3][0].is_nan());
}

mod allocation {
    use super::*;
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::cell::Cell;

    /// Counts this thread's allocations, to show that a scan makes none.
    struct Counting;

    thread_local! {
        static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
    }

    fn count() -> usize {
        ALLOCATIONS.with(Cell::get)
    }

    // SAFETY: forwards every call to the system allocator unchanged.
    unsafe impl GlobalAlloc for Counting {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
            // SAFETY: same contract as our caller's.
            unsafe { System.alloc(layout) }
        }
        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            // SAFETY: same contract as our caller's.
            unsafe { System.dealloc(ptr, layout) }
        }
        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
            // SAFETY: same contract as our caller's.
            unsafe { System.realloc(ptr, layout, new_size) }
        }
    }

    #[global_allocator]
    static GLOBAL: Counting = Counting;

    #[test]
    fn a_scan_allocates_nothing() {
        let scene = warehouse();
        let mut r = Raycaster::new(&LidarConfig::default(), &scene).unwrap();
        let two = LidarConfig {
            scan_threads: 2,
            ..LidarConfig::default()
        };
        let mut r2 = Raycaster::new(&two, &scene).unwrap();
        let mut out = cloud(&r);
        let (rack, _) = scene.body("rack2b").unwrap();
        let tilted = SensorPose::from_xyz_rpy([2.0, 11.0, 0.2], [0.1, 0.2, 1.0]);
        let before = count();
        for k in 0..3 {
            r.set_body_pose(rack, Pose2::new(2.0, 13.0 + 0.1 * k as f64, 1.0))
                .unwrap();
            r2.set_body_pose(rack, Pose2::new(2.0, 13.0 + 0.1 * k as f64, 1.0))
                .unwrap();
            r.scan(&level(2.0, 11.0, FRAC_PI_2), k, &mut out).unwrap();
            r.scan(&level(0.0, 0.0, 0.0), k, &mut out).unwrap();
            r.scan(&tilted, k, &mut out).unwrap();
            // The helper thread's hand-over allocates nothing either.
            r2.scan(&tilted, k, &mut out).unwrap();
            r.scan_robot(&Pose2::new(2.0, 12.0, 1.0), k, &mut out)
                .unwrap();
        }
        assert_eq!(count(), before);
    }
}

mod golden;
mod large;
mod threads;

//! One thread or two for a tilted scan: the same points bit for bit (the helper sweeps
//! the second half of the columns), in the seed warehouse and a generated one, with
//! moved bodies between scans and from a copy of the raycaster; a third is refused.

use super::{bits, cloud, quiet, warehouse};
use crate::*;
use aisle_config::Validate;
use aisle_config::scene_gen::{GenParams, generate_scene};
use aisle_geometry::Pose2;

fn with_threads(threads: u32) -> LidarConfig {
    LidarConfig {
        scan_threads: threads,
        ..quiet()
    }
}

#[test]
fn two_threads_scan_the_points_of_one() {
    let scenes = [warehouse(), generate_scene(&GenParams::new(4, 80.0, 1))];
    let mut compared = 0;
    for scene in &scenes {
        let mut one = Raycaster::new(&with_threads(1), scene).unwrap();
        let two = Raycaster::new(&with_threads(2), scene).unwrap();
        // A copy has a helper of its own.
        let mut two = two.clone();
        let (mut a, mut b) = (cloud(&one), cloud(&two));
        let movable = (0..scene.bodies.len()).find(|&i| !scene.bodies[i].is_static);
        for k in 0..12u32 {
            let t = f64::from(k);
            let sensor = SensorPose::from_xyz_rpy(
                [1.0 + 0.7 * t % 6.0, 2.0 + 1.3 * t % 20.0, 0.3],
                [0.02 * t - 0.13, 0.15 - 0.03 * t, 0.5 * t],
            );
            if let Some(i) = movable {
                let pose = Pose2::new(1.5 + 0.2 * t, 3.0, 0.3 * t);
                one.set_body_pose(i, pose).unwrap();
                two.set_body_pose(i, pose).unwrap();
            }
            let sa = one.scan(&sensor, k.into(), &mut a).unwrap();
            let sb = two.scan(&sensor, k.into(), &mut b).unwrap();
            assert_eq!(sa, sb, "scan {k}");
            assert_eq!(sa.path, ScanPath::General);
            assert_eq!(bits(&a), bits(&b), "scan {k}");
            compared += sa.returns;
        }
    }
    assert!(compared > 100_000, "{compared} returns compared");
}

#[test]
fn a_third_thread_is_refused_by_name() {
    for threads in [0, 3] {
        let err = with_threads(threads).validate().unwrap_err();
        assert!(err.to_string().contains("scan_threads"), "{err}");
    }
}

//! The generated warehouses and the sensor pose in them that `benches/scan.rs` times
//! and `examples/scan_cpu.rs` measures in CPU time: one list, so both speak of the same
//! scans.

use aisle_config::scene_gen::{GenParams, Layout};
use aisle_geometry::Pose2;
use aisle_lidar::SensorPose;

/// Label and parameters of each generated warehouse (about 1k, 5k, 10k and 20k bodies;
/// `large` is `config/large`'s).
pub fn generated() -> [(&'static str, GenParams); 4] {
    [
        ("1k", GenParams::new(4, 80.0, 1)),
        ("5k", GenParams::new(10, 150.0, 1)),
        ("large", GenParams::new(19, 172.0, 1)),
        ("20k", GenParams::new(28, 230.0, 1)),
    ]
}

/// The robot in the middle aisle of `p`'s layout, 14 m in, heading along it.
pub fn robot_in_aisle(p: &GenParams) -> Pose2 {
    let layout = Layout::new(p);
    // aisles[0..2] are the main and back cross aisles, then the picking aisles.
    let a = layout.aisles[2 + p.aisles as usize / 2];
    Pose2::new(
        0.5 * (a[0] + a[2]),
        a[1] + 14.0,
        std::f64::consts::FRAC_PI_2,
    )
}

/// The sensor of a robot at `robot`: the bench's mount, level or tilted.
pub fn on_robot(robot: &Pose2, tilted: bool) -> SensorPose {
    let rpy = if tilted { [0.05, -0.1, 0.0] } else { [0.0; 3] };
    SensorPose::on_robot(robot, &SensorPose::from_xyz_rpy([0.25, 0.1, 0.2], rpy))
}

/// Rooms per side of [`seed_tiled`]: 3 x 3 seed warehouses (every room the lidar's 12 m
/// reach from the middle one meets, 270 bodies) and 10 x 10 (200 x 300 m, 3,000 bodies,
/// larger than `config/large` and as dense as the seed).
pub const SEED_TILES: [usize; 2] = [3, 10];

/// The seed warehouse (`seed`, a 20 x 30 m room with its walls) repeated `n x n` times
/// side by side, and the offset of the middle room: the same scene at `n^2` times the
/// area, so a scan from the same pose in the middle room shows what size alone costs
/// (the generated warehouses are denser than the seed, which costs on its own).
pub fn seed_tiled(
    seed: &aisle_config::scene::Scene,
    n: usize,
) -> (aisle_config::scene::Scene, (f64, f64)) {
    let (w, h) = (20.0, 30.0);
    let mut bodies = Vec::with_capacity(seed.bodies.len() * n * n);
    for i in 0..n {
        for j in 0..n {
            bodies.extend(seed.bodies.iter().map(|b| {
                let mut b = b.clone();
                b.name = format!("{}_{i}_{j}", b.name);
                b.pose = Pose2::new(
                    b.pose.x + w * i as f64,
                    b.pose.y + h * j as f64,
                    b.pose.theta,
                );
                b
            }));
        }
    }
    let mid = (n / 2) as f64;
    (aisle_config::scene::Scene { bodies }, (w * mid, h * mid))
}

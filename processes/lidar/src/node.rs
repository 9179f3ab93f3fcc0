//! The lidar process: on every tick, one organised scan from the robot's pose at that
//! tick, written in place into the loaned `PointCloud` sample.
//!
//! The sensor's mounting comes from `robot.toml` ([lidar_mount]: a URDF link and a
//! pose), resolved through the robot's URDF by `aisle-robot`. Movable bodies (the
//! carried rack above all) are moved to their ground-truth poses before each scan: the lidar is part of the
//! simulation, so unlike the navigation processes it may read `WorldTruth`.
//!
//! Adapter only: the raycasting is [`crate::Raycaster`].

use crate::{LidarConfig, Raycaster, SensorPose};
use aisle_bus::{Bus, NodeArgs, NodeError, StageTimer, Stamp, TickFollower};
use aisle_config::scene::Scene;
use aisle_geometry::Pose2;
use aisle_messages::{
    MAX_CLOUD_COLS, MAX_CLOUD_ROWS, NodeKind, PointCloud, Pose3Msg, RobotState, StageStatus,
    WorldTruth, services,
};

/// Roll, pitch, yaw (URDF convention) of a rotation matrix.
fn rpy_of(r: &[[f64; 3]; 3]) -> [f64; 3] {
    let pitch = (-r[2][0]).clamp(-1.0, 1.0).asin();
    let roll = r[2][1].atan2(r[2][2]);
    let yaw = r[1][0].atan2(r[0][0]);
    [roll, pitch, yaw]
}

pub fn run(args: &NodeArgs) -> Result<(), NodeError> {
    let lidar_toml = args.config_dir.join("lidar.toml");
    let cfg =
        aisle_config::load::<LidarConfig>(&lidar_toml).map_err(|e| NodeError::setup("lidar", e))?;
    let scene = Scene::load(&args.config_dir.join("warehouse.toml"))
        .map_err(|e| NodeError::setup("lidar", e))?;
    let (robot_cfg, model) = aisle_robot::load_robot(&args.config_dir.join("robot.toml"))
        .map_err(|e| NodeError::setup("lidar", e))?;
    let mount = model
        .mount_in_base(&robot_cfg.lidar_mount)
        .map_err(|e| NodeError::setup("lidar", e))?;
    let mut raycaster = Raycaster::new(&cfg, &scene).map_err(|e| NodeError::setup("lidar", e))?;
    let (rows, cols) = (raycaster.rows(), raycaster.columns());
    if rows > MAX_CLOUD_ROWS || cols > MAX_CLOUD_COLS {
        return Err(NodeError::setup(
            format!("lidar: {}", lidar_toml.display()),
            format!(
                "{rows} x {cols} channels exceed the PointCloud capacity of {MAX_CLOUD_ROWS} x {MAX_CLOUD_COLS}"
            ),
        ));
    }
    let n = raycaster.len();

    let (bus, info) = Bus::join(&args.instance, NodeKind::Lidar, NodeArgs::JOIN_TIMEOUT)?;
    // The run's seed and the configured one together select the noise streams.
    let seed = cfg.noise.seed ^ info.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    raycaster
        .set_noise(cfg.noise.enabled, cfg.noise.sigma, seed)
        .map_err(|e| NodeError::setup("lidar: noise", e))?;
    let mut cloud = bus.publisher::<PointCloud>(services::POINT_CLOUD)?;
    let robot = bus.subscriber::<RobotState>(services::ROBOT_STATE)?;
    let truth = bus.subscriber::<WorldTruth>(services::WORLD_TRUTH)?;
    let mut ticks = TickFollower::new(&bus)?;
    ticks.ready()?;

    let mut pose = Pose2::new(args.start[0], args.start[1], args.start[2]);
    let mut carried: i32 = -1;
    loop {
        // A tick seen again (the simulator restarted) is scanned again: the scan is a
        // function of the tick, and the mapper recognises the repeat and acknowledges.
        let tick = ticks.wait_tick_refreshing(|| {
            let _ = cloud.update_connections();
        })?;
        let timer = StageTimer::start();
        if let Some(rs) = robot.latest()? {
            pose = rs.pose.into();
            carried = rs.carried_body;
        }
        if let Some(t) = truth.latest()? {
            let len = (t.len as usize)
                .min(t.bodies.len())
                .min(raycaster.body_count());
            for (i, b) in t.bodies[..len].iter().enumerate() {
                if b.is_static == 0 {
                    let p: Pose2 = b.pose.into();
                    if raycaster.body_pose(i) != Some(p) {
                        raycaster
                            .set_body_pose(i, p)
                            .map_err(|e| NodeError::Protocol(format!("lidar: {e}")))?;
                    }
                }
            }
        }
        let sensor = SensorPose::on_robot(&pose, &mount);
        let mut failure = None;
        cloud.publish(Stamp::of(&tick.header), |m| {
            m.rows = rows as u32;
            m.cols = cols as u32;
            m.sensor_pose = Pose3Msg {
                position: sensor.position,
                rpy: rpy_of(&sensor.rotation),
            };
            m.robot_pose = pose.into();
            m.carried_body = carried;
            let points = &mut m.points[..n];
            if args.lidar_off {
                points.fill([f32::NAN; 3]);
            } else if let Err(e) = raycaster.scan(&sensor, tick.header.tick, points) {
                points.fill([f32::NAN; 3]);
                failure = Some(e);
            }
        })?;
        let status = if failure.is_some() {
            StageStatus::Failed
        } else {
            StageStatus::Done
        };
        if let Some(e) = failure {
            tracing::warn!("lidar: scan of tick {} failed: {e}", tick.header.tick);
        }
        ticks.done(&tick, status, timer.elapsed_ns())?;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rpy_round_trips() {
        let rpy = [0.1, -0.2, 2.5];
        let p = SensorPose::from_xyz_rpy([0.0; 3], rpy);
        let back = rpy_of(&p.rotation);
        for i in 0..3 {
            assert!((back[i] - rpy[i]).abs() < 1e-12, "{back:?}");
        }
    }
}

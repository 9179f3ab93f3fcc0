//! The lidar process: on every tick, one organised scan from the robot's pose at that
//! tick, written in place into the loaned `PointCloud` sample.
//!
//! The sensor's mounting comes from `robot.toml` ([lidar_mount]: a URDF link and a
//! pose), resolved through the robot's URDF by `aisle-robot`. Movable bodies (the
//! carried rack above all) are moved to their ground-truth poses before each scan: the lidar is part of the
//! simulation, so unlike the navigation processes it may read `WorldTruth`.
//!
//! Adapter only: the raycasting is [`crate::Raycaster`]; the loop around it is the
//! node runtime's (`aisle_node::run`).

use crate::{LidarConfig, Raycaster, SensorPose};
use aisle_bus::{NodeArgs, NodeError, Stamp};
use aisle_config::scene::Scene;
use aisle_geometry::Pose2;
use aisle_messages::{
    MAX_CLOUD_COLS, MAX_CLOUD_ROWS, NodeKind, Pose3Msg, StageStatus, Tick, Topic, WorldTruth,
    topics,
};
use aisle_node::{Cycle, Io, RunContext, Stage};

/// Roll, pitch, yaw (URDF convention) of a rotation matrix.
fn rpy_of(r: &[[f64; 3]; 3]) -> [f64; 3] {
    let pitch = (-r[2][0]).clamp(-1.0, 1.0).asin();
    let roll = r[2][1].atan2(r[2][2]);
    let yaw = r[1][0].atan2(r[0][0]);
    [roll, pitch, yaw]
}

/// The lidar as a stage: one scan per tick, from the robot's pose of that tick.
pub struct LidarStage {
    raycaster: Raycaster,
    mount: SensorPose,
    noise: crate::NoiseConfig,
    rows: usize,
    cols: usize,
    lidar_off: bool,
    pose: Pose2,
    carried: i32,
}

impl LidarStage {
    /// Loads `lidar.toml`, the robot and the scene from `config_dir`.
    pub fn new(
        config_dir: &std::path::Path,
        start: Pose2,
        lidar_off: bool,
    ) -> Result<LidarStage, NodeError> {
        let lidar_toml = config_dir.join("lidar.toml");
        let cfg = aisle_config::load::<LidarConfig>(&lidar_toml)
            .map_err(|e| NodeError::setup("lidar", e))?;
        let scene = Scene::load(&config_dir.join("warehouse.toml"))
            .map_err(|e| NodeError::setup("lidar", e))?;
        let (robot_cfg, model) = aisle_robot::load_robot(&config_dir.join("robot.toml"))
            .map_err(|e| NodeError::setup("lidar", e))?;
        let mount = model
            .mount_in_base(&robot_cfg.lidar_mount)
            .map_err(|e| NodeError::setup("lidar", e))?;
        let raycaster = Raycaster::new(&cfg, &scene).map_err(|e| NodeError::setup("lidar", e))?;
        let (rows, cols) = (raycaster.rows(), raycaster.columns());
        if rows > MAX_CLOUD_ROWS || cols > MAX_CLOUD_COLS {
            return Err(NodeError::setup(
                format!("lidar: {}", lidar_toml.display()),
                format!(
                    "{rows} x {cols} channels exceed the PointCloud capacity of {MAX_CLOUD_ROWS} x {MAX_CLOUD_COLS}"
                ),
            ));
        }
        Ok(LidarStage {
            raycaster,
            mount,
            noise: cfg.noise.clone(),
            rows,
            cols,
            lidar_off,
            pose: start,
            carried: -1,
        })
    }

    /// Moves the movable bodies to their ground-truth poses.
    fn follow_truth(&mut self, t: &WorldTruth) -> Result<(), NodeError> {
        let len = (t.len as usize).min(t.bodies.len());
        for b in &t.bodies[..len] {
            let i = b.index as usize;
            if b.is_static == 0 && i < self.raycaster.body_count() {
                let p: Pose2 = b.pose.into();
                if self.raycaster.body_pose(i) != Some(p) {
                    self.raycaster
                        .set_body_pose(i, p)
                        .map_err(|e| NodeError::Protocol(format!("lidar: {e}")))?;
                }
            }
        }
        Ok(())
    }
}

impl Stage for LidarStage {
    const KIND: NodeKind = NodeKind::Lidar;
    type Trigger = Tick;
    const TRIGGER: Topic<Tick> = topics::TICK;
    const NEWEST_ONLY: bool = true;

    fn start(&mut self, _io: &impl Io, ctx: &RunContext) -> Result<(), NodeError> {
        // The run's seed and the configured one together select the noise streams.
        let seed = self.noise.seed ^ ctx.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        self.raycaster
            .set_noise(self.noise.enabled, self.noise.sigma, seed)
            .map_err(|e| NodeError::setup("lidar: noise", e))
    }

    // A tick seen again (the simulator restarted) is scanned again: the scan is a
    // function of the tick, and the mapper recognises the repeat and acknowledges.
    fn process(&mut self, tick: &Tick, io: &impl Io) -> Result<Cycle, NodeError> {
        if let Some(rs) = io.latest(topics::ROBOT_STATE)? {
            self.pose = rs.pose.into();
            self.carried = rs.carried_body;
        }
        if let Some(t) = io.latest(topics::WORLD_TRUTH)? {
            self.follow_truth(&t)?;
        }
        let sensor = SensorPose::on_robot(&self.pose, &self.mount);
        let n = self.raycaster.len();
        let mut failure = None;
        io.publish(topics::POINT_CLOUD, Stamp::of(&tick.header), |m| {
            m.rows = self.rows as u32;
            m.cols = self.cols as u32;
            m.sensor_pose = Pose3Msg {
                position: sensor.position,
                rpy: rpy_of(&sensor.rotation),
            };
            m.robot_pose = self.pose.into();
            m.carried_body = self.carried;
            let points = &mut m.points[..n];
            if self.lidar_off {
                points.fill([f32::NAN; 3]);
            } else if let Err(e) = self.raycaster.scan(&sensor, tick.header.tick, points) {
                points.fill([f32::NAN; 3]);
                failure = Some(e);
            }
        })?;
        Ok(match failure {
            Some(e) => {
                tracing::warn!("lidar: scan of tick {} failed: {e}", tick.header.tick);
                Cycle::with_status(StageStatus::Failed)
            }
            None => Cycle::done(),
        })
    }
}

pub fn run(args: &NodeArgs) -> Result<(), NodeError> {
    let start = Pose2::new(args.start[0], args.start[1], args.start[2]);
    let mut stage = LidarStage::new(&args.config_dir, start, args.lidar_off)?;
    aisle_node::run(&mut stage, args)
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

    #[test]
    fn a_tick_gives_one_organised_cloud_from_the_robot_pose() {
        use aisle_node::testing::MemIo;
        let dir = aisle_config::testing::shipped_dir();
        let mut stage = LidarStage::new(&dir, Pose2::new(0.0, 0.0, 0.0), false).unwrap();
        let io = MemIo::new();
        let ctx = RunContext {
            mode: aisle_messages::TickMode::Lockstep,
            seed: 1,
            restarted: false,
        };
        stage.start(&io, &ctx).unwrap();
        io.push(topics::ROBOT_STATE, |m| {
            m.pose = Pose2::new(1.0, 2.0, 0.5).into()
        });
        let mut tick = *aisle_messages::zeroed_box::<Tick>();
        tick.header.tick = 3;
        let cycle = stage.process(&tick, &io).unwrap();
        assert_eq!(cycle.status, StageStatus::Done);
        assert_eq!(io.published_len(topics::POINT_CLOUD), 1);
        let (rows, cols, pose, tick_no, returns) = io
            .published(topics::POINT_CLOUD, 0, |c| {
                let n = (c.rows * c.cols) as usize;
                let returns = c.points[..n].iter().filter(|p| p[0].is_finite()).count();
                (c.rows, c.cols, c.robot_pose, c.header.tick, returns)
            })
            .unwrap();
        assert_eq!((rows as usize, cols as usize), (stage.rows, stage.cols));
        assert_eq!((pose.x, pose.y, pose.theta), (1.0, 2.0, 0.5));
        assert_eq!(tick_no, 3);
        assert!(returns > 100, "{returns} returns in the warehouse");
    }
}

//! The monitor as a stage of the group: triggered by each point cloud, it judges the
//! scan against the footprint (the carrying one while a rack is on the robot) and, when
//! the robot would not stop in time, publishes a `SimCommand` Stop stamped with the
//! scan's tick. The simulator then drives no trajectory of that tick or before. Muted
//! while the controller drives a straight docking move or turns on the spot
//! (`GoalMode::Straight`, `GoalMode::RotateInPlace`).

use crate::{Corridor, MonitorConfig, StopRule};
use aisle_bus::{NodeError, Stamp};
use aisle_messages::{
    ExternalNode, GoalMode, NodeKind, PointCloud, SimCommand, SimCommandKind, Topic, topics,
};
use aisle_node::{Cycle, Io, RunContext, Stage};
use aisle_robot::RobotConfig;
use std::path::Path;

/// The node's name in `graph.toml`.
pub const NAME: &str = "safety_monitor";

/// The monitor and what it needs to know of the robot.
#[derive(Debug, Clone)]
pub struct MonitorStage {
    rule: StopRule,
    alone: Corridor,
    carrying: Corridor,
    /// The controller drives a straight docking or undocking move (between a rack's
    /// legs, slowly, swept against the map by the controller itself): the monitor's
    /// field is muted, as a safety scanner's is at a docking station.
    docking: bool,
    /// A goal's mute decision not yet in force: (the goal's tick, muted). See
    /// [`MonitorStage::update_mute`].
    pending_mute: Option<(u64, bool)>,
    /// The newest velocity the simulator applied (linear, angular).
    twist: Option<[f64; 2]>,
    /// The sign of the robot's last linear motion (+1 forward, -1 backwards).
    last_direction: f64,
    /// The monitor's own command ids (the simulator keeps the supervisor's apart).
    next_id: u64,
    /// Stops asked so far.
    pub stops: u64,
}

impl MonitorStage {
    /// From `robot.toml` and the optional `safety_monitor.toml` of `config_dir`.
    pub fn load(config_dir: &Path) -> Result<MonitorStage, aisle_config::ConfigError> {
        let robot: RobotConfig = aisle_config::load(&config_dir.join("robot.toml"))?;
        let path = config_dir.join("safety_monitor.toml");
        let config = if path.exists() {
            aisle_config::load(&path)?
        } else {
            MonitorConfig::default()
        };
        Ok(Self::new(&robot, config))
    }

    pub fn new(robot: &RobotConfig, config: MonitorConfig) -> MonitorStage {
        let corridor = |length: f64, width: f64| Corridor {
            half_length: 0.5 * length,
            half_width: 0.5 * width,
            lateral_margin: config.lateral_margin,
            min_height: config.min_height,
            max_height: robot.body.height + config.max_height_above_body,
        };
        let f = &robot.footprint;
        MonitorStage {
            rule: StopRule { config },
            alone: corridor(f.alone.length, f.alone.width),
            carrying: corridor(f.carrying.length, f.carrying.width),
            docking: false,
            pending_mute: None,
            twist: None,
            last_direction: 1.0,
            next_id: 1,
            stops: 0,
        }
    }
}

/// The cloud's returns in the robot's base frame (x forward, y left, z up from the
/// floor), from the sensor pose and robot pose the lidar stamped on it.
pub fn base_frame_points(cloud: &PointCloud) -> impl Iterator<Item = [f64; 3]> + '_ {
    let [roll, pitch, yaw] = cloud.sensor_pose.rpy;
    let (sr, cr) = roll.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    let (sy, cy) = yaw.sin_cos();
    // R = Rz(yaw) Ry(pitch) Rx(roll), as `Pose3Msg` states its angles.
    let r = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ];
    let t = cloud.sensor_pose.position;
    let base = cloud.robot_pose;
    let (sb, cb) = base.theta.sin_cos();
    let n = (cloud.rows as usize * cloud.cols as usize).min(cloud.points.len());
    cloud.points[..n].iter().map(move |p| {
        let p = p.map(f64::from);
        let m: [f64; 3] =
            std::array::from_fn(|i| t[i] + r[i][0] * p[0] + r[i][1] * p[1] + r[i][2] * p[2]);
        let (dx, dy) = (m[0] - base.x, m[1] - base.y);
        [cb * dx + sb * dy, -sb * dx + cb * dy, m[2]]
    })
}

impl MonitorStage {
    /// Brings the mute decision up to the goals made before tick `tick`. The supervisor
    /// sends a goal while it handles a tick, in lockstep at the same time as this node
    /// judges that tick's scan: whether a goal of tick `tick` has arrived yet is a race,
    /// so it waits for the next scan; every goal of an earlier tick was sent before the
    /// simulator released `tick`, and is here.
    fn update_mute(&mut self, tick: u64, io: &impl Io) -> Result<(), NodeError> {
        let muted = |mode: u32| {
            // Straight docking moves and turns on the spot: neither drives the
            // footprint towards anything ahead of it.
            mode == GoalMode::Straight as u32 || mode == GoalMode::RotateInPlace as u32
        };
        if let Some((_, m)) = self.pending_mute.take_if(|(t, _)| *t < tick) {
            self.docking = m;
        }
        // Goals arrive in the order they were sent: once one waits, so do the newer.
        while let Some(goal) = io.receive(topics::CONTROLLER_GOAL)? {
            match (goal.header.tick, muted(goal.mode)) {
                (t, m) if t < tick && self.pending_mute.is_none() => self.docking = m,
                later => self.pending_mute = Some(later),
            }
        }
        Ok(())
    }
}

impl Stage for MonitorStage {
    const KIND: NodeKind = NodeKind::External(ExternalNode::new(NAME));
    type Trigger = PointCloud;
    const TRIGGER: Topic<PointCloud> = topics::POINT_CLOUD;
    const NEWEST_ONLY: bool = true;

    fn start(&mut self, _io: &impl Io, ctx: &RunContext) -> Result<(), NodeError> {
        // Ids must grow across a restart too: start above any a predecessor could have
        // used in a run of this length (the simulator ignores stale ones anyway).
        if ctx.restarted {
            self.next_id = 1 << 32;
        }
        Ok(())
    }

    fn process(&mut self, cloud: &PointCloud, io: &impl Io) -> Result<Cycle, NodeError> {
        self.update_mute(cloud.header.tick, io)?;
        // The velocity the simulator applied at the scan's tick.
        if let Some(rs) = io.latest(topics::ROBOT_STATE)? {
            self.twist = Some(rs.twist);
            if rs.twist[0].abs() >= self.rule.config.moving_speed {
                self.last_direction = rs.twist[0].signum();
            }
        }
        let Some(twist) = self.twist.filter(|_| !self.docking) else {
            return Ok(Cycle::done());
        };
        let corridor = if cloud.carried_body >= 0 {
            &self.carrying
        } else {
            &self.alone
        };
        let verdict = self.rule.judge(
            base_frame_points(cloud),
            twist,
            self.last_direction,
            corridor,
        );
        let speed = twist[0];
        if verdict.stop {
            self.stops += 1;
            tracing::info!(
                "safety_monitor: tick {}: return {:.2} m ahead, stopping distance {:.2} m at {speed:.2} m/s: stop",
                cloud.header.tick,
                verdict.nearest.unwrap_or(0.0),
                verdict.stopping_distance
            );
            let id = self.next_id;
            self.next_id += 1;
            io.publish(
                topics::SIM_COMMAND,
                Stamp::of(&cloud.header),
                |c: &mut SimCommand| {
                    c.command_id = id;
                    c.kind = SimCommandKind::Stop as u32;
                    c.body_index = -1;
                },
            )?;
        }
        Ok(Cycle::done())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_node::testing::MemIo;

    fn stage() -> MonitorStage {
        let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config");
        MonitorStage::load(&shipped).unwrap()
    }

    fn send_goal(io: &MemIo, tick: u64, mode: GoalMode) {
        io.push(topics::CONTROLLER_GOAL, |g| {
            g.header.tick = tick;
            g.mode = mode as u32;
        });
    }

    /// The supervisor sends goals while it handles a tick, in lockstep at the same time
    /// as the monitor judges that tick's scan. Whether the goal arrived first or not, it
    /// mutes (or unmutes) from the next scan on, so two runs judge every scan alike.
    #[test]
    fn a_goal_takes_effect_from_the_scan_after_its_tick_whenever_it_arrives() {
        let (mut early, mut late) = (stage(), stage());
        let (io_early, io_late) = (MemIo::new(), MemIo::new());
        send_goal(&io_early, 9, GoalMode::RotateInPlace);
        send_goal(&io_late, 9, GoalMode::RotateInPlace);
        for (s, io) in [(&mut early, &io_early), (&mut late, &io_late)] {
            s.update_mute(10, io).unwrap();
            assert!(s.docking, "a goal of tick 9 is in force at scan 10");
        }
        // Tick 10's goal: here before scan 10 is judged, there after it.
        send_goal(&io_early, 10, GoalMode::Follow);
        early.update_mute(10, &io_early).unwrap();
        late.update_mute(10, &io_late).unwrap();
        send_goal(&io_late, 10, GoalMode::Follow);
        assert!(early.docking && late.docking, "scan 10 judged alike");
        early.update_mute(11, &io_early).unwrap();
        late.update_mute(11, &io_late).unwrap();
        assert!(
            !early.docking && !late.docking,
            "scan 11 follows tick 10's goal"
        );
        // Goals of one tick: the last one sent holds.
        send_goal(&io_early, 11, GoalMode::Straight);
        send_goal(&io_early, 11, GoalMode::Follow);
        send_goal(&io_early, 12, GoalMode::Straight);
        early.update_mute(12, &io_early).unwrap();
        assert!(!early.docking, "tick 11's last goal, not tick 12's");
        early.update_mute(13, &io_early).unwrap();
        assert!(early.docking);
    }
}

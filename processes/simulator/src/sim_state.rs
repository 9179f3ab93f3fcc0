//! The simulator's resumable state on the bus: `SimState` written from a world
//! snapshot every tick, and read back by a restarted simulator, every float copied and
//! none recomputed, so a lockstep run goes on bit for bit. Also what the simulator has
//! consumed of its inputs ([`Applied`]), which is part of that state.

use crate::World;
use crate::kinematics::{Twist, WheelSpeeds};
use crate::timeline::{CommandTimeline, TimedCommand};
use crate::world::{Carried, RobotState as WorldRobot, WorldSnapshot};
use aisle_bus::{Bus, NodeError, Publisher, Stamp, WaitOutcome};
use aisle_geometry::Pose2;
use aisle_messages::{SimState, Trajectory, topics};
use std::time::Duration;

/// How long a restarted simulator waits for its published state.
const RESUME_TIMEOUT: Duration = Duration::from_secs(5);

/// What the simulator has consumed so far (part of its resumable state).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Applied {
    pub command_id: u64,
    pub trajectory: (u64, u64),
    /// The tick stamped on the last `Stop` (u64::MAX: none): a trajectory of that tick
    /// or older was computed before the stop, and one of a later tick from inputs of
    /// that tick or older acts on what was sensed before it (a hung mapper's last map,
    /// young enough for the controller's age limit): neither starts the robot again.
    pub stop_tick: u64,
}

impl Default for Applied {
    fn default() -> Self {
        Applied {
            command_id: 0,
            trajectory: (0, 0),
            stop_tick: u64::MAX,
        }
    }
}

impl Applied {
    pub(crate) fn drives(&self, traj: &Trajectory) -> bool {
        self.stop_tick == u64::MAX
            || (traj.header.tick > self.stop_tick && traj.inputs_tick > self.stop_tick)
    }
}

/// A restarted simulator reads its last `SimState` back (kept by the supervisor) and
/// resumes at that tick; returns the tick and what it had consumed.
pub(crate) fn resume(bus: &Bus, world: &mut World) -> Result<(u64, Applied), NodeError> {
    let own = bus.subscriber(topics::SIM_STATE)?;
    let (outcome, sample) = own.wait_for(RESUME_TIMEOUT, |_| true, || {})?;
    let (WaitOutcome::Matched, Some(s)) = (outcome, sample) else {
        return Err(NodeError::Protocol(
            "simulator: restarted, but no published state to resume from".into(),
        ));
    };
    let mut newest = *s;
    drop(s);
    while let Some(s) = own.receive()? {
        newest = *s;
    }
    restore(world, &newest)?;
    let k = newest.next_tick;
    tracing::warn!(
        "simulator: resumed at tick {k} (t = {:.1} s)",
        world.time_ns() as f64 * 1e-9
    );
    let applied = Applied {
        command_id: newest.last_command_id,
        trajectory: (newest.last_trajectory_tick, newest.last_trajectory_seq),
        stop_tick: newest.last_stop_tick,
    };
    Ok((k, applied))
}

pub(crate) fn publish_sim_state(
    port: &mut Publisher<SimState>,
    world: &World,
    stamp: Stamp,
    applied: Applied,
) -> Result<(), NodeError> {
    let snap = world.snapshot();
    port.publish(stamp, |m| {
        m.next_tick = stamp.tick;
        m.time_ns = snap.time_ns;
        m.pose = snap.robot.pose.into();
        m.twist = [snap.robot.twist.v, snap.robot.twist.w];
        m.wheels = [snap.robot.wheels.left, snap.robot.wheels.right];
        m.watchdog_stopped = snap.robot.watchdog_stopped as u8;
        m.wheels_clamped = snap.robot.wheels_clamped as u8;
        match snap.carried {
            Some(c) => {
                m.carried_body = c.body as i32;
                m.carried_offset = c.offset.into();
            }
            None => m.carried_body = -1,
        }
        m.collisions = snap.collisions;
        m.min_clearance = snap.min_clearance;
        m.last_command_id = applied.command_id;
        m.last_trajectory_tick = applied.trajectory.0;
        m.last_trajectory_seq = applied.trajectory.1;
        m.last_stop_tick = applied.stop_tick;
        // Static bodies never move: only the others' poses are state.
        let movable = world.bodies().iter().zip(&snap.body_poses);
        let movable = movable.filter(|(b, _)| !b.is_static).map(|(_, p)| p);
        let mut n = 0;
        for (dst, p) in m.body_poses.iter_mut().zip(movable) {
            *dst = (*p).into();
            n += 1;
        }
        m.bodies_len = n as u32;
        let touching = snap.in_contact.iter().enumerate().filter(|(_, c)| **c);
        let mut n = 0;
        for (dst, (i, _)) in m.contacts.iter_mut().zip(touching) {
            *dst = i as u32;
            n += 1;
        }
        m.contacts_len = n as u32;
        let entries = snap.timeline.commands();
        m.timeline_len = entries.len() as u32;
        m.timeline_start_ns = snap.timeline.start_ns();
        m.timeline_expiry_ns = snap.timeline.expiry_ns();
        for (dst, e) in m.timeline.iter_mut().zip(entries) {
            dst.offset_ns = e.offset_ns;
            dst.v = e.twist.v;
            dst.w = e.twist.w;
        }
    })?;
    Ok(())
}

/// Puts `world` back into the state `m` describes.
fn restore(world: &mut World, m: &SimState) -> Result<(), NodeError> {
    let (body_poses, in_contact) = bodies_of(world, m)?;
    let tl = (m.timeline_len as usize).min(m.timeline.len());
    let entries: Vec<TimedCommand> = m.timeline[..tl]
        .iter()
        .map(|e| TimedCommand {
            offset_ns: e.offset_ns,
            twist: Twist { v: e.v, w: e.w },
        })
        .collect();
    let mut timeline = CommandTimeline::from_entries(m.timeline_start_ns, &entries)
        .map_err(|e| NodeError::Protocol(format!("simulator: published timeline: {e}")))?;
    timeline.set_expiry(m.timeline_expiry_ns);
    let snap = WorldSnapshot {
        time_ns: m.time_ns,
        robot: WorldRobot {
            pose: m.pose.into(),
            twist: Twist {
                v: m.twist[0],
                w: m.twist[1],
            },
            wheels: WheelSpeeds {
                left: m.wheels[0],
                right: m.wheels[1],
            },
            watchdog_stopped: m.watchdog_stopped != 0,
            wheels_clamped: m.wheels_clamped != 0,
        },
        carried: (m.carried_body >= 0).then(|| Carried {
            body: m.carried_body as usize,
            offset: m.carried_offset.into(),
        }),
        body_poses,
        in_contact,
        collisions: m.collisions,
        min_clearance: m.min_clearance,
        timeline,
    };
    world
        .restore(&snap)
        .map_err(|e| NodeError::Protocol(format!("simulator: resuming: {e}")))
}

/// Every body's pose and contact flag in scene order, from a `SimState` that names only
/// the bodies that can move and those in contact.
fn bodies_of(world: &World, m: &SimState) -> Result<(Vec<Pose2>, Vec<bool>), NodeError> {
    let bodies = world.bodies();
    let movable = bodies.iter().filter(|b| !b.is_static).count();
    if m.bodies_len as usize != movable {
        return Err(NodeError::Protocol(format!(
            "simulator: published state has {} movable bodies, the scene {movable}",
            m.bodies_len
        )));
    }
    let mut published = m.body_poses[..movable].iter();
    let poses = bodies
        .iter()
        .map(|b| match b.is_static {
            true => b.pose,
            false => published.next().map_or(b.pose, |p| (*p).into()),
        })
        .collect();
    let mut in_contact = vec![false; bodies.len()];
    let n = (m.contacts_len as usize).min(m.contacts.len());
    for &i in &m.contacts[..n] {
        let flag = in_contact.get_mut(i as usize).ok_or_else(|| {
            NodeError::Protocol(format!(
                "simulator: published contact with body {i} of {}",
                bodies.len()
            ))
        })?;
        *flag = true;
    }
    Ok((poses, in_contact))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A trajectory made on controller tick `tick` from inputs of tick `inputs`.
    fn trajectory(tick: u64, inputs: u64) -> Box<Trajectory> {
        let mut t: Box<Trajectory> = aisle_messages::zeroed_box();
        t.header.tick = tick;
        t.inputs_tick = inputs;
        t
    }

    #[test]
    fn after_a_stop_only_a_trajectory_from_later_inputs_drives() {
        let mut applied = Applied::default();
        assert!(applied.drives(&trajectory(3, 1)), "no stop yet");
        applied.stop_tick = 10;
        assert!(
            !applied.drives(&trajectory(10, 10)),
            "made on the stop's tick"
        );
        // A later step on a map sensed before the stop (a hung mapper's last one).
        assert!(!applied.drives(&trajectory(15, 8)));
        assert!(!applied.drives(&trajectory(15, 10)));
        assert!(applied.drives(&trajectory(15, 11)));
    }
}

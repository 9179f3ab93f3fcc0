//! The simulated world: the robot's pose, twist and wheel speeds, every body's pose,
//! the command timeline in force, a carried rack, and ground-truth collision metrics.
//!
//! One [`World::step`] advances simulated time by `dt` (integer nanoseconds):
//! 1. motion: the interval is cut where the command in force changes (timeline entry
//!    boundaries, watchdog expiry); each piece pushes its command through the wheel
//!    limits and moves the robot along the exact arc (see [`crate::kinematics`]). With
//!    no command in force the robot stands still (watchdog);
//! 2. a carried body is placed rigidly on the carry mount;
//! 3. contacts: the robot's body box and the carried body's parts are checked against
//!    every other body (see [`crate::collision`]) at the end of the step. Motion is
//!    kinematic: a collision is counted, it does not stop the robot.
//!
//! Carrying is a rigid grasp: [`World::attach`] records the body's pose relative to
//! the carry mount at that instant and keeps it until [`World::detach`], which leaves
//! the body where it is. The body keeps its own heights (planar carrying).
//!
//! Knows nothing of the bus, of wall clocks or of who sends commands.

mod contacts;
mod snapshot;
#[cfg(test)]
mod tests;

pub use snapshot::WorldSnapshot;

use crate::collision::{Bound, Prism};
use crate::error::SimError;
use crate::kinematics::{Applied, DiffDrive, Twist, WheelSpeeds, integrate};
use crate::timeline::CommandTimeline;
use aisle_config::Validate;
use aisle_config::scene::{Body, Scene};
use aisle_geometry::Pose2;
use aisle_robot::{RobotConfig, RobotModel};

/// The sim rate of the seed: 10 Hz.
pub const DEFAULT_DT_NS: u64 = 100_000_000;

/// What odometry would report about the robot.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RobotState {
    /// `base_link` on the floor plane, map frame.
    pub pose: Pose2,
    /// Twist applied over the last piece of motion (after wheel clamping).
    pub twist: Twist,
    /// Wheel speeds over the last piece of motion, rad/s.
    pub wheels: WheelSpeeds,
    /// The last piece of motion had no command in force (timeline empty or expired).
    pub watchdog_stopped: bool,
    /// The last piece's command exceeded a wheel's speed limit.
    pub wheels_clamped: bool,
}

/// A body held on the carry mount: its pose in the mount's planar frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Carried {
    pub body: usize,
    pub offset: Pose2,
}

/// What one step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport {
    pub time_ns: u64,
    pub robot: RobotState,
    /// Bodies in contact with the robot or the carried body after the step.
    pub contacts: u32,
    /// Bodies that came into contact during this step (collision events).
    pub new_collisions: u32,
    /// Lowest scene index among the bodies in contact.
    pub first_contact: Option<usize>,
    /// Planar distance from the robot (and carried body) to the nearest body at
    /// overlapping heights, 0 in contact; infinite with nothing in reach.
    pub clearance: f64,
    pub nearest_body: Option<usize>,
}

/// The world the simulator process owns.
#[derive(Debug, Clone)]
pub struct World {
    drive: DiffDrive,
    hold_ns: u64,
    robot_length: f64,
    robot_width: f64,
    robot_height: f64,
    mount: Pose2,
    bodies: Vec<Body>,
    /// Radius around each body's pose that covers all its parts.
    reach: Vec<f64>,
    /// Each body's prisms: `prisms[ranges[i].0..ranges[i].1]`.
    ranges: Vec<(usize, usize)>,
    prisms: Vec<Prism>,
    bounds: Vec<Bound>,
    time_ns: u64,
    robot: RobotState,
    carried: Option<Carried>,
    timeline: CommandTimeline,
    in_contact: Vec<bool>,
    collisions: u64,
    min_clearance: f64,
    /// The nearest body at the last sweep: a hint that speeds up the next one and
    /// changes none of its results (so it is not part of a snapshot).
    last_nearest: Option<usize>,
}

impl World {
    /// A world with the robot at `cfg.start.pose`, time 0, no command.
    pub fn new(scene: &Scene, model: &RobotModel, cfg: &RobotConfig) -> Result<World, SimError> {
        Self::new_at(scene, model, cfg, cfg.start_pose())
    }

    /// A world with the robot at `start`. Refused when the robot would stand inside a
    /// body (the error names it).
    pub fn new_at(
        scene: &Scene,
        model: &RobotModel,
        cfg: &RobotConfig,
        start: Pose2,
    ) -> Result<World, SimError> {
        cfg.validate()?;
        if !start.is_finite() {
            return Err(SimError::StartNotFinite { pose: start });
        }
        let mut ranges = Vec::with_capacity(scene.bodies.len());
        let mut reach = Vec::with_capacity(scene.bodies.len());
        let mut n = 0;
        for b in &scene.bodies {
            ranges.push((n, n + b.parts.len()));
            n += b.parts.len();
            reach.push(b.parts.iter().fold(0.0f64, |r, p| {
                r.max(
                    (p.center[0].abs() + 0.5 * p.size[0])
                        .hypot(p.center[1].abs() + 0.5 * p.size[1]),
                )
            }));
        }
        let alone = cfg.footprint.alone;
        let mut world = World {
            drive: DiffDrive::new(&cfg.kinematics),
            hold_ns: cfg.watchdog_hold_ns(),
            robot_length: alone.length,
            robot_width: alone.width,
            robot_height: cfg.body.height,
            mount: model.carry_mount_planar(),
            bodies: scene.bodies.clone(),
            reach,
            ranges,
            prisms: vec![Prism::default(); n],
            bounds: vec![Bound::default(); scene.bodies.len()],
            time_ns: 0,
            robot: RobotState {
                pose: start,
                watchdog_stopped: true,
                ..RobotState::default()
            },
            carried: None,
            timeline: CommandTimeline::default(),
            in_contact: vec![false; scene.bodies.len()],
            collisions: 0,
            min_clearance: f64::INFINITY,
            last_nearest: None,
        };
        for i in 0..world.bodies.len() {
            world.place_body(i);
        }
        let report = world.sweep();
        if let Some(i) = report.first_contact {
            return Err(SimError::StartInCollision {
                body: world.bodies[i].name.clone(),
                pose: start,
            });
        }
        world.min_clearance = report.clearance;
        Ok(world)
    }

    /// Refreshes body `i`'s prisms and bound from its pose.
    fn place_body(&mut self, i: usize) {
        let (lo, hi) = self.ranges[i];
        let b = &self.bodies[i];
        for (p, part) in self.prisms[lo..hi].iter_mut().zip(&b.parts) {
            *p = Prism::from_part(&b.pose, part);
        }
        self.bounds[i] = Bound {
            x: b.pose.x,
            y: b.pose.y,
            r: self.reach[i],
        };
    }

    /// Replaces the command timeline: `commands` are (t seconds from `start_ns`, v, w).
    /// A refused timeline leaves the previous one in force.
    pub fn set_timeline(
        &mut self,
        start_ns: u64,
        commands: &[(f64, f64, f64)],
    ) -> Result<(), SimError> {
        Ok(self.timeline.set(start_ns, commands)?)
    }

    /// As [`World::set_timeline`], from a cloneable iterator of (t, v, w), so a message
    /// adapter can map its command array straight in without allocating.
    pub fn set_timeline_iter<I>(&mut self, start_ns: u64, commands: I) -> Result<(), SimError>
    where
        I: IntoIterator<Item = (f64, f64, f64)>,
        I::IntoIter: Clone,
    {
        Ok(self.timeline.set_iter(start_ns, commands)?)
    }

    /// Ends the timeline in force at `expiry_ns` (sim time): the robot stops then, even
    /// if the timeline holds later commands (see [`CommandTimeline::set_expiry`]).
    pub fn set_timeline_expiry(&mut self, expiry_ns: u64) {
        self.timeline.set_expiry(expiry_ns);
    }

    /// Drops the timeline: the robot stops from the next step on.
    pub fn stop(&mut self) {
        self.timeline.clear();
    }

    /// Advances simulated time by `dt_ns` (see the module doc for the order of work).
    pub fn step(&mut self, dt_ns: u64) -> StepReport {
        let end = self.time_ns.saturating_add(dt_ns);
        let mut t = self.time_ns;
        while t < end {
            let seg = self.timeline.segment_at(t, self.hold_ns);
            let piece_end = seg.until_ns.min(end);
            let applied = seg
                .command
                .map_or(Applied::default(), |c| self.drive.apply(c));
            let dt = (piece_end - t) as f64 / 1e9;
            self.robot.pose = integrate(&self.robot.pose, applied.twist, dt);
            self.robot.twist = applied.twist;
            self.robot.wheels = applied.wheels;
            self.robot.watchdog_stopped = seg.command.is_none();
            self.robot.wheels_clamped = applied.clamped;
            t = piece_end;
        }
        self.time_ns = end;
        if let Some(c) = self.carried {
            self.bodies[c.body].pose = self.robot.pose.compose(&self.mount).compose(&c.offset);
            self.place_body(c.body);
        }
        let report = self.sweep();
        self.min_clearance = self.min_clearance.min(report.clearance);
        report
    }

    /// Index of the body called `name`.
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    /// Attaches body `index` to the carry mount (rigid grasp at the current relative
    /// pose). The body must be movable and the mount must be over its footprint.
    pub fn attach(&mut self, index: usize) -> Result<(), SimError> {
        let count = self.bodies.len();
        let body = self
            .bodies
            .get(index)
            .ok_or(SimError::BodyIndex { index, count })?;
        if let Some(c) = self.carried {
            return Err(SimError::AlreadyCarrying {
                carried: self.bodies[c.body].name.clone(),
            });
        }
        if body.is_static {
            return Err(SimError::StaticBody {
                name: body.name.clone(),
            });
        }
        let mount = self.robot.pose.compose(&self.mount);
        if !body.footprint().contains(&body.pose, mount.x, mount.y) {
            return Err(SimError::NotUnder {
                body: body.name.clone(),
            });
        }
        self.carried = Some(Carried {
            body: index,
            offset: mount.inverse().compose(&body.pose),
        });
        // It travels with the robot now; it is no longer something to bump into.
        self.in_contact[index] = false;
        Ok(())
    }

    /// As [`World::attach`], by name.
    pub fn attach_by_name(&mut self, name: &str) -> Result<(), SimError> {
        let index = self.body_index(name).ok_or_else(|| SimError::UnknownBody {
            name: name.to_string(),
        })?;
        self.attach(index)
    }

    /// Lets go of the carried body, which stays where it is; returns its index.
    pub fn detach(&mut self) -> Result<usize, SimError> {
        let c = self.carried.take().ok_or(SimError::NotCarrying)?;
        Ok(c.body)
    }

    pub fn time_ns(&self) -> u64 {
        self.time_ns
    }

    pub fn robot_state(&self) -> RobotState {
        self.robot
    }

    /// Every body with its current pose, in scene order.
    pub fn bodies(&self) -> &[Body] {
        &self.bodies
    }

    pub fn carried(&self) -> Option<Carried> {
        self.carried
    }

    pub fn timeline(&self) -> &CommandTimeline {
        &self.timeline
    }

    /// Collision events since the start (a body coming into contact counts once
    /// until it separates again).
    pub fn collisions(&self) -> u64 {
        self.collisions
    }

    /// Smallest clearance seen at any step end since the start.
    pub fn min_clearance(&self) -> f64 {
        self.min_clearance
    }

    /// Whether body `index` touches the robot or the carried body now.
    pub fn in_contact(&self, index: usize) -> bool {
        self.in_contact.get(index).copied().unwrap_or(false)
    }
}

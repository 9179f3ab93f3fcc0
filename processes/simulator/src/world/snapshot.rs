//! The world's whole mutable state as plain data, so a restarted simulator resumes
//! exactly where the previous one stopped (bit for bit: every float is copied, none
//! is recomputed).
//!
//! Knows nothing of how the snapshot is published or stored.

use super::{Carried, RobotState, World};
use crate::error::SimError;
use crate::timeline::CommandTimeline;
use aisle_geometry::Pose2;

/// Everything [`World::step`] reads or writes besides the scene and the config.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldSnapshot {
    pub time_ns: u64,
    pub robot: RobotState,
    pub carried: Option<Carried>,
    /// Pose of every body, in scene order.
    pub body_poses: Vec<Pose2>,
    /// Contact flag of every body, in scene order (collision events are edges).
    pub in_contact: Vec<bool>,
    pub collisions: u64,
    pub min_clearance: f64,
    pub timeline: CommandTimeline,
}

impl World {
    pub fn snapshot(&self) -> WorldSnapshot {
        WorldSnapshot {
            time_ns: self.time_ns,
            robot: self.robot,
            carried: self.carried,
            body_poses: self.bodies.iter().map(|b| b.pose).collect(),
            in_contact: self.in_contact.clone(),
            collisions: self.collisions,
            min_clearance: self.min_clearance,
            timeline: self.timeline.clone(),
        }
    }

    /// Overwrites the state with `snap`, taken from a world built from the same scene
    /// and config. Refused (world unchanged) when it cannot belong to this world.
    pub fn restore(&mut self, snap: &WorldSnapshot) -> Result<(), SimError> {
        let n = self.bodies.len();
        let bad = |reason: String| Err(SimError::Snapshot { reason });
        if snap.body_poses.len() != n || snap.in_contact.len() != n {
            return bad(format!(
                "{} body poses and {} contact flags for {n} bodies",
                snap.body_poses.len(),
                snap.in_contact.len()
            ));
        }
        if !snap.robot.pose.is_finite() {
            return bad(format!("robot pose {:?} is not finite", snap.robot.pose));
        }
        if let Some(i) = snap.body_poses.iter().position(|p| !p.is_finite()) {
            return bad(format!(
                "pose of body `{}` is not finite",
                self.bodies[i].name
            ));
        }
        if let Some(c) = snap.carried {
            match self.bodies.get(c.body) {
                None => return bad(format!("carried body index {} out of range", c.body)),
                Some(b) if b.is_static => {
                    return bad(format!("carried body `{}` is static", b.name));
                }
                Some(_) if !c.offset.is_finite() => {
                    return bad("carried offset is not finite".into());
                }
                Some(_) => {}
            }
        }
        self.time_ns = snap.time_ns;
        self.robot = snap.robot;
        self.carried = snap.carried;
        for (i, p) in snap.body_poses.iter().enumerate() {
            self.bodies[i].pose = *p;
            self.place_body(i);
        }
        self.in_contact.copy_from_slice(&snap.in_contact);
        self.collisions = snap.collisions;
        self.min_clearance = snap.min_clearance;
        self.timeline.clone_from(&snap.timeline);
        Ok(())
    }
}

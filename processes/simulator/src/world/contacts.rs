//! The per-step contact sweep: robot body and carried parts against every other body,
//! updating contact flags, the collision-event count and the clearance.
//!
//! Bounding circles reject most bodies before any box test: a body whose circle is
//! farther than the best clearance so far can neither touch nor be the nearest.
//! Allocation-free: it reads the prism cache kept by the world.

use super::{StepReport, World};
use crate::collision::{Bound, Prism};

impl World {
    /// Smallest planar distance from `p` to body `i`'s parts at overlapping heights;
    /// infinite when none is within `best` (culled) or none shares `p`'s heights.
    fn prism_to_body(&self, p: &Prism, i: usize, best: f64) -> f64 {
        let pb = p.bound();
        if pb.gap(&self.bounds[i]) > best {
            return f64::INFINITY;
        }
        let (lo, hi) = self.ranges[i];
        let mut d = f64::INFINITY;
        for q in &self.prisms[lo..hi] {
            if !p.heights_overlap(q) || pb.gap(&q.bound()) > best.min(d) {
                continue;
            }
            d = d.min(p.rect_distance(q));
        }
        d
    }

    /// Distance from the robot box and the carried body's parts to body `i`, with the
    /// same culling as [`World::prism_to_body`].
    fn body_distance(
        &self,
        robot: &Prism,
        carried: Option<(usize, Bound)>,
        i: usize,
        best: f64,
    ) -> f64 {
        let mut d = self.prism_to_body(robot, i, best);
        if let Some((c, cb)) = carried
            && cb.gap(&self.bounds[i]) <= best.min(d)
        {
            let (lo, hi) = self.ranges[c];
            for k in lo..hi {
                let p = self.prisms[k];
                d = d.min(self.prism_to_body(&p, i, best.min(d)));
            }
        }
        d
    }

    pub(super) fn sweep(&mut self) -> StepReport {
        let robot = Prism::at_pose(
            &self.robot.pose,
            self.robot_length,
            self.robot_width,
            0.0,
            self.robot_height,
        );
        let carried = self.carried.map(|c| (c.body, self.bounds[c.body]));
        let carried_index = carried.map(|(c, _)| c);
        // The last step's nearest body is most likely near again: its distance bounds
        // the clearance from the start, so most bodies are culled at once. Culling only
        // skips bodies that can be neither touching nor the nearest, so the report is
        // the same with or without this seed.
        let seed = match self.last_nearest {
            Some(j) if Some(j) != carried_index => {
                self.body_distance(&robot, carried, j, f64::INFINITY)
            }
            _ => f64::INFINITY,
        };
        let mut report = StepReport {
            time_ns: self.time_ns,
            robot: self.robot,
            contacts: 0,
            new_collisions: 0,
            first_contact: None,
            clearance: f64::INFINITY,
            nearest_body: None,
        };
        for i in 0..self.bodies.len() {
            if Some(i) == carried_index {
                continue;
            }
            let d = self.body_distance(&robot, carried, i, report.clearance.min(seed));
            let touching = d <= 0.0;
            if touching {
                report.contacts += 1;
                report.first_contact.get_or_insert(i);
                if !self.in_contact[i] {
                    report.new_collisions += 1;
                }
            }
            self.in_contact[i] = touching;
            if d < report.clearance {
                report.clearance = d;
                report.nearest_body = Some(i);
            }
        }
        self.last_nearest = report.nearest_body;
        self.collisions += u64::from(report.new_collisions);
        report
    }
}

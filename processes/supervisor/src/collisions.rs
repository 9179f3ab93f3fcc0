//! Collision events from ground truth: which body the robot (or the rack it carries)
//! came into contact with, and when. Pure: fed every `WorldTruth` sample in order, it
//! reports each body whose contact flag turned on (the simulator counts exactly these
//! edges). Knows nothing of the bus or of what a collision does to the mission.

use aisle_messages::{WorldTruth, read_name};
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;

/// One collision: the body touched and the sim time at which the contact was seen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CollisionEvent {
    pub body: String,
    pub t_s: f64,
}

impl std::fmt::Display for CollisionEvent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "collision with `{}` at t = {:.1} s", self.body, self.t_s)
    }
}

/// Name given to a collision the simulator counted but whose body was not seen (a
/// truth sample lost between two reads in realtime).
pub const UNSEEN_BODY: &str = "an unseen body";

/// The bodies in contact in the previous sample (scene indices) and the collisions
/// found so far.
#[derive(Debug, Default)]
pub struct CollisionWatch {
    in_contact: BTreeSet<u32>,
    touching: BTreeSet<u32>,
    counted: u32,
    pub events: Vec<CollisionEvent>,
}

impl CollisionWatch {
    /// Takes the next truth sample; returns how many new collisions it showed.
    pub fn observe(&mut self, truth: &WorldTruth) -> usize {
        let before = self.events.len();
        let t_s = truth.header.stamp_ns as f64 * 1e-9;
        let n = (truth.len as usize).min(truth.bodies.len());
        self.touching.clear();
        for b in truth.bodies[..n].iter().filter(|b| b.in_contact != 0) {
            self.touching.insert(b.index);
            if !self.in_contact.contains(&b.index) {
                self.events.push(CollisionEvent {
                    body: read_name(&b.name).to_string(),
                    t_s,
                });
            }
        }
        std::mem::swap(&mut self.in_contact, &mut self.touching);
        // The simulator's count is the reference: a contact that began and ended
        // between two samples this side read is still a collision.
        let named = (self.events.len() - before) as u32;
        let counted = truth.collisions.saturating_sub(self.counted);
        for _ in named..counted {
            self.events.push(CollisionEvent {
                body: UNSEEN_BODY.to_string(),
                t_s,
            });
        }
        self.counted = self.counted.max(truth.collisions);
        self.events.len() - before
    }

    /// The first collision of the run, if any.
    pub fn first(&self) -> Option<&CollisionEvent> {
        self.events.first()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_messages::{write_name, zeroed_box};

    fn truth(t_s: f64, contacts: &[bool], count: u32) -> Box<WorldTruth> {
        let mut w = zeroed_box::<WorldTruth>();
        w.header.stamp_ns = (t_s * 1e9).round() as u64;
        w.len = contacts.len() as u32;
        w.collisions = count;
        for (i, (b, &c)) in w.bodies.iter_mut().zip(contacts).enumerate() {
            write_name(&mut b.name, &format!("body{i}"));
            b.index = i as u32;
            b.in_contact = c as u8;
        }
        w
    }

    #[test]
    fn contacts_are_followed_by_scene_index_not_by_place_in_the_list() {
        let mut w = CollisionWatch::default();
        // A static wall (scene index 7) in contact is listed after the movable bodies;
        // the next sample lists it in another place, still touching: one collision.
        let mut t = truth(0.1, &[false, false, true], 1);
        t.bodies[2].index = 7;
        write_name(&mut t.bodies[2].name, "wall");
        assert_eq!(w.observe(&t), 1);
        let mut t = truth(0.2, &[true, false], 1);
        t.bodies[0].index = 7;
        write_name(&mut t.bodies[0].name, "wall");
        assert_eq!(w.observe(&t), 0, "the same contact, listed elsewhere");
        // Body 0 of the first sample (index 0) touches now: a new collision, named.
        let t = truth(0.3, &[true, false], 2);
        assert_eq!(w.observe(&t), 1);
        let names: Vec<_> = w.events.iter().map(|e| e.body.as_str()).collect();
        assert_eq!(names, ["wall", "body0"]);
    }

    #[test]
    fn a_contact_edge_is_one_collision_named_with_its_time() {
        let mut w = CollisionWatch::default();
        assert_eq!(w.observe(&truth(0.1, &[false, false], 0)), 0);
        assert_eq!(w.observe(&truth(0.2, &[false, true], 1)), 1);
        // Staying in contact is the same collision.
        assert_eq!(w.observe(&truth(0.3, &[false, true], 1)), 0);
        assert_eq!(w.observe(&truth(0.4, &[true, false], 2)), 1);
        let e = &w.events;
        assert_eq!(e.len(), 2);
        assert_eq!(e[0].to_string(), "collision with `body1` at t = 0.2 s");
        assert_eq!(e[1].body, "body0");
        assert_eq!(w.first().unwrap().t_s, 0.2);
    }

    #[test]
    fn a_counted_collision_between_two_samples_is_not_lost() {
        let mut w = CollisionWatch::default();
        w.observe(&truth(0.1, &[false], 0));
        // Touched and left between two samples: no edge seen, the count says one.
        assert_eq!(w.observe(&truth(0.5, &[false], 1)), 1);
        assert_eq!(w.events[0].body, UNSEEN_BODY);
        assert_eq!(w.observe(&truth(0.6, &[false], 1)), 0);
    }
}

//! Where along the task the robot is: the active goal with its reference, the section
//! (between cusps and rotations) being driven and the progress along it, and the leg of
//! one step (the section and the local goal a look-ahead distance ahead). Knows nothing
//! of bands or the optimiser.

use aisle_geometry::{Direction, PathPose, Pose2, wrap_angle};

use crate::config::TebConfig;
use crate::goal::{Goal, Mode};
use crate::reference::{Reference, Section};

/// The task being driven.
pub(crate) struct Active {
    pub goal: Goal,
    pub reference: Reference,
    pub section: usize,
    pub progress: f64,
}

/// What one step's band runs along.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Leg {
    pub section: Section,
    /// Where the band should end (its heading is made continuous with the band's end).
    pub goal: Pose2,
    /// The goal is the section's end: the band ends at rest.
    pub at_rest: bool,
    /// Arc length of the robot's projection on the reference.
    pub s_robot: f64,
    /// Arc-length window of the reference the band may project onto.
    pub s_lo: f64,
    pub s_hi: f64,
}

fn within(tol: &[f64; 3], robot: &Pose2, goal: &Pose2) -> bool {
    let (lx, ly) = goal.inverse_transform_point(robot.x, robot.y);
    lx.abs() <= tol[0] && ly.abs() <= tol[1] && wrap_angle(robot.theta - goal.theta).abs() <= tol[2]
}

/// Whether the robot has done section `sec`. A rotation on the spot is done when the
/// heading is: it cannot change the position, which the previous section already
/// accepted in its own frame (an offset inside that frame's box can fall outside the
/// rotated one, and the robot would then turn in place forever).
fn section_done(tol: &[f64; 3], robot: &Pose2, reference: &Reference, sec: &Section) -> bool {
    let end = reference.section_end(sec);
    if sec.direction == Direction::Rotate {
        wrap_angle(robot.theta - end.theta).abs() <= tol[2]
    } else {
        within(tol, robot, &end)
    }
}

impl Active {
    pub fn new(goal: &Goal) -> Active {
        let reference = match goal.mode {
            Mode::Follow => Reference::new(goal.reference.clone()),
            // Built at the first step, where the robot is.
            Mode::RotateInPlace { .. } => Reference::default(),
            // Driven along its line by `straight.rs`, without a reference.
            Mode::Straight { .. } => Reference::default(),
        };
        Active {
            goal: goal.clone(),
            reference,
            section: 0,
            progress: 0.0,
        }
    }

    /// A rotation in place gets its reference at the first step: from the robot's pose
    /// to the target heading on the spot.
    pub fn begin_rotation(&mut self, pose: &Pose2) {
        if let Mode::RotateInPlace { target_heading } = self.goal.mode
            && self.reference.poses.is_empty()
        {
            self.reference = Reference::new(vec![
                PathPose::new(*pose, Direction::Forward),
                PathPose::new(
                    Pose2::new(pose.x, pose.y, wrap_angle(target_heading)),
                    Direction::Rotate,
                ),
            ]);
        }
    }

    /// Moves on past every section the robot has done but the last; returns whether it
    /// moved on (the band of the old section is then useless).
    pub fn advance(&mut self, tol: &[f64; 3], pose: &Pose2) -> bool {
        let sections = self.reference.sections.len();
        let mut moved = false;
        while self.section + 1 < sections {
            let sec = self.reference.sections[self.section];
            if !section_done(tol, pose, &self.reference, &sec) {
                break;
            }
            self.section += 1;
            self.progress = self.reference.cum[self.reference.sections[self.section].first];
            moved = true;
        }
        moved
    }

    /// Whether the robot is within the tolerance of the final goal.
    pub fn finished(&self, tol: &[f64; 3], pose: &Pose2) -> bool {
        let sec = self.reference.sections[self.section];
        self.section + 1 == self.reference.sections.len()
            && section_done(tol, pose, &self.reference, &sec)
    }

    /// The leg of this step from `pose`, and the progress along the section updated;
    /// `None` when the robot is farther from the reference than the look-ahead distance.
    pub fn leg(&mut self, cfg: &TebConfig, pose: &Pose2) -> Option<Leg> {
        let sec = self.reference.sections[self.section];
        let lad = cfg.look_ahead_distance();
        let end_s = self.reference.cum[sec.last];
        if sec.direction == Direction::Rotate {
            let g = self.reference.section_end(&sec);
            return Some(Leg {
                section: sec,
                goal: Pose2::new(pose.x, pose.y, g.theta),
                at_rest: true,
                s_robot: 0.0,
                s_lo: 0.0,
                s_hi: 0.0,
            });
        }
        let pr = self.reference.project(
            &sec,
            pose.x,
            pose.y,
            self.progress - 1.0,
            self.progress + lad + 2.0,
        );
        if pr.distance > lad {
            return None;
        }
        self.progress = self.progress.max(pr.s);
        let s_goal = (pr.s + lad).min(end_s);
        Some(Leg {
            section: sec,
            goal: self.reference.sample(&sec, s_goal),
            at_rest: s_goal >= end_s - 1e-9,
            s_robot: pr.s,
            s_lo: pr.s - 1.0,
            s_hi: s_goal + 1.0,
        })
    }
}

//! The mission's straight moves under and out of bodies: which plan to ask for (into the
//! approached body, out of the one the robot stands under), how a plan with a straight
//! move is driven (the path to the pose outside, then the move; or the move out, then the
//! path), what the carried body adds to the footprint, and where a set-down body stands.
//!
//! Part of the pure state machine: no bus, no clocks.

use super::{Mission, Phase, Stage};
use crate::mission::events::{Action, Dock, DockBody, Planned};
use aisle_geometry::{Direction, Footprint, Pose2};

/// Tolerances (along, across, heading) for the pose a docking move starts from: the
/// straight move corrects what is left, but it has only the run-in to do so.
const DOCK_START_TOLERANCE: [f64; 3] = [0.1, 0.06, 0.08];

impl Mission {
    /// The plan request for the current leg from `start`: with the move out of the body
    /// the robot stands under first (unless the leg carries it, or says `depart`), else
    /// with the move under the approached body.
    pub(super) fn plan_action(&self, start: Pose2, use_detections: bool) -> Action {
        let (footprint, margin) = self.footprint();
        let dock = if let Some(body) = self.under.clone().filter(|_| self.departure.is_none()) {
            Some(Dock::OutOf { body })
        } else {
            self.approached().map(|body| Dock::Into {
                body,
                free_heading: self.spec().free_heading,
            })
        };
        Action::Plan {
            start,
            goal: self.goal(),
            footprint,
            margin,
            use_detections,
            dock,
            fixed_budget: None,
        }
    }

    /// Starts driving a fresh plan.
    pub(super) fn drive(&mut self, planned: Planned) -> Vec<Action> {
        let (footprint, margin) = self.footprint();
        let mut path = planned.path;
        if let Some(k) = planned.undock_to.filter(|&k| k < path.len()) {
            let rest = path.split_off(k);
            let out = rest[0].pose;
            // A side exit: the plan turns in place under the body before the move.
            if path.len() > 1 && path[0].direction == Direction::Rotate {
                let facing = Pose2::new(path[0].pose.x, path[0].pose.y, out.theta);
                self.stage = Stage::UndockTurn { out, rest };
                return vec![
                    self.mapper_control(),
                    Action::Rotate {
                        goal: facing,
                        footprint,
                        margin,
                    },
                ];
            }
            self.stage = Stage::Undocking { rest };
            return vec![self.mapper_control(), straight(out, footprint, margin)];
        }
        if let Some(k) = planned.dock_from.filter(|&k| k + 1 < path.len()) {
            let under = path.last().map_or(self.goal(), |p| p.pose);
            path.truncate(k + 1);
            let goal = path[k].pose;
            self.stage = Stage::ToDock { from: goal, under };
            return vec![Action::Follow {
                reference: path,
                goal,
                footprint,
                margin,
                tolerance: Some(DOCK_START_TOLERANCE),
            }];
        }
        self.stage = Stage::Path;
        vec![Action::Follow {
            reference: path,
            goal: self.goal(),
            footprint,
            margin,
            tolerance: None,
        }]
    }

    /// The controller reached the goal of the current stage; `None` when that is the
    /// leg's goal.
    pub(super) fn stage_reached(&mut self, pose: Pose2) -> Option<Vec<Action>> {
        let (footprint, margin) = self.footprint();
        match std::mem::replace(&mut self.stage, Stage::Path) {
            Stage::Path => None,
            Stage::Docking => {
                // Kept for finish_leg, which marks the robot under the body.
                self.stage = Stage::Docking;
                None
            }
            Stage::ToDock { under, .. } => {
                self.stage = Stage::Docking;
                Some(vec![
                    self.mapper_control(),
                    straight(under, footprint, margin),
                ])
            }
            Stage::UndockTurn { out, rest } => {
                self.stage = Stage::Undocking { rest };
                Some(vec![straight(out, footprint, margin)])
            }
            Stage::Undocking { rest } => {
                // Out: the body is an obstacle again.
                self.under = None;
                let mut actions = vec![self.mapper_control()];
                if self.approached().is_some() || rest.len() < 2 {
                    // The leg also enters a body (or the rest is nothing): plan from here.
                    self.phase = Phase::Planning;
                    self.has_reference = false;
                    actions.push(self.plan_action(pose, false));
                } else {
                    actions.push(Action::Follow {
                        reference: rest,
                        goal: self.goal(),
                        footprint,
                        margin,
                        tolerance: None,
                    });
                }
                Some(actions)
            }
        }
    }

    /// What the controller drives to in the current stage (stall detection).
    pub(super) fn stage_target(&self, pose: Pose2) -> Pose2 {
        match &self.stage {
            Stage::Path => self.goal(),
            Stage::ToDock { from, .. } => *from,
            Stage::Docking => self.redo_target(pose),
            Stage::UndockTurn { out, .. } => *out,
            Stage::Undocking { rest } => rest.first().map_or(pose, |p| p.pose),
        }
    }

    /// The controller stays infeasible: on a path, plan again with the detections (a
    /// docking leg chooses its side again); on a straight move, try the move again
    /// (something stands in the way; the replan count bounds the waiting).
    pub(super) fn recover(&mut self, pose: Pose2) -> Vec<Action> {
        let (footprint, margin) = self.footprint();
        match &self.stage {
            Stage::Docking => match self.approached() {
                Some(_) => vec![self.redo_docking(pose, footprint, margin)],
                None => Vec::new(),
            },
            // On a move out from under a body, the way out is blocked (often by what
            // the lidar could not see from under it when the first plan, on the static
            // map, chose it): plan the move out again from here, with the detections;
            // the planner takes the other side when this one stays blocked. The stage
            // stays until a plan replaces it (`drive`): if none comes, the controller
            // goes on with what it drives, and the end of that is the stage's end, not
            // necessarily the leg's.
            Stage::UndockTurn { .. }
            | Stage::Undocking { .. }
            | Stage::Path
            | Stage::ToDock { .. } => {
                self.phase = Phase::Planning;
                vec![self.plan_action(pose, true)]
            }
        }
    }

    fn redo_docking(&self, pose: Pose2, footprint: Footprint, margin: f64) -> Action {
        straight(self.redo_target(pose), footprint, margin)
    }

    /// Where the docking move ends: the last pose of the leg's plan.
    fn redo_target(&self, pose: Pose2) -> Pose2 {
        self.reference_paths
            .last()
            .and_then(|(_, p)| p.last())
            .map_or(pose, |p| p.pose)
    }

    /// The robot takes `body` (standing under it at `robot`): remember how it sits.
    pub(super) fn begin_carrying(&mut self, body: &str, robot: Pose2) {
        self.carrying = true;
        let standing = self.standing(body).map(|b| b.pose);
        let at = self.under.as_ref().map(|u| u.pose).or(standing);
        self.carried_rel = at.map(|b| robot.inverse().compose(&b));
        self.under = None;
        self.placed.retain(|(name, _)| name != body);
    }

    /// The goal the leg states, or (an approach leg without one) the body where it stands
    /// now.
    pub(super) fn leg_goal(&self) -> Pose2 {
        let spec = self.spec();
        match self.approached().filter(|_| spec.goal_given.is_none()) {
            Some(body) => body.pose,
            None => Pose2::new(spec.goal[0], spec.goal[1], spec.goal[2]),
        }
    }

    /// How far `pose` is turned from `goal`, the leg's: a body approached without a
    /// stated goal is docked under through any of its four sides, so there the error is
    /// to the nearest of them (at most an eighth of a turn).
    pub(super) fn heading_error(&self, pose: &Pose2, goal: &Pose2) -> f64 {
        let e = pose.heading_error(goal);
        let any_side = self.departure.is_none()
            && self.spec().goal_given.is_none()
            && self.approached().is_some();
        if any_side {
            let quarter = std::f64::consts::FRAC_PI_2;
            let r = e % quarter;
            r.min(quarter - r)
        } else {
            e
        }
    }

    /// The approached body where it stands (where the mission set it down, else where
    /// the scene puts it).
    pub(super) fn approached(&self) -> Option<DockBody> {
        self.standing(self.spec().approach.as_deref()?)
    }

    /// Where `name` stands: where the mission set it down, else where the scene has it.
    pub(super) fn standing(&self, name: &str) -> Option<DockBody> {
        if let Some((_, b)) = self.placed.iter().find(|(n, _)| n == name) {
            return Some(b.clone());
        }
        let b = self.body(name)?;
        Some(b.placed_at(b.pose))
    }

    /// The parts of every body set down (map frame), but those of `except`: the mapper
    /// keeps them as obstacles the lidar need not see.
    pub(super) fn placed_parts(&self, except: Option<&DockBody>) -> Vec<(Pose2, Footprint)> {
        self.placed
            .iter()
            .filter(|(_, b)| except.is_none_or(|e| e.pose != b.pose))
            .flat_map(|(_, b)| b.parts.iter().copied())
            .collect()
    }

    /// What the mapper ignores: the body the robot is under or about to drive under
    /// (only once the straight move begins: before, its legs are obstacles like any),
    /// and the carried one; and what it keeps whatever it sees: the legs of the bodies
    /// set down but the ignored one.
    pub(super) fn mapper_control(&self) -> Action {
        let approached = match self.stage {
            Stage::Docking => self.approached(),
            _ if self.phase == Phase::Rotating => self.approached(),
            _ => None,
        };
        let ignored = self.under.clone().or(approached);
        let carried = self.carrying.then(|| self.carried_footprint()).flatten();
        Action::MapperControl {
            placed: self.placed_parts(ignored.as_ref()),
            ignore: ignored.map(|b| (b.pose, b.footprint)),
            carried,
        }
    }

    /// The robot sets the carried body down at `robot`: it stands there now, and the
    /// next leg leaves it straight.
    pub(super) fn end_carrying(&mut self, robot: Pose2) {
        self.carrying = false;
        let body = self
            .spec()
            .carry
            .as_deref()
            .and_then(|n| self.body(n))
            .cloned();
        self.under = match (body, self.carried_rel.take()) {
            (Some(b), Some(rel)) => {
                let set_down = b.placed_at(robot.compose(&rel));
                self.placed.retain(|(name, _)| *name != b.name);
                self.placed.push((b.name.clone(), set_down.clone()));
                Some(set_down)
            }
            _ => None,
        };
    }

    /// The carried body's rectangle in the robot frame, axis-aligned (a rack picked from
    /// its long side sits across the robot).
    pub(super) fn carried_footprint(&self) -> Option<Footprint> {
        let name = self.spec().carry.as_deref()?;
        let body = self.body(name)?;
        Some(carried_footprint(
            body.footprint,
            self.carried_rel.unwrap_or_default(),
        ))
    }

    /// The footprint while carrying: robot.toml's, grown to the carried body as it sits.
    pub(super) fn carrying_footprint(&self) -> Footprint {
        let configured = self.footprints.carrying;
        match self.carried_footprint() {
            Some(f) => carrying_footprint(configured, f),
            None => configured,
        }
    }
}

/// A carried body's rectangle `body` at `rel` (its pose in the robot frame), as a
/// rectangle centred on the robot and axis-aligned with it.
pub fn carried_footprint(body: Footprint, rel: Pose2) -> Footprint {
    let (c, s) = (rel.theta.cos().abs(), rel.theta.sin().abs());
    Footprint::new(
        body.length * c + body.width * s + 2.0 * rel.x.abs(),
        body.length * s + body.width * c + 2.0 * rel.y.abs(),
    )
}

/// The footprint while carrying: `configured` (robot.toml's) grown to `carried`.
pub fn carrying_footprint(configured: Footprint, carried: Footprint) -> Footprint {
    Footprint::new(
        configured.length.max(carried.length),
        configured.width.max(carried.width),
    )
}

fn straight(goal: Pose2, footprint: Footprint, margin: f64) -> Action {
    Action::Straight {
        goal,
        footprint,
        margin,
    }
}

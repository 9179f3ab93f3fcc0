//! `TebController`: one step = pick the reference section and local goal, warm-start
//! (prune, extend, resize) or build the band, bend it around blocking obstacles,
//! optimise it, and turn it into a command timeline with MATLAB's exit flags.
//!
//! Pure computation: no clock, no randomness, no bus. The node calls
//! [`TebController::step`] on its own schedule. The phases of a step live in `leg.rs`
//! (where along the task), `planner.rs` (the band) and `objective/` (what is optimised).
//! A straight move (docking) is not optimised: `straight.rs` rolls it out, without a
//! band. The goal tolerance is the goal's own, or `band.goal_tolerance` without one.

use aisle_geometry::{GridView, Pose2, wrap_angle};
use serde::{Deserialize, Serialize};

use crate::band::Band;
use crate::config::TebConfig;
use crate::detour::Side;
use crate::feasibility;
use crate::goal::{Goal, Mode};
use crate::leg::{Active, Leg};
use crate::objective::segment::{segment_rate, segment_velocity};
use crate::objective::{self, Problem};
use crate::output::{Command, ExitFlag, MAX_COMMANDS, StepOutput, TimedPose};
use crate::planner::Planner;
use crate::straight;

/// The controller's memory between steps, for publishing and for a warm restart.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Snapshot {
    pub band: Band,
    /// Index of the reference section (between cusps / rotations) being driven.
    pub section: usize,
    /// Arc length along the reference the robot has reached, m.
    pub progress: f64,
    /// Side the band was last pushed around a blocker (1 left, -1 right, 0 none): the
    /// next detour keeps to it.
    #[serde(default)]
    pub detour_side: i8,
}

/// Timed-elastic-band local controller.
pub struct TebController {
    cfg: TebConfig,
    active: Option<Active>,
    planner: Planner,
    out: StepOutput,
}

fn check_map(map: &GridView) -> Result<(), String> {
    if !(map.resolution.is_finite() && map.resolution > 0.0) {
        return Err(format!("map resolution {} is not positive", map.resolution));
    }
    if !(map.origin_x.is_finite() && map.origin_y.is_finite()) {
        return Err("map origin is not finite".into());
    }
    if map.width.checked_mul(map.height) != Some(map.cells.len()) {
        return Err(format!(
            "map has {} cells, {} x {} expected",
            map.cells.len(),
            map.width,
            map.height
        ));
    }
    Ok(())
}

/// The inputs of a step are numbers and a readable map.
fn check_inputs(
    pose: &Pose2,
    velocity: (f64, f64),
    t: f64,
    map: &GridView,
) -> Result<(), crate::TebError> {
    if !pose.is_finite() || !velocity.0.is_finite() || !velocity.1.is_finite() {
        return Err(crate::TebError::InvalidInput(
            "pose or velocity is not finite".into(),
        ));
    }
    if !t.is_finite() {
        return Err(crate::TebError::InvalidInput(format!(
            "time {t} is not finite"
        )));
    }
    check_map(map).map_err(crate::TebError::InvalidInput)
}

impl TebController {
    pub fn new(cfg: TebConfig) -> Result<TebController, crate::TebError> {
        aisle_config::Validate::validate(&cfg)?;
        let n = cfg.band.max_poses;
        Ok(TebController {
            cfg,
            active: None,
            planner: Planner::new(n),
            out: StepOutput {
                commands: Vec::with_capacity(MAX_COMMANDS),
                poses: Vec::with_capacity(MAX_COMMANDS),
                ..StepOutput::default()
            },
        })
    }

    pub fn config(&self) -> &TebConfig {
        &self.cfg
    }

    /// Sets the task. The same goal again is a no-op (the warm band is kept); a new one
    /// drops the band.
    pub fn set_goal(&mut self, goal: &Goal) -> Result<(), crate::TebError> {
        goal.validate()?;
        if self.active.as_ref().is_some_and(|a| a.goal == *goal) {
            return Ok(());
        }
        self.active = Some(Active::new(goal));
        self.planner.clear();
        Ok(())
    }

    /// Forgets the goal and the band.
    pub fn clear_goal(&mut self) {
        self.active = None;
        self.planner.clear();
    }

    /// The current band (empty before the first step and after the goal is reached).
    pub fn band(&self) -> &Band {
        &self.planner.band
    }

    pub fn snapshot(&self) -> Snapshot {
        let (section, progress) = self
            .active
            .as_ref()
            .map_or((0, 0.0), |a| (a.section, a.progress));
        Snapshot {
            band: self.planner.band.clone(),
            section,
            progress,
            detour_side: self.planner.side.map_or(0, Side::code),
        }
    }

    /// Restores a [`Snapshot`] after [`TebController::set_goal`] with the goal it was
    /// taken under (a warm start after a restart). An empty band is allowed.
    pub fn restore(&mut self, snap: &Snapshot) -> Result<(), crate::TebError> {
        let Some(active) = self.active.as_mut() else {
            return Err(crate::TebError::NoGoal);
        };
        if !snap.band.is_empty() {
            snap.band.validate(self.cfg.band.max_poses)?;
        }
        if matches!(active.goal.mode, Mode::Follow)
            && snap.section >= active.reference.sections.len()
        {
            return Err(crate::TebError::InvalidBand(format!(
                "section {} of {}",
                snap.section,
                active.reference.sections.len()
            )));
        }
        if !snap.progress.is_finite() {
            return Err(crate::TebError::InvalidBand(
                "progress is not finite".into(),
            ));
        }
        active.section = snap.section;
        active.progress = snap.progress;
        self.planner.band.copy_from(&snap.band);
        self.planner.band.unwrap_headings();
        self.planner.side = Side::from_code(snap.detour_side);
        Ok(())
    }

    /// One control cycle from the robot's `pose`, its measured `(v, w)`, the sim time
    /// `t` (s; every timestamp of the output is absolute, starting at `t`) and the
    /// local occupancy map (cells 0 free, anything else occupied; outside it counts as
    /// free). Invalid inputs (NaN, inconsistent map, no goal) are errors; the node
    /// should then command zero. A robot that cannot move safely is not an error: the
    /// exit flag says why and the timeline is a single zero command.
    pub fn step(
        &mut self,
        pose: Pose2,
        velocity: (f64, f64),
        t: f64,
        map: &GridView,
    ) -> Result<&StepOutput, crate::TebError> {
        check_inputs(&pose, velocity, t, map)?;
        let Some(active) = self.active.as_mut() else {
            return Err(crate::TebError::NoGoal);
        };
        let pose = Pose2::new(pose.x, pose.y, wrap_angle(pose.theta));
        self.out.clear();
        self.out.t0 = t;
        let tol = active
            .goal
            .tolerance
            .unwrap_or(self.cfg.band.goal_tolerance);
        if let Mode::Straight { target } = active.goal.mode {
            let fp = active.goal.footprint;
            straight::step(
                &self.cfg,
                &fp,
                &target,
                &tol,
                pose,
                velocity,
                map,
                &mut self.out,
            );
            return Ok(&self.out);
        }

        // Where along the task: the section, done or not, and this step's leg.
        active.begin_rotation(&pose);
        if active.advance(&tol, &pose) {
            self.planner.clear();
        }
        self.out.poses.push(TimedPose { t, pose });
        if active.finished(&tol, &pose) {
            self.out.reached_goal = true;
            self.out.set_stop();
            self.planner.band.clear();
            return Ok(&self.out);
        }
        let Some(mut leg) = active.leg(&self.cfg, &pose) else {
            self.out.exit_flag = ExitFlag::OffPath;
            self.out.set_stop();
            self.planner.band.clear();
            return Ok(&self.out);
        };

        // The band: start, detour, optimise, the other side, repair.
        let fresh = self
            .planner
            .start(&self.cfg, &active.reference, &mut leg, &pose, velocity.0);
        let problem = problem(
            &self.cfg,
            map,
            &active.goal,
            &active.reference,
            &leg,
            velocity,
        );
        self.planner.detour(&problem);
        let mut done = self.planner.optimise(&problem, fresh);
        self.planner
            .try_other_side(&problem, &leg, &pose, &mut done);
        self.planner.finish(&problem);

        // Judge it and write the output.
        let band = &self.planner.band;
        let cfg = &self.cfg;
        let verdict = feasibility::check(
            band,
            map,
            &problem.footprint,
            problem.margin,
            cfg.solver.check_step,
            cfg.limits.min_turning_radius,
            &problem.timing(),
        );
        let (_, violations) = objective::merit(&problem, band);
        let out = &mut self.out;
        out.iterations = done.iterations;
        out.cost = done.merit;
        out.max_violation = violations.max();
        out.exit_flag = verdict.flag;
        out.last_feasible_index = verdict.last_feasible_index;
        write_timeline(out, band, t, leg.at_rest);
        Ok(&self.out)
    }
}

/// The optimisation problem of one step.
fn problem<'a>(
    cfg: &'a TebConfig,
    map: &'a GridView<'a>,
    goal: &Goal,
    reference: &'a crate::reference::Reference,
    leg: &Leg,
    velocity: (f64, f64),
) -> Problem<'a> {
    Problem {
        cfg,
        map,
        footprint: goal.footprint,
        margin: goal.margin,
        v0: velocity.0,
        w0: velocity.1,
        goal: leg.goal,
        at_rest: leg.at_rest,
        direction: leg.section.direction,
        reference,
        section: leg.section,
        s_lo: leg.s_lo,
        s_hi: leg.s_hi,
    }
}

/// The band's poses with their times from `t0`, and, unless the exit flag stops the
/// robot, its segments' commands (ending at rest when the band does).
fn write_timeline(out: &mut StepOutput, band: &Band, t0: f64, at_rest: bool) {
    out.poses.clear();
    let mut t = t0;
    for (i, p) in band.poses.iter().enumerate().take(MAX_COMMANDS) {
        out.poses.push(TimedPose {
            t,
            pose: Pose2::new(p.x, p.y, wrap_angle(p.theta)),
        });
        if i < band.dts.len() {
            t += band.dts[i];
        }
    }
    if out.exit_flag.stops_robot() {
        out.set_stop();
        return;
    }
    let mut t = t0;
    for k in 0..band.dts.len().min(MAX_COMMANDS - 1) {
        out.commands.push(Command {
            t,
            v: segment_velocity(band, k),
            w: segment_rate(band, k),
        });
        t += band.dts[k];
    }
    if at_rest {
        out.commands.push(Command { t, v: 0.0, w: 0.0 });
    }
}

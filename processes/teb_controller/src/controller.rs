//! `TebController`: one step = pick the reference section and local goal, warm-start
//! (prune, extend, resize) or build the band, bend it around blocking obstacles,
//! optimise it, and turn it into a command timeline with MATLAB's exit flags.
//!
//! Pure computation: no clock, no randomness, no bus. The node calls
//! [`TebController::step`] on its own schedule.

use aisle_geometry::{Direction, Footprint, GridView, PathPose, Pose2, wrap_angle};
use serde::{Deserialize, Serialize};

use crate::band::Band;
use crate::config::TebConfig;
use crate::detour::{self, Side};
use crate::feasibility;
use crate::goal::{Goal, Mode};
use crate::output::{Command, ExitFlag, MAX_COMMANDS, StepOutput, TimedPose};
use crate::reference::{Reference, Section};
use crate::scp::{self, Problem, Scp, assess, segment_rate, segment_velocity};
use crate::timing;

/// Farthest a blocked pose is pushed sideways before the optimiser runs, m.
const MAX_DETOUR: f64 = 3.0;
/// Initial trust-region scale for a warm band (1 = the configured radius).
const WARM_TRUST_SCALE: f64 = 0.3;
/// Poses searched when pruning the passed part of the band.
const PRUNE_WINDOW: usize = 10;
/// Metres per radian when pruning, so turning on the spot prunes too.
const PRUNE_HEADING_WEIGHT: f64 = 0.3;

/// The controller's memory between steps, for publishing and for a warm restart.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Snapshot {
    pub band: Band,
    /// Index of the reference section (between cusps / rotations) being driven.
    pub section: usize,
    /// Arc length along the reference the robot has reached, m.
    pub progress: f64,
}

struct Active {
    goal: Goal,
    reference: Reference,
    section: usize,
    progress: f64,
}

/// Timed-elastic-band local controller.
pub struct TebController {
    cfg: TebConfig,
    active: Option<Active>,
    band: Band,
    side: Option<Side>,
    scp: Scp,
    out: StepOutput,
    alt: Band,
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

impl TebController {
    pub fn new(cfg: TebConfig) -> Result<TebController, crate::TebError> {
        aisle_config::Validate::validate(&cfg)?;
        let n = cfg.band.max_poses;
        Ok(TebController {
            cfg,
            active: None,
            band: Band::with_capacity(n + 2),
            side: None,
            scp: Scp::new(),
            out: StepOutput {
                commands: Vec::with_capacity(MAX_COMMANDS),
                poses: Vec::with_capacity(MAX_COMMANDS),
                ..StepOutput::default()
            },
            alt: Band::with_capacity(n + 2),
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
        let reference = match goal.mode {
            Mode::Follow => Reference::new(goal.reference.clone()),
            // Built at the first step, where the robot is.
            Mode::RotateInPlace { .. } => Reference::default(),
        };
        self.active = Some(Active {
            goal: goal.clone(),
            reference,
            section: 0,
            progress: 0.0,
        });
        self.band.clear();
        self.side = None;
        Ok(())
    }

    /// Forgets the goal and the band.
    pub fn clear_goal(&mut self) {
        self.active = None;
        self.band.clear();
        self.side = None;
    }

    /// The current band (empty before the first step and after the goal is reached).
    pub fn band(&self) -> &Band {
        &self.band
    }

    pub fn snapshot(&self) -> Snapshot {
        let (section, progress) = self
            .active
            .as_ref()
            .map_or((0, 0.0), |a| (a.section, a.progress));
        Snapshot {
            band: self.band.clone(),
            section,
            progress,
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
        self.band.copy_from(&snap.band);
        self.band.unwrap_headings();
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
        let t_step = t;
        check_map(map).map_err(crate::TebError::InvalidInput)?;
        let Some(active) = self.active.as_mut() else {
            return Err(crate::TebError::NoGoal);
        };
        let pose = Pose2::new(pose.x, pose.y, wrap_angle(pose.theta));
        self.out.clear();
        self.out.t0 = t_step;
        if let Mode::RotateInPlace { target_heading } = active.goal.mode
            && active.reference.poses.is_empty()
        {
            active.reference = Reference::new(vec![
                PathPose::new(pose, Direction::Forward),
                PathPose::new(
                    Pose2::new(pose.x, pose.y, wrap_angle(target_heading)),
                    Direction::Rotate,
                ),
            ]);
        }
        let cfg = &self.cfg;
        let tol = cfg.band.goal_tolerance;
        let sections = active.reference.sections.len();
        while active.section + 1 < sections {
            let sec = active.reference.sections[active.section];
            if !section_done(&tol, &pose, &active.reference, &sec) {
                break;
            }
            active.section += 1;
            active.progress = active.reference.cum[active.reference.sections[active.section].first];
            self.band.clear();
            self.side = None;
        }
        let sec = active.reference.sections[active.section];
        self.out.poses.push(TimedPose { t: t_step, pose });
        if active.section + 1 == sections && section_done(&tol, &pose, &active.reference, &sec) {
            self.out.reached_goal = true;
            self.out.set_stop();
            self.band.clear();
            return Ok(&self.out);
        }

        let sigma = match sec.direction {
            Direction::Forward => 1.0,
            Direction::Reverse => -1.0,
            Direction::Rotate => 0.0,
        };
        let lad = cfg.look_ahead_distance();
        let end_s = active.reference.cum[sec.last];
        let (mut goal, at_rest, s_robot, s_lo, s_hi) = if sigma == 0.0 {
            let g = active.reference.section_end(&sec);
            (Pose2::new(pose.x, pose.y, g.theta), true, 0.0, 0.0, 0.0)
        } else {
            let pr = active.reference.project(
                &sec,
                pose.x,
                pose.y,
                active.progress - 1.0,
                active.progress + lad + 2.0,
            );
            if pr.distance > lad {
                self.out.exit_flag = ExitFlag::OffPath;
                self.out.set_stop();
                self.band.clear();
                return Ok(&self.out);
            }
            active.progress = active.progress.max(pr.s);
            let s_goal = (pr.s + lad).min(end_s);
            let g = active.reference.sample(&sec, s_goal);
            (g, s_goal >= end_s - 1e-9, pr.s, pr.s - 1.0, s_goal + 1.0)
        };

        // Warm start, or a new band along the reference.
        let mut fresh = self.band.poses.len() < 2;
        if !fresh {
            let d0 = self.band.poses[..self.band.poses.len().min(PRUNE_WINDOW + 1)]
                .iter()
                .map(|p| p.distance(&pose))
                .fold(f64::INFINITY, f64::min);
            if d0 > cfg.band.reinit_distance {
                fresh = true;
            } else {
                self.band.prune(&pose, PRUNE_WINDOW, PRUNE_HEADING_WEIGHT);
                if sigma != 0.0 {
                    fresh = !extend(
                        &mut self.band,
                        &active.reference,
                        &sec,
                        &goal,
                        s_lo,
                        s_hi,
                        cfg,
                        sigma,
                    );
                }
            }
        }
        if fresh {
            init_band(
                &mut self.band,
                &active.reference,
                &sec,
                &pose,
                &goal,
                s_robot,
                at_rest,
                velocity.0,
                cfg,
                sigma,
            );
            self.side = None;
        }
        self.band.unwrap_headings();
        resize(&mut self.band, cfg);
        let last = self.band.poses[self.band.poses.len() - 1].theta;
        goal.theta = last + wrap_angle(goal.theta - last);

        let fp: Footprint = active.goal.footprint;
        let margin = active.goal.margin;
        if sigma != 0.0 && detour::blocked(&self.band, map, &fp, margin) {
            let side = detour::repair(&mut self.band, map, &fp, margin, self.side, MAX_DETOUR);
            if side.is_some() {
                self.side = side;
            }
        }
        let problem = Problem {
            cfg,
            map,
            footprint: fp,
            margin,
            v0: velocity.0,
            w0: velocity.1,
            goal,
            at_rest,
            sigma,
            reference: &active.reference,
            section: sec,
            s_lo,
            s_hi,
        };
        let budget = cfg.solver.max_iterations;
        // A warm band was optimal one period ago: start with a trust region that
        // refines it instead of one sized for bending a fresh band around obstacles.
        let scale = if fresh { 1.0 } else { WARM_TRUST_SCALE };
        let stats = self.scp.optimise(&problem, &mut self.band, budget, scale);
        let mut iterations = stats.iterations;
        let mut merit = stats.merit;
        // TEB's outer loop, once: the optimiser stretches segments where the band swerves
        // or speeds up, so a long segment is split (and short ones merged).
        if has_long_segment(&self.band, cfg) {
            resize(&mut self.band, cfg);
            // A merged segment's chord no longer follows the mean heading of its ends.
            if sigma != 0.0 {
                self.scp.project_kinematics(&mut self.band);
            }
            fit_time_steps(&mut self.band, cfg, sigma);
            // A split halves the span a velocity change is spread over.
            timing::retime(&mut self.band, &problem.timing());
            // Splits follow the band's arcs and the repairs above keep it within every
            // limit, so the resized band usually only costs a little more (the next step
            // starts from it anyway). One that still violates a constraint gets a
            // shorter second round from the trust region the first round ended with.
            let (resized, rv) = assess(&problem, &self.band);
            if rv.max() > scp::FEASIBLE && resized > merit + cfg.solver.tolerance {
                let again = self.scp.optimise(
                    &problem,
                    &mut self.band,
                    budget.div_ceil(2),
                    (2.0 * stats.scale).min(1.0),
                );
                iterations += again.iterations;
                merit = again.merit;
            } else {
                merit = resized;
            }
        }

        // Homotopy: the same band pushed around blockers on the other side.
        if cfg.homotopy.enabled
            && sigma != 0.0
            && let Some(side) = self.side
        {
            self.alt.copy_from(&self.band);
            init_band(
                &mut self.alt,
                &active.reference,
                &sec,
                &pose,
                &problem.goal,
                s_robot,
                at_rest,
                velocity.0,
                cfg,
                sigma,
            );
            self.alt.unwrap_headings();
            resize(&mut self.alt, cfg);
            if detour::repair(
                &mut self.alt,
                map,
                &fp,
                margin,
                Some(side.other()),
                MAX_DETOUR,
            )
            .is_some()
            {
                let alt_stats = self.scp.optimise(&problem, &mut self.alt, budget, 1.0);
                iterations += alt_stats.iterations;
                if alt_stats.merit < cfg.homotopy.hysteresis * merit {
                    std::mem::swap(&mut self.band, &mut self.alt);
                    merit = alt_stats.merit;
                    self.side = Some(side.other());
                }
            }
        }

        // Numerical slack of the cones must not leak into the commands, nor a sharper
        // acceleration than slowing down can avoid.
        fit_time_steps(&mut self.band, cfg, sigma);
        timing::retime(&mut self.band, &problem.timing());
        let verdict = feasibility::check(
            &self.band,
            map,
            &fp,
            margin,
            cfg.solver.check_step,
            cfg.limits.min_turning_radius,
            &problem.timing(),
        );
        let (_, violations) = assess(&problem, &self.band);

        let out = &mut self.out;
        out.iterations = iterations;
        out.cost = merit;
        out.max_violation = violations.max();
        out.exit_flag = verdict.flag;
        out.last_feasible_index = verdict.last_feasible_index;
        out.poses.clear();
        let mut t = t_step;
        for (i, p) in self.band.poses.iter().enumerate().take(MAX_COMMANDS) {
            out.poses.push(TimedPose {
                t,
                pose: Pose2::new(p.x, p.y, wrap_angle(p.theta)),
            });
            if i < self.band.dts.len() {
                t += self.band.dts[i];
            }
        }
        if verdict.flag.stops_robot() {
            out.set_stop();
            return Ok(&self.out);
        }
        let mut t = t_step;
        for k in 0..self.band.dts.len().min(MAX_COMMANDS - 1) {
            out.commands.push(Command {
                t,
                v: segment_velocity(&self.band, k),
                w: segment_rate(&self.band, k),
            });
            t += self.band.dts[k];
        }
        if at_rest {
            out.commands.push(Command { t, v: 0.0, w: 0.0 });
        }
        Ok(&self.out)
    }
}

/// Stretches every time step that is too short for its segment under the velocity
/// limits (cone slack of the solver, or a split whose halves follow an arc and so are
/// together longer than the chord they replace).
fn fit_time_steps(band: &mut Band, cfg: &TebConfig, sigma: f64) {
    let vlim = if sigma < 0.0 {
        cfg.limits.max_reverse_velocity
    } else {
        cfg.limits.max_velocity
    };
    scp::fit_time_steps(band, vlim, cfg.limits.max_angular_velocity);
}

/// Whether a segment is long enough that auto-resize would split it.
fn has_long_segment(band: &Band, cfg: &TebConfig) -> bool {
    band.poses.len() < cfg.band.max_poses
        && band
            .dts
            .iter()
            .any(|&t| t > cfg.band.dt_ref + cfg.band.dt_hysteresis)
}

/// Resizes the band around the reference time step (with hysteresis) and splits it up
/// to the minimum number of poses.
fn resize(band: &mut Band, cfg: &TebConfig) {
    let b = &cfg.band;
    band.resize(b.dt_ref, b.dt_hysteresis, b.min_poses, b.max_poses);
    ensure_min_poses(band, b.min_poses);
}

/// Splits the longest segment until the band has `min_poses` poses.
fn ensure_min_poses(band: &mut Band, min_poses: usize) {
    while band.poses.len() < min_poses && !band.dts.is_empty() {
        let (k, _) =
            band.dts.iter().enumerate().fold(
                (0, f64::MIN),
                |acc, (i, &t)| if t > acc.1 { (i, t) } else { acc },
            );
        let a = band.poses[k];
        let b = band.poses[k + 1];
        band.poses.insert(
            k + 1,
            Pose2::new(
                0.5 * (a.x + b.x),
                0.5 * (a.y + b.y),
                0.5 * (a.theta + b.theta),
            ),
        );
        let t = band.dts[k];
        band.dts[k] = 0.5 * t;
        band.dts.insert(k + 1, 0.5 * t);
    }
}

/// Appends reference poses between the band's end and the new local goal. Returns
/// false when the band no longer fits the reference (then it is rebuilt).
#[allow(clippy::too_many_arguments)]
fn extend(
    band: &mut Band,
    reference: &Reference,
    sec: &Section,
    goal: &Pose2,
    s_lo: f64,
    s_hi: f64,
    cfg: &TebConfig,
    sigma: f64,
) -> bool {
    let end = band.poses[band.poses.len() - 1];
    let pe = reference.project(sec, end.x, end.y, s_lo - 1.0, s_hi + 1.0);
    let s_goal = s_hi - 1.0;
    if pe.distance > cfg.band.reinit_distance || pe.s > s_goal + cfg.band.reinit_distance {
        return false;
    }
    let vlim = if sigma < 0.0 {
        cfg.limits.max_reverse_velocity
    } else {
        cfg.limits.max_velocity
    };
    let ds = vlim * cfg.band.dt_ref;
    let gap = s_goal - pe.s;
    if gap < 0.25 * ds {
        return true;
    }
    let n = (gap / ds).ceil() as usize;
    for j in 1..=n {
        if band.poses.len() >= cfg.band.max_poses {
            break;
        }
        let p = if j == n {
            *goal
        } else {
            reference.sample(sec, pe.s + gap * j as f64 / n as f64)
        };
        let prev = band.poses[band.poses.len() - 1];
        let dt = (prev.distance(&p) / vlim)
            .max(wrap_angle(p.theta - prev.theta).abs() / cfg.limits.max_angular_velocity)
            .max(cfg.band.dt_ref);
        band.poses.push(p);
        band.dts.push(dt);
    }
    true
}

/// A band along the reference from the robot to the local goal, timed by a
/// trapezoidal speed profile (or, on the spot, by the turn rate).
#[allow(clippy::too_many_arguments)]
fn init_band(
    band: &mut Band,
    reference: &Reference,
    sec: &Section,
    robot: &Pose2,
    goal: &Pose2,
    s_robot: f64,
    at_rest: bool,
    v0: f64,
    cfg: &TebConfig,
    sigma: f64,
) {
    band.clear();
    band.poses.push(*robot);
    let lim = &cfg.limits;
    let b = &cfg.band;
    if sigma == 0.0 {
        let turn = wrap_angle(goal.theta - robot.theta);
        let n = ((turn.abs() / (0.7 * lim.max_angular_velocity * b.dt_ref)).ceil() as usize)
            .clamp(b.min_poses - 1, b.max_poses - 1);
        let dt = (turn.abs() / n as f64 / (0.7 * lim.max_angular_velocity)).max(b.dt_ref);
        for j in 1..=n {
            let u = j as f64 / n as f64;
            band.poses
                .push(Pose2::new(robot.x, robot.y, robot.theta + u * turn));
            band.dts.push(dt);
        }
        return;
    }
    let vlim = if sigma < 0.0 {
        lim.max_reverse_velocity
    } else {
        lim.max_velocity
    };
    let s_end = reference
        .project(
            sec,
            goal.x,
            goal.y,
            s_robot,
            s_robot + cfg.look_ahead_distance() + 1.0,
        )
        .s;
    let length = (s_end - s_robot).max(0.0);
    let ds = vlim * b.dt_ref;
    let n = ((length / ds).ceil() as usize).clamp(b.min_poses - 1, b.max_poses - 1);
    let speed_at = |s: f64| -> f64 {
        let mut v = vlim.min((v0 * v0 + 2.0 * lim.max_acceleration * s).sqrt());
        if at_rest {
            v = v.min((2.0 * lim.max_acceleration * (length - s).max(0.0)).sqrt());
        }
        v.max(0.2 * vlim)
    };
    for j in 1..=n {
        let s = length * j as f64 / n as f64;
        let p = if j == n {
            *goal
        } else {
            reference.sample(sec, s_robot + s)
        };
        let prev = band.poses[band.poses.len() - 1];
        let s_prev = length * (j - 1) as f64 / n as f64;
        let v = 0.5 * (speed_at(s_prev) + speed_at(s));
        let dt = (prev.distance(&p) / v)
            .max(wrap_angle(p.theta - prev.theta).abs() / (0.8 * lim.max_angular_velocity))
            .max(b.min_dt * 2.0);
        band.poses.push(p);
        band.dts.push(dt);
    }
}

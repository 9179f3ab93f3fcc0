//! `TebController`: one step = pick the reference section and local goal, warm-start
//! (prune, extend, resize) or build the band, bend it around blocking obstacles,
//! optimise it, and turn it into a command timeline with MATLAB's exit flags.
//!
//! Pure computation: no clock, no randomness, no bus. The node calls
//! [`TebController::step`] on its own schedule. The phases of a step live in `leg.rs`
//! (where along the task), `planner.rs` (the band) and `objective/` (what is optimised).
//! A straight move (docking) is not optimised: `straight.rs` rolls it out, without a
//! band. The goal tolerance is the goal's own, or `band.goal_tolerance` without one;
//! the speed limits are the lower of `teb.toml`'s and the task's (`set_speed_limit`).
//! Where the optimised band collides and the robot is no faster than a straight move,
//! the reference itself (what the global planner found free), timed at that move's
//! speed, is judged by the same rules and driven if it does not collide: the
//! optimiser can end in a local minimum through an obstacle in a tight spot, the same
//! one each step while the robot stands still.

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
use crate::{seed, straight};

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
    /// The configuration steps use: `configured` with the task's speed limit.
    cfg: TebConfig,
    configured: TebConfig,
    active: Option<Active>,
    planner: Planner,
    /// The reference band driven at `straight.speed` when the optimised one collides
    /// (reused).
    crawl: Band,
    out: StepOutput,
    /// Subproblems each optimised step's band is run on for [`TebController::converged_cost`].
    audit: Option<usize>,
    converged: Option<f64>,
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
            configured: cfg.clone(),
            cfg,
            active: None,
            planner: Planner::new(n),
            crawl: Band::with_capacity(n),
            out: StepOutput {
                commands: Vec::with_capacity(MAX_COMMANDS),
                poses: Vec::with_capacity(MAX_COMMANDS),
                ..StepOutput::default()
            },
            audit: None,
            converged: None,
        })
    }

    /// With `Some(n)`, every later optimised step also runs a copy of its band on to
    /// convergence on the same problem (at most `n` more subproblems; see
    /// [`TebController::converged_cost`]). For offline measurement only: it multiplies a
    /// step's time; the step's output is unchanged.
    pub fn set_convergence_audit(&mut self, max_subproblems: Option<usize>) {
        self.audit = max_subproblems;
    }

    /// The cost the last step's band reaches when its optimisation runs on to
    /// convergence on the same problem; `None` unless auditing (see
    /// [`TebController::set_convergence_audit`]) or when the step optimised nothing.
    /// The step's own `cost` over this is how far it stopped from its local optimum.
    pub fn converged_cost(&self) -> Option<f64> {
        self.converged
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

    /// Lowers the speed limits to `limit` (linear m/s, angular rad/s, each positive and
    /// finite) until the next call; `None` restores `teb.toml`'s. The lower of the two
    /// applies to each, forwards and backwards, and to straight moves.
    pub fn set_speed_limit(&mut self, limit: Option<[f64; 2]>) -> Result<(), crate::TebError> {
        let mut cfg = self.configured.clone();
        if let Some([v, w]) = limit {
            if !(v.is_finite() && v > 0.0 && w.is_finite() && w > 0.0) {
                return Err(crate::TebError::InvalidGoal(format!(
                    "speed limit [{v}, {w}] is not two positive numbers"
                )));
            }
            let l = &mut cfg.limits;
            l.max_velocity = l.max_velocity.min(v);
            l.max_reverse_velocity = l.max_reverse_velocity.min(v);
            l.max_angular_velocity = l.max_angular_velocity.min(w);
            cfg.straight.speed = cfg.straight.speed.min(v);
        }
        self.cfg = cfg;
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
        self.converged = None;
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
        self.converged = self
            .audit
            .filter(|_| done.iterations > 0)
            .map(|n| self.planner.converged_merit(&problem, n));
        self.planner.finish(&problem);

        // Judge it (or, where it collides, the reference itself at a crawl) and write
        // the output.
        let verdict = judge_or_crawl(
            &problem,
            &mut self.planner.band,
            &mut self.crawl,
            &leg,
            &pose,
        );
        let band = &self.planner.band;
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

/// The verdict on the optimised `band`; where it collides and the robot is no faster
/// than a straight move, the reference band at that move's speed (built in `crawl`)
/// replaces it when it does not collide.
fn judge_or_crawl(
    problem: &Problem,
    band: &mut Band,
    crawl: &mut Band,
    leg: &Leg,
    pose: &Pose2,
) -> feasibility::Verdict {
    let cfg = problem.cfg;
    let judge = |band: &Band| problem.judge(band);
    let verdict = judge(band);
    if verdict.flag != ExitFlag::Collision || problem.v0.abs() > cfg.straight.speed {
        return verdict;
    }
    let speed = cfg.straight.speed;
    seed::init_band_at(crawl, problem.reference, leg, pose, problem.v0, speed, cfg);
    let along = judge(crawl);
    if along.flag.stops_robot() {
        return verdict;
    }
    band.copy_from(crawl);
    along
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

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::{Direction, Footprint, GridMap, OCCUPIED_DETECTED, PathPose};

    /// A reference along y = 0 from the robot at the origin, a crate at y = 0.6-1.0
    /// beside it, and a band that bends into the crate (what an optimiser stuck in a
    /// local minimum may return).
    fn setup() -> (TebConfig, GridMap, Goal, Band) {
        let cfg = TebConfig::default();
        let mut map = GridMap::new_free(-5.0, -5.0, 0.1, 10.0, 10.0).unwrap();
        for ix in 0..10 {
            for iy in 0..4 {
                let c = map
                    .view()
                    .cell_of(1.0 + 0.1 * ix as f64, 0.65 + 0.1 * iy as f64);
                map.set(c, OCCUPIED_DETECTED);
            }
        }
        let reference = (0..=40)
            .map(|i| PathPose::new(Pose2::new(0.1 * i as f64, 0.0, 0.0), Direction::Forward))
            .collect();
        let goal = Goal {
            reference,
            footprint: Footprint::new(0.508, 0.43),
            margin: 0.1,
            mode: Mode::Follow,
            tolerance: None,
        };
        let mut band = Band::default();
        band.poses.push(Pose2::new(0.0, 0.0, 0.0));
        for k in 1..=8 {
            let x = 0.25 * k as f64;
            band.poses
                .push(Pose2::new(x, 0.8 * (x / 2.0).min(1.0), 0.3));
            band.dts.push(0.3);
        }
        (cfg, map, goal, band)
    }

    fn judged(v0: f64) -> (feasibility::Verdict, Band) {
        let (cfg, map, goal, mut band) = setup();
        let mut active = Active::new(&goal);
        let pose = Pose2::new(0.0, 0.0, 0.0);
        let leg = active.leg(&cfg, &pose).unwrap();
        let view = map.view();
        let problem = problem(&cfg, &view, &goal, &active.reference, &leg, (v0, 0.0));
        let mut crawl = Band::default();
        let verdict = judge_or_crawl(&problem, &mut band, &mut crawl, &leg, &pose);
        (verdict, band)
    }

    #[test]
    fn a_colliding_band_gives_way_to_the_reference_at_a_crawl() {
        let (verdict, band) = judged(0.0);
        assert!(!verdict.flag.stops_robot(), "{:?}", verdict.flag);
        // The band is now the reference's, at most the straight moves' speed.
        let speed = TebConfig::default().straight.speed;
        assert!(
            band.poses.iter().all(|p| p.y.abs() < 1e-9),
            "{:?}",
            band.poses
        );
        for (k, w) in band.poses.windows(2).enumerate() {
            assert!(w[0].distance(&w[1]) / band.dts[k] <= speed + 1e-9);
        }
    }

    #[test]
    fn a_faster_robot_is_stopped_instead() {
        let speed = TebConfig::default().straight.speed;
        let (verdict, band) = judged(2.0 * speed);
        assert_eq!(verdict.flag, ExitFlag::Collision);
        assert!(band.poses.iter().any(|p| p.y > 0.5));
    }
}

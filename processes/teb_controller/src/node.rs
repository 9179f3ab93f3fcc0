//! The controller process: on every controller tick, one TEB step from the robot's
//! state at that tick on the local map of that tick, published as a `Trajectory`
//! (commands timed from the tick's sim time) and the band (`ControllerBand`, history 1).
//!
//! Goals come from the supervisor (`ControllerGoal`, history 1): a new `goal_id`
//! replaces the task; `Idle` clears it. A goal's `goal_tolerance` is used when it
//! holds three positive numbers, else `teb.toml`'s `band.goal_tolerance`; its
//! `max_velocity`, when two positive numbers, lowers `teb.toml`'s limits. Without a
//! task, or when a step fails, the trajectory is a single zero command, so the robot
//! stops.
//!
//! Freshness is a safety rule here: a local map or robot state older than
//! `teb.toml`'s `inputs.max_age` (sim time since its tick; in realtime also wall time
//! since its tick started) is not acted on: the trajectory is a zero command with exit
//! flag [`EXIT_STALE_INPUT`], so a hung lidar or mapper never leaves the robot driving
//! on a frozen map. Each trajectory also names the oldest tick of its inputs
//! (`inputs_tick`): a simulator stopped for a hung node drives none made from inputs
//! sensed before the stop, however young they were when the step ran.
//!
//! Adapter only: the optimisation is [`crate::TebController`]; the loop around it is
//! the node runtime's (`aisle_node::run`).

use crate::resume::{goal_of, snapshot_of, speed_limit_of};
use crate::{Snapshot, StepOutput, TebConfig, TebController};
use aisle_bus::{NodeArgs, NodeError, StageTimer, Stamp};
use aisle_geometry::Pose2;
use aisle_messages::{
    ControllerBand, GridCopy, MAX_COMMANDS, NodeKind, STAGE_CONTROLLER, StageStatus, Tick,
    TickMode, Topic, Trajectory, topics,
};
use aisle_node::{Cycle, Io, RunContext, Stage};
use std::time::Duration;

const MAP_TIMEOUT: Duration = Duration::from_secs(30);

/// Exit flag of a trajectory that stops the robot because an input was too old
/// (aisle's own, beside MATLAB's 0-5 and 6; the supervisor does not replan for it).
pub const EXIT_STALE_INPUT: u32 = 7;

/// When an input was produced: its tick's sim time and the wall time that tick started.
#[derive(Debug, Clone, Copy, Default)]
struct Produced {
    tick: u64,
    stamp_ns: u64,
    tick_wall_ns: u64,
}

impl Produced {
    fn of(h: &aisle_messages::Header) -> Produced {
        Produced {
            tick: h.tick,
            stamp_ns: h.stamp_ns,
            tick_wall_ns: h.tick_wall_ns,
        }
    }

    /// Age at `tick` in sim time, and in realtime the larger of that and the wall age.
    fn age_ns(&self, tick: &Tick, mode: TickMode) -> u64 {
        let sim = tick.header.stamp_ns.saturating_sub(self.stamp_ns);
        match mode {
            TickMode::Lockstep => sim,
            TickMode::Realtime => {
                sim.max(aisle_bus::clock::monotonic_ns().saturating_sub(self.tick_wall_ns))
            }
        }
    }
}

/// What a controller tick does.
enum Outcome<'a> {
    /// No task: stand still.
    NoTask,
    /// An input is too old: stop (the reason, for the log).
    Stale(String),
    /// One TEB step, or why it failed.
    Step(Result<&'a StepOutput, String>),
}

/// The task the controller is on, by goal id.
struct Task {
    goal_id: u64,
    active: bool,
}

/// The controller as a stage: one TEB step on every controller tick.
pub struct ControllerStage {
    teb: TebController,
    task: Task,
    mode: TickMode,
    /// The last controller tick stepped: a tick seen again (the simulator restarted) is
    /// only acknowledged, so the band is never stepped twice for one tick.
    last_done: Option<u64>,
    /// The trajectory of `last_done` as the predecessor published it (lockstep, after a
    /// restart): a restarted simulator repeats that tick, and its copy of the trajectory
    /// died with it, so it is sent once more, unchanged, when the tick is repeated.
    resend: Option<Box<Trajectory>>,
    pose: Pose2,
    velocity: (f64, f64),
    /// The local map in use, copied out of shared memory (a realtime step may have to
    /// reuse it when no newer one arrived). Capacity is reserved once.
    map: GridCopy,
    /// When the map in use and the robot state in use were produced.
    map_made: Produced,
    state_made: Produced,
    /// `inputs.max_age` of teb.toml, ns.
    max_age_ns: u64,
    /// `inputs.avoid_detected` of teb.toml.
    avoid_detected: bool,
    /// The last tick stopped for stale inputs (log once per episode).
    stale: bool,
}

impl ControllerStage {
    /// Loads `teb.toml` from `config_dir`.
    pub fn new(config_dir: &std::path::Path, start: Pose2) -> Result<ControllerStage, NodeError> {
        let path = config_dir.join("teb.toml");
        let cfg = aisle_config::load::<TebConfig>(&path)
            .map_err(|e| NodeError::setup("teb_controller", e))?;
        let max_age_ns = (cfg.inputs.max_age * 1e9).round() as u64;
        let avoid_detected = cfg.inputs.avoid_detected;
        let teb = TebController::new(cfg)
            .map_err(|e| NodeError::setup(format!("teb_controller: {}", path.display()), e))?;
        Ok(ControllerStage {
            teb,
            task: Task {
                goal_id: 0,
                active: false,
            },
            mode: TickMode::Lockstep,
            last_done: None,
            resend: None,
            pose: start,
            velocity: (0.0, 0.0),
            map: GridCopy::with_capacity(aisle_messages::MAX_GRID_CELLS),
            map_made: Produced::default(),
            state_made: Produced::default(),
            max_age_ns,
            avoid_detected,
            stale: false,
        })
    }

    /// Copies the local map of tick `k` (lockstep) or the newest one (realtime).
    fn take_map(&mut self, io: &impl Io, k: u64) -> Result<(), NodeError> {
        match self.mode {
            TickMode::Lockstep => {
                match io.wait_for(topics::LOCAL_MAP, MAP_TIMEOUT, |m| m.header.tick >= k)? {
                    Some(m) => {
                        self.map.copy_from(&*m);
                        self.map_made = Produced::of(&m.header);
                    }
                    None => {
                        return Err(NodeError::Protocol(format!(
                            "teb_controller: no local map for tick {k}"
                        )));
                    }
                }
            }
            TickMode::Realtime => {
                if let Some(m) = io.latest(topics::LOCAL_MAP)? {
                    self.map.copy_from(&*m);
                    self.map_made = Produced::of(&m.header);
                }
            }
        }
        if !self.avoid_detected {
            use aisle_geometry::OCCUPIED_DETECTED;
            self.map
                .map_in_place(|c| if c == OCCUPIED_DETECTED { 0 } else { c });
        }
        Ok(())
    }

    /// Takes a new goal (by id) from the supervisor, if one arrived.
    fn take_goal(&mut self, io: &impl Io) -> Result<(), NodeError> {
        if let Some(g) = io.latest(topics::CONTROLLER_GOAL)?
            && g.goal_id != self.task.goal_id
        {
            self.task.goal_id = g.goal_id;
            self.task.active = false;
            if let Err(e) = self.teb.set_speed_limit(speed_limit_of(&g)) {
                tracing::warn!("teb_controller: goal {}: {e}", g.goal_id);
            }
            match goal_of(&g) {
                None => self.teb.clear_goal(),
                Some(Ok(goal)) => match self.teb.set_goal(&goal) {
                    Ok(()) => self.task.active = true,
                    Err(e) => tracing::warn!("teb_controller: goal {} refused: {e}", g.goal_id),
                },
                Some(Err(e)) => tracing::warn!("teb_controller: goal {} refused: {e}", g.goal_id),
            }
        }
        Ok(())
    }

    /// Why the inputs of `tick` may not be acted on, if an input is too old.
    fn stale_input(&self, tick: &Tick) -> Option<String> {
        let limit = self.max_age_ns;
        [
            ("local map", self.map_made),
            ("robot state", self.state_made),
        ]
        .into_iter()
        .find_map(|(what, made)| {
            let age = made.age_ns(tick, self.mode);
            (age > limit).then(|| {
                format!(
                    "the {what} is {:.2} s old (limit {:.2} s, teb.toml inputs.max_age)",
                    age as f64 * 1e-9,
                    limit as f64 * 1e-9
                )
            })
        })
    }

    /// What tick `tick` does: nothing without a task, a stop on stale inputs, else one
    /// TEB step.
    fn step(&mut self, tick: &Tick) -> Outcome<'_> {
        if !self.task.active {
            return Outcome::NoTask;
        }
        if self.map.is_empty() {
            return Outcome::Step(Err("no local map yet".into()));
        }
        if let Some(why) = self.stale_input(tick) {
            return Outcome::Stale(why);
        }
        let now_s = tick.header.stamp_ns as f64 * 1e-9;
        match self.map.view() {
            Ok(view) => Outcome::Step(
                self.teb
                    .step(self.pose, self.velocity, now_s, &view)
                    .map_err(|e| e.to_string()),
            ),
            Err(e) => Outcome::Step(Err(format!("local map: {e}"))),
        }
    }

    /// Logs the start (`stale`: why) and the end (`stepped`) of a stop for stale
    /// inputs, once each.
    fn note_staleness(&mut self, stale: Option<String>, stepped: bool, k: u64) {
        match (stale, self.stale) {
            (Some(why), false) => {
                tracing::warn!("teb_controller: tick {k}: {why}: stopping the robot");
                self.stale = true;
            }
            (None, true) if stepped => {
                tracing::warn!("teb_controller: tick {k}: inputs fresh again");
                self.stale = false;
            }
            _ => {}
        }
    }
}

/// Writes a step's outcome into a `Trajectory`: its commands, or a single zero command.
fn fill_trajectory(
    t: &mut Trajectory,
    step: &Outcome,
    goal_id: u64,
    start_ns: u64,
    inputs_tick: u64,
    compute_ns: u64,
) {
    let now_s = start_ns as f64 * 1e-9;
    t.goal_id = goal_id;
    t.start_ns = start_ns;
    t.inputs_tick = inputs_tick;
    t.solve_ns = compute_ns;
    match step {
        Outcome::Step(Ok(out)) => {
            let n = out.commands.len().min(MAX_COMMANDS);
            t.len = n as u32;
            for (dst, c) in t.commands.iter_mut().zip(&out.commands[..n]) {
                // The library's times are absolute; the message's count from start_ns.
                dst.t = c.t - now_s;
                dst.v = c.v;
                dst.w = c.w;
            }
            let np = out.poses.len().min(MAX_COMMANDS);
            t.poses_len = np as u32;
            for (dst, p) in t.poses.iter_mut().zip(&out.poses[..np]) {
                dst.t = p.t - now_s;
                dst.x = p.pose.x;
                dst.y = p.pose.y;
                dst.theta = p.pose.theta;
            }
            t.exit_flag = out.exit_flag.code() as u32;
            t.last_feasible_index = out.last_feasible_index as i32;
            t.reached_goal = out.reached_goal as u32;
            t.iterations = out.iterations as u32;
            t.cost = out.cost;
            t.max_violation = out.max_violation;
        }
        Outcome::Step(Err(_)) => {
            // Stop: one zero command, flagged as infeasible so the supervisor replans.
            t.len = 1;
            t.exit_flag = 1;
            t.last_feasible_index = -1;
        }
        Outcome::Stale(_) => {
            // Stop: one zero command; a new reference would not make the inputs fresh.
            t.len = 1;
            t.exit_flag = EXIT_STALE_INPUT;
            t.last_feasible_index = -1;
        }
        Outcome::NoTask => {
            t.len = 1;
            t.last_feasible_index = -1;
        }
    }
}

/// Writes the controller's resumable state (its band) into a `ControllerBand`.
fn fill_band(m: &mut ControllerBand, snap: &Snapshot, goal_id: u64) {
    m.goal_id = goal_id;
    let b = &snap.band;
    let n = b.poses.len().min(MAX_COMMANDS);
    m.len = n as u32;
    m.section = snap.section as u32;
    m.progress = snap.progress;
    m.detour_side = i32::from(snap.detour_side);
    let mut t = 0.0;
    for (i, (dst, p)) in m.poses.iter_mut().zip(&b.poses[..n]).enumerate() {
        dst.t = t;
        dst.x = p.x;
        dst.y = p.y;
        dst.theta = p.theta;
        t += b.dts.get(i).copied().unwrap_or(0.0);
    }
    for (dst, dt) in m.dts.iter_mut().zip(&b.dts) {
        *dst = *dt;
    }
}

impl Stage for ControllerStage {
    const KIND: NodeKind = NodeKind::TebController;
    type Trigger = Tick;
    const TRIGGER: Topic<Tick> = topics::TICK;
    const NEWEST_ONLY: bool = true;

    fn start(&mut self, _io: &impl Io, ctx: &RunContext) -> Result<(), NodeError> {
        self.mode = ctx.mode;
        Ok(())
    }

    /// A restarted controller takes its task back (the newest goal) and, in lockstep
    /// when its last band belongs to that goal, the band itself.
    fn restore(&mut self, io: &impl Io, ctx: &RunContext) -> Result<(), NodeError> {
        let wait = Duration::from_secs(1);
        let Some(goal) = io.wait_for(topics::CONTROLLER_GOAL, wait, |_| true)? else {
            return Ok(());
        };
        self.task.goal_id = goal.goal_id;
        match goal_of(&goal) {
            Some(Ok(g)) => {
                self.teb.set_goal(&g).map_err(|e| {
                    NodeError::Protocol(format!("teb_controller: resuming goal: {e}"))
                })?;
                self.task.active = true;
            }
            Some(Err(e)) => {
                return Err(NodeError::Protocol(format!(
                    "teb_controller: resuming goal: {e}"
                )));
            }
            None => self.teb.clear_goal(),
        }
        let Some(b) = io.retained(topics::CONTROLLER_BAND, wait)? else {
            return Ok(());
        };
        // In realtime the robot has moved on since that band (and was stopped): start a
        // fresh band from where it stands. In lockstep nothing moved, and resuming the
        // band keeps the run identical to an undisturbed one.
        if ctx.mode == TickMode::Lockstep && b.goal_id == self.task.goal_id && self.task.active {
            let snap = snapshot_of(&b);
            self.teb
                .restore(&snap)
                .map_err(|e| NodeError::Protocol(format!("teb_controller: resuming band: {e}")))?;
            // Retained beside the band (`graph.toml`), published before it.
            self.resend = io
                .retained(topics::TRAJECTORY, wait)?
                .filter(|t| t.header.tick == b.header.tick)
                .map(|t| Box::new(*t));
        }
        tracing::warn!(
            "teb_controller: resumed goal {} after tick {}",
            self.task.goal_id,
            b.header.tick
        );
        self.last_done = Some(b.header.tick);
        Ok(())
    }

    fn process(&mut self, tick: &Tick, io: &impl Io) -> Result<Cycle, NodeError> {
        if tick.stages & STAGE_CONTROLLER == 0 {
            return Ok(Cycle {
                status: StageStatus::Idle,
                compute_ns: Some(0),
            });
        }
        let k = tick.header.tick;
        if self.last_done.is_some_and(|d| k <= d) {
            if let Some(t) = self.resend.take_if(|t| t.header.tick == k) {
                io.publish(topics::TRAJECTORY, Stamp::of(&tick.header), |m| *m = *t)?;
            }
            return Ok(Cycle::repeat());
        }
        self.last_done = Some(k);
        self.take_map(io, k)?;
        let timer = StageTimer::start();
        if let Some(rs) = io.latest(topics::ROBOT_STATE)? {
            self.pose = rs.pose.into();
            self.velocity = (rs.twist[0], rs.twist[1]);
            self.state_made = Produced::of(&rs.header);
        }
        self.take_goal(io)?;
        let stamp = Stamp::of(&tick.header);
        let start_ns = tick.header.stamp_ns;
        let goal_id = self.task.goal_id;
        let inputs_tick = self.map_made.tick.min(self.state_made.tick);
        let step = self.step(tick);
        let stale = match &step {
            Outcome::Stale(why) => Some(why.clone()),
            _ => None,
        };
        let stepped = matches!(step, Outcome::Step(_));
        let status = match &step {
            Outcome::Step(Err(e)) => {
                tracing::warn!("teb_controller: step of tick {k} failed: {e}");
                StageStatus::Failed
            }
            _ => StageStatus::Done,
        };
        let compute_ns = timer.elapsed_ns();
        io.publish(topics::TRAJECTORY, stamp, |t| {
            fill_trajectory(t, &step, goal_id, start_ns, inputs_tick, compute_ns)
        })?;
        self.note_staleness(stale, stepped, k);
        let snap = self.teb.snapshot();
        io.publish(topics::CONTROLLER_BAND, stamp, |m| {
            fill_band(m, &snap, goal_id)
        })?;
        Ok(Cycle {
            status,
            compute_ns: Some(compute_ns),
        })
    }
}

pub fn run(args: &NodeArgs) -> Result<(), NodeError> {
    let start = Pose2::new(args.start[0], args.start[1], args.start[2]);
    let mut stage = ControllerStage::new(&args.config_dir, start)?;
    aisle_node::run(&mut stage, args)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Mode;
    use aisle_messages::{ControllerGoal, GoalMode};
    use aisle_node::testing::MemIo;

    fn stage() -> ControllerStage {
        let dir = aisle_config::testing::shipped_dir();
        ControllerStage::new(&dir, Pose2::new(0.0, 0.0, 0.0)).unwrap()
    }

    fn tick(k: u64, stages: u32) -> Tick {
        let mut t = *aisle_messages::zeroed_box::<Tick>();
        t.header.tick = k;
        t.header.stamp_ns = k * 100_000_000;
        t.stages = stages;
        t
    }

    #[test]
    fn other_ticks_are_acknowledged_idle_without_output() {
        let (mut s, io) = (stage(), MemIo::new());
        let c = s.process(&tick(1, 0), &io).unwrap();
        assert_eq!(c.status, StageStatus::Idle);
        assert_eq!(io.published_len(topics::TRAJECTORY), 0);
    }

    #[test]
    fn without_a_goal_the_robot_is_told_to_stop_and_a_repeat_is_not_stepped() {
        let (mut s, io) = (stage(), MemIo::new());
        io.push(topics::LOCAL_MAP, |m| {
            m.header.tick = 5;
            m.width = 4;
            m.height = 4;
            m.resolution = 0.1;
        });
        let c = s.process(&tick(5, STAGE_CONTROLLER), &io).unwrap();
        assert_eq!(c.status, StageStatus::Done);
        let (len, v, w, start) = io
            .published(topics::TRAJECTORY, 0, |t| {
                (t.len, t.commands[0].v, t.commands[0].w, t.start_ns)
            })
            .unwrap();
        assert_eq!((len, v, w, start), (1, 0.0, 0.0, 500_000_000));
        assert_eq!(io.published_len(topics::CONTROLLER_BAND), 1);
        // The same tick again (a restarted simulator): acknowledged, not stepped.
        let c = s.process(&tick(5, STAGE_CONTROLLER), &io).unwrap();
        assert_eq!(c, Cycle::repeat());
        assert_eq!(io.published_len(topics::TRAJECTORY), 1);
    }

    /// A rotate-in-place task, a 4 m free local map stamped `map_s`, and the robot's
    /// state stamped `state_s`, for the controller tick `k`.
    fn rotate_task(io: &MemIo, k: u64, map_s: f64, state_s: f64) {
        io.push(topics::CONTROLLER_GOAL, |g| {
            g.goal_id = 1;
            g.mode = GoalMode::RotateInPlace as u32;
            g.footprint_length = 0.508;
            g.footprint_width = 0.43;
            g.margin = 0.1;
            g.goal_tolerance = [0.2; 3];
            g.target.theta = 1.5;
        });
        io.push(topics::LOCAL_MAP, |m| {
            m.header.tick = k;
            m.header.stamp_ns = (map_s * 1e9) as u64;
            m.width = 40;
            m.height = 40;
            m.resolution = 0.1;
            m.origin_x = -2.0;
            m.origin_y = -2.0;
        });
        io.push(topics::ROBOT_STATE, |r| {
            r.header.stamp_ns = (state_s * 1e9) as u64;
        });
    }

    fn exit_flag_and_first_v(io: &MemIo, i: usize) -> (u32, f64, u32) {
        io.published(topics::TRAJECTORY, i, |t| {
            (
                t.exit_flag,
                t.commands[0].v.abs() + t.commands[0].w.abs(),
                t.len,
            )
        })
        .unwrap()
    }

    #[test]
    fn a_stale_map_or_robot_state_stops_the_robot_and_fresh_inputs_resume() {
        let (mut s, io) = (stage(), MemIo::new());
        // Tick 10 (1.0 s) with a map of 0.6 s: 0.4 s old, over the 0.3 s limit.
        rotate_task(&io, 10, 0.6, 1.0);
        s.process(&tick(10, STAGE_CONTROLLER), &io).unwrap();
        assert_eq!(exit_flag_and_first_v(&io, 0), (EXIT_STALE_INPUT, 0.0, 1));
        // A robot state 0.5 s old, the map fresh: stopped all the same.
        rotate_task(&io, 15, 1.5, 1.0);
        s.process(&tick(15, STAGE_CONTROLLER), &io).unwrap();
        assert_eq!(exit_flag_and_first_v(&io, 1).0, EXIT_STALE_INPUT);
        // Both at most 0.3 s old: a real step, which turns the robot.
        rotate_task(&io, 20, 1.8, 2.0);
        s.process(&tick(20, STAGE_CONTROLLER), &io).unwrap();
        let (flag, speed, len) = exit_flag_and_first_v(&io, 2);
        assert_ne!(flag, EXIT_STALE_INPUT);
        assert!(
            speed > 0.0 && len > 1,
            "flag {flag}, |v|+|w| {speed}, {len} commands"
        );
    }

    #[test]
    fn a_trajectory_names_the_oldest_tick_of_its_inputs() {
        let (mut s, io) = (stage(), MemIo::new());
        // Realtime: the newest map is of tick 18 (the mapper a tick behind), the state
        // of tick 20; both young enough to step on.
        s.mode = TickMode::Realtime;
        rotate_task(&io, 18, 1.8, 2.0);
        io.push(topics::ROBOT_STATE, |r| {
            r.header.tick = 20;
            r.header.stamp_ns = 2_000_000_000;
            r.header.tick_wall_ns = aisle_bus::clock::monotonic_ns();
        });
        io.push(topics::LOCAL_MAP, |m| {
            m.header.tick = 18;
            m.header.stamp_ns = 1_800_000_000;
            m.header.tick_wall_ns = aisle_bus::clock::monotonic_ns();
            m.width = 40;
            m.height = 40;
            m.resolution = 0.1;
            m.origin_x = -2.0;
            m.origin_y = -2.0;
        });
        s.process(&tick(20, STAGE_CONTROLLER), &io).unwrap();
        let (flag, inputs) = io
            .published(topics::TRAJECTORY, 0, |t| (t.exit_flag, t.inputs_tick))
            .unwrap();
        assert_ne!(flag, EXIT_STALE_INPUT);
        assert_eq!(inputs, 18);
    }

    /// A straight move from the origin to (1, 0) heading +x, and a free local map and
    /// the robot's state for tick `k`.
    fn straight_task(io: &MemIo, k: u64, tolerance: [f64; 3]) {
        io.push(topics::CONTROLLER_GOAL, |g| {
            g.goal_id = 3;
            g.mode = GoalMode::Straight as u32;
            g.footprint_length = 0.508;
            g.footprint_width = 0.43;
            g.margin = 0.1;
            g.goal_tolerance = tolerance;
            g.target.x = 1.0;
        });
        io.push(topics::LOCAL_MAP, |m| {
            m.header.tick = k;
            m.header.stamp_ns = k * 100_000_000;
            m.width = 40;
            m.height = 40;
            m.resolution = 0.1;
            m.origin_x = -2.0;
            m.origin_y = -2.0;
        });
        io.push(topics::ROBOT_STATE, |r| {
            r.header.stamp_ns = k * 100_000_000;
        });
    }

    #[test]
    fn a_straight_goal_maps_with_its_own_tolerance_or_the_fallback() {
        let mut g = *aisle_messages::zeroed_box::<ControllerGoal>();
        g.mode = GoalMode::Straight as u32;
        g.footprint_length = 0.508;
        g.footprint_width = 0.43;
        g.target.x = 2.0;
        g.target.theta = 0.5;
        g.goal_tolerance = [0.08, 0.04, 0.06];
        let goal = goal_of(&g).unwrap().unwrap();
        assert_eq!(
            goal.mode,
            Mode::Straight {
                target: Pose2::new(2.0, 0.0, 0.5)
            }
        );
        assert_eq!(goal.tolerance, Some([0.08, 0.04, 0.06]));
        assert!(goal.reference.is_empty());
        for bad in [
            [0.0; 3],
            [0.1, 0.0, 0.1],
            [0.1, f64::NAN, 0.1],
            [-0.1, 0.1, 0.1],
        ] {
            g.goal_tolerance = bad;
            assert_eq!(goal_of(&g).unwrap().unwrap().tolerance, None, "{bad:?}");
        }
    }

    #[test]
    fn a_goal_s_max_velocity_is_its_speed_limit_when_two_positive_numbers() {
        let mut g = *aisle_messages::zeroed_box::<ControllerGoal>();
        assert_eq!(speed_limit_of(&g), None, "an older sender leaves it zero");
        g.max_velocity = [0.5, 0.3];
        assert_eq!(speed_limit_of(&g), Some([0.5, 0.3]));
        for bad in [[0.5, 0.0], [-1.0, 1.0], [f64::INFINITY, 1.0]] {
            g.max_velocity = bad;
            assert_eq!(speed_limit_of(&g), None, "{bad:?}");
        }
    }

    #[test]
    fn a_straight_goal_drives_and_a_restarted_controller_resumes_it_without_a_band() {
        let (mut s, io) = (stage(), MemIo::new());
        straight_task(&io, 10, [0.08, 0.04, 0.06]);
        s.process(&tick(10, STAGE_CONTROLLER), &io).unwrap();
        let (flag, len, v) = io
            .published(topics::TRAJECTORY, 0, |t| {
                (t.exit_flag, t.len, t.commands[5].v)
            })
            .unwrap();
        assert_eq!(flag, 0);
        assert!(len > 10 && v > 0.0, "{len} commands, v {v}");
        let band_len = io.published(topics::CONTROLLER_BAND, 0, |b| b.len).unwrap();
        assert_eq!(band_len, 0);

        // A restarted controller: the goal and the (empty) band it published.
        let (mut r, io) = (stage(), MemIo::new());
        straight_task(&io, 15, [0.08, 0.04, 0.06]);
        io.retain(topics::CONTROLLER_BAND, |b| {
            b.header.tick = 14;
            b.goal_id = 3;
        });
        let ctx = RunContext {
            mode: TickMode::Lockstep,
            seed: 1,
            restarted: true,
        };
        r.restore(&io, &ctx).unwrap();
        r.process(&tick(15, STAGE_CONTROLLER), &io).unwrap();
        let got = io
            .published(topics::TRAJECTORY, 0, |t| (t.goal_id, t.exit_flag, t.len))
            .unwrap();
        assert_eq!((got.0, got.1), (3, 0));
        assert!(got.2 > 10, "{got:?}");
    }

    #[test]
    fn a_restarted_controller_sends_the_trajectory_of_a_repeated_tick_again_once() {
        let (mut r, io) = (stage(), MemIo::new());
        straight_task(&io, 15, [0.08, 0.04, 0.06]);
        io.retain(topics::CONTROLLER_BAND, |b| {
            b.header.tick = 14;
            b.goal_id = 3;
        });
        io.retain(topics::TRAJECTORY, |t| {
            t.header.tick = 14;
            t.goal_id = 3;
            t.len = 1;
            t.commands[0].v = 0.123;
        });
        let ctx = RunContext {
            mode: TickMode::Lockstep,
            seed: 1,
            restarted: true,
        };
        r.restore(&io, &ctx).unwrap();
        // The restarted simulator repeats tick 14 (twice, were it to restart again).
        for _ in 0..2 {
            let c = r.process(&tick(14, STAGE_CONTROLLER), &io).unwrap();
            assert_eq!(c.compute_ns, Some(0));
        }
        assert_eq!(io.published_len(topics::TRAJECTORY), 1);
        let sent = io.published(topics::TRAJECTORY, 0, |t| {
            (t.header.tick, t.len, t.commands[0].v)
        });
        assert_eq!(sent, Some((14, 1, 0.123)));
        // Tick 15 is stepped as always.
        r.process(&tick(15, STAGE_CONTROLLER), &io).unwrap();
        assert_eq!(io.published_len(topics::TRAJECTORY), 2);
    }

    #[test]
    fn lockstep_without_the_local_map_of_the_tick_is_an_error() {
        let (mut s, io) = (stage(), MemIo::new());
        let e = s.process(&tick(5, STAGE_CONTROLLER), &io).unwrap_err();
        assert!(e.to_string().contains("no local map for tick 5"), "{e}");
    }
}

//! The tick loop: per simulator tick, wait (in lockstep) until the pipeline has
//! acknowledged it, read the robot's state and the controller's trajectories, feed the
//! mission, carry out its actions, publish the mission status and acknowledge the tick.
//!
//! In lockstep the supervisor acts on tick k only after lidar, mapper (and, on its
//! ticks, the controller) have acknowledged k, and the simulator advances only after
//! the supervisor's own acknowledgement; plans are requested inside that window, so a
//! run depends on its inputs and seed alone. In realtime nobody waits for anybody.

use super::run_config::RunConfig;
use super::{RunAborted, RunOptions, Session};
use crate::mission::{Action, ControllerReport};
use aisle_bus::{StageTimer, Stamp};
use aisle_geometry::Pose2;
use aisle_messages::{NodeKind, SimCommandKind, StageStatus, Tick, TickDone, TickMode};
use aisle_tools::latency::SampleBook;
use std::time::{Duration, Instant};

/// Longest a lockstep tick may take before the run is declared stuck.
const LOCKSTEP_STALL: Duration = Duration::from_secs(60);
const REALTIME_STALL: Duration = Duration::from_secs(5);

impl Session {
    /// Waits for the group, starts the simulator and runs the mission tick by tick
    /// until it ends; `Err` when the run cannot go on.
    pub(super) fn drive(
        &mut self,
        opts: &RunOptions,
        config: &RunConfig,
    ) -> Result<(), RunAborted> {
        self.wait_ready()?;
        self.sim_command(SimCommandKind::Start, None)?;
        let stall = if self.mode == TickMode::Lockstep {
            LOCKSTEP_STALL
        } else {
            REALTIME_STALL
        };
        let mut next_tick = 0u64;
        let mut started = false;
        let mut kills = config.kills.clone();
        let planner_timeout = Duration::from_secs_f64(config.mission.planner_timeout_s);
        loop {
            let tick = self.next_tick(stall)?;
            let k = tick.header.tick;
            if k < next_tick {
                // A restarted simulator repeats the tick it died in: acknowledge again,
                // act once.
                if self.mode == TickMode::Lockstep {
                    self.acknowledge(&tick, None)?;
                }
                continue;
            }
            next_tick = k + 1;
            self.ticks = k;
            self.now_s = tick.header.stamp_ns as f64 * 1e-9;
            self.health.stamp = self.stamp();
            if self.mode == TickMode::Lockstep {
                // Act after the perception pipeline (and the controller) finished this tick,
                // so plans see the newest map and the run is repeatable.
                self.await_tick_acknowledgements(k, tick.stages, stall)?;
            }
            self.inject_kills(&mut kills, k);
            let work = Instant::now();
            let cpu = StageTimer::start();
            self.observe()?;
            let mut actions = Vec::new();
            if !started {
                started = true;
                actions = self.mission.start_leg(self.now_s, self.pose);
            }
            actions.extend(self.read_trajectories()?);
            actions.extend(self.mission.on_tick(self.now_s, self.pose));
            if let Some(halt) = self.grasp_failed() {
                actions = halt;
            }
            if let Some(halt) = self.collision_halt(opts) {
                actions = halt;
            }
            let mut planner_ns = 0;
            self.execute(actions, config, planner_timeout, &mut planner_ns)?;
            self.publish_status()?;
            self.progress(opts);
            let compute = (work.elapsed().as_nanos() as u64).saturating_sub(planner_ns);
            let done = (compute, cpu.cpu_ns());
            self.book.record_cpu("supervisor", k, done.0, done.1);
            // In realtime nobody waits for it, but a record then holds the supervisor's
            // compute time as the run's table does.
            self.acknowledge(&tick, Some(done))?;
            self.health.restarted.clear();
            if self.mission.is_finished() {
                for (kind, at) in &kills {
                    tracing::warn!(
                        "--kill {}@{at}: not injected, the run ended at tick {k}",
                        kind.name()
                    );
                }
                return Ok(());
            }
        }
    }

    /// The next tick to act on, while watching the children.
    fn next_tick(&mut self, stall: Duration) -> Result<Tick, RunAborted> {
        let mut tick =
            self.health
                .wait_on(&self.ports.tick, stall, "tick from the simulator", |_| true)?;
        self.book.record_tick(&tick);
        // Realtime: act on the newest tick; lockstep delivers them one by one.
        while let Some(t) = self.ports.tick.receive()? {
            self.book.record_tick(&t);
            tick = *t;
        }
        // Ticks may keep coming (realtime) while a node is dead: look every tick.
        self.supervise()?;
        Ok(tick)
    }

    /// Lockstep: waits until the nodes the graph puts before the supervisor (`after`:
    /// lidar, mapper and, on a controller tick, the controller) have acknowledged tick
    /// `k`, recording every acknowledgement's compute time.
    fn await_tick_acknowledgements(
        &mut self,
        k: u64,
        stages: u32,
        stall: Duration,
    ) -> Result<(), RunAborted> {
        self.awaited
            .expect(k, self.graph.waits_of(NodeKind::Supervisor, stages));
        while !self.awaited.is_complete() {
            let (book, awaited) = (&mut self.book, &self.awaited);
            let done =
                self.health
                    .wait_on(&self.ports.tick_done_in, stall, "acknowledgement", |d| {
                        record_done(book, d);
                        awaited.matches(d)
                    })?;
            self.awaited.take(&done);
        }
        Ok(())
    }

    /// The supervisor's own acknowledgement of `tick` (no compute time for a tick it
    /// acknowledges again without acting).
    /// `compute`: wall and CPU time of the supervisor's work on it.
    fn acknowledge(&mut self, tick: &Tick, compute: Option<(u64, u64)>) -> Result<(), RunAborted> {
        self.ports.tick_done.publish(Stamp::of(&tick.header), |m| {
            m.node = NodeKind::Supervisor.code();
            m.status = StageStatus::Done as u32;
            if let Some((wall, cpu)) = compute {
                m.compute_ns = wall;
                m.cpu_ns = cpu;
            }
        })?;
        Ok(())
    }

    /// Fault injection: a node killed at a known tick, restarted as after a crash.
    /// (Realtime may skip the very tick: the first tick at or after it counts.)
    fn inject_kills(&mut self, kills: &mut Vec<(NodeKind, u64)>, k: u64) {
        kills.retain(|(kind, at)| {
            if *at > k {
                return true;
            }
            tracing::warn!("killing `{}` at tick {k}, as --kill asks", kind.name());
            self.health.group.kill(*kind);
            false
        });
    }

    /// Late acknowledgements, the robot's pose (and the distance driven), ground truth.
    fn observe(&mut self) -> Result<(), RunAborted> {
        while let Some(d) = self.ports.tick_done_in.receive()? {
            record_done(&mut self.book, &d);
        }
        if let Some(rs) = self.ports.robot.latest()? {
            self.health
                .links
                .note_robot(rs.twist, rs.header.publish_wall_ns);
            let pose: Pose2 = rs.pose.into();
            if !self.driven.is_empty() {
                self.path_length += pose.distance(&self.pose);
            }
            self.pose = pose;
            self.note_carried(rs.carried_body);
            self.driven
                .push([rs.header.stamp_ns as f64 * 1e-9, pose.x, pose.y, pose.theta]);
        }
        self.observe_truth()
    }

    /// Every trajectory since the last tick: its end-to-end latency, and for the
    /// current goal the controller's report to the mission.
    /// Once a report has moved the mission on (a stage reached, a replan), the reports
    /// still queued for the same goal are stale: a supervisor that fell behind (stopped,
    /// or waiting on a plan in realtime) finds several, and each would otherwise count
    /// again, a stage reached once ending the stages after it too.
    fn read_trajectories(&mut self) -> Result<Vec<Action>, RunAborted> {
        let mut actions = Vec::new();
        while let Some(traj) = self.ports.trajectory.receive()? {
            let k = traj.header.tick;
            if self.trajectory_tick.is_some_and(|seen| k <= seen) {
                continue;
            }
            self.trajectory_tick = Some(k);
            self.book.record_trajectory(&traj.header);
            if traj.goal_id == self.goal_id && traj.goal_id != 0 && actions.is_empty() {
                let n = (traj.len as usize).min(traj.commands.len());
                let increasing = traj.commands[..n].windows(2).all(|w| w[1].t > w[0].t);
                tracing::debug!(
                    "t = {:.1} s goal {}: exit flag {}, reached {}, {} commands, first (v {:.3}, w {:.3}), {} iterations",
                    self.now_s,
                    traj.goal_id,
                    traj.exit_flag,
                    traj.reached_goal,
                    n,
                    traj.commands[0].v,
                    traj.commands[0].w,
                    traj.iterations
                );
                let report = ControllerReport {
                    reached_goal: traj.reached_goal != 0,
                    exit_flag: traj.exit_flag,
                    timestamps_increasing: increasing,
                };
                actions.extend(self.mission.on_controller(self.now_s, self.pose, report));
            }
        }
        Ok(actions)
    }
}

/// Another stage's acknowledgement (the supervisor's own compute time is recorded
/// where it is measured).
fn record_done(book: &mut SampleBook, d: &TickDone) {
    if d.node != NodeKind::Supervisor.code() {
        book.record_done(d);
    }
}

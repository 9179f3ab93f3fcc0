//! The children and their health: liveness by reaping and by heartbeat, restarts
//! against the policy, readiness. Kept apart from the data ports so that a wait on a
//! port can watch the children at the same time. Knows nothing of the mission.

use super::retained_state::RetainedState;
use super::{POLL, RunAborted, Session};
use crate::launch::{ProcessGroup, describe};
use crate::restart::{RestartBook, RestartConfig};
use aisle_bus::{Bus, Publisher, Subscriber, WaitOutcome};
use aisle_messages::{
    ControllerGoal, Heartbeat, InstanceInfo, MapperControl, NodeKind, NodeState, SimCommand,
    SimCommandKind, TickMode,
};
use anyhow::anyhow;
use std::collections::HashMap;
use std::time::{Duration, Instant};

const READY_TIMEOUT: Duration = Duration::from_secs(60);

/// The process group, what the supervisor knows of each child's health, and the
/// supervisor's own state publishers (which a (re)joining node must be connected to).
pub(super) struct NodeHealth {
    // Field order matters: ports drop before the bus node.
    pub info: Publisher<InstanceInfo>,
    /// The supervisor's own state publishers (history 1): a node that (re)joins gets
    /// them through `update_connections`.
    pub sim_command: Publisher<SimCommand>,
    pub goal: Publisher<ControllerGoal>,
    pub mapper_control: Publisher<MapperControl>,
    pub retained: RetainedState,
    pub heartbeat: Subscriber<Heartbeat>,
    pub bus: Bus,
    pub group: ProcessGroup,
    pub restart: RestartConfig,
    pub restarts: RestartBook,
    pub last_seen: HashMap<NodeKind, Instant>,
    pub ready: Vec<NodeKind>,
    /// The nodes of this run (the five, and a recorder when recording).
    pub expected: Vec<NodeKind>,
    /// The mission runs: a node that dies now resumes from its published state.
    pub running: bool,
    /// Nodes restarted since the session last looked (plans to resend, a robot to stop).
    pub restarted: Vec<NodeKind>,
    pub started: Instant,
}

impl NodeHealth {
    /// Reaps dead children and restarts them within the policy, kills nodes whose
    /// heartbeats stopped, serves the instance announcement to (re)joining nodes.
    pub fn check(&mut self) -> Result<(), RunAborted> {
        self.drain_heartbeats()?;
        self.retained.copy_newest()?;
        self.restart_dead()?;
        self.kill_silent();
        self.connect_joiners()
    }

    /// Reaps every child that exited and restarts it, or ends the run when the policy's
    /// limit is reached. A dead recorder is let go.
    fn restart_dead(&mut self) -> Result<(), RunAborted> {
        while let Some((kind, status)) = self.group.poll_exit() {
            if kind == NodeKind::Recorder {
                // Losing the record must not stop the robot: go on without it.
                tracing::error!(
                    "the recorder {}; the run goes on unrecorded",
                    describe(&status)
                );
                self.expected.retain(|k| *k != NodeKind::Recorder);
                continue;
            }
            let policy = self.restart.policy(kind);
            let now_s = self.started.elapsed().as_secs_f64();
            let last = self
                .group
                .last_line(kind)
                .map(|l| format!("; its last words: {l}"))
                .unwrap_or_default();
            match self.restarts.allow(kind, &policy, now_s) {
                Ok(n) => {
                    tracing::warn!(
                        "node `{}` {}{last}: restarting it ({n} of {} within {} s)",
                        kind.name(),
                        describe(&status),
                        policy.max_restarts,
                        policy.window_s
                    );
                    // Its iceoryx2 node is dead: free what it held before its successor joins,
                    // and hand the successor the state the dead one published.
                    self.bus.cleanup_dead_nodes();
                    if self.running {
                        self.retained.republish(kind)?;
                    }
                    self.ready.retain(|k| *k != kind);
                    self.group
                        .spawn(kind, self.running)
                        .map_err(|e| RunAborted::Error(anyhow!(e)))?;
                    self.last_seen.insert(kind, Instant::now());
                    self.restarted.push(kind);
                }
                Err(n) => {
                    return Err(RunAborted::Error(anyhow!(
                        "node `{}` {}{last}; it was restarted {n} times within {} s, the limit of config/restart.toml",
                        kind.name(),
                        describe(&status),
                        policy.window_s
                    )));
                }
            }
        }
        Ok(())
    }

    /// Kills every node whose heartbeats stopped; the next check reaps and restarts it.
    fn kill_silent(&mut self) {
        let now = Instant::now();
        for kind in NodeKind::LAUNCHED
            .into_iter()
            .filter(|k| self.expected.contains(k))
        {
            let timeout = Duration::from_secs_f64(self.restart.policy(kind).heartbeat_timeout_s);
            if self
                .last_seen
                .get(&kind)
                .is_some_and(|t| now.duration_since(*t) > timeout)
            {
                tracing::warn!(
                    "node `{}` sent no heartbeat for {:.1} s: killing it",
                    kind.name(),
                    timeout.as_secs_f64()
                );
                self.group.kill(kind);
                // Reaped (and restarted) by the next check; do not kill it twice.
                self.last_seen.insert(kind, now);
            }
        }
    }

    /// Connects the supervisor's state publishers to nodes that (re)joined.
    fn connect_joiners(&mut self) -> Result<(), RunAborted> {
        self.info.update_connections()?;
        self.sim_command.update_connections()?;
        self.goal.update_connections()?;
        self.mapper_control.update_connections()?;
        self.retained.update_connections()?;
        Ok(())
    }

    fn note_heartbeat(&mut self, hb: &Heartbeat) {
        let Some(kind) = NodeKind::from_u32(hb.node) else {
            return;
        };
        self.last_seen.insert(kind, Instant::now());
        if matches!(
            NodeState::from_u32(hb.state),
            Some(NodeState::Ready | NodeState::Running)
        ) && !self.ready.contains(&kind)
        {
            self.ready.push(kind);
        }
    }

    fn drain_heartbeats(&mut self) -> Result<(), RunAborted> {
        while let Some(hb) = self.heartbeat.receive()? {
            let hb = *hb;
            self.note_heartbeat(&hb);
        }
        Ok(())
    }

    /// Sleeps on the heartbeat service up to `timeout`, taking note of what arrives.
    fn heartbeat_wait(&mut self, timeout: Duration) -> Result<(), RunAborted> {
        let mut seen = Vec::new();
        let _ = self.heartbeat.wait_for(
            timeout,
            |hb| {
                seen.push(*hb);
                false
            },
            || {},
        )?;
        for hb in &seen {
            self.note_heartbeat(hb);
        }
        Ok(())
    }

    /// Waits for a message matching `pred` on `sub` while watching the children.
    pub fn wait_on<M: aisle_messages::Message + Copy>(
        &mut self,
        sub: &Subscriber<M>,
        limit: Duration,
        what: &str,
        mut pred: impl FnMut(&M) -> bool,
    ) -> Result<M, RunAborted> {
        let started = Instant::now();
        loop {
            let (outcome, sample) = sub.wait_for(POLL, &mut pred, || {})?;
            if outcome == WaitOutcome::Matched
                && let Some(s) = sample
            {
                return Ok(*s);
            }
            let restarts = self.restarted.len();
            self.check()?;
            if self.restarted.len() > restarts {
                // A node is coming back: give it the time it needs to resume.
                return self.wait_on(sub, limit, what, pred);
            }
            if started.elapsed() > limit {
                return Err(RunAborted::Error(anyhow!(
                    "no {what} within {} s",
                    limit.as_secs()
                )));
            }
        }
    }
}

impl Session {
    /// Watches the children (see [`NodeHealth::check`]); a realtime run whose
    /// controller died stops the robot at once.
    pub(super) fn supervise(&mut self) -> Result<(), RunAborted> {
        self.health.check()?;
        self.after_restarts()
    }

    fn after_restarts(&mut self) -> Result<(), RunAborted> {
        if self.mode == TickMode::Realtime
            && self.health.restarted.contains(&NodeKind::TebController)
        {
            self.health
                .restarted
                .retain(|k| *k != NodeKind::TebController);
            // Its timeline may run for seconds: stop now; motion resumes with the
            // restarted controller's first fresh trajectory.
            self.sim_command(SimCommandKind::Stop, None)?;
        }
        Ok(())
    }

    /// Waits until every expected node reported ready, then marks the mission running.
    pub(super) fn wait_ready(&mut self) -> Result<(), RunAborted> {
        let started = Instant::now();
        while self
            .health
            .expected
            .iter()
            .any(|k| !self.health.ready.contains(k))
        {
            self.health.check()?;
            self.health.heartbeat_wait(POLL)?;
            if started.elapsed() > READY_TIMEOUT {
                let missing: Vec<&str> = self
                    .health
                    .expected
                    .iter()
                    .filter(|k| !self.health.ready.contains(k))
                    .map(|k| k.name())
                    .collect();
                return Err(RunAborted::Error(anyhow!(
                    "not ready within {} s: {}",
                    READY_TIMEOUT.as_secs(),
                    missing.join(", ")
                )));
            }
        }
        self.health.running = true;
        tracing::info!(
            "all {} nodes ready after {:.2} s",
            self.health.ready.len(),
            started.elapsed().as_secs_f64()
        );
        Ok(())
    }
}

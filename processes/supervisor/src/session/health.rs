//! The children and their health: liveness by reaping and by heartbeat, restarts
//! against the policy, readiness. Kept apart from the data ports so that a wait on a
//! port can watch the children at the same time. Knows nothing of the mission.

use super::link_watch::{LinkEvent, LinkWatch};
use super::retained_state::RetainedState;
use super::{POLL, RunAborted, Session};
use crate::launch::{ProcessGroup, describe};
use crate::restart::{RestartBook, RestartConfig};
use aisle_bus::{Bus, BusError, Publisher, Stamp, Subscriber, WaitOutcome, clock};
use aisle_messages::{
    ControllerGoal, GroupMembers, Heartbeat, InstanceInfo, MapperControl, NodeKind, NodeState,
    SimCommand, SimCommandKind, TickMode, write_name,
};
use anyhow::anyhow;
use std::collections::HashMap;
use std::time::{Duration, Instant};

const READY_TIMEOUT: Duration = Duration::from_secs(60);
/// Shortest time a host's nodes get to settle after its link came back (see
/// [`NodeHealth::rejoining`]).
const SETTLE_MIN_S: f64 = 1.0;

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
    /// Who is in the group (`GroupMembers`): whose acknowledgements a tick waits for.
    pub members: Publisher<GroupMembers>,
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
    /// Nodes declared dead or hung since the session last looked, with how long each
    /// had been silent (0 for a crash): the robot must stop.
    pub declared_dead: Vec<(NodeKind, f64)>,
    /// Nodes killed as hung, not reaped yet (so their death is declared once).
    pub hung: Vec<NodeKind>,
    /// The links to other hosts (a spread run).
    pub links: LinkWatch,
    /// Restarted nodes on other hosts not ready yet: their retained state is sent again
    /// at every check, because a sample's history does not cross the link (a late
    /// subscriber over there gets only what is published after it joined).
    pub resuming: Vec<NodeKind>,
    /// Nodes of a host whose link came back, until when they settle: the link takes a
    /// while to flow steadily again (TCP's retransmissions back off while it is down,
    /// up to about as long as it was down), so until then a silence of theirs counts
    /// against `link.down_limit_s`, not their heartbeat timeout.
    pub rejoining: HashMap<NodeKind, Instant>,
    /// Which heartbeat timeout applies to ready nodes.
    pub mode: TickMode,
    /// The last `SimCommand` id sent (ids only grow; the simulator applies each once).
    pub command_id: u64,
    /// The stamp of the newest tick, for what the supervisor sends between ticks.
    pub stamp: Stamp,
    pub started: Instant,
}

impl NodeHealth {
    /// Reaps dead children and restarts them within the policy, kills nodes whose
    /// heartbeats stopped, serves the instance announcement to (re)joining nodes.
    pub fn check(&mut self) -> Result<(), RunAborted> {
        self.drain_heartbeats()?;
        self.retained.copy_newest()?;
        self.restart_dead()?;
        self.resuming.retain(|k| !self.ready.contains(k));
        for kind in self.resuming.clone() {
            self.retained.republish(kind)?;
            self.resend_orders(kind)?;
        }
        self.watch_links()?;
        if let Some((host, down_s)) = self
            .links
            .overdue(clock::monotonic_ns(), &self.restart.link)
        {
            return Err(RunAborted::Error(anyhow!(
                "the link to host `{host}` has been down for {down_s:.1} s, longer than config/restart.toml link.down_limit_s = {} s",
                self.restart.link.down_limit_s
            )));
        }
        self.kill_silent()?;
        self.stop_for_the_dead()?;
        self.connect_joiners()
    }

    /// The supervisor's standing orders `kind` reads, sent again through its own
    /// publishers (see `retained_state::ORDERS`).
    fn resend_orders(&mut self, kind: NodeKind) -> Result<(), RunAborted> {
        for (name, bytes) in self.retained.orders_for(kind) {
            if name == aisle_messages::topics::CONTROLLER_GOAL.name {
                self.goal.publish_bytes(bytes)?;
            } else if name == aisle_messages::topics::MAPPER_CONTROL.name {
                self.mapper_control.publish_bytes(bytes)?;
            }
        }
        Ok(())
    }

    /// The part of [`NodeHealth::check`] that must not wait for the next tick: hangs
    /// declared, and the robot stopped for them. Runs between the sleeps of every wait.
    fn watch(&mut self) {
        if let Err(e) = self.watch_links() {
            tracing::error!("could not stop the robot: {e:?}");
        }
        if let Err(e) = self.kill_silent() {
            tracing::error!("could not read the heartbeats: {e:?}");
        }
        if let Err(e) = self.stop_for_the_dead() {
            tracing::error!("could not stop the robot: {e:?}");
        }
    }

    /// Realtime: the robot stops as soon as any node is declared dead or hung, whatever
    /// its last timeline still holds; it moves again only on a fresh trajectory from
    /// fresh inputs (the controller refuses stale ones), so after the restart.
    /// Lockstep: the sim clock waits for the node, nothing moves meanwhile.
    fn stop_for_the_dead(&mut self) -> Result<(), BusError> {
        if self.declared_dead.is_empty() {
            return Ok(());
        }
        let dead = std::mem::take(&mut self.declared_dead);
        if self.mode == TickMode::Realtime && self.running {
            let names: Vec<String> = dead
                .iter()
                .map(|(k, silent)| format!("`{}` (silent {silent:.2} s)", k.name()))
                .collect();
            tracing::warn!(
                "t = {:.2} s: robot stopped: {} declared dead",
                self.stamp.stamp_ns as f64 * 1e-9,
                names.join(", ")
            );
            self.send_sim_command(self.stamp, SimCommandKind::Stop, None)?;
        }
        Ok(())
    }

    /// Sends a command to the simulator with the next command id.
    pub fn send_sim_command(
        &mut self,
        stamp: Stamp,
        kind: SimCommandKind,
        body: Option<(i32, &str)>,
    ) -> Result<(), BusError> {
        self.command_id += 1;
        let id = self.command_id;
        self.sim_command.publish(stamp, |m| {
            m.command_id = id;
            m.kind = kind as u32;
            m.body_index = body.map_or(-1, |b| b.0);
            if let Some((_, name)) = body {
                write_name(&mut m.name, name);
            }
        })?;
        Ok(())
    }

    /// Reaps every child that exited and restarts it, or ends the run when the policy's
    /// limit is reached. A dead recorder is let go.
    fn restart_dead(&mut self) -> Result<(), RunAborted> {
        while let Some((kind, status)) = self.group.poll_exit() {
            if kind == NodeKind::Recorder {
                // Losing the record must not stop the robot: go on without it, and tell
                // the simulator not to wait for its acknowledgements any more.
                let why = self
                    .group
                    .last_line(kind)
                    .map(|l| format!(": {l}"))
                    .unwrap_or_default();
                tracing::error!(
                    "the recorder {}{why}; the run goes on unrecorded",
                    describe(&status)
                );
                self.expected.retain(|k| *k != NodeKind::Recorder);
                self.publish_members()?;
                continue;
            }
            let policy = self.restart.policy(kind);
            let now_s = self.started.elapsed().as_secs_f64();
            let last = self
                .group
                .last_line(kind)
                .map(|l| format!("; its last words: {l}"))
                .unwrap_or_default();
            // Exit 2 is every node's "cannot run as launched" (arguments, environment,
            // a program that is not that node): its successor would fail the same way.
            if status.code() == Some(i32::from(crate::exit::COULD_NOT)) {
                return Err(RunAborted::Error(anyhow!(
                    "node `{}` {} (it cannot run as launched, so it is not restarted){last}",
                    kind.name(),
                    describe(&status),
                )));
            }
            // A hung node killed here was declared dead when it was killed.
            if !self.hung.contains(&kind) {
                self.declared_dead.push((kind, 0.0));
            }
            self.hung.retain(|k| *k != kind);
            // The robot stops now, not after the restart below: freeing the dead node's
            // resources and spawning its successor took 0.26 s in one realtime run.
            self.stop_for_the_dead()?;
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
                    if self.running && !self.group.is_local(kind) {
                        self.resuming.push(kind);
                    }
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

    /// Kills every node whose heartbeats stopped (a hang: SIGSTOP, a deadlock, a cycle
    /// that never ends); the next check reaps and restarts it. A ready node gets the
    /// clock mode's timeout, one still starting its start timeout. Judged on the beats
    /// drained here, not by an earlier drain: a restart in between (0.27 s once) left
    /// the beats sent meanwhile queued, and all four other nodes were judged hung.
    fn kill_silent(&mut self) -> Result<(), RunAborted> {
        self.drain_heartbeats()?;
        let now = Instant::now();
        let watched: Vec<NodeKind> = self
            .expected
            .iter()
            .copied()
            .filter(|k| NodeKind::LAUNCHED.contains(k) || k.is_external())
            .collect();
        for kind in watched {
            let policy = self.restart.policy(kind);
            let timeout_s = match (self.ready.contains(&kind), self.mode) {
                _ if self.rejoining.get(&kind).is_some_and(|until| now < *until) => {
                    self.restart.link.down_limit_s
                }
                (false, _) => policy.start_timeout_s,
                (true, TickMode::Lockstep) => policy.heartbeat_timeout_s,
                (true, TickMode::Realtime) => policy.realtime_heartbeat_timeout_s,
            };
            let Some(silent) = self.last_seen.get(&kind).map(|t| now.duration_since(*t)) else {
                continue;
            };
            if self.cut_off(kind) {
                // Its heartbeats cannot arrive: held, not hung.
                continue;
            }
            if silent.as_secs_f64() > timeout_s {
                tracing::warn!(
                    "node `{}` sent no heartbeat for {:.2} s (timeout {timeout_s} s): declared hung, killing it",
                    kind.name(),
                    silent.as_secs_f64()
                );
                self.group.kill(kind);
                self.declared_dead.push((kind, silent.as_secs_f64()));
                self.hung.push(kind);
                // Reaped (and restarted) by the next check; do not kill it twice.
                self.last_seen.insert(kind, now);
            }
        }
        Ok(())
    }

    /// Whether `kind` runs on a host that is cut off now.
    fn cut_off(&self, kind: NodeKind) -> bool {
        let host = self.group.remote().and_then(|r| r.host_of(kind));
        host.is_some_and(|h| self.links.is_down(h))
    }

    /// A spread run: notes hosts cut off and back. Realtime: the robot stops at once
    /// when a host is cut off (its nodes' outputs cannot arrive); it moves again on
    /// fresh trajectories once the host is back. The cut-off nodes' heartbeats count
    /// from their host's return.
    fn watch_links(&mut self) -> Result<(), BusError> {
        let Some(beats) = self.group.remote().map(|r| r.beats()) else {
            return Ok(());
        };
        if !self.running {
            return Ok(());
        }
        let stamp_s = self.stamp.stamp_ns as f64 * 1e-9;
        let now = clock::monotonic_ns();
        for event in self.links.update(&beats, now, &self.restart.link, stamp_s) {
            match event {
                LinkEvent::Lost { host, silent_s } => {
                    tracing::warn!(
                        "t = {stamp_s:.2} s: the link to host `{host}` is down (nothing from it for {silent_s:.2} s): robot stopped, its nodes held until it is back"
                    );
                    if self.mode == TickMode::Realtime {
                        self.send_sim_command(self.stamp, SimCommandKind::Stop, None)?;
                    }
                }
                LinkEvent::Back { host, down_s } => {
                    tracing::warn!(
                        "t = {stamp_s:.2} s: the link to host `{host}` is back after {down_s:.2} s"
                    );
                    let now = Instant::now();
                    let until = now + Duration::from_secs_f64(down_s.max(SETTLE_MIN_S));
                    for kind in self.expected.clone() {
                        let remote = self.group.remote().and_then(|r| r.host_of(kind));
                        if remote == Some(host.as_str()) {
                            self.last_seen.insert(kind, now);
                            self.rejoining.insert(kind, until);
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// Announces who is in the group: the supervisor and the expected nodes.
    pub fn publish_members(&mut self) -> Result<(), RunAborted> {
        let members: Vec<NodeKind> = self
            .expected
            .iter()
            .copied()
            .chain([NodeKind::Supervisor])
            .collect();
        let mut too_many = None;
        self.members.publish(aisle_bus::Stamp::default(), |m| {
            too_many = m.set(members.iter().copied()).err();
        })?;
        match too_many {
            None => Ok(()),
            Some(n) => Err(RunAborted::Error(anyhow!(
                "the group has {n} nodes; at most {} fit in `GroupMembers`",
                aisle_messages::MAX_GROUP_MEMBERS
            ))),
        }
    }

    /// Connects the supervisor's state publishers to nodes that (re)joined.
    fn connect_joiners(&mut self) -> Result<(), RunAborted> {
        self.info.update_connections()?;
        self.sim_command.update_connections()?;
        self.goal.update_connections()?;
        self.mapper_control.update_connections()?;
        self.members.update_connections()?;
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
            let (outcome, sample) = sub.wait_for(POLL, &mut pred, || self.watch())?;
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
    /// Watches the children (see [`NodeHealth::check`]).
    pub(super) fn supervise(&mut self) -> Result<(), RunAborted> {
        self.health.check()
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
        self.health.publish_members()?;
        // Every publisher of the group exists now: connect to them before the first tick,
        // not inside it (mapping the controller's trajectory pool took 15 ms there).
        self.ports.connect()?;
        self.health.running = true;
        tracing::info!(
            "all {} nodes ready after {:.2} s",
            self.health.ready.len(),
            started.elapsed().as_secs_f64()
        );
        Ok(())
    }
}

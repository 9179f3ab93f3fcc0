//! The end of a session: the robot stopped whatever happened, the group stopped, and
//! the run's report assembled from the mission, the latency book and ground truth.

use super::run_config::RunConfig;
use super::{GRACE, RunAborted, RunOptions, Session};
use crate::report::{BodyPose, ReferencePath, RunReport};
use crate::usage::ProcessUsage;
use aisle_messages::{SimCommandKind, TickMode, WorldTruth, read_name};
use std::time::Instant;

impl Session {
    /// Stops the robot and the group and assembles the report.
    pub(super) fn finish(
        &mut self,
        opts: &RunOptions,
        config: &RunConfig,
        wall_start: Instant,
        outcome: &Result<(), RunAborted>,
    ) -> RunReport {
        if let Err(aborted) = outcome {
            let why = match aborted {
                RunAborted::Interrupted => "interrupted".to_string(),
                RunAborted::Error(e) => format!("{e:#}"),
            };
            let _ = self.mission.abort(self.now_s, self.pose, why);
            // Whatever happened, the robot must not keep moving.
            let _ = self.sim_command(SimCommandKind::Stop, None);
        }
        let processes = self.usage();
        self.link_latency();
        self.health.group.stop(GRACE);
        let mut report = self.report(opts, config, wall_start);
        report.processes = processes;
        report
    }

    /// A spread run: the one-way latency of every topic that crossed, a series per
    /// direction and topic (`link a>b robot_state`), beside the stages'.
    fn link_latency(&mut self) {
        let Some(remote) = self.health.group.remote() else {
            return;
        };
        let links = &self.health.links;
        for (from, to, s) in remote.link_samples(|h| links.is_down(h)) {
            let topic = s.topic.strip_prefix("aisle/").unwrap_or(&s.topic);
            self.book
                .record(&format!("link {from}>{to} {topic}"), s.tick, s.ns);
        }
    }

    /// Every live node's resource usage, and the supervisor's, before they stop.
    fn usage(&self) -> Vec<ProcessUsage> {
        let nodes = self.health.group.children.iter();
        let live = nodes.filter(|c| c.exited.is_none());
        let mut rows: Vec<ProcessUsage> = live
            .filter_map(|c| crate::usage::read(c.kind.name(), c.child.id()))
            .collect();
        rows.extend(crate::usage::read("supervisor", std::process::id()));
        rows
    }

    fn report(&mut self, opts: &RunOptions, config: &RunConfig, wall_start: Instant) -> RunReport {
        // The window both views use: the ticks before the last one acted on.
        self.book.end_at(self.ticks);
        let latency = self.book.summarise(Some(&config.budgets));
        let truth = self.truth.as_ref();
        let m = &self.mission;
        RunReport {
            success: m.succeeded(),
            failure: m.failure().map(str::to_string),
            mode: match self.mode {
                TickMode::Lockstep => "lockstep".into(),
                TickMode::Realtime => "realtime".into(),
            },
            seed: opts.seed,
            lidar: !opts.lidar_off,
            sim_time_s: self.now_s,
            wall_time_s: wall_start.elapsed().as_secs_f64(),
            ticks: self.ticks,
            path_length_m: self.path_length,
            min_clearance_m: truth.map_or(f64::NAN, |t| t.min_clearance),
            collisions: truth.map_or(0, |t| t.collisions),
            collision_events: self.collisions.events.clone(),
            replans: m.replans_total(),
            restarts: self.health.restarts.total(),
            link_outages: self.health.links.report(),
            legs: m.results.clone(),
            latency: latency.stages,
            tick_release: latency.tick_release,
            processes: Vec::new(),
            driven_path: std::mem::take(&mut self.driven),
            reference_paths: m
                .reference_paths
                .iter()
                .map(|(leg, poses)| ReferencePath {
                    leg: *leg,
                    poses: poses
                        .iter()
                        .map(|p| [p.pose.x, p.pose.y, p.pose.theta, p.direction.as_i8() as f64])
                        .collect(),
                })
                .collect(),
            bodies_final: truth
                .map(|t| movable_bodies(t, &config.scene))
                .unwrap_or_default(),
        }
    }
}

impl Session {
    /// Every latency sample of the run as CSV (`--samples`).
    pub(super) fn write_samples(&self, path: &std::path::Path) -> std::io::Result<()> {
        let file = std::fs::File::create(path)?;
        self.book.write_csv(std::io::BufWriter::new(file))
    }
}

/// Where the movable bodies stand, ground truth.
fn movable_bodies(t: &WorldTruth, scene: &aisle_config::scene::Scene) -> Vec<BodyPose> {
    t.bodies[..(t.len as usize).min(t.bodies.len())]
        .iter()
        .filter(|b| b.is_static == 0)
        .map(|b| BodyPose {
            // The message holds a name's first bytes; the scene (the simulator's, by
            // index) has all of it.
            name: scene
                .bodies
                .get(b.index as usize)
                .filter(|s| s.name.starts_with(read_name(&b.name)))
                .map_or_else(|| read_name(&b.name).to_string(), |s| s.name.clone()),
            x: b.pose.x,
            y: b.pose.y,
            theta: b.pose.theta,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_body_named_longer_than_the_message_holds_is_reported_by_its_whole_name() {
        let long = "rack_row_17_slot_42_pallet_stack_north";
        let text = format!(
            "[[body]]\nname = \"{long}\"\nkind = \"box\"\nstatic = false\npose = [1.0, 2.0, 0.0]\nsize = [0.5, 0.5, 0.5]\n"
        );
        let scene = aisle_config::scene::Scene::parse(std::path::Path::new("w.toml"), &text)
            .expect("scene");
        let mut t = *aisle_messages::zeroed_box::<WorldTruth>();
        t.len = 1;
        aisle_messages::write_name(&mut t.bodies[0].name, long);
        t.bodies[0].index = 0;
        t.bodies[0].pose.x = 3.0;
        let got = movable_bodies(&t, &scene);
        assert_eq!(got[0].name, long);
        assert_eq!(got[0].x, 3.0);
        // A name that is not the scene's (another scene) stays the message's.
        let other = aisle_config::scene::Scene { bodies: Vec::new() };
        assert_eq!(movable_bodies(&t, &other)[0].name, &long[..32]);
    }
}

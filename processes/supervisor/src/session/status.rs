//! What the session tells the outside while it runs: the mission status message every
//! tick and, unless quiet, a progress line every 5 s of sim time.

use super::{RunAborted, RunOptions, Session};
use aisle_messages::{MissionState, write_name};

impl Session {
    pub(super) fn publish_status(&mut self) -> Result<(), RunAborted> {
        let m = &self.mission;
        let state = if m.succeeded() {
            MissionState::Succeeded
        } else if m.is_finished() {
            MissionState::Failed
        } else if m.is_planning() {
            MissionState::Planning
        } else if m.is_rotating() {
            MissionState::Rotating
        } else {
            MissionState::Driving
        };
        let (segment, segments, replans) = (
            m.leg_index() as u32,
            m.leg_count() as u32,
            m.replans_total(),
        );
        let text = m
            .failure()
            .map(str::to_string)
            .unwrap_or_else(|| m.leg_name().to_string());
        let distance = self.path_length;
        let stamp = self.stamp();
        self.ports.status.publish(stamp, |s| {
            s.state = state as u32;
            s.segment = segment;
            s.segments = segments;
            s.replans = replans;
            s.distance = distance;
            write_name(&mut s.text, &text);
        })?;
        Ok(())
    }

    pub(super) fn progress(&mut self, opts: &RunOptions) {
        if opts.quiet || self.now_s - self.last_progress_s < 5.0 {
            return;
        }
        self.last_progress_s = self.now_s;
        let m = &self.mission;
        println!(
            "[{:7.1} s] leg {}/{} {:<14} driven {:6.2} m  replans {}",
            self.now_s,
            m.leg_index() + 1,
            m.leg_count(),
            m.leg_name(),
            self.path_length,
            m.replans_total()
        );
    }
}

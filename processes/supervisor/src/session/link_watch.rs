//! The links to other hosts in a spread run, as the supervisor sees them. Each host
//! daemon beats every 20 ms (`aisle_link::BEAT`); a host whose beat is silent for
//! `restart.toml` `link.silent_s` is cut off (its link, or the host itself, is gone):
//! its nodes are not declared hung (their heartbeats cannot arrive), the session stops
//! the robot, and the host counts as back at its next beat. A link down for
//! `link.down_limit_s` ends the run.
//!
//! Each outage is measured on this host's monotonic clock: from the host's last beat
//! (at or before the cut: the figures are upper bounds) to the detection, to the first
//! ground-truth robot state at rest that stays at rest, and to the first beat after it;
//! then from that beat to the first robot state in motion (the mission resumed).
//!
//! Pure bookkeeping: it is handed beats, the time and robot states; it sends nothing.

use crate::report::LinkOutage;
use crate::restart::LinkPolicy;
use std::collections::BTreeMap;

/// One outage, in monotonic nanoseconds of this host.
#[derive(Debug, Clone, PartialEq)]
struct Outage {
    host: String,
    /// Sim time of the newest tick when it was detected.
    stamp_s: f64,
    last_beat_ns: u64,
    detected_ns: u64,
    /// Publication of the first robot state at rest that the robot stayed at rest from.
    rest_ns: Option<u64>,
    back_ns: Option<u64>,
    /// Publication of the first robot state in motion after it was back.
    moving_ns: Option<u64>,
}

/// What changed since the last look.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum LinkEvent {
    /// Nothing from `host` for `silent_s`.
    Lost { host: String, silent_s: f64 },
    /// `host` beats again after `down_s` (from its last beat before the outage).
    Back { host: String, down_s: f64 },
}

/// The outages of one run.
#[derive(Debug, Default)]
pub(super) struct LinkWatch {
    outages: Vec<Outage>,
}

fn secs(from_ns: u64, to_ns: u64) -> f64 {
    to_ns.saturating_sub(from_ns) as f64 * 1e-9
}

impl LinkWatch {
    /// Compares each host's last beat (`beats`: host -> arrival) with `now_ns`.
    pub fn update(
        &mut self,
        beats: &BTreeMap<String, u64>,
        now_ns: u64,
        policy: &LinkPolicy,
        stamp_s: f64,
    ) -> Vec<LinkEvent> {
        let mut events = Vec::new();
        for (host, &last) in beats {
            let silent_s = secs(last, now_ns);
            let open = self
                .outages
                .iter_mut()
                .find(|o| &o.host == host && o.back_ns.is_none());
            match open {
                None if silent_s > policy.silent_s => {
                    self.outages.push(Outage {
                        host: host.clone(),
                        stamp_s,
                        last_beat_ns: last,
                        detected_ns: now_ns,
                        rest_ns: None,
                        back_ns: None,
                        moving_ns: None,
                    });
                    events.push(LinkEvent::Lost {
                        host: host.clone(),
                        silent_s,
                    });
                }
                Some(o) if last > o.last_beat_ns => {
                    o.back_ns = Some(last);
                    events.push(LinkEvent::Back {
                        host: host.clone(),
                        down_s: secs(o.last_beat_ns, last),
                    });
                }
                _ => {}
            }
        }
        events
    }

    /// Whether `host` is cut off now.
    pub fn is_down(&self, host: &str) -> bool {
        self.outages
            .iter()
            .any(|o| o.host == host && o.back_ns.is_none())
    }

    /// A host down longer than `policy.down_limit_s`, with how long.
    pub fn overdue(&self, now_ns: u64, policy: &LinkPolicy) -> Option<(&str, f64)> {
        self.outages
            .iter()
            .filter(|o| o.back_ns.is_none())
            .map(|o| (o.host.as_str(), secs(o.last_beat_ns, now_ns)))
            .find(|(_, down)| *down > policy.down_limit_s)
    }

    /// A robot state (ground truth) published at `publish_ns` with `twist`.
    pub fn note_robot(&mut self, twist: [f64; 2], publish_ns: u64) {
        let at_rest = twist == [0.0, 0.0];
        for o in self.outages.iter_mut().filter(|o| o.moving_ns.is_none()) {
            if publish_ns < o.last_beat_ns {
                continue;
            }
            if let Some(back) = o.back_ns {
                if !at_rest && publish_ns >= back {
                    o.moving_ns = Some(publish_ns);
                }
                continue;
            }
            match (at_rest, o.rest_ns) {
                (true, None) => o.rest_ns = Some(publish_ns),
                // It moved again while cut off: rest counts from a later state.
                (false, Some(_)) => o.rest_ns = None,
                _ => {}
            }
        }
    }

    /// The outages for the report.
    pub fn report(&self) -> Vec<LinkOutage> {
        self.outages
            .iter()
            .map(|o| LinkOutage {
                host: o.host.clone(),
                at_s: o.stamp_s,
                detected_after_s: secs(o.last_beat_ns, o.detected_ns),
                at_rest_after_s: o.rest_ns.map(|r| secs(o.last_beat_ns, r)),
                down_s: o.back_ns.map(|b| secs(o.last_beat_ns, b)),
                moving_after_s: o.back_ns.zip(o.moving_ns).map(|(b, m)| secs(b, m)),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;

    #[test]
    fn a_silent_host_is_cut_off_until_it_beats_again() {
        let policy = LinkPolicy {
            silent_s: 0.1,
            down_limit_s: 1.0,
        };
        let mut w = LinkWatch::default();
        let mut beats = BTreeMap::from([("b".to_string(), 1000 * MS)]);
        assert!(w.update(&beats, 1090 * MS, &policy, 5.0).is_empty());
        let lost = w.update(&beats, 1120 * MS, &policy, 5.1);
        assert_eq!(lost.len(), 1);
        assert!(matches!(&lost[0], LinkEvent::Lost { host, .. } if host == "b"));
        assert!(w.is_down("b") && !w.is_down("c"));
        assert!(
            w.update(&beats, 1130 * MS, &policy, 5.1).is_empty(),
            "said once"
        );
        // Ground truth: moving, then at rest, then (a stale timeline) moving, at rest.
        w.note_robot([0.5, 0.0], 1050 * MS);
        w.note_robot([0.0, 0.0], 1100 * MS);
        w.note_robot([0.2, 0.0], 1200 * MS);
        w.note_robot([0.0, 0.0], 1300 * MS);
        assert_eq!(w.overdue(1900 * MS, &policy), None);
        assert_eq!(w.overdue(2100 * MS, &policy).map(|o| o.0), Some("b"));
        beats.insert("b".into(), 3000 * MS);
        let back = w.update(&beats, 3001 * MS, &policy, 7.0);
        assert_eq!(
            back,
            [LinkEvent::Back {
                host: "b".into(),
                down_s: 2.0
            }]
        );
        assert!(!w.is_down("b"));
        w.note_robot([0.0, 0.0], 3100 * MS);
        w.note_robot([0.3, 0.0], 3400 * MS);
        w.note_robot([0.0, 0.0], 3500 * MS);
        let r = &w.report()[0];
        assert_eq!((r.host.as_str(), r.at_s), ("b", 5.1));
        assert!((r.detected_after_s - 0.12).abs() < 1e-9);
        assert!((r.at_rest_after_s.unwrap() - 0.3).abs() < 1e-9);
        assert_eq!(r.down_s, Some(2.0));
        assert!((r.moving_after_s.unwrap() - 0.4).abs() < 1e-9);
    }
}

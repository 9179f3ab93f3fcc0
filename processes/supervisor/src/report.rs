//! The metrics of one run, as printed at the end and written by `--report` (JSON).
//! Plain data: the session fills it, tests and tools read it back.

use crate::collisions::CollisionEvent;
use crate::mission::LegResult;
use crate::usage::ProcessUsage;
use aisle_tools::latency::{Summary, TickRelease};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BodyPose {
    pub name: String,
    pub x: f64,
    pub y: f64,
    pub theta: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ReferencePath {
    /// Index of the leg (0-based) the path was planned for.
    pub leg: usize,
    /// x, y, heading, direction (1 forward, -1 reverse, 0 rotate).
    pub poses: Vec<[f64; 4]>,
}

/// A link to another host that went down in a spread run (`session::link_watch`): the
/// times count from the host's last beat before it, which is at or before the cut.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct LinkOutage {
    pub host: String,
    /// Sim time when it was detected.
    pub at_s: f64,
    pub detected_after_s: f64,
    /// Until the first ground-truth robot state at rest that stayed at rest while the
    /// link was down (`None`: not at rest before it came back).
    pub at_rest_after_s: Option<f64>,
    /// Until the host's first beat after it (`None`: it did not come back).
    pub down_s: Option<f64>,
    /// From that beat to the first ground-truth robot state in motion.
    #[serde(default)]
    pub moving_after_s: Option<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunReport {
    pub success: bool,
    pub failure: Option<String>,
    pub mode: String,
    pub seed: u64,
    pub lidar: bool,
    pub sim_time_s: f64,
    pub wall_time_s: f64,
    pub ticks: u64,
    pub path_length_m: f64,
    /// Smallest distance between the robot (plus carried rack) and any body, ground truth.
    pub min_clearance_m: f64,
    pub collisions: u32,
    /// Each collision: the body touched and when (the first one fails the mission
    /// unless the run allowed collisions).
    #[serde(default)]
    pub collision_events: Vec<CollisionEvent>,
    pub replans: u32,
    /// Node restarts after a crash or a missed heartbeat deadline.
    pub restarts: u32,
    /// Links to other hosts that went down (a spread run).
    #[serde(default)]
    pub link_outages: Vec<LinkOutage>,
    pub legs: Vec<LegResult>,
    /// One row per stage and end to end (`aisle_tools::latency`: nearest-rank
    /// quantiles, budgets from `budgets.toml`).
    pub latency: Vec<Summary>,
    /// When ticks started against the ideal schedule (realtime); not scored.
    #[serde(default)]
    pub tick_release: Option<TickRelease>,
    /// Per process: peak RSS, context switches, page faults, CPU time.
    #[serde(default)]
    pub processes: Vec<ProcessUsage>,
    /// t, x, y, heading of the robot at every tick (ground truth).
    pub driven_path: Vec<[f64; 4]>,
    pub reference_paths: Vec<ReferencePath>,
    /// Movable bodies at the end of the run (ground truth).
    pub bodies_final: Vec<BodyPose>,
}

impl RunReport {
    /// The human summary printed at the end of a run.
    pub fn summary(&self) -> String {
        let mut out = String::new();
        let verdict = if self.success {
            "mission succeeded".to_string()
        } else {
            format!(
                "mission FAILED: {}",
                self.failure.as_deref().unwrap_or("unknown")
            )
        };
        out.push_str(&format!("{verdict}\n"));
        out.push_str(&format!(
            "  sim time {:.1} s, wall time {:.1} s ({:.2} x sim), {} ticks, {} mode\n",
            self.sim_time_s,
            self.wall_time_s,
            if self.sim_time_s > 0.0 {
                self.wall_time_s / self.sim_time_s
            } else {
                0.0
            },
            self.ticks,
            self.mode
        ));
        // No ground truth (the run ended before its first tick): no clearance to show.
        let clearance = if self.min_clearance_m.is_finite() {
            format!("{:.3} m", self.min_clearance_m)
        } else {
            "not measured".to_string()
        };
        out.push_str(&format!(
            "  driven {:.2} m, min clearance {clearance}, collisions {}, replans {}, restarts {}\n",
            self.path_length_m, self.collisions, self.replans, self.restarts
        ));
        for e in &self.collision_events {
            out.push_str(&format!("  {e}\n"));
        }
        for o in &self.link_outages {
            let opt =
                |v: Option<f64>, none: &str| v.map_or(none.to_string(), |v| format!("{v:.3} s"));
            out.push_str(&format!(
                "  link to host `{}` lost at t = {:.1} s: detected {:.3} s, robot at rest {}, back {} after its last beat; moving again {} after that\n",
                o.host,
                o.at_s,
                o.detected_after_s,
                opt(o.at_rest_after_s, "never"),
                opt(o.down_s, "never"),
                opt(o.moving_after_s, "never"),
            ));
        }
        for (i, l) in self.legs.iter().enumerate() {
            // Said only when a plan failed: most legs plan once or replan cleanly.
            let mut failed = String::new();
            if l.plan_failures + l.margin_backoffs > 0 {
                failed = format!(
                    ", plan failures {}, margin backoffs {}",
                    l.plan_failures, l.margin_backoffs
                );
            }
            out.push_str(&format!(
                "  leg {} {:<14} {:<8} {:6.1} s -> {:6.1} s  error {:.3} m {:.3} rad  replans {}{failed}\n",
                i + 1,
                l.name,
                if l.reached { "reached" } else { "failed" },
                l.start_s,
                l.end_s,
                l.final_error_m,
                l.final_heading_error_rad,
                l.replans
            ));
        }
        out
    }
}

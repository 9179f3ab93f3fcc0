//! Latency budgets (`config/budgets.toml`) and the per-stage measurements against them.
//!
//! Stages report their compute time per tick in `TickDone`; the end-to-end latency is
//! measured from the wall time at which a tick started (stamped by the simulator) to the
//! publication of the controller's trajectory for that tick. This module only keeps and
//! summarises numbers; it does not read clocks.

use aisle_config::{InvalidKey, Validate};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageBudgets {
    pub simulator: f64,
    pub lidar: f64,
    pub mapper: f64,
    pub teb_controller: f64,
    pub global_planner: f64,
    pub supervisor: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EndToEndBudget {
    pub tick_to_command: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Budgets {
    pub stage: StageBudgets,
    pub end_to_end: EndToEndBudget,
}

impl Validate for Budgets {
    fn validate(&self) -> Result<(), InvalidKey> {
        let s = &self.stage;
        for (key, v) in [
            ("stage.simulator", s.simulator),
            ("stage.lidar", s.lidar),
            ("stage.mapper", s.mapper),
            ("stage.teb_controller", s.teb_controller),
            ("stage.global_planner", s.global_planner),
            ("stage.supervisor", s.supervisor),
            (
                "end_to_end.tick_to_command",
                self.end_to_end.tick_to_command,
            ),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(InvalidKey::new(
                    key,
                    format!("a budget must be a positive number of milliseconds, got {v}"),
                ));
            }
        }
        Ok(())
    }
}

impl Budgets {
    /// Budget in milliseconds of a named stage.
    pub fn of(&self, stage: &str) -> Option<f64> {
        let s = &self.stage;
        Some(match stage {
            "simulator" => s.simulator,
            "lidar" => s.lidar,
            "mapper" => s.mapper,
            "teb_controller" => s.teb_controller,
            "global_planner" => s.global_planner,
            "supervisor" => s.supervisor,
            "end_to_end" => self.end_to_end.tick_to_command,
            _ => return None,
        })
    }
}

/// One row of the latency table (and of the report's `latency`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StageSummary {
    pub stage: String,
    pub samples: usize,
    pub p50_ms: f64,
    pub p99_ms: f64,
    pub max_ms: f64,
    /// Standard deviation of the latency.
    pub jitter_ms: f64,
    pub budget_ms: f64,
    pub misses: usize,
}

/// Latency samples per stage, in nanoseconds.
#[derive(Debug, Default)]
pub struct LatencyBook {
    samples: BTreeMap<String, Vec<u64>>,
}

impl LatencyBook {
    pub fn record(&mut self, stage: &str, ns: u64) {
        self.samples.entry(stage.to_string()).or_default().push(ns);
    }

    pub fn summarise(&self, budgets: &Budgets) -> Vec<StageSummary> {
        let order = [
            "simulator",
            "lidar",
            "mapper",
            "teb_controller",
            "global_planner",
            "supervisor",
            "end_to_end",
        ];
        let mut rows = Vec::new();
        for stage in order {
            let Some(v) = self.samples.get(stage) else {
                continue;
            };
            if v.is_empty() {
                continue;
            }
            let mut s = v.clone();
            s.sort_unstable();
            // The same quantile as `aisle profile` computes from a record.
            let pick = |q: f64| aisle_tools::profile::nearest_rank(&s, q) as f64 / 1e6;
            let mean = s.iter().map(|&x| x as f64).sum::<f64>() / s.len() as f64;
            let var = s.iter().map(|&x| (x as f64 - mean).powi(2)).sum::<f64>() / s.len() as f64;
            let budget_ms = budgets.of(stage).unwrap_or(f64::INFINITY);
            rows.push(StageSummary {
                stage: stage.to_string(),
                samples: s.len(),
                p50_ms: pick(0.5),
                p99_ms: pick(0.99),
                max_ms: *s.last().unwrap_or(&0) as f64 / 1e6,
                jitter_ms: var.sqrt() / 1e6,
                budget_ms,
                misses: s.iter().filter(|&&x| x as f64 / 1e6 > budget_ms).count(),
            });
        }
        rows
    }
}

/// The table as text, one stage a line.
pub fn format_table(rows: &[StageSummary]) -> String {
    let mut out = format!(
        "{:<16} {:>7} {:>9} {:>9} {:>9} {:>9} {:>9} {:>7}\n",
        "stage", "samples", "p50 ms", "p99 ms", "max ms", "jitter", "budget", "misses"
    );
    for r in rows {
        out.push_str(&format!(
            "{:<16} {:>7} {:>9.3} {:>9.3} {:>9.3} {:>9.3} {:>9.1} {:>7}\n",
            r.stage, r.samples, r.p50_ms, r.p99_ms, r.max_ms, r.jitter_ms, r.budget_ms, r.misses
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn budgets() -> Budgets {
        Budgets {
            stage: StageBudgets {
                simulator: 1.0,
                lidar: 2.0,
                mapper: 1.0,
                teb_controller: 5.0,
                global_planner: 50.0,
                supervisor: 1.0,
            },
            end_to_end: EndToEndBudget {
                tick_to_command: 10.0,
            },
        }
    }

    #[test]
    fn percentiles_and_misses() {
        let mut book = LatencyBook::default();
        for i in 1..=100u64 {
            book.record("lidar", i * 100_000); // 0.1 .. 10 ms
        }
        let rows = book.summarise(&budgets());
        assert_eq!(rows.len(), 1);
        let r = &rows[0];
        assert_eq!(r.samples, 100);
        // Nearest rank, as `aisle profile` computes it: the 50th and 99th of 100.
        assert_eq!((r.p50_ms, r.p99_ms), (5.0, 9.9));
        let samples: Vec<u64> = (1..=100u64).map(|i| i * 100_000).collect();
        let s = aisle_tools::profile::Stats::of(&samples, 2_000_000).unwrap();
        assert_eq!(
            (s.p50 as f64 / 1e6, s.p99 as f64 / 1e6),
            (r.p50_ms, r.p99_ms)
        );
        assert_eq!(s.deadline_misses, r.misses);
        assert!((r.max_ms - 10.0).abs() < 1e-9);
        assert_eq!(r.misses, 80, "samples above 2 ms");
        assert!(format_table(&rows).contains("lidar"));
    }

    #[test]
    fn the_shipped_budgets_load() {
        let p = aisle_config::testing::shipped("budgets.toml");
        let b = aisle_config::load::<Budgets>(&p).unwrap();
        assert!(b.of("end_to_end").unwrap() > 0.0);
    }
}

//! What a sweep found, per scenario and per family: feasibility from the oracle,
//! success with 0 collisions, clean failures of the infeasible ones, the success rate
//! with its 95% Wilson interval, mean time to goal and path length against the
//! oracle's. Plain data and arithmetic; knows nothing of running.

use super::runner::{Outcome, RunSummary};
use serde::Serialize;
use std::path::PathBuf;

/// One scenario of a sweep.
#[derive(Debug, Clone, Serialize)]
pub struct ScenarioResult {
    pub id: String,
    pub family: String,
    pub seed: u64,
    pub config_dir: PathBuf,
    pub varied: Vec<String>,
    /// The oracle succeeded, or the run did.
    pub feasible: bool,
    pub outcome: Outcome,
    /// A failure with no collision and a reason named.
    pub clean_failure: bool,
    pub reason: Option<String>,
    pub collisions: u32,
    /// Sim time to the last goal (a success).
    pub time_to_goal_s: Option<f64>,
    pub path_length_m: Option<f64>,
    pub oracle_path_length_m: Option<f64>,
    pub replans: Option<u32>,
    pub run: Option<RunSummary>,
    pub oracle: Option<RunSummary>,
    /// The failure re-run with `--record`, and its picture.
    pub record: Option<PathBuf>,
    pub picture: Option<PathBuf>,
}

impl ScenarioResult {
    /// What the sweep asks of it: a feasible one succeeds with 0 collisions, an
    /// infeasible one fails cleanly.
    pub fn as_expected(&self) -> bool {
        if self.feasible {
            self.outcome == Outcome::Success
        } else {
            self.clean_failure
        }
    }
}

/// The 95% Wilson score interval of `k` successes in `n` trials (None for n = 0).
pub fn wilson(k: u32, n: u32) -> Option<(f64, f64)> {
    if n == 0 {
        return None;
    }
    let z = 1.959_963_984_540_054_f64;
    let (n, p) = (n as f64, k as f64 / n as f64);
    let denom = 1.0 + z * z / n;
    let centre = (p + z * z / (2.0 * n)) / denom;
    let half = z * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt() / denom;
    Some(((centre - half).max(0.0), (centre + half).min(1.0)))
}

/// One family's figures (or all families', as `family = "all"`).
#[derive(Debug, Clone, Serialize)]
pub struct FamilyStats {
    pub family: String,
    pub scenarios: u32,
    pub feasible: u32,
    /// Feasible ones that succeeded with 0 collisions.
    pub succeeded: u32,
    pub success_rate: Option<f64>,
    pub ci95: Option<(f64, f64)>,
    /// Scenarios whose run touched a body.
    pub collisions: u32,
    pub infeasible: u32,
    pub infeasible_clean: u32,
    pub errors: u32,
    pub mean_time_to_goal_s: Option<f64>,
    /// Mean of driven / oracle's driven path length, over successes the oracle shares.
    pub mean_path_ratio: Option<f64>,
}

fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

pub fn family_stats(family: &str, results: &[&ScenarioResult]) -> FamilyStats {
    let count =
        |f: &dyn Fn(&ScenarioResult) -> bool| results.iter().filter(|r| f(r)).count() as u32;
    let feasible = count(&|r| r.feasible);
    let succeeded = count(&|r| r.feasible && r.outcome == Outcome::Success);
    let times: Vec<f64> = results.iter().filter_map(|r| r.time_to_goal_s).collect();
    let ratios: Vec<f64> = results
        .iter()
        .filter(|r| r.outcome == Outcome::Success)
        .filter_map(|r| match (r.path_length_m, r.oracle_path_length_m) {
            (Some(a), Some(b)) if b > 0.0 => Some(a / b),
            _ => None,
        })
        .collect();
    FamilyStats {
        family: family.to_string(),
        scenarios: results.len() as u32,
        feasible,
        succeeded,
        success_rate: (feasible > 0).then(|| succeeded as f64 / feasible as f64),
        ci95: wilson(succeeded, feasible),
        collisions: count(&|r| r.collisions > 0),
        infeasible: count(&|r| !r.feasible),
        infeasible_clean: count(&|r| !r.feasible && r.clean_failure),
        errors: count(&|r| r.outcome == Outcome::Error),
        mean_time_to_goal_s: mean(&times),
        mean_path_ratio: mean(&ratios),
    }
}

/// A failure reason with its numbers blanked, so that alike reasons count together
/// (digits inside a name, such as `rack2b`, are kept).
pub fn reason_kind(reason: &str) -> String {
    let mut out = String::with_capacity(reason.len());
    let mut in_number = false;
    let mut prev = ' ';
    for c in reason.chars() {
        let starts = c.is_ascii_digit() && !(prev.is_alphanumeric() || prev == '_');
        let digit = if in_number {
            c.is_ascii_digit() || c == '.'
        } else {
            starts
        };
        if digit && !in_number {
            out.push('#');
        } else if !digit {
            out.push(c);
        }
        in_number = digit;
        prev = c;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_matches_known_values() {
        // 129 of 168: p = 0.768, interval about 0.698..0.825.
        let (lo, hi) = wilson(129, 168).unwrap();
        assert!(
            (lo - 0.6982).abs() < 1e-3 && (hi - 0.8256).abs() < 1e-3,
            "{lo} {hi}"
        );
        // All successes: the upper end is 1 and the lower end 1 - z^2 / (n + z^2).
        let (lo, hi) = wilson(10, 10).unwrap();
        assert!((hi - 1.0).abs() < 1e-12);
        assert!((lo - 0.7225).abs() < 1e-3, "{lo}");
        let (lo, hi) = wilson(0, 5).unwrap();
        assert!(lo == 0.0 && (hi - 0.4345).abs() < 1e-3, "{hi}");
        assert!(wilson(0, 0).is_none());
    }

    #[test]
    fn reasons_group_without_their_numbers() {
        assert_eq!(
            reason_kind("leg 2 (park): timed out after 120.0 s at (1.25, -3.5)"),
            "leg # (park): timed out after # s at (#, -#)"
        );
        assert_eq!(
            reason_kind("collision with `rack2b` at t = 4.7 s"),
            "collision with `rack2b` at t = # s"
        );
    }
}

//! The sweep's markdown: the table per family, the failures with their reason and
//! picture, and the failure reasons counted. Knows the figures, not how they were made.

use super::stats::{FamilyStats, ScenarioResult, reason_kind};
use std::collections::BTreeMap;
use std::fmt::Write;

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "-".to_string(), |v| format!("{v:.digits$}"))
}

fn row(s: &FamilyStats) -> String {
    let rate = match (s.success_rate, s.ci95) {
        (Some(r), Some((lo, hi))) => {
            format!("{:.1}% ({:.1}-{:.1})", 100.0 * r, 100.0 * lo, 100.0 * hi)
        }
        _ => "-".to_string(),
    };
    format!(
        "| {} | {} | {} | {} | {} | {} | {} of {} | {} | {} | {} |",
        s.family,
        s.scenarios,
        s.feasible,
        s.succeeded,
        rate,
        s.collisions,
        s.infeasible_clean,
        s.infeasible,
        s.errors,
        opt(s.mean_time_to_goal_s, 1),
        opt(s.mean_path_ratio, 2)
    )
}

/// The whole markdown text.
pub fn markdown(families: &[FamilyStats], all: &FamilyStats, results: &[ScenarioResult]) -> String {
    let mut out = String::new();
    out.push_str(
        "| family | scenarios | feasible | succeeded (0 collisions) | success rate (95% CI) | with collisions | infeasible failed cleanly | errors | mean time to goal s | path / oracle |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    for f in families {
        let _ = writeln!(out, "{}", row(f));
    }
    let _ = writeln!(out, "{}", row(all).replacen("| all |", "| **all** |", 1));
    let bad: Vec<&ScenarioResult> = results.iter().filter(|r| !r.as_expected()).collect();
    if !bad.is_empty() {
        let _ = writeln!(out, "\nNot as expected ({}):\n", bad.len());
        for r in &bad {
            let _ = writeln!(
                out,
                "- {} {} seed {}{}: {:?}{}, {}{}",
                r.id,
                r.family,
                r.seed,
                if r.feasible { "" } else { " (infeasible)" },
                r.outcome,
                if r.collisions > 0 {
                    format!(" with {} collision(s)", r.collisions)
                } else {
                    String::new()
                },
                r.reason.as_deref().unwrap_or("no reason given"),
                r.picture
                    .as_ref()
                    .map(|p| format!(" ({})", p.display()))
                    .unwrap_or_default()
            );
        }
    }
    let mut kinds: BTreeMap<String, u32> = BTreeMap::new();
    for r in results
        .iter()
        .filter(|r| r.outcome != super::runner::Outcome::Success)
    {
        *kinds
            .entry(reason_kind(
                r.reason.as_deref().unwrap_or("no reason given"),
            ))
            .or_default() += 1;
    }
    if !kinds.is_empty() {
        let mut kinds: Vec<(String, u32)> = kinds.into_iter().collect();
        kinds.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        out.push_str("\nFailure reasons (numbers as #):\n\n");
        for (k, n) in kinds {
            let _ = writeln!(out, "- {n} x {k}");
        }
    }
    out
}

//! The latency table as text: one series a line, then the tick-release row.

use super::book::LatencyTable;
use super::release::TickRelease;
use super::stats::Summary;
use std::fmt::Write as _;

/// The table, in milliseconds, with the definitions it uses in its last line.
pub fn format_table(t: &LatencyTable) -> String {
    let width = t
        .stages
        .iter()
        .map(|s| s.stage.len())
        .chain([21])
        .max()
        .unwrap_or(5);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<width$} {:>7} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>6} {:>8} {:>8}",
        "stage [ms]",
        "samples",
        "p50",
        "p90",
        "p99",
        "p99.9",
        "max",
        "jitter",
        "budget",
        "misses",
        "cpu p50",
        "cpu p99"
    );
    let opt = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.3}"));
    for s in &t.stages {
        let _ = writeln!(
            out,
            "{} {:>8} {:>6} {:>8} {:>8}",
            row(s, width),
            s.budget_ms.map_or("-".into(), |b| format!("{b:.1}")),
            s.budget_ms.map_or("-".into(), |_| s.misses.to_string()),
            opt(s.cpu_p50_ms),
            opt(s.cpu_p99_ms)
        );
    }
    if let Some(r) = &t.tick_release {
        release(&mut out, r, width);
    }
    let _ = writeln!(
        out,
        "quantiles: nearest rank; jitter: standard deviation; miss: a sample over its budget; \
         cpu: CPU time of the computing thread"
    );
    out
}

/// Name, samples, quantiles, max and jitter of one series.
fn row(s: &Summary, width: usize) -> String {
    format!(
        "{:<width$} {:>7} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>8.3}",
        s.stage, s.samples, s.p50_ms, s.p90_ms, s.p99_ms, s.p999_ms, s.max_ms, s.jitter_ms
    )
}

fn release(out: &mut String, r: &TickRelease, width: usize) {
    match &r.lateness {
        Some(l) => {
            let _ = writeln!(
                out,
                "{} {:>8} {:>6} {:>8} {:>8}",
                row(l, width),
                "-",
                "-",
                "-",
                "-"
            );
            let _ = writeln!(
                out,
                "tick release ({}): {} ticks every {} ms, lateness against start + k*dt \
                 (not scored), {} overruns (a period or more late), {} skipped",
                r.mode, r.ticks, r.period_ms, r.overruns, r.skipped
            );
        }
        None => {
            let _ = writeln!(
                out,
                "tick release ({}): {} ticks every {} ms of sim time, each once the group \
                 finished the previous one (lateness not applicable), {} skipped",
                r.mode, r.ticks, r.period_ms, r.skipped
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_show_budgets_or_not_scored() {
        let t = LatencyTable {
            stages: vec![
                Summary::of("lidar", &[1_000_000, 3_000_000], Some(2.0)).unwrap(),
                Summary::of("latency aisle/map/local", &[1_000_000], None).unwrap(),
            ],
            tick_release: Some(TickRelease::of(&[(0, 0), (1, 100), (3, 300)], 100, true)),
        };
        let text = format_table(&t);
        let lines: Vec<&str> = text.lines().collect();
        assert!(
            lines[1].starts_with("lidar") && lines[1].contains("2.0      1"),
            "{text}"
        );
        assert!(lines[2].ends_with("-      -        -        -"), "{text}");
        assert!(lines[3].starts_with("tick release lateness"), "{text}");
        assert!(lines[4].contains("1 skipped"), "{text}");
        let lockstep = LatencyTable {
            tick_release: Some(TickRelease::of(&[(0, 0)], 100, false)),
            ..t
        };
        assert!(format_table(&lockstep).contains("not applicable"));
    }
}

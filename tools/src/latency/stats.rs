//! The figures of one series of samples: nearest-rank quantiles, jitter and misses
//! (definitions in the module above). Pure arithmetic.

use serde::{Deserialize, Serialize};

/// The ⌈q·n⌉-th smallest of `sorted` (nearest rank). `sorted` must be sorted and not
/// empty.
pub fn nearest_rank(sorted: &[u64], q: f64) -> u64 {
    let n = sorted.len();
    sorted[((q * n as f64).ceil() as usize).clamp(1, n) - 1]
}

/// One row of the latency table (and of a report's `latency`), in milliseconds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub stage: String,
    pub samples: usize,
    pub p50_ms: f64,
    pub p90_ms: f64,
    pub p99_ms: f64,
    pub p999_ms: f64,
    pub max_ms: f64,
    pub mean_ms: f64,
    /// Population standard deviation.
    pub jitter_ms: f64,
    /// `None`: the series is not scored against a budget.
    pub budget_ms: Option<f64>,
    /// Samples strictly over the budget.
    pub misses: usize,
    /// CPU time of the computing thread (median, p99), where the stage reports it.
    #[serde(default)]
    pub cpu_p50_ms: Option<f64>,
    #[serde(default)]
    pub cpu_p99_ms: Option<f64>,
}

impl Summary {
    /// The figures of `values` (nanoseconds); `None` for an empty series.
    pub fn of(stage: &str, values: &[u64], budget_ms: Option<f64>) -> Option<Summary> {
        if values.is_empty() {
            return None;
        }
        let mut v = values.to_vec();
        v.sort_unstable();
        let n = v.len() as f64;
        let ms = |ns: u64| ns as f64 / 1e6;
        let q = |q: f64| ms(nearest_rank(&v, q));
        let mean = v.iter().map(|&x| x as f64).sum::<f64>() / n;
        let var = v.iter().map(|&x| (x as f64 - mean).powi(2)).sum::<f64>() / n;
        Some(Summary {
            stage: stage.to_string(),
            samples: v.len(),
            p50_ms: q(0.5),
            p90_ms: q(0.9),
            p99_ms: q(0.99),
            p999_ms: q(0.999),
            max_ms: ms(v[v.len() - 1]),
            mean_ms: mean / 1e6,
            jitter_ms: var.sqrt() / 1e6,
            budget_ms,
            misses: budget_ms.map_or(0, |b| v.iter().filter(|&&x| ms(x) > b).count()),
            cpu_p50_ms: None,
            cpu_p99_ms: None,
        })
    }

    /// With the CPU-time figures of `cpu` (nanoseconds; nothing when empty).
    pub fn with_cpu(mut self, cpu: &[u64]) -> Summary {
        if !cpu.is_empty() {
            let mut v = cpu.to_vec();
            v.sort_unstable();
            self.cpu_p50_ms = Some(nearest_rank(&v, 0.5) as f64 / 1e6);
            self.cpu_p99_ms = Some(nearest_rank(&v, 0.99) as f64 / 1e6);
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_picks_measured_samples() {
        let v: Vec<u64> = (1..=100).collect();
        assert_eq!(nearest_rank(&v, 0.5), 50);
        assert_eq!(nearest_rank(&v, 0.9), 90);
        assert_eq!(nearest_rank(&v, 0.99), 99);
        assert_eq!(nearest_rank(&v, 0.999), 100);
        assert_eq!(nearest_rank(&v, 0.0), 1);
        assert_eq!(nearest_rank(&[7], 0.99), 7);
        // 1000 samples: p99.9 is the 999th.
        let w: Vec<u64> = (1..=1000).collect();
        assert_eq!(nearest_rank(&w, 0.999), 999);
    }

    #[test]
    fn summary_of_a_series() {
        // 0.1 .. 10 ms
        let v: Vec<u64> = (1..=100u64).rev().map(|i| i * 100_000).collect();
        let s = Summary::of("lidar", &v, Some(2.0)).unwrap();
        assert_eq!(s.samples, 100);
        assert_eq!(
            (s.p50_ms, s.p90_ms, s.p99_ms, s.p999_ms),
            (5.0, 9.0, 9.9, 10.0)
        );
        assert_eq!(s.max_ms, 10.0);
        assert!((s.mean_ms - 5.05).abs() < 1e-12);
        assert!((s.jitter_ms - 2.8866).abs() < 1e-4, "{}", s.jitter_ms);
        assert_eq!(s.misses, 80, "samples strictly above 2 ms");
        let exactly = Summary::of("x", &[2_000_000], Some(2.0)).unwrap();
        assert_eq!(exactly.misses, 0, "a sample at the budget is not a miss");
        assert_eq!(Summary::of("x", &v, None).unwrap().misses, 0);
        assert!(Summary::of("x", &[], Some(1.0)).is_none());
    }
}

//! Rate and period statistics of a topic from the arrival times of its samples (as
//! `ros2 topic hz` prints them). Pure arithmetic: the caller measures the arrivals.

/// Statistics of the periods between consecutive arrivals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RateStats {
    /// Arrivals counted.
    pub samples: usize,
    /// Samples per second: one over the mean period.
    pub rate_hz: f64,
    pub min_period_s: f64,
    pub max_period_s: f64,
    pub mean_period_s: f64,
    /// Population standard deviation of the periods.
    pub std_period_s: f64,
}

/// The statistics of `arrivals_ns` (increasing); `None` with fewer than two arrivals.
pub fn rate_stats(arrivals_ns: &[u64]) -> Option<RateStats> {
    if arrivals_ns.len() < 2 {
        return None;
    }
    let periods: Vec<f64> = arrivals_ns
        .windows(2)
        .map(|w| w[1].saturating_sub(w[0]) as f64 * 1e-9)
        .collect();
    let n = periods.len() as f64;
    let mean = periods.iter().sum::<f64>() / n;
    let var = periods.iter().map(|p| (p - mean).powi(2)).sum::<f64>() / n;
    Some(RateStats {
        samples: arrivals_ns.len(),
        rate_hz: if mean > 0.0 {
            1.0 / mean
        } else {
            f64::INFINITY
        },
        min_period_s: periods.iter().copied().fold(f64::INFINITY, f64::min),
        max_period_s: periods.iter().copied().fold(0.0, f64::max),
        mean_period_s: mean,
        std_period_s: var.sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steady_and_jittery_arrivals() {
        let steady: Vec<u64> = (0..11).map(|i| i * 100_000_000).collect();
        let s = rate_stats(&steady).unwrap();
        assert_eq!(s.samples, 11);
        assert!((s.rate_hz - 10.0).abs() < 1e-9, "{s:?}");
        assert!(s.std_period_s < 1e-12);
        let jitter = [0, 100_000_000, 300_000_000];
        let s = rate_stats(&jitter).unwrap();
        assert!((s.mean_period_s - 0.15).abs() < 1e-12);
        assert!((s.min_period_s - 0.1).abs() < 1e-12 && (s.max_period_s - 0.2).abs() < 1e-12);
        assert!((s.std_period_s - 0.05).abs() < 1e-12, "{s:?}");
        assert!((s.rate_hz - 1.0 / 0.15).abs() < 1e-9);
        assert_eq!(rate_stats(&[5]), None);
        assert_eq!(rate_stats(&[]), None);
    }
}

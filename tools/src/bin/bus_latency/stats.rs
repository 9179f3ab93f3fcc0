//! Nearest-rank percentiles of latency samples.

/// Nearest-rank percentiles of a set of samples (all zero when empty).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Percentiles {
    pub(crate) p50: u64,
    pub(crate) p99: u64,
    pub(crate) max: u64,
}

impl Percentiles {
    pub(crate) fn of(samples: &mut [u64]) -> Percentiles {
        samples.sort_unstable();
        let rank = |p: f64| -> u64 {
            if samples.is_empty() {
                return 0;
            }
            let k = (p * samples.len() as f64).ceil() as usize;
            samples[k.clamp(1, samples.len()) - 1]
        };
        Percentiles {
            p50: rank(0.50),
            p99: rank(0.99),
            max: samples.last().copied().unwrap_or(0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_use_nearest_rank() {
        let mut v: Vec<u64> = (1..=100).rev().collect();
        assert_eq!(
            Percentiles::of(&mut v),
            Percentiles {
                p50: 50,
                p99: 99,
                max: 100
            }
        );
        let mut one = vec![7];
        assert_eq!(Percentiles::of(&mut one).p99, 7);
        assert_eq!(Percentiles::of(&mut []).max, 0);
    }
}

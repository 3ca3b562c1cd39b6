//! Latency samples in bounded memory: a histogram of log-spaced buckets from 1 µs to
//! 100 s, 2 % wide, so that hours of frames from many viewers cost a few kilobytes each
//! and quantiles stay within 2 % of the exact ones.

/// Smallest latency told apart, milliseconds; anything below counts here.
const MIN_MS: f64 = 1e-3;
/// Ratio of one bucket's upper to lower bound.
const GROWTH: f64 = 1.02;
/// Buckets from `MIN_MS` to 100 s.
const BUCKETS: usize = 931;

#[derive(Debug, Clone)]
pub struct Latencies {
    counts: Vec<u64>,
    samples: u64,
    max_ms: f64,
}

impl Default for Latencies {
    fn default() -> Self {
        Latencies {
            counts: vec![0; BUCKETS],
            samples: 0,
            max_ms: 0.0,
        }
    }
}

impl Latencies {
    pub fn record(&mut self, ms: f64) {
        let ms = if ms.is_finite() { ms.max(0.0) } else { f64::MAX };
        let bucket = if ms <= MIN_MS {
            0
        } else {
            ((ms / MIN_MS).ln() / GROWTH.ln()).ceil() as usize
        };
        self.counts[bucket.min(BUCKETS - 1)] += 1;
        self.samples += 1;
        self.max_ms = self.max_ms.max(ms);
    }

    pub fn merge(&mut self, other: &Latencies) {
        for (a, b) in self.counts.iter_mut().zip(&other.counts) {
            *a += b;
        }
        self.samples += other.samples;
        self.max_ms = self.max_ms.max(other.max_ms);
    }

    pub fn samples(&self) -> u64 {
        self.samples
    }

    pub fn max_ms(&self) -> f64 {
        self.max_ms
    }

    /// The `q` quantile (0 to 1), milliseconds: the upper bound of the bucket that holds it
    /// (never above the largest sample); 0 with no samples.
    pub fn quantile(&self, q: f64) -> f64 {
        if self.samples == 0 {
            return 0.0;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.samples as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (bucket, &count) in self.counts.iter().enumerate() {
            seen += count;
            if seen >= rank {
                return (MIN_MS * GROWTH.powi(bucket as i32)).min(self.max_ms);
            }
        }
        self.max_ms
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_are_within_two_percent_and_never_above_the_maximum() {
        let mut latencies = Latencies::default();
        for i in 1..=1000 {
            latencies.record(i as f64 * 0.01);
        }
        for (q, exact) in [(0.5, 5.0), (0.9, 9.0), (0.99, 9.9)] {
            let got = latencies.quantile(q);
            assert!((got - exact).abs() <= 0.02 * exact, "q{q}: {got} vs {exact}");
        }
        assert_eq!(latencies.quantile(1.0), 10.0);
        assert_eq!(latencies.max_ms(), 10.0);
        assert_eq!(Latencies::default().quantile(0.5), 0.0);
    }

    #[test]
    fn merged_histograms_count_every_sample() {
        let (mut a, mut b) = (Latencies::default(), Latencies::default());
        a.record(1.0);
        b.record(100.0);
        b.record(f64::NAN);
        a.merge(&b);
        assert_eq!(a.samples(), 3);
        assert!((a.quantile(0.3) - 1.0).abs() < 0.02);
        assert!((a.quantile(0.6) - 100.0).abs() < 2.0);
    }
}

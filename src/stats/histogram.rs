//! Fixed-range histograms (marginal densities, link ranges).

use crate::stats;
use serde::Serialize;

/// Histogram over `[lo, hi]`.
#[derive(Debug, Clone, Serialize)]
pub struct Histogram {
    pub lo: f64,
    pub hi: f64,
    pub counts: Vec<f64>,
}

impl Histogram {
    pub fn new(lo: f64, hi: f64, bins: usize) -> Histogram {
        let (lo, hi) = if hi > lo { (lo, hi) } else { (lo - 0.5, lo + 0.5) };
        Histogram {
            lo,
            hi,
            counts: vec![0.0; bins],
        }
    }
    pub fn push(&mut self, z: f64) {
        let q = (z - self.lo) / (self.hi - self.lo) * self.counts.len() as f64;
        if let Some(b) = stats::bin(q, self.counts.len()) {
            self.counts[b] += 1.0;
        }
    }
    /// Probability density per bin (normalised by the count given).
    pub fn density(&self, total: f64) -> Vec<f64> {
        let w = (self.hi - self.lo) / self.counts.len() as f64;
        self.counts.iter().map(|c| c / (total * w)).collect()
    }
}

//! The Cramér–Rao bound of continuous observation, estimated from the samples: how small
//! a standard error any unbiased estimator of the drift's coefficients could reach had it
//! seen the whole path, not samples of it (docs/methods.md, "How close to optimal").
//!
//! For white-noise forcing the drift is `F(y) = F₀(y) + G(y) θ` with `G` non-zero on the
//! masses' velocity rows only (`μ_i` times each unknown's unit force on mass `i`), and the
//! noise covariance per unit time on those rows is `S_ij = Σ σ² μ_i μ_j` over the forces
//! acting on both. Girsanov's likelihood gives the Fisher information per unit time
//! `I = E[Gᵀ S⁻¹ G]` under the stationary density, so a path of total length `T` bounds
//! the covariance of any unbiased estimate by `(T I)⁻¹`. The expectation is the samples'
//! mean; `T` is the number of samples times the sample interval.
//!
//! Known answer: the linear oscillator `m ẍ + c ẋ + k x = σ ξ` has `I = diag(1/(2kc),
//! 1/(2cm))`, so `var(k̂) ≥ 2kc/T` and `var(ĉ) ≥ 2cm/T` (`tests/baselines.rs`).

use super::baseline::{applicable, DriftParts};
use super::Problem;
use nalgebra::DMatrix;

/// The samples' mean of `Gᵀ S⁻¹ G`, accumulated one sample at a time.
pub struct FisherInformation {
    problem: Problem,
    parts: DriftParts,
    /// `S⁻¹` over the masses (`n × n`, row-major).
    s_inv: Vec<f64>,
    mu: Vec<f64>,
    /// `Σ Gᵀ S⁻¹ G` (`r × r`) and the samples summed.
    sum: Vec<f64>,
    count: u64,
    y: Vec<f64>,
    known: Vec<f64>,
    unit: Vec<f64>,
    g: Vec<f64>,
}

impl FisherInformation {
    /// For `problem`, or why the bound does not apply: white forcing and unknown
    /// coefficients only (as the increment baselines need), and noise on every mass (a
    /// mass without noise would be observed exactly: an infinite information).
    pub fn new(problem: &Problem) -> Result<FisherInformation, String> {
        applicable(problem).map_err(|e| e.to_string())?;
        let n = problem.n;
        let mu: Vec<f64> = problem.model.mass.iter().map(|m| 1.0 / m).collect();
        let mut s = DMatrix::<f64>::zeros(n, n);
        for (targets, sigma, _) in &problem.white {
            for &i in targets {
                for &j in targets {
                    s[(i, j)] += sigma * sigma * mu[i] * mu[j];
                }
            }
        }
        let s_inv = s
            .cholesky()
            .ok_or("a mass has no random force of its own: its motion is not noisy, and the bound of continuous observation is not finite")?
            .inverse();
        let r = problem.unknowns.len();
        Ok(FisherInformation {
            parts: DriftParts::of(problem),
            s_inv: s_inv.transpose().as_slice().to_vec(),
            mu,
            sum: vec![0.0; r * r],
            count: 0,
            y: vec![0.0; problem.dim()],
            known: vec![0.0; n],
            unit: vec![0.0; r * n],
            g: vec![0.0; r * n],
            problem: problem.clone(),
        })
    }

    /// One sample (a log row).
    pub fn push(&mut self, row: &[f64]) {
        let (n, r) = (self.problem.n, self.problem.unknowns.len());
        for (j, &c) in self.problem.columns.iter().enumerate() {
            self.y[j] = row[c];
        }
        self.parts.at(&self.y, &mut self.known, &mut self.unit);
        // G: per unknown, the drift per unit on each mass's velocity.
        for q in 0..r {
            for i in 0..n {
                self.g[q * n + i] = self.mu[i] * self.unit[q * n + i];
            }
        }
        for a in 0..r {
            let ga = &self.g[a * n..(a + 1) * n];
            for b in a..r {
                let gb = &self.g[b * n..(b + 1) * n];
                let mut v = 0.0;
                for i in 0..n {
                    if ga[i] == 0.0 {
                        continue;
                    }
                    for j in 0..n {
                        v += ga[i] * self.s_inv[i * n + j] * gb[j];
                    }
                }
                self.sum[a * r + b] += v;
            }
        }
        self.count += 1;
    }

    /// The bound's standard deviation of every unknown, for a path of `total_time`
    /// seconds; `None` when the information is singular (an unknown the path does not
    /// determine) or no sample was seen.
    pub fn bound(&self, total_time: f64) -> Option<Vec<f64>> {
        let r = self.problem.unknowns.len();
        if self.count == 0 || total_time <= 0.0 {
            return None;
        }
        let mut info = DMatrix::<f64>::zeros(r, r);
        for a in 0..r {
            for b in a..r {
                let v = self.sum[a * r + b] / self.count as f64 * total_time;
                info[(a, b)] = v;
                info[(b, a)] = v;
            }
        }
        let cov = info.cholesky()?.inverse();
        let sd: Vec<f64> = (0..r).map(|k| cov[(k, k)].sqrt()).collect();
        sd.iter().all(|v| v.is_finite()).then_some(sd)
    }
}

impl super::accumulate::Accumulator for FisherInformation {
    fn push(&mut self, s: &super::accumulate::Sample) {
        FisherInformation::push(self, s.row)
    }
}

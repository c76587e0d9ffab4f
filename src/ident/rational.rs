//! The second-order rational spectral density of a shaped force — a Kanai–Tajimi ground,
//! a second-order Butterworth low- or band-pass, any force that is white noise through two
//! poles and at most one zero:
//!
//! `S(ω) = L·((1 − μ) + μ·ω²/Ω²) / ((Ω² − ω²)² + (2ζΩω)²)`, `0 ≤ μ ≤ 1`,
//!
//! fitted by least squares on the log density of the samples (the process's density folded
//! at the sampling rate) as (3.20) is ([`super::spectrum::fit_ou`]).
//! It is the candidate beyond first order when the identifier chooses a measured force's
//! model from its spectrum (docs/methods.md, "The force model"): a force it fits and (3.20)
//! does not is named for what it is, and the methods that need a white or first-order
//! force are refused.

use super::spectrum::{Spectrum, SKIP_LOW_BINS};

/// The fitted second-order density and the quality of the fit.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Rational2Fit {
    /// The level `L`.
    pub level: f64,
    /// The poles' natural angular frequency `Ω`, rad/s.
    pub omega: f64,
    /// Their damping ratio `ζ`.
    pub zeta: f64,
    /// The numerator's share of `ω²`: 0 an all-pole low-pass, 1 a band-pass, `4ζ²/(1 + 4ζ²)`
    /// a Kanai–Tajimi ground.
    pub mu: f64,
    /// RMS of `ln Ŝ − ln S_fit` over the fitted frequencies.
    pub rms_log_residual: f64,
    /// What the averaging alone gives of that RMS, `≈ 1/√K`.
    pub expected_rms: f64,
}

/// The density of [`Rational2Fit`]'s form at `w`.
pub fn rational2_density(level: f64, omega: f64, zeta: f64, mu: f64, w: f64) -> f64 {
    let (o2, w2) = (omega * omega, w * w);
    let den = (o2 - w2).powi(2) + 4.0 * zeta * zeta * o2 * w2;
    level * ((1.0 - mu) + mu * w2 / o2) / den
}

impl Rational2Fit {
    /// The fitted density at `w`.
    pub fn density(&self, w: f64) -> f64 {
        rational2_density(self.level, self.omega, self.zeta, self.mu, w)
    }
}

/// Aliases folded in on either side of each bin.
const ALIASES: usize = 3;

/// The smallest and largest damping ratio searched.
const ZETA_RANGE: (f64, f64) = (0.01, 5.0);

/// Fit the second-order density to `s`: a grid over `ln Ω` (a decade beyond the analysed
/// band at either end), `ln ζ` and `μ`, the level in closed form for each (the mean log
/// residual), then a compass search from the grid's best point. `None` with fewer than 8
/// bins or no segment.
pub fn fit_rational2(s: &Spectrum) -> Option<Rational2Fit> {
    let skip = SKIP_LOW_BINS.min(s.omega.len().saturating_sub(8));
    let omega = s.omega.get(skip..)?;
    if omega.len() < 8 || s.segments == 0 {
        return None;
    }
    let logs: Vec<f64> = s.density[skip..].iter().map(|d| d.max(1e-300).ln()).collect();
    // The samples' density is the process's folded at the sampling rate: each bin's
    // frequency and its aliases `ω + 2πk/h`, |k| ≤ ALIASES, squared.
    let fold = 2.0 * std::f64::consts::PI / s.sample_interval;
    let w2: Vec<[f64; 2 * ALIASES + 1]> = omega
        .iter()
        .map(|w| std::array::from_fn(|k| (w + (k as f64 - ALIASES as f64) * fold).powi(2)))
        .collect();
    let n = logs.len() as f64;
    // (sum of squares, ln L) at a point (ln Ω, ln ζ, μ).
    let cost = |p: [f64; 3]| -> (f64, f64) {
        let (o2, z2, mu) = ((2.0 * p[0]).exp(), (2.0 * p[1]).exp(), p[2].clamp(0.0, 1.0));
        let mut shape = [0.0; 2];
        let mut residuals = 0.0;
        let mut squares = 0.0;
        for (&l, aliases) in logs.iter().zip(&w2) {
            let density: f64 = aliases
                .iter()
                .map(|&w2| ((1.0 - mu) + mu * w2 / o2) / ((o2 - w2).powi(2) + 4.0 * z2 * o2 * w2))
                .sum();
            let r = l - density.max(1e-300).ln();
            residuals += r;
            squares += r * r;
        }
        shape[0] = residuals / n;
        shape[1] = squares - n * shape[0] * shape[0];
        (shape[1].max(0.0), shape[0])
    };
    let (lo, hi) = ((omega[0] / 10.0).ln(), (10.0 * omega[omega.len() - 1]).ln());
    let (zlo, zhi) = (ZETA_RANGE.0.ln(), ZETA_RANGE.1.ln());
    let mut best = ([lo, zlo, 0.0], f64::INFINITY);
    for i in 0..=48 {
        for j in 0..=24 {
            for k in 0..=10 {
                let p = [
                    lo + (hi - lo) * i as f64 / 48.0,
                    zlo + (zhi - zlo) * j as f64 / 24.0,
                    k as f64 / 10.0,
                ];
                let c = cost(p).0;
                if c < best.1 {
                    best = (p, c);
                }
            }
        }
    }
    // Compass search: each coordinate a step either way while it lowers the cost, the
    // steps halved when none does.
    let mut step = [(hi - lo) / 48.0, (zhi - zlo) / 24.0, 0.1];
    let bounds = [(lo, hi), (zlo, zhi), (0.0, 1.0)];
    for _ in 0..200 {
        let mut moved = false;
        for d in 0..3 {
            for sign in [-1.0, 1.0] {
                let mut p = best.0;
                p[d] = (p[d] + sign * step[d]).clamp(bounds[d].0, bounds[d].1);
                let c = cost(p).0;
                if c < best.1 {
                    best = (p, c);
                    moved = true;
                }
            }
        }
        if !moved {
            step.iter_mut().for_each(|s| *s *= 0.5);
            if step[0] < 1e-6 {
                break;
            }
        }
    }
    let (squares, ln_level) = cost(best.0);
    // E[ln] of an average of K periodograms is ln S − 1/(2K) − …: undo that bias.
    let k = s.segments as f64;
    Some(Rational2Fit {
        level: (ln_level + 1.0 / (2.0 * k) + 1.0 / (12.0 * k * k)).exp(),
        omega: best.0[0].exp(),
        zeta: best.0[1].exp(),
        mu: best.0[2].clamp(0.0, 1.0),
        rms_log_residual: (squares / n).sqrt(),
        expected_rms: 1.0 / k.sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::super::spectrum::{fit_ou, ou_density};
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// A Welch estimate of `K` segments of a process of density `density` sampled every
    /// π/204.8 s: each bin the exact density of the samples (the process's folded, 50
    /// aliases either side) times the mean of `K` unit exponentials (a periodogram's
    /// scatter).
    fn estimate(density: impl Fn(f64) -> f64, segments: usize, seed: u64) -> Spectrum {
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
        let omega: Vec<f64> = (1..=1024).map(|k| k as f64 * 0.2).collect();
        let density = omega
            .iter()
            .map(|&w| {
                let mean: f64 = (0..segments).map(|_| -(1.0 - rng.random::<f64>()).ln()).sum::<f64>() / segments as f64;
                let folded: f64 = (-50..=50).map(|k| density((w + 409.6 * k as f64).abs())).sum();
                folded * mean
            })
            .collect();
        Spectrum {
            omega,
            density,
            segments,
            segment_len: 2048,
            sample_interval: std::f64::consts::PI / 204.8,
        }
    }

    #[test]
    fn a_kanai_tajimi_density_is_fitted_and_first_order_is_not() {
        // A ground at 15 rad/s with 30 % damping: μ = 4ζ²/(1 + 4ζ²).
        let (wg, zg) = (15.0, 0.3);
        let kt = |w: f64| {
            let (o2, w2) = (wg * wg, w * w);
            2.0 * (o2 * o2 + 4.0 * zg * zg * o2 * w2) / ((o2 - w2).powi(2) + 4.0 * zg * zg * o2 * w2)
        };
        for seed in 0..4 {
            let s = estimate(kt, 64, seed);
            let fit = fit_rational2(&s).unwrap();
            assert!((fit.omega / wg - 1.0).abs() < 0.02, "{fit:?}");
            assert!((fit.zeta / zg - 1.0).abs() < 0.05, "{fit:?}");
            let mu = 4.0 * zg * zg / (1.0 + 4.0 * zg * zg);
            assert!((fit.mu - mu).abs() < 0.03, "{fit:?}");
            assert!(fit.rms_log_residual < 1.1 * fit.expected_rms, "{fit:?}");
            let ou = fit_ou(&s);
            assert!(ou.rms_log_residual > 3.0 * ou.expected_rms, "{ou:?}");
        }
    }

    #[test]
    fn a_second_order_low_pass_and_a_first_order_density_are_fitted() {
        // Butterworth of order 2 at 20 rad/s: all poles, ζ = 1/√2.
        let bw = |w: f64| 3.0 / (1.0 + (w / 20.0).powi(4));
        let fit = fit_rational2(&estimate(bw, 64, 7)).unwrap();
        assert!((fit.omega / 20.0 - 1.0).abs() < 0.02, "{fit:?}");
        assert!((fit.zeta - std::f64::consts::FRAC_1_SQRT_2).abs() < 0.03, "{fit:?}");
        assert!(fit.mu < 0.02, "{fit:?}");
        assert!((fit.density(5.0) / bw(5.0) - 1.0).abs() < 0.03, "{fit:?}");
        // An OU density is two real poles with one of them far away: fitted too.
        let s = estimate(|w| ou_density(2.0, 8.0, w), 64, 8);
        let fit = fit_rational2(&s).unwrap();
        assert!(fit.rms_log_residual < 1.2 * fit.expected_rms, "{fit:?}");
    }
}

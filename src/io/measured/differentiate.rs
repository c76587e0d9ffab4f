//! Velocities from measured displacements with a noisy displacement sensor (docs/data.md,
//! "Velocities from a noisy displacement").
//!
//! The velocity is `v̂[n] = Σₖ wₖ (x[n+k] − x[n−k]) / h` over `k = 1 … m`: the central
//! difference (`m = 1`, `w₁ = ½`), or for `m ≥ 2` the slope of the least-squares cubic
//! through the `2m + 1` samples (Savitzky–Golay), exact for polynomials up to degree four,
//! so that its smoothing of the motion's own band is of order `(ωmh)⁴`. White displacement
//! noise of variance `σ²` becomes velocity noise of variance `σ²·2Σwₖ²/h²`, independent of
//! the displacement's own at the same instant (the stencil skips it), and is taken out of
//! the weak form's moments like any sensor noise (docs/measurement.md).
//!
//! The noise is found from the displacement's autocovariance `R(k)`: at lags of one sample
//! or more it is the noise-free signal's, and an expansion
//! `R(k) = a₀ + a₂k² + a₃|k|³ + a₄k⁴` fitted to lags `1 … FIT_LAGS` (the odd power carries
//! the kink of a velocity driven by white forces) gives the noise-free variance `a₀`, so the
//! noise is `R(0) − a₀`. The width is the smallest that brings the velocity's noise to at
//! most [`NOISE_SHARE`] of its variance (`m = 1` where the data show no noise).
//!
//! Where the sampling is coarse and the displacement clean, the derivatives are the exact
//! central differences instead ([`exact_weights`], and for an acceleration from a
//! displacement alone the second difference, [`exact_second_weights`]), of the lowest order
//! that holds the derivative's RMS and its band edge (`Resolution`; docs/data.md, "Derived
//! velocities and accelerations").
//!
//! What a stencil does lose is the tail of a velocity driven by white forces, whose
//! spectrum falls only as `σ²/(2πm²ω²)` above the modes: [`white_tail_loss`] computes
//! it, and the identification puts it back where the forces are known. `derive_notes`
//! says what was done, and warns where the sampling is too coarse for any stencil.

use super::DERIVE_LIMIT;
use crate::ident::spectrum::Welch;

/// The widest half-width considered, in samples.
pub const MOST_HALF: usize = 16;
/// Lags of the autocovariance kept: up to `2·MOST_HALF + 1`.
pub const LAGS: usize = 2 * MOST_HALF + 1;
/// Lags the expansion is fitted to.
const FIT_LAGS: usize = 6;
/// Terms of the expansion.
const POWERS: [i32; 4] = [0, 2, 3, 4];

/// Lagged sums of one displacement, per jackknife block.
#[derive(Debug, Clone)]
pub(super) struct Autocovariance {
    /// Per record: its last `LAGS` values (a ring) and how many it has seen.
    rings: Vec<(Vec<f64>, usize)>,
    /// Per block: `Σ x`, and per lag `Σ x[n−k]x[n]` and its count.
    blocks: Vec<Block>,
    /// Blocks per record (1 with many records, else slices of each).
    per_record: usize,
    lengths: Vec<usize>,
}

#[derive(Debug, Clone)]
struct Block {
    sum: f64,
    products: [f64; LAGS + 1],
    count: [f64; LAGS + 1],
}

impl Block {
    fn new() -> Block {
        Block {
            sum: 0.0,
            products: [0.0; LAGS + 1],
            count: [0.0; LAGS + 1],
        }
    }
}

/// The displacement noise found, and the differences chosen against it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Differencing {
    /// Half-width `m` of the central difference, in samples.
    pub half: usize,
    /// The stencil is the exact central difference of order `2m` ([`exact_weights`],
    /// chosen where the sampling is coarse and the data show no noise), not the
    /// least-squares cubic's slope ([`weights`]).
    pub exact: bool,
    /// The displacement's noise variance, its jackknife standard error, and the noise-free
    /// displacement's variance.
    pub noise: f64,
    pub noise_std_error: f64,
    pub signal: f64,
    /// The noise-free velocity's variance (`−R''(0)`, from the expansion).
    pub velocity: f64,
}

impl Differencing {
    /// Whether the data show noise: the variance is 3 standard errors above 0.
    pub fn detected(&self) -> bool {
        self.noise > 3.0 * self.noise_std_error
    }

    /// The stencil's weights `w₁ … w_m`.
    pub fn weights(&self) -> Vec<f64> {
        stencil(self.half, self.exact, false)
    }
}

/// The weights of the half-width `half`: the exact central difference of order `2·half`
/// where `exact`, else [`weights`]; with `second`, the exact second central difference of
/// that order ([`exact_second_weights`]: `w₀, w₁ … w_m`).
pub fn stencil(half: usize, exact: bool, second: bool) -> Vec<f64> {
    match (second, exact) {
        (true, _) => exact_second_weights(half),
        (false, true) => exact_weights(half),
        (false, false) => weights(half),
    }
}

/// `(m!)² / ((m−k)! (m+k)!)` as a product, to stay finite for every `m ≤ MOST_HALF`.
fn factorial_ratio(m: usize, k: usize) -> f64 {
    (1..=k).map(|j| (m - k + j) as f64 / (m + j) as f64).product()
}

/// The central difference of order `2m` (exact for polynomials up to degree `2m`):
/// `wₖ = (−1)^{k+1} (m!)² / (k (m−k)! (m+k)!)`; it passes `D̃(θ)/θ = Σ 2wₖ sin kθ / θ` of the
/// derivative at `θ = ωh`, which is `1 − O(θ^{2m})`: at `θ = 0.72` (nine samples a period)
/// 0.9158 for `m = 1`, 0.9916 for `m = 2`, 0.9999 for `m = 4`.
pub fn exact_weights(half: usize) -> Vec<f64> {
    let m = half.max(1);
    (1..=m)
        .map(|k| {
            let sign = if k % 2 == 1 { 1.0 } else { -1.0 };
            sign * factorial_ratio(m, k) / k as f64
        })
        .collect()
}

/// The second central difference of order `2m` (exact for polynomials up to degree
/// `2m + 1`): `x″[n] ≈ (w₀x[n] + Σₖ wₖ(x[n+k] + x[n−k])) / h²` with
/// `wₖ = 2(−1)^{k+1} (m!)² / (k² (m−k)! (m+k)!)` and `w₀ = −2Σwₖ`; returned as `[w₀, w₁ … w_m]`.
/// It passes [`passed_second`]: at nine samples a period (`θ = 0.72`) 0.9575 for `m = 1`,
/// and at `θ = 2.06` (a multisine's band edge at a third of the sampling rate) 0.977 for
/// `m = 5` and 0.9977 for `m = 10`, where twice the first difference of the same order
/// passes 0.79 and 0.964.
pub fn exact_second_weights(half: usize) -> Vec<f64> {
    let m = half.max(1);
    let mut w: Vec<f64> = std::iter::once(0.0)
        .chain((1..=m).map(|k| {
            let sign = if k % 2 == 1 { 2.0 } else { -2.0 };
            sign * factorial_ratio(m, k) / (k * k) as f64
        }))
        .collect();
    w[0] = -2.0 * w[1..].iter().sum::<f64>();
    w
}

/// What the second-difference stencil `w` (`[w₀, w₁ … w_m]`) passes of the second
/// derivative at `θ = ωh`: `−(w₀ + Σ 2wₖ cos kθ) / θ²`.
pub fn passed_second(w: &[f64], theta: f64) -> f64 {
    let sum: f64 = w[1..]
        .iter()
        .enumerate()
        .map(|(k, wk)| 2.0 * wk * ((k + 1) as f64 * theta).cos())
        .sum();
    -(w[0] + sum) / (theta * theta)
}

/// What the stencil `w` passes of the derivative at `θ = ωh`: `Σ 2wₖ sin kθ / θ`.
pub fn passed(w: &[f64], theta: f64) -> f64 {
    w.iter()
        .enumerate()
        .map(|(k, wk)| 2.0 * wk * ((k + 1) as f64 * theta).sin())
        .sum::<f64>()
        / theta
}

/// The largest share of the derivative's std the differences may lose where the sampling is
/// coarse: the exact central difference of the lowest order that keeps to it is chosen.
pub const EXACT_LOSS: f64 = 0.001;

impl Autocovariance {
    /// For records of `lengths` samples.
    pub(super) fn new(lengths: &[usize]) -> Autocovariance {
        let per_record = if lengths.len() >= 8 { 1 } else { 16 };
        Autocovariance {
            rings: vec![(vec![0.0; LAGS], 0); lengths.len()],
            blocks: vec![Block::new(); lengths.len() * per_record],
            per_record,
            lengths: lengths.to_vec(),
        }
    }

    /// The next sample `x` of record `j` (each record's samples in time order).
    pub(super) fn push(&mut self, j: usize, x: f64) {
        let (ring, seen) = &mut self.rings[j];
        let pos = *seen;
        let slice = (pos * self.per_record / self.lengths[j].max(1)).min(self.per_record - 1);
        let b = &mut self.blocks[j * self.per_record + slice];
        b.sum += x;
        b.products[0] += x * x;
        b.count[0] += 1.0;
        for k in 1..=LAGS.min(pos) {
            let old = ring[(pos - k) % LAGS];
            b.products[k] += old * x;
            b.count[k] += 1.0;
        }
        ring[pos % LAGS] = x;
        *seen += 1;
    }

    /// The autocovariance at lags `0..=LAGS` of the blocks `keep` selects.
    fn covariance(&self, keep: impl Fn(usize) -> bool) -> Option<[f64; LAGS + 1]> {
        let mut t = Block::new();
        for (_, b) in self.blocks.iter().enumerate().filter(|(i, _)| keep(*i)) {
            t.sum += b.sum;
            for k in 0..=LAGS {
                t.products[k] += b.products[k];
                t.count[k] += b.count[k];
            }
        }
        if t.count[LAGS] < 2.0 {
            return None;
        }
        let mean = t.sum / t.count[0];
        let mut r = [0.0; LAGS + 1];
        for k in 0..=LAGS {
            r[k] = t.products[k] / t.count[k] - mean * mean;
        }
        Some(r)
    }

    /// The noise, its standard error (delete-one jackknife over the blocks), and the
    /// differences chosen against it at the sampling `h`; `None` if the records are too
    /// short for the lags.
    pub(super) fn differencing(&self, h: f64) -> Option<Differencing> {
        let r = self.covariance(|_| true)?;
        let (noise, signal, b2) = fit(&r)?;
        let used: Vec<usize> = (0..self.blocks.len())
            .filter(|&i| self.blocks[i].count[0] > 0.0)
            .collect();
        let g = used.len() as f64;
        let replicates: Vec<f64> = used
            .iter()
            .filter_map(|&i| self.covariance(|k| k != i).and_then(|r| fit(&r)).map(|f| f.0))
            .collect();
        let se = if replicates.len() >= 2 {
            let mean = replicates.iter().sum::<f64>() / replicates.len() as f64;
            ((g - 1.0) / g * replicates.iter().map(|v| (v - mean).powi(2)).sum::<f64>()).sqrt()
        } else {
            f64::NAN
        };
        let velocity = (-2.0 * b2 * r[0] / (h * h)).max(0.0);
        let mut d = Differencing {
            half: 1,
            exact: false,
            noise,
            noise_std_error: se,
            signal,
            velocity,
        };
        // Only noise the data show steers the choice.
        if d.detected() {
            d.half = (1..=MOST_HALF)
                .find(|&m| noise * noise_gain(&weights(m), h) <= NOISE_SHARE * velocity)
                .unwrap_or(MOST_HALF);
        }
        Some(d)
    }
}

/// The largest share of the velocity's variance its noise may have after the differences.
pub const NOISE_SHARE: f64 = 0.05;

/// The stencil's weights `w₁ … w_m` (module docs): the central difference for `m = 1`,
/// else the least-squares cubic's slope, `wₖ = (c₁k + c₃k³)` with `Σ wₖ·2k = 1` and
/// `Σ wₖ·2k³ = 0` minimising `Σ wₖ²`.
pub fn weights(half: usize) -> Vec<f64> {
    if half <= 1 {
        return vec![0.5];
    }
    use nalgebra::{DMatrix, DVector};
    // The slope of the least-squares cubic over k = −m … m: the second row of the
    // pseudo-inverse of the Vandermonde matrix.
    let n = 2 * half + 1;
    let a = DMatrix::<f64>::from_fn(n, 4, |i, p| (i as f64 - half as f64).powi(p as i32));
    let pinv = (a.transpose() * &a)
        .try_inverse()
        .expect("a full-rank Vandermonde matrix")
        * a.transpose();
    let row = DVector::<f64>::from_fn(n, |i, _| pinv[(1, i)]);
    (1..=half).map(|k| row[half + k]).collect()
}

/// The velocity noise variance per unit displacement noise variance: `2Σwₖ²/h²`.
pub fn noise_gain(w: &[f64], h: f64) -> f64 {
    2.0 * w.iter().map(|v| v * v).sum::<f64>() / (h * h)
}

/// The variance the stencil `w` at the sampling `h` takes out of the velocity of a unit
/// mass under a white force of unit intensity (`P dt = dW`): above the modes that
/// velocity has density `1/(2πω²)` and the displacement `1/(2πω⁴)`; sampled, they fold to
/// `(h/2)²/sin²(θ/2)` and `(h/2)⁴(1/sin⁴(θ/2) − ⅔/sin²(θ/2))` (`θ = ωh`), and the stencil
/// passes `D(θ)² = (Σ 2wₖ sin kθ)²/h²` of the displacement's, so the loss is
/// `(h/2π)∫_{−π}^{π} [1/(4s²) − D̃²/(16s⁴) + D̃²/(24s²)] dθ`, `s = sin(θ/2)`,
/// `D̃ = Σ 2wₖ sin kθ`. A mass `m` under white forces of intensities `σ_e` loses
/// `Σσ_e²/m²` times it.
pub fn white_tail_loss(w: &[f64], h: f64) -> f64 {
    let n = 100_000;
    let d = std::f64::consts::PI / n as f64;
    let mut sum = 0.0;
    for i in 0..n {
        let theta = (i as f64 + 0.5) * d;
        let dt: f64 = w
            .iter()
            .enumerate()
            .map(|(k, wk)| 2.0 * wk * ((k + 1) as f64 * theta).sin())
            .sum();
        let s2 = (0.5 * theta).sin().powi(2);
        sum += 1.0 / (4.0 * s2) - dt * dt / (16.0 * s2 * s2) + dt * dt / (24.0 * s2);
    }
    // Both halves of the symmetric integrand.
    h / std::f64::consts::PI * sum * d
}

/// The expansion fitted to `r[1..=FIT_LAGS]`: the noise `r[0] − a₀`, the signal `a₀`, and
/// `b₂ = a₂/r[0]` (per lag²).
fn fit(r: &[f64; LAGS + 1]) -> Option<(f64, f64, f64)> {
    use nalgebra::{DMatrix, DVector};
    if r[0] <= 0.0 || !r[0].is_finite() {
        return None;
    }
    let mut a = DMatrix::<f64>::zeros(FIT_LAGS, POWERS.len());
    let mut b = DVector::<f64>::zeros(FIT_LAGS);
    for k in 1..=FIT_LAGS {
        b[k - 1] = r[k] / r[0];
        for (c, &p) in POWERS.iter().enumerate() {
            a[(k - 1, c)] = (k as f64).powi(p);
        }
    }
    let coef = crate::ident::lsq::svd(a, true, true)?.solve(&b, 1e-12).ok()?;
    let signal = coef[0] * r[0];
    Some((r[0] - signal, signal, coef[1]))
}

/// How well differences at the sampling `h` resolve a signal's first (`second = false`) or
/// second derivative, from the signal's own spectrum (Welch, up to the Nyquist frequency):
/// the RMS frequency `ω` of the signal (`√(∫ω²S / ∫S)`) or, for the second derivative, of
/// its first (`√(∫ω⁴S / ∫ω²S)`); the share of the derivative's amplitude central
/// differences lose (they pass `sin(ωh)/(ωh)` at each `ω`, twice for the second
/// derivative); and where the sampling is coarse, the lowest-order exact central difference
/// ([`exact_weights`], [`exact_second_weights`]) that loses at most [`EXACT_LOSS`] of the
/// derivative's RMS and at most [`EDGE_LOSS`] at its band edge: the frequency above which
/// only [`EDGE_TAIL`] of the derivative's power lies. The RMS alone is not enough: a force
/// that reaches a third of the sampling rate (a multisine to 200 Hz at 610 Hz) puts the
/// acceleration's power up to there, and the nonlinear terms are read from it (on the
/// Silverbox twin at 610 Hz the RMS rule chose ±5 samples, which pass 0.89 of the
/// derivative at the band edge, and `k3` came out 6–8 % low; docs/data.md).
#[derive(Debug, Clone, Copy)]
pub(super) struct Resolution {
    /// `ω·h`.
    pub(super) wh: f64,
    /// `1 − std(central differences) / std(derivative)`.
    pub(super) loss: f64,
    /// Where the sampling is coarse (`ω·h` above `DERIVE_LIMIT`): the half-width of the
    /// exact central difference of the lowest order within both bounds, its RMS loss and
    /// its loss at the band edge (the widest's where none is).
    pub(super) exact: Option<(usize, f64, f64)>,
    /// The derivative's band edge, `ω·h`.
    pub(super) edge: f64,
    /// Whether some exact difference keeps both bounds. Where none does (the derivative's
    /// power reaches the Nyquist frequency, as a white-forced acceleration's does), the
    /// lowest order within [`EXACT_LOSS`] alone is chosen: no width reaches the edge.
    pub(super) band_limited: bool,
    /// Of the second derivative.
    pub(super) second: bool,
}

/// The share of a derivative's power above its band edge (`Resolution`).
pub const EDGE_TAIL: f64 = 1e-3;
/// The largest share of a derivative's amplitude the exact differences may lose at its band
/// edge.
pub const EDGE_LOSS: f64 = 0.005;

impl Resolution {
    pub(super) fn of(welch: &Welch, h: f64, second: bool) -> Resolution {
        let sp = welch.spectrum();
        let order = if second { 2 } else { 1 };
        let weight = |om: f64| om.powi(2 * order);
        let pass = |w: &[f64], theta: f64| match second {
            true => passed_second(w, theta),
            false => passed(w, theta),
        };
        let total: f64 = sp.omega.iter().zip(&sp.density).map(|(&om, &s)| weight(om) * s).sum();
        let loss_of = |p: &dyn Fn(f64) -> f64| {
            let kept: f64 = sp
                .omega
                .iter()
                .zip(&sp.density)
                .map(|(&om, &s)| weight(om) * s * p(om * h).powi(2))
                .sum();
            1.0 - (kept / total).sqrt()
        };
        // The band edge: the lowest frequency with at most EDGE_TAIL of the power above it.
        let mut above = total;
        let mut edge = sp.omega.last().copied().unwrap_or(0.0);
        for (&om, &s) in sp.omega.iter().zip(&sp.density) {
            above -= weight(om) * s;
            if above <= EDGE_TAIL * total {
                edge = om;
                break;
            }
        }
        let edge = edge * h;
        let below: f64 = sp
            .omega
            .iter()
            .zip(&sp.density)
            .map(|(&om, &s)| om.powi(2 * order - 2) * s)
            .sum();
        let wh = (total / below).sqrt() * h;
        let (mut both, mut rms_only, mut widest) = (None, None, None);
        if wh > DERIVE_LIMIT {
            for half in 2..=MOST_HALF {
                let w = stencil(half, true, second);
                let found = (half, loss_of(&|t| pass(&w, t)), 1.0 - pass(&w, edge));
                widest = Some(found);
                if found.1 <= EXACT_LOSS {
                    rms_only = rms_only.or(Some(found));
                    if found.2 <= EDGE_LOSS {
                        both = Some(found);
                        break;
                    }
                }
            }
        }
        Resolution {
            wh,
            loss: loss_of(&|t| passed(&[0.5], t).powi(order)),
            exact: both.or(rms_only).or(widest),
            edge,
            second,
            band_limited: both.is_some(),
        }
    }
}

/// A derived column's loss beyond which the report warns that the sampling is too coarse.
pub const WARN_LOSS: f64 = 0.01;

/// What the report says of a derived column: the rule, and a warning where the sampling is
/// too coarse for it. `stencil` is the differences used: the half-width, and whether they
/// are the exact central difference of its order.
pub(super) fn derive_notes(
    from: &str,
    derived: &str,
    h: f64,
    mut r: Resolution,
    d: Option<Differencing>,
    noisy_source: bool,
    (half, exact): (usize, bool),
) -> Vec<String> {
    let rule = if exact {
        let (kept, at_edge) = r.exact.map_or((f64::NAN, f64::NAN), |e| (e.1, e.2));
        let (what, spectrum, central) = match r.second {
            true => (
                "second central difference",
                "velocity",
                "central differences taken twice",
            ),
            false => ("central difference", "", "central differences"),
        };
        format!(
            "the exact {what} of order {} over ±{half} samples of {h} s: the sampling is coarse \
             (ω·h = {:.2}, ω the RMS frequency of {from}'s {spectrum}{}spectrum), where {central} would lose \
             {:.1} % of the derivative and these lose {:.2} % (at its band edge, ω·h = {:.2}, {:.2} %)",
            2 * half,
            r.wh,
            if r.second { " " } else { "" },
            100.0 * r.loss,
            100.0 * kept,
            r.edge,
            100.0 * at_edge
        )
    } else if half == 1 {
        format!("central differences over 2 × {h} s")
    } else {
        format!("differences over ±{half} samples of {h} s")
    };
    let mut notes = vec![format!("{derived} derived from {from} by {rule} (docs/data.md)")];
    if let Some(d) = d.filter(|d| d.detected()) {
        notes.push(format!(
            "{from} carries sensor noise of std {:.3e} ± {:.1e} ({:.2} % of its std, from its autocovariance): \
             {derived} is the slope of the least-squares cubic through {} samples, the fewest that bring the noise \
             on it to at most {:.0} % of its variance (std {:.3e}) (docs/data.md)",
            d.noise.sqrt(),
            d.noise_std_error / (2.0 * d.noise.sqrt()),
            100.0 * (d.noise / d.signal).sqrt(),
            2 * half + 1,
            100.0 * NOISE_SHARE,
            (d.noise * noise_gain(&weights(half), h)).sqrt(),
        ));
        // The noise-free motion's frequency, not the noise floor's.
        let wh = (d.velocity / d.signal).sqrt() * h;
        r = Resolution {
            wh,
            loss: 1.0 - wh.sin() / wh,
            exact: None,
            ..r
        };
    }
    if noisy_source {
        notes.push(format!(
            "{derived} is differenced from {from}, which carries its displacement's noise through the differences: \
             the noise is amplified again, and only a model with filtered excitations reads {derived} (docs/data.md)"
        ));
        return notes;
    }
    let loss = match (exact, r.exact) {
        (true, Some((_, loss, _))) => loss,
        _ => r.loss,
    };
    if r.wh > DERIVE_LIMIT && (!exact || loss > WARN_LOSS) {
        notes.push(format!(
            "WARNING: the sampling is too coarse to differentiate {from}: ω·h = {:.2} (ω the RMS frequency of \
             {from}'s spectrum), so the derived {derived} lacks about {:.0} % of the motion's derivative ({}) and \
             the estimates are biased (on sdof_duffing at ω·h = 0.33, k3 by −24 % with central differences); \
             sample at least {:.0}× faster or measure it",
            r.wh,
            100.0 * loss,
            if exact {
                "even the widest exact central difference loses it: the motion reaches the Nyquist frequency"
            } else {
                "central differences pass sin(ωh)/(ωh); the noise the displacement carries rules out the exact \
                 differences of higher order, which would amplify it"
            },
            (r.wh / DERIVE_LIMIT).ceil()
        ));
    }
    notes
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A damped oscillation's displacement (the exact autocovariance of a linear
    /// oscillator under white force, `R(τ) = e^{−ζω|τ|}(cos ω_d τ + ζω/ω_d sin ω_d|τ|)`),
    /// sampled at `ω·h` = 0.05, with white noise of 5 % of its std added at lag 0: the fit
    /// finds the noise within 2 % of its variance and the signal within 1e-4.
    #[test]
    fn the_expansion_finds_the_noise() {
        let (w, zeta, h): (f64, f64, f64) = (1.0, 0.05, 0.05);
        let wd = w * (1.0 - zeta * zeta).sqrt();
        let exact = |k: usize| {
            let t = k as f64 * h;
            (-zeta * w * t).exp() * ((wd * t).cos() + zeta * w / wd * (wd * t).sin())
        };
        for noise in [0.0, 0.0025] {
            let mut r = [0.0; LAGS + 1];
            for (k, v) in r.iter_mut().enumerate() {
                *v = exact(k);
            }
            r[0] += noise;
            let (n, s, _) = fit(&r).unwrap();
            assert!(
                (n - noise).abs() < 0.02 * noise + 1e-5 && (s - 1.0).abs() < 1e-4,
                "{n} {s}"
            );
        }
    }

    /// The stencils differentiate a quartic exactly (the cubic's slope; the central
    /// difference a quadratic), their noise gain falls with the width, and the white tail's
    /// loss of the central difference agrees with a direct sum over the folded spectra
    /// (within 0.2 %) and grows about linearly with `m`.
    /// The exact central differences: the textbook weights, exact on every polynomial up to
    /// degree 2m (and not beyond), and what they pass at nine samples a period.
    #[test]
    fn exact_central_differences_are_exact_to_their_order() {
        let w = exact_weights(2);
        assert!((w[0] - 2.0 / 3.0).abs() < 1e-15 && (w[1] + 1.0 / 12.0).abs() < 1e-15);
        assert_eq!(exact_weights(1), vec![0.5]);
        for m in 1..=MOST_HALF {
            let w = exact_weights(m);
            // The derivative at 0 of t^p (h = 1): 1 for p = 1, 0 for the others up to 2m.
            for p in 1..=(2 * m + 1) as i32 {
                let d: f64 = w
                    .iter()
                    .enumerate()
                    .map(|(k, wk)| wk * (((k + 1) as f64).powi(p) - (-((k + 1) as f64)).powi(p)))
                    .sum();
                let scale: f64 = w
                    .iter()
                    .enumerate()
                    .map(|(k, wk)| 2.0 * (wk * ((k + 1) as f64).powi(p)).abs())
                    .sum();
                let want = if p == 1 { 1.0 } else { 0.0 };
                if p <= 2 * m as i32 {
                    assert!((d - want).abs() < 1e-13 * scale, "m = {m}, t^{p}: {d}");
                } else {
                    assert!((d - want).abs() > 1e-6 * scale, "m = {m} is exact beyond its order");
                }
            }
        }
        let at = |m: usize| passed(&exact_weights(m), 0.72);
        assert!((at(1) - 0.72f64.sin() / 0.72).abs() < 1e-15);
        assert!((at(1) - 0.9158).abs() < 1e-4 && (at(2) - 0.9916).abs() < 1e-4 && (at(4) - 0.9999).abs() < 1e-4);
    }

    #[test]
    fn stencils_are_exact_on_polynomials_and_their_losses_are_known() {
        let h = 0.1;
        for m in 1..=MOST_HALF {
            let w = weights(m);
            let p = |t: f64| {
                if m == 1 {
                    3.0 * t * t - t + 2.0
                } else {
                    t.powi(4) - 2.0 * t.powi(3) + 3.0 * t * t - t + 2.0
                }
            };
            let dp = |t: f64| {
                if m == 1 {
                    6.0 * t - 1.0
                } else {
                    4.0 * t.powi(3) - 6.0 * t * t + 6.0 * t - 1.0
                }
            };
            let t0 = 0.37;
            let v: f64 = w
                .iter()
                .enumerate()
                .map(|(k, wk)| {
                    let k = (k + 1) as f64;
                    wk * (p(t0 + k * h) - p(t0 - k * h)) / h
                })
                .sum();
            assert!((v - dp(t0)).abs() < 1e-9, "m = {m}: {v} against {}", dp(t0));
            if m > 2 {
                assert!(noise_gain(&w, h) < noise_gain(&weights(m - 1), h), "m = {m}");
            }
        }
        // The folded sums, summed directly for the central difference.
        let w = weights(1);
        let direct = {
            let n = 20_000;
            let mut sum = 0.0;
            for i in 0..n {
                let omega = (i as f64 + 0.5) / n as f64 * std::f64::consts::PI / h;
                let (mut sv, mut sx) = (0.0, 0.0);
                for k in -2000i64..=2000 {
                    let o = omega + 2.0 * std::f64::consts::PI * k as f64 / h;
                    sv += 1.0 / (o * o);
                    sx += 1.0 / o.powi(4);
                }
                let d = (omega * h).sin() / h;
                sum += sv - d * d * sx;
            }
            2.0 * sum * (std::f64::consts::PI / h / n as f64) / (2.0 * std::f64::consts::PI)
        };
        let loss = white_tail_loss(&w, h);
        assert!((loss / direct - 1.0).abs() < 2e-3, "{loss} against {direct}");
        let (l4, l8) = (white_tail_loss(&weights(4), h), white_tail_loss(&weights(8), h));
        assert!(l8 / l4 > 1.8 && l8 / l4 < 2.2, "{l4} {l8}");
    }
}

//! Sensor noise on measured displacements and velocities, estimated from the samples
//! themselves (docs/measurement.md).
//!
//! A sensor adds white noise `e` to what it measures: `y = x + e`. White noise is
//! uncorrelated between different instants and between different sensors, so every
//! covariance of the samples at a lag of one sample interval or more, and every
//! covariance between the displacement and the velocity sensor of a mass, is the noise-free
//! signal's. The noise-free signal is smooth where the noise is not: the displacement's
//! autocovariance `R(τ)` is even and, with `v = ẋ`, `R_xv(τ) = R'(τ)` and
//! `R_vv(τ) = −R''(τ)`. One expansion `R(τ) = a₀ + a₂τ² + a₃|τ|³ + … + a₆τ⁶` (the
//! odd powers carry the kink of a velocity driven by white forces) fitted to all three
//! families at lags `1 … LAGS` gives the noise-free variances `a₀` and `−2a₂`; what the
//! samples' variances have beyond them is the noise. Standard errors by the delete-one
//! jackknife over the identification's batches.
//!
//! The expansion holds where the signal's power lies well below the Nyquist frequency. A
//! signal that reaches towards it (a shaker's band edge near Nyquist, the harmonics of a
//! stiff nonlinearity) bends the covariances at the fitted lags beyond the expansion, and
//! the extrapolation then finds a "noise" that is the expansion's truncation. White noise
//! spreads its variance evenly over the band, so the spectrum's flattest stretch bounds it
//! from above ([`NoiseFloor`]'s ceiling): an estimate the ceiling cannot hold is not noise,
//! and is neither reported as detected nor taken out.
//!
//! The weak form then reads unbiased moments ([`super::moments::RawMoments::deconvolve`]).

use super::spectrum::Welch;
use nalgebra::{DMatrix, DVector};

/// Lags (in sample intervals) the expansion is fitted to. On a linear oscillator's exact
/// covariances the noise-free variances come back within 3e-6 (displacement) and 1.3e-3
/// (velocity) of their values at ω·h = 0.5, 1.4e-2 at ω·h = 0.8 (docs/measurement.md).
pub const LAGS: usize = 4;
/// Terms of the expansion: `1, τ², |τ|³, τ⁴, |τ|⁵, τ⁶`.
const POWERS: [i32; 6] = [0, 2, 3, 4, 5, 6];

/// Samples per segment of the spectra the ceiling reads (128 bins up to Nyquist).
const CEILING_SEGMENT: usize = 256;
/// Adjacent bins averaged into one stretch of the spectrum: the ceiling is the quietest
/// stretch's mean density over the whole band.
const CEILING_BINS: usize = 8;
/// The ceiling's allowance for the spectral estimate's scatter, in relative standard
/// deviations of a stretch's mean (with the Hann window's correlation of adjacent bins):
/// the quietest of 16 stretches lies about 2 below its mean.
const CEILING_ALLOWANCE: f64 = 5.0;

/// A mass whose displacement and velocity are both measured (not derived).
#[derive(Debug, Clone)]
pub struct Pair {
    /// Log columns of the displacement and the velocity.
    pub columns: [usize; 2],
    /// State variables of the displacement and the velocity.
    pub state: [usize; 2],
    /// Column names, for reports.
    pub names: [String; 2],
}

/// Lagged sums of one batch: per pair, per lag `k`: `Σ x₋ₖx`, `Σ v₋ₖv`, `Σ x₋ₖv`,
/// `Σ v₋ₖx` and their count; lag 0 also `Σ x`, `Σ v`.
#[derive(Debug, Clone)]
struct Sums {
    count: [f64; LAGS + 1],
    products: Vec<[[f64; 4]; LAGS + 1]>,
    first: Vec<[f64; 2]>,
}

impl Sums {
    fn new(pairs: usize) -> Sums {
        Sums {
            count: [0.0; LAGS + 1],
            products: vec![[[0.0; 4]; LAGS + 1]; pairs],
            first: vec![[0.0; 2]; pairs],
        }
    }

    fn add(&mut self, o: &Sums) {
        for k in 0..=LAGS {
            self.count[k] += o.count[k];
        }
        for (a, b) in self.products.iter_mut().zip(&o.products) {
            for k in 0..=LAGS {
                for q in 0..4 {
                    a[k][q] += b[k][q];
                }
            }
        }
        for (a, b) in self.first.iter_mut().zip(&o.first) {
            a[0] += b[0];
            a[1] += b[1];
        }
    }
}

/// The last `LAGS` samples of one trajectory.
#[derive(Debug, Clone, Default)]
struct Recent {
    t: f64,
    /// How many of the last samples were one interval apart, up to `LAGS`.
    run: usize,
    /// `values[k·2p + …]`: the sample `k + 1` intervals back, `[x, v]` per pair.
    values: Vec<f64>,
}

/// Lagged products of the measured displacement–velocity pairs, per jackknife batch,
/// accumulated one sample at a time in constant memory (per trajectory, the last
/// [`LAGS`] samples).
#[derive(Debug, Clone)]
pub struct NoiseFloor {
    pairs: Vec<Pair>,
    interval: f64,
    recent: Vec<Recent>,
    batches: Vec<Sums>,
    /// Consecutive samples of a trajectory not one interval apart.
    pub gaps: u64,
    /// Per channel (displacement, velocity of each pair): the smallest and largest value
    /// so far and how many samples hold each exactly (a clipped sensor repeats them).
    extremes: Vec<[(f64, u64); 2]>,
    /// Per channel and side, the most extreme values seen (largest, and negated smallest):
    /// a clipped sensor whose limit jitters piles its samples up just inside it.
    tails: Vec<[Tail; 2]>,
    /// Per channel, its spectrum, for the ceiling on its noise.
    spectra: Vec<Welch>,
}

/// The [`Tail::KEPT`] largest values of a stream, ascending.
#[derive(Debug, Clone)]
pub(crate) struct Tail(Vec<f64>);

impl Tail {
    pub(crate) const KEPT: usize = 64;

    pub(crate) fn new() -> Tail {
        Tail(Vec::with_capacity(Self::KEPT))
    }

    #[inline]
    pub(crate) fn push(&mut self, y: f64) {
        let full = self.0.len() == Self::KEPT;
        if full && y <= self.0[0] || y.is_nan() {
            return;
        }
        if full {
            self.0.remove(0);
        }
        let at = self.0.partition_point(|&v| v < y);
        self.0.insert(at, y);
    }

    /// How many of the kept values lie within `width` of the largest.
    pub(crate) fn near_top(&self, width: f64) -> u64 {
        let top = self.0.last().copied().unwrap_or(f64::NAN);
        self.0.iter().filter(|&&v| top - v <= width).count() as u64
    }
}

/// A pile-up at a channel's limit counts the samples within this fraction of the
/// channel's standard deviation of its extreme: a continuous record's next-to-largest
/// value lies a few tenths of a standard deviation below its largest, so a full tail
/// ([`Tail::KEPT`] values) within a thousandth is a limit (jittering or not), not the
/// signal's tail. (A noise-free periodic record puts one peak a period there: fewer than
/// [`Tail::KEPT`] periods are not counted.)
pub(crate) const PILE_UP: f64 = 1e-3;

/// One sensor's noise as estimated.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ChannelNoise {
    /// The log column.
    pub column: String,
    /// State variable of the problem.
    #[serde(skip)]
    pub state: usize,
    /// Noise variance (may come out negative by sampling noise when there is none).
    pub variance: f64,
    /// Its jackknife standard error.
    pub variance_std_error: f64,
    /// The most noise variance the channel's spectrum can hold: white noise's density is
    /// flat, so no more than the quietest stretch's density over the whole band (with an
    /// allowance for the spectral estimate's scatter). `None` where the records are too
    /// short for a spectrum.
    pub ceiling: Option<f64>,
    /// The noise-free signal's standard deviation.
    pub signal_std: f64,
    /// Samples that hold the channel's smallest or largest value, exactly or within a
    /// thousandth of its standard deviation (counted to 64), where that is more than one
    /// of each: a clipped sensor or ADC repeats its limits, or piles up at a jittering one.
    pub at_limits: u64,
}

impl ChannelNoise {
    /// The noise's standard deviation (0 where the variance came out negative).
    pub fn std(&self) -> f64 {
        self.variance.max(0.0).sqrt()
    }

    /// Whether the data show noise: the variance is 3 standard errors above 0, and not
    /// above what the spectrum can hold ([`ChannelNoise::above_ceiling`]).
    pub fn detected(&self) -> bool {
        self.variance > 3.0 * self.variance_std_error && !self.above_ceiling()
    }

    /// The estimate exceeds the spectrum's ceiling by more than 3 standard errors: the
    /// signal holds power where the expansion at [`LAGS`] lags does not hold, and what it
    /// extrapolates is its truncation, not noise.
    pub fn above_ceiling(&self) -> bool {
        self.ceiling
            .is_some_and(|c| self.variance - 3.0 * self.variance_std_error > c)
    }
}

impl NoiseFloor {
    /// For `pairs` sampled every `interval` seconds, standard errors over `batches`.
    pub fn new(pairs: Vec<Pair>, interval: f64, batches: usize) -> NoiseFloor {
        let p = pairs.len();
        NoiseFloor {
            pairs,
            interval,
            recent: Vec::new(),
            batches: vec![Sums::new(p); batches.max(1)],
            gaps: 0,
            extremes: vec![[(f64::INFINITY, 0), (f64::NEG_INFINITY, 0)]; 2 * p],
            tails: (0..2 * p).map(|_| [Tail::new(), Tail::new()]).collect(),
            spectra: (0..2 * p).map(|_| Welch::new(CEILING_SEGMENT, interval, 0)).collect(),
        }
    }

    /// The pairs it watches.
    pub fn pairs(&self) -> &[Pair] {
        &self.pairs
    }

    /// One sample (`row`: the log's columns) of `trajectory` at `t`, in jackknife batch
    /// `batch`; a trajectory's samples come in time order.
    pub fn push(&mut self, trajectory: u32, t: f64, batch: usize, row: &[f64]) {
        let p = self.pairs.len();
        if p == 0 {
            return;
        }
        let j = trajectory as usize;
        if j >= self.recent.len() {
            self.recent.resize_with(j + 1, || Recent {
                t: f64::NAN,
                run: 0,
                values: vec![0.0; 2 * p * LAGS],
            });
            for w in &mut self.spectra {
                w.grow(j + 1);
            }
        }
        let r = &mut self.recent[j];
        if r.run > 0 && ((t - r.t) - self.interval).abs() > 1e-6 * self.interval {
            self.gaps += 1;
            r.run = 0;
        }
        let last = self.batches.len() - 1;
        let s = &mut self.batches[batch.min(last)];
        for k in 0..=r.run {
            s.count[k] += 1.0;
        }
        for (q, pair) in self.pairs.iter().enumerate() {
            let (x, v) = (row[pair.columns[0]], row[pair.columns[1]]);
            for (e, y) in self.extremes[2 * q..2 * q + 2].iter_mut().zip([x, v]) {
                for (side, (at, n)) in e.iter_mut().enumerate() {
                    if y == *at {
                        *n += 1;
                    } else if (side == 0 && y < *at) || (side == 1 && y > *at) {
                        (*at, *n) = (y, 1);
                    }
                }
            }
            for (t, y) in self.tails[2 * q..2 * q + 2].iter_mut().zip([x, v]) {
                t[0].push(-y);
                t[1].push(y);
            }
            self.spectra[2 * q].push(j, x);
            self.spectra[2 * q + 1].push(j, v);
            let sums = &mut s.products[q];
            sums[0][0] += x * x;
            sums[0][1] += v * v;
            sums[0][2] += x * v;
            sums[0][3] += v * x;
            s.first[q][0] += x;
            s.first[q][1] += v;
            for k in 1..=r.run {
                let back = &r.values[(k - 1) * 2 * p + 2 * q..];
                let (xb, vb) = (back[0], back[1]);
                sums[k][0] += xb * x;
                sums[k][1] += vb * v;
                sums[k][2] += xb * v;
                sums[k][3] += vb * x;
            }
        }
        // Shift the window by one sample.
        r.values.copy_within(0..2 * p * (LAGS - 1), 2 * p);
        for (q, pair) in self.pairs.iter().enumerate() {
            r.values[2 * q] = row[pair.columns[0]];
            r.values[2 * q + 1] = row[pair.columns[1]];
        }
        r.run = (r.run + 1).min(LAGS);
        r.t = t;
    }

    /// Each channel's noise, or why it cannot be estimated, with the jackknife's
    /// replicates: per batch (`None`
    /// where it holds no sample), each channel's noise variance from every other batch —
    /// the identification corrects its own replicates with them, so that its standard
    /// errors carry the noise estimate's uncertainty.
    #[allow(clippy::type_complexity)]
    pub fn estimate_with_replicates(&self) -> Result<(Vec<ChannelNoise>, Vec<Option<Vec<f64>>>), String> {
        if self.pairs.is_empty() {
            return Err("no mass has both its displacement and its velocity measured".into());
        }
        let mut total = Sums::new(self.pairs.len());
        for b in &self.batches {
            total.add(b);
        }
        if total.count[LAGS] < 100.0 {
            return Err(format!(
                "too few runs of {} samples one sample interval ({} s) apart ({} gaps in the records)",
                LAGS + 1,
                self.interval,
                self.gaps
            ));
        }
        let full = self.variances(&total);
        // Delete-one jackknife over the batches that hold samples.
        let by_batch: Vec<Option<Vec<f64>>> = self
            .batches
            .iter()
            .enumerate()
            .map(|(out, b)| {
                (b.count[0] > 0.0).then(|| {
                    let mut rest = Sums::new(self.pairs.len());
                    for (k, s) in self.batches.iter().enumerate() {
                        if k != out {
                            rest.add(s);
                        }
                    }
                    self.variances(&rest).iter().map(|c| c.0).collect()
                })
            })
            .collect();
        let replicates: Vec<Vec<f64>> = by_batch.iter().flatten().cloned().collect();
        let cov = super::estimate::jackknife(&replicates, full.len());
        let channels = full
            .iter()
            .enumerate()
            .map(|(k, &(variance, signal))| {
                let (q, w) = (k / 2, k % 2);
                ChannelNoise {
                    column: self.pairs[q].names[w].clone(),
                    state: self.pairs[q].state[w],
                    variance,
                    variance_std_error: cov.get(k).map_or(f64::NAN, |r| r[k].sqrt()),
                    ceiling: self.ceiling(k),
                    signal_std: signal.max(0.0).sqrt(),
                    at_limits: self.at_limits(k, signal.max(0.0).sqrt()),
                }
            })
            .collect();
        Ok((channels, by_batch))
    }

    /// Channel `k`'s ceiling on its noise variance: white noise of variance `σ²` has the
    /// flat two-sided density `σ²h/2π` up to Nyquist, and the signal's density adds to it,
    /// so `σ² ≤ 2π/h · min S`, the minimum over stretches of [`CEILING_BINS`] bins, raised
    /// by [`CEILING_ALLOWANCE`] of a stretch's relative scatter (`√(1.5/(bins·segments))`,
    /// the Hann window correlating neighbouring bins).
    fn ceiling(&self, k: usize) -> Option<f64> {
        let s = self.spectra[k].spectrum();
        let stretches = s.density.len() / CEILING_BINS;
        if s.segments < 4 || stretches < 4 {
            return None;
        }
        let quietest = s
            .density
            .chunks_exact(CEILING_BINS)
            .map(|c| c.iter().sum::<f64>() / CEILING_BINS as f64)
            .fold(f64::INFINITY, f64::min);
        let scatter = (1.5 / (CEILING_BINS * s.segments) as f64).sqrt();
        Some(2.0 * std::f64::consts::PI / self.interval * quietest * (1.0 + CEILING_ALLOWANCE * scatter))
    }

    /// Channel `k`'s samples at its limits: per side, those holding the extreme exactly,
    /// or [`Tail::KEPT`] when every kept value lies within [`PILE_UP`] standard deviations
    /// `std` of it; where more than one does.
    fn at_limits(&self, k: usize, std: f64) -> u64 {
        let kept = Tail::KEPT as u64;
        self.extremes[k]
            .iter()
            .zip(&self.tails[k])
            .map(|(&(_, exact), tail)| {
                let near = tail.near_top(PILE_UP * std);
                exact.max(if near == kept { near } else { 0 })
            })
            .filter(|&n| n > 1)
            .sum()
    }

    /// Per channel (displacement, velocity of each pair): the noise variance and the
    /// noise-free signal's variance.
    fn variances(&self, s: &Sums) -> Vec<(f64, f64)> {
        let h = self.interval;
        let mut out = Vec::with_capacity(2 * self.pairs.len());
        for q in 0..self.pairs.len() {
            let n0 = s.count[0];
            let (mx, mv) = (s.first[q][0] / n0, s.first[q][1] / n0);
            let cov = |k: usize, which: usize| {
                let m = [mx * mx, mv * mv, mx * mv, mx * mv][which];
                s.products[q][k][which] / s.count[k] - m
            };
            let (var_x, var_v) = (cov(0, 0), cov(0, 1));
            let sx = var_x.max(1e-300).sqrt();
            let sv = var_v.max(1e-300).sqrt();
            // Rows: R(kh) / var_x, R'(kh) / (sx·sv), −R''(kh) / var_v; unknowns a_p scaled
            // so each column is of order one: a_p = b_p · sx² / (h^p) for the
            // displacement's terms (τ = kh, so τ^p / h^p = k^p).
            let mut a = DMatrix::<f64>::zeros(3 * LAGS, POWERS.len());
            let mut b = DVector::<f64>::zeros(3 * LAGS);
            for k in 1..=LAGS {
                let kf = k as f64;
                let r = 3 * (k - 1);
                b[r] = cov(k, 0) / var_x;
                b[r + 1] = 0.5 * (cov(k, 2) - cov(k, 3)) / (sx * sv);
                b[r + 2] = cov(k, 1) / var_v;
                for (c, &p) in POWERS.iter().enumerate() {
                    let pf = p as f64;
                    // a_p τ^p = b_p sx² k^p; its derivative a_p p τ^{p−1} = b_p sx² p k^{p−1} / h.
                    a[(r, c)] = kf.powi(p);
                    a[(r + 1, c)] = if p >= 1 {
                        pf * kf.powi(p - 1) * sx / (h * sv)
                    } else {
                        0.0
                    };
                    a[(r + 2, c)] = if p >= 2 {
                        -pf * (pf - 1.0) * kf.powi(p - 2) * var_x / (h * h * var_v)
                    } else {
                        0.0
                    };
                }
            }
            let bcoef = super::lsq::svd(a.clone(), true, true)
                .and_then(|s| s.solve(&b, 1e-12).ok())
                .unwrap_or_else(|| DVector::zeros(POWERS.len()));
            let signal_x = bcoef[0] * var_x;
            // −R''(0) = −2 a₂ = −2 b₂ sx² / h².
            let signal_v = -2.0 * bcoef[1] * var_x / (h * h);
            out.push((var_x - signal_x, signal_x));
            out.push((var_v - signal_v, signal_v));
        }
        out
    }
}

/// Remove additive Gaussian noise of variance `s2` from power sums `Σ z^k`
/// (`k = 0 …`): each becomes the sum of [`super::moments::RawMoments::deconvolve`]'s
/// Hermite polynomial.
pub fn deconvolve_powers(sums: &mut [f64], s2: f64) {
    if s2 == 0.0 {
        return;
    }
    let old = sums.to_vec();
    for (b, out) in sums.iter_mut().enumerate() {
        let mut c = 1.0;
        let mut acc = 0.0;
        for k in 0..=b / 2 {
            acc += c * old[b - 2 * k];
            let m = (b - 2 * k) as f64;
            c *= -s2 * m * (m - 1.0) / (2.0 * (k + 1) as f64);
        }
        *out = acc;
    }
}

impl super::accumulate::Accumulator for NoiseFloor {
    fn push(&mut self, s: &super::accumulate::Sample) {
        NoiseFloor::push(self, s.trajectory, s.t, s.batch, s.row)
    }
}

#[cfg(test)]
mod tests {
    use super::super::moments::RawMoments;
    use super::super::poly::var;
    use super::*;

    /// Uniform numbers in (0, 1) from a xorshift stream started at `state`.
    fn uniform(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }
    }

    /// A clipped channel whose limit jitters by ±10⁻⁴ of its standard deviation (no two
    /// clipped samples equal) is counted at its limits, as one that repeats its limit
    /// exactly is; the same record unclipped has one sample at each extreme.
    #[test]
    fn a_jittering_limit_is_counted_as_clipping() {
        let mut uniform = uniform(0x9e37_79b9_7f4a_7c15);
        // An AR(2) oscillator's displacement and its difference, unit-scale.
        let (mut x, mut x1) = (0.0f64, 0.0f64);
        let rows: Vec<[f64; 2]> = (0..200_000)
            .map(|_| {
                let e = (-2.0 * uniform().ln()).sqrt() * (2.0 * std::f64::consts::PI * uniform()).cos();
                let next = 1.9 * x - 0.95 * x1 + 0.1 * e;
                (x1, x) = (x, next);
                [x, x - x1]
            })
            .collect();
        let std = (rows.iter().map(|r| r[0] * r[0]).sum::<f64>() / rows.len() as f64).sqrt();
        let limit = 1.5 * std;
        let counted = |clip: bool, jitter: &mut dyn FnMut() -> f64| {
            let pair = Pair {
                columns: [0, 1],
                state: [0, 1],
                names: ["x".into(), "v".into()],
            };
            let mut floor = NoiseFloor::new(vec![pair], 0.01, 4);
            for (k, r) in rows.iter().enumerate() {
                let x = if clip && r[0] > limit {
                    limit + 1e-4 * std * (2.0 * jitter() - 1.0)
                } else {
                    r[0]
                };
                floor.push(0, k as f64 * 0.01, k * 4 / rows.len(), &[x, r[1]]);
            }
            let (channels, _) = floor.estimate_with_replicates().unwrap();
            channels[0].at_limits
        };
        let mut jitter = uniform;
        assert_eq!(counted(true, &mut jitter), 64, "a jittering limit is clipping");
        assert_eq!(
            counted(false, &mut jitter),
            0,
            "a continuous record's extremes are single"
        );
    }

    /// A multisine's exact displacement and velocity (flat velocity lines from `ω·h` =
    /// `edge`/3 to `edge`), 8 records of 8192 samples, with white noise of `noise` times each
    /// channel's std added: the channels' noise estimates.
    fn multisine_noise(edge: f64, noise: [f64; 2]) -> Vec<ChannelNoise> {
        let mut uniform = uniform(0x2545_f491_4f6c_dd1d);
        let mut gauss = move || (-2.0 * uniform().ln()).sqrt() * (2.0 * std::f64::consts::PI * uniform()).cos();
        let (period, n) = (1024usize, 8192usize);
        let lines: Vec<f64> = (1..)
            .map(|j| 2.0 * std::f64::consts::PI * j as f64 / period as f64)
            .take_while(|&w| w <= edge)
            .filter(|&w| w >= edge / 3.0)
            .collect();
        // Per line: x = sin(ωt + φ)/ω, v = cos(ωt + φ); the velocity's variance is lines/2.
        let (sx, sv) = (
            (lines.iter().map(|w| 0.5 / (w * w)).sum::<f64>()).sqrt(),
            (0.5 * lines.len() as f64).sqrt(),
        );
        let pair = Pair {
            columns: [0, 1],
            state: [0, 1],
            names: ["x".into(), "v".into()],
        };
        let mut floor = NoiseFloor::new(vec![pair], 1.0, 8);
        for record in 0..8 {
            let phases: Vec<f64> = lines
                .iter()
                .map(|_| 2.0 * std::f64::consts::PI * gauss().abs())
                .collect();
            for k in 0..n {
                let t = k as f64;
                let (mut x, mut v) = (0.0, 0.0);
                for (w, p) in lines.iter().zip(&phases) {
                    let (s, c) = (w * t + p).sin_cos();
                    x += s / w;
                    v += c;
                }
                let row = [x + noise[0] * sx * gauss(), v + noise[1] * sv * gauss()];
                floor.push(record, t, record as usize, &row);
            }
        }
        floor.estimate_with_replicates().unwrap().0
    }

    /// A clean signal whose velocity reaches ω·h = 2 (a shaker's band to two thirds of
    /// Nyquist) bends the covariances at the fitted lags beyond the expansion, which then
    /// extrapolates a "noise" of several per cent of the velocity: its spectrum, empty
    /// above the band, cannot hold it, and it is neither detected nor taken out. A band
    /// to ω·h = 0.3 with 10 % noise on the displacement and 20 % on the velocity: both are
    /// detected, within the ceiling, and the velocity's within a tenth of its value.
    #[test]
    fn noise_the_spectrum_cannot_hold_is_the_expansions_truncation() {
        let wide = multisine_noise(2.0, [0.0; 2]);
        let v = &wide[1];
        assert!(
            v.variance > 3.0 * v.variance_std_error && v.std() > 0.02 * v.signal_std,
            "the expansion's truncation shows as noise: {v:?}"
        );
        assert!(v.above_ceiling() && !v.detected(), "{v:?}");
        assert!(wide.iter().all(|c| !c.detected()), "{wide:?}");
        let narrow = multisine_noise(0.3, [0.1, 0.2]);
        for c in &narrow {
            assert!(c.detected() && !c.above_ceiling(), "{c:?}");
        }
        let v = &narrow[1];
        assert!(
            (v.std() / (0.2 * v.signal_std) - 1.0).abs() < 0.1,
            "velocity noise {} against {}",
            v.std(),
            0.2 * v.signal_std
        );
    }

    /// Gaussian moments: `E[z^b]` for `z ~ N(μ, s²)`, by the recursion
    /// `E[z^b] = μ E[z^{b−1}] + (b−1) s² E[z^{b−2}]`.
    fn gauss(mu: f64, s2: f64, b: u32) -> f64 {
        let (mut m0, mut m1) = (1.0, mu);
        if b == 0 {
            return 1.0;
        }
        for k in 2..=b {
            let m2 = mu * m1 + (k - 1) as f64 * s2 * m0;
            (m0, m1) = (m1, m2);
        }
        m1
    }

    /// The expansion's bias on a linear oscillator's exact covariances (`m ẍ + c ẋ + k x`
    /// under white force of intensity `q`: `R(τ) = q/(2ck) e^{−ζω|τ|}(cos ω_d τ +
    /// ζω/ω_d sin ω_d|τ|)`, `R_vv(0) = q/(2cm)`), with known noise added at lag 0: the
    /// noise comes back to within a small fraction of the signal's variance, where the
    /// sampling is as coarse as the shipped scenarios' (ω·h up to 0.5).
    #[test]
    fn the_noise_of_a_linear_oscillator_comes_back_from_its_exact_covariances() {
        let (m, c, k, q) = (1.0f64, 0.4f64, 10.0f64, 1.0f64);
        let w0 = (k / m).sqrt();
        let zeta = c / (2.0 * (k * m).sqrt());
        let wd = w0 * (1.0 - zeta * zeta).sqrt();
        let r0 = q / (2.0 * c * k);
        let rv0 = q / (2.0 * c * m);
        let r = |t: f64| {
            let a = t.abs();
            r0 * (-zeta * w0 * a).exp() * ((wd * a).cos() + zeta * w0 / wd * (wd * a).sin())
        };
        // R'(τ) and −R''(τ) by the closed form's derivatives (central differences of the
        // exact function at a tiny step are exact enough here).
        let d = 1e-5;
        let r1 = |t: f64| (r(t + d) - r(t - d)) / (2.0 * d);
        let r2 = |t: f64| -(r(t + d) - 2.0 * r(t) + r(t - d)) / (d * d);
        for h in [0.02, 0.05, 0.1, 0.16] {
            let (nx, nv) = (0.01 * r0, 0.09 * rv0);
            let mut floor = NoiseFloor::new(
                vec![Pair {
                    columns: [0, 1],
                    state: [0, 1],
                    names: ["x".into(), "v".into()],
                }],
                h,
                1,
            );
            let s = &mut floor.batches[0];
            s.count = [1.0; LAGS + 1];
            s.products[0][0] = [r0 + nx, rv0 + nv, 0.0, 0.0];
            for kk in 1..=LAGS {
                let t = kk as f64 * h;
                s.products[0][kk] = [r(t), r2(t), r1(t), -r1(t)];
            }
            let got = floor.variances(&floor.batches[0]);
            let (ex, ev) = ((got[0].0 - nx) / r0, (got[1].0 - nv) / rv0);
            assert!(
                ex.abs() < 1e-5 && ev.abs() < 2e-3,
                "ω·h = {:.2}: noise variance off by {ex:e} of the displacement's variance, {ev:e} of the \
                 velocity's",
                w0 * h
            );
        }
    }

    /// The noisy moments of independent Gaussian variables, deconvolved, are the clean
    /// ones exactly: `x_j ~ N(μ_j, s_j²)`, `y_j = x_j + e_j`, `e_j ~ N(0, σ_j²)`.
    #[test]
    fn deconvolved_moments_are_the_noise_free_gaussian_moments() {
        let mu = [0.3, -1.1, 0.0];
        let s2 = [0.8, 2.0, 0.5];
        let noise = [0.2, 0.0, 0.7];
        let moment = |e: u128, add: bool| -> f64 {
            (0..3)
                .map(|j| {
                    let b = super::super::poly::exponent(e, j);
                    gauss(mu[j], s2[j] + if add { noise[j] } else { 0.0 }, b)
                })
                .product()
        };
        let mut m = RawMoments::exact(3, 6, |e| moment(e, true));
        m.deconvolve(&noise);
        let mut worst = 0.0f64;
        for &e in m.monomials() {
            let (got, want) = (m.moment(e), moment(e, false));
            worst = worst.max((got - want).abs() / want.abs().max(1.0));
        }
        assert!(worst < 1e-12, "largest relative difference {worst:e}");
        // A sparse set of wanted monomials still reaches every term it needs.
        let wanted = [4 * var(0) + 3 * var(2), 2 * var(1) + 5 * var(2)];
        let mut m = RawMoments::with_monomials(3, 7, &wanted);
        m.sums = m.monomials().iter().map(|&e| moment(e, true)).collect();
        m.count = 1;
        m.deconvolve(&noise);
        for e in wanted {
            assert!((m.moment(e) - moment(e, false)).abs() < 1e-12 * moment(e, false).abs().max(1.0));
        }
        // The one-variable power sums the same way.
        let mut p: Vec<f64> = (0..8).map(|b| gauss(0.4, 1.3 + 0.25, b)).collect();
        deconvolve_powers(&mut p, 0.25);
        for (b, got) in p.iter().enumerate() {
            let want = gauss(0.4, 1.3, b as u32);
            assert!(
                (got - want).abs() < 1e-12 * want.abs().max(1.0),
                "power {b}: {got} against {want}"
            );
        }
    }
}

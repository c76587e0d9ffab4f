//! Power spectral density of a measured force and the fit of the rational spectral
//! density (3.20) `S(ω) = A² / (2π (B² + ω²))` of an Ornstein–Uhlenbeck force to it.
//!
//! The estimate is Welch's: Hann-windowed segments with 50 % overlap, averaged
//! periodograms, streamed per trajectory in constant memory. It is a two-sided density in
//! angular frequency (`∫ S dω` = variance), the paper's convention. Because the force is
//! sampled every `Δ`, the fit uses the exact spectrum of the sampled process (an AR(1)
//! with `φ = e^{−BΔ}`), which tends to (3.20) as `Δ → 0`, so aliasing does not bias `B`.
//! Each segment's transform is a real-input FFT (`realfft`, over `rustfft`): half the work
//! of a complex transform of real data, in its maintained vectorised kernels.

use realfft::num_complex::Complex;
use realfft::{RealFftPlanner, RealToComplex};
use std::f64::consts::PI;
use std::sync::Arc;

/// A planned real-input FFT of one length (shared by the clones of an estimator).
#[derive(Clone)]
struct RealFft(Arc<dyn RealToComplex<f64>>);

impl std::fmt::Debug for RealFft {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "RealFft({})", self.0.len())
    }
}

/// A one-sided view of a two-sided spectral density estimate.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Spectrum {
    /// Angular frequencies, rad/s (excluding 0, up to Nyquist).
    pub omega: Vec<f64>,
    /// Two-sided spectral density at `omega`, unit²·s/rad.
    pub density: Vec<f64>,
    /// Segments averaged.
    pub segments: usize,
    pub segment_len: usize,
    pub sample_interval: f64,
}

/// Fitted `A`, `B` of (3.20) and the quality of the fit.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct OuFit {
    pub a: f64,
    pub b: f64,
    /// RMS of `ln Ŝ − ln S_fit` over the fitted frequencies (0 = perfect; the scatter of
    /// a log-periodogram averaged over K segments is about `1/√K`).
    pub rms_log_residual: f64,
    /// Expected RMS of the log residual from the averaging alone, `≈ 1/√K`.
    pub expected_rms: f64,
}

/// Streaming Welch estimate for one signal sampled every `dt` in several trajectories.
#[derive(Debug, Clone)]
pub struct Welch {
    len: usize,
    dt: f64,
    window: Vec<f64>,
    wsum2: f64,
    /// Per trajectory: samples not yet in a processed segment.
    buffers: Vec<Vec<f64>>,
    acc: Vec<f64>,
    segments: usize,
    fft: RealFft,
    /// Scratch: the windowed segment, its transform `k = 0..=len/2`, the FFT's own.
    input: Vec<f64>,
    output: Vec<Complex<f64>>,
    scratch: Vec<Complex<f64>>,
}

impl Welch {
    /// Segments of `len` samples (rounded up to a power of two, at least 16).
    pub fn new(len: usize, dt: f64, trajectories: usize) -> Welch {
        let len = len.next_power_of_two().max(16);
        let window: Vec<f64> = (0..len)
            .map(|k| 0.5 - 0.5 * (2.0 * PI * k as f64 / len as f64).cos())
            .collect();
        let wsum2 = window.iter().map(|w| w * w).sum();
        let fft = RealFftPlanner::<f64>::new().plan_fft_forward(len);
        Welch {
            len,
            dt,
            window,
            wsum2,
            // Each its own capacity (`vec![v; n]` clones, and a clone keeps none).
            buffers: (0..trajectories).map(|_| Vec::with_capacity(len)).collect(),
            acc: vec![0.0; len / 2 + 1],
            segments: 0,
            input: fft.make_input_vec(),
            output: fft.make_output_vec(),
            scratch: fft.make_scratch_vec(),
            fft: RealFft(fft),
        }
    }

    /// The segment length that resolves a corner `b_guess` (rad/s) with 32 bins below it,
    /// capped so that each trajectory gives at least 8 segments.
    pub fn segment_for(b_guess: f64, dt: f64, samples_per_trajectory: usize) -> usize {
        let want = (32.0 * 2.0 * PI / (b_guess.max(1e-9) * dt)).ceil() as usize;
        let cap = (samples_per_trajectory / 4).max(16).next_power_of_two() / 2;
        want.next_power_of_two().clamp(64, cap.max(64))
    }

    /// An empty estimator with this one's segment length and interval for `trajectories`.
    pub fn fresh(&self, trajectories: usize) -> Welch {
        Welch::new(self.len, self.dt, trajectories)
    }

    /// Room for `trajectories` (more than it was made for; never fewer).
    pub fn grow(&mut self, trajectories: usize) {
        let len = self.len;
        if trajectories > self.buffers.len() {
            self.buffers.resize_with(trajectories, || Vec::with_capacity(len));
        }
    }

    pub fn push(&mut self, trajectory: usize, x: f64) {
        if trajectory >= self.buffers.len() {
            return;
        }
        self.buffers[trajectory].push(x);
        if self.buffers[trajectory].len() == self.len {
            self.segment_and_overlap(trajectory);
        }
    }

    /// Values `xs` of the trajectories `trajectories` (one each) in the order given: what
    /// samples interleaved across trajectories (a log's: one instant of every trajectory,
    /// then the next) are pushed by, with no search for runs that are one sample long.
    pub fn push_each(&mut self, trajectories: &[u32], xs: &[f64]) {
        for (&t, &x) in trajectories.iter().zip(xs) {
            self.push(t as usize, x);
        }
    }

    /// Successive values `xs` of one trajectory: the same segments as pushing them one by
    /// one, copied into the segment buffer a stretch at a time.
    pub fn push_run(&mut self, trajectory: usize, mut xs: &[f64]) {
        if trajectory >= self.buffers.len() {
            return;
        }
        while !xs.is_empty() {
            let buffer = &mut self.buffers[trajectory];
            let take = (self.len - buffer.len()).min(xs.len());
            buffer.extend_from_slice(&xs[..take]);
            xs = &xs[take..];
            if buffer.len() == self.len {
                self.segment_and_overlap(trajectory);
            }
        }
    }

    /// The full buffer of `trajectory` taken as a segment; its second half kept as the next
    /// one's first (50 % overlap, in the same buffer: no allocation).
    fn segment_and_overlap(&mut self, trajectory: usize) {
        let mut seg = std::mem::take(&mut self.buffers[trajectory]);
        self.segment(&seg);
        seg.copy_within(self.len / 2.., 0);
        seg.truncate(self.len / 2);
        self.buffers[trajectory] = seg;
    }

    fn segment(&mut self, seg: &[f64]) {
        let mean = seg.iter().sum::<f64>() / seg.len() as f64;
        for ((x, &s), &w) in self.input.iter_mut().zip(seg).zip(&self.window) {
            *x = (s - mean) * w;
        }
        self.fft
            .0
            .process_with_scratch(&mut self.input, &mut self.output, &mut self.scratch)
            .expect("buffers made by the plan");
        for (a, z) in self.acc.iter_mut().zip(&self.output) {
            *a += z.norm_sqr();
        }
        self.segments += 1;
    }

    /// The averaged two-sided density at `ω_k = 2πk/(len·dt)`, `k = 1..=len/2`.
    pub fn spectrum(&self) -> Spectrum {
        let scale = self.dt / (2.0 * PI * self.wsum2 * self.segments.max(1) as f64);
        let omega = (1..=self.len / 2)
            .map(|k| 2.0 * PI * k as f64 / (self.len as f64 * self.dt))
            .collect();
        let density = (1..=self.len / 2).map(|k| self.acc[k] * scale).collect();
        Spectrum {
            omega,
            density,
            segments: self.segments,
            segment_len: self.len,
            sample_interval: self.dt,
        }
    }
}

/// How one signal relates to another's rate of change ([`CrossWelch::derivative_gain`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Derivative {
    /// Its size over the rate of change's: 1 for the derivative in the same units.
    pub gain: f64,
    /// +1 a quarter period ahead (the derivative), −1 behind (its negative), 0 in phase.
    pub lead: f64,
}

/// Streaming Welch estimate of two signals `q`, `r` and their cross-spectrum, so that the
/// spectrum of any combination `q + c·r` follows without another pass (the paper's
/// `P3s = P2 + m1ẍ1 + 2k1(x1 − x2)` for every iterate of `k1`, (4.9)).
#[derive(Debug, Clone)]
pub struct CrossWelch {
    q: Welch,
    r: Welch,
    /// `Σ Re(Q R̄)` and `Σ Im(Q R̄)` per frequency.
    cross: Vec<f64>,
    cross_im: Vec<f64>,
}

impl CrossWelch {
    pub fn new(len: usize, dt: f64, trajectories: usize) -> CrossWelch {
        let q = Welch::new(len, dt, trajectories);
        let cross = vec![0.0; q.len / 2 + 1];
        CrossWelch {
            r: q.clone(),
            cross_im: cross.clone(),
            q,
            cross,
        }
    }

    pub fn push(&mut self, trajectory: usize, q: f64, r: f64) {
        if trajectory >= self.q.buffers.len() {
            return;
        }
        self.q.buffers[trajectory].push(q);
        self.r.buffers[trajectory].push(r);
        if self.q.buffers[trajectory].len() == self.q.len {
            let len = self.q.len;
            for w in [&mut self.q, &mut self.r] {
                // 50 % overlap, in the same buffer (no allocation).
                let mut seg = std::mem::take(&mut w.buffers[trajectory]);
                w.segment(&seg);
                seg.copy_within(len / 2.., 0);
                seg.truncate(len / 2);
                w.buffers[trajectory] = seg;
            }
            // Both transforms are still in the scratch buffers.
            for (k, (q, r)) in self.q.output.iter().zip(&self.r.output).enumerate() {
                self.cross[k] += q.re * r.re + q.im * r.im;
                self.cross_im[k] += q.im * r.re - q.re * r.im;
            }
        }
    }

    /// How `r` relates to the rate of change of `q` where `q` has its power, over the
    /// frequencies whose coherence is at least [`DERIVATIVE_COHERENCE`] among those
    /// that hold 99 % of `q`'s variance, below 0.7 of the Nyquist frequency:
    /// the gain `Σ ω |S_qr| / Σ ω² S_qq` and the lead `Σ ω Im S_rq / Σ ω |S_qr|`. For
    /// `r = dq/dt`, `S_rq = iω S_qq`: the gain is 1 at any sampling that resolves `q`
    /// (aliasing aside) and the lead +1 (`r` a quarter period ahead); `r` in other units
    /// gives their factor as the gain, `r = −dq/dt` a lead of −1. `None` without segments
    /// or power.
    pub fn derivative_gain(&self) -> Option<Derivative> {
        let sq = self.q.spectrum();
        if sq.segments == 0 {
            return None;
        }
        let total: f64 = sq.density.iter().sum();
        if total.is_nan() || total <= 0.0 {
            return None;
        }
        let nyquist = PI / self.q.dt;
        // Sensor noise lifts `S_qq` by its floor where the motion is weak: bins whose
        // coherence shows them dominated by noise are left out (all kept if fewer than a
        // few are left, so that unrelated columns still show a wrong gain).
        let coherence = |k: usize| {
            let c2 = self.cross[k].powi(2) + self.cross_im[k].powi(2);
            c2 / (self.q.acc[k] * self.r.acc[k])
        };
        let mut band = Vec::new();
        let mut seen = 0.0;
        for (k, (&w, &d)) in sq.omega.iter().zip(&sq.density).enumerate() {
            if seen >= 0.99 * total || w > 0.7 * nyquist {
                break;
            }
            seen += d;
            band.push((k, w));
        }
        let coherent: Vec<(usize, f64)> = band
            .iter()
            .copied()
            .filter(|&(k, _)| coherence(k + 1) >= DERIVATIVE_COHERENCE)
            .collect();
        if coherent.len() >= 3 {
            band = coherent;
        }
        let (mut num, mut den, mut lead) = (0.0, 0.0, 0.0);
        for (k, w) in band {
            num += w * self.cross[k + 1].hypot(self.cross_im[k + 1]);
            // `cross_im` is `Im(Q R̄)`, so `Im S_rq` is its negative.
            lead -= w * self.cross_im[k + 1];
            den += w * w * self.q.acc[k + 1];
        }
        (den > 0.0 && num > 0.0).then(|| Derivative {
            gain: num / den,
            lead: lead / num,
        })
    }

    /// Spectrum of `q + c·r`: `S_qq + 2c Re S_qr + c² S_rr`.
    pub fn spectrum_of(&self, c: f64) -> Spectrum {
        let mut s = self.q.spectrum();
        let sr = self.r.spectrum();
        let scale = self.q.dt / (2.0 * PI * self.q.wsum2 * self.q.segments.max(1) as f64);
        for (k, d) in s.density.iter_mut().enumerate() {
            *d += 2.0 * c * self.cross[k + 1] * scale + c * c * sr.density[k];
        }
        s
    }
}

/// Smallest coherence `|S_qr|² / (S_qq S_rr)` of a frequency that
/// [`CrossWelch::derivative_gain`] judges by: at 0.8, sensor noise lifts `S_qq` there by at
/// most 25 % (docs/measurement.md).
pub const DERIVATIVE_COHERENCE: f64 = 0.8;

/// Two-sided density of an OU process `dP = −B P dt + A dW` sampled every `dt`, at `ω`.
pub fn sampled_ou_density(a: f64, b: f64, dt: f64, omega: f64) -> f64 {
    let phi = (-b * dt).exp();
    let var = a * a / (2.0 * b);
    dt / (2.0 * PI) * var * (1.0 - phi * phi) / (1.0 - 2.0 * phi * (omega * dt).cos() + phi * phi)
}

/// The rational density (3.20), `A² / (2π (B² + ω²))`.
pub fn ou_density(a: f64, b: f64, omega: f64) -> f64 {
    a * a / (2.0 * PI * (b * b + omega * omega))
}

/// `s` with a white noise floor of density `floor` taken out, where the force stands out
/// of it: the bins at least twice the floor (a force cell's noise, stated, adds `floor`
/// to every bin; what is left is the force's own spectrum, which (3.20) is fitted to).
pub fn without_floor(s: &Spectrum, floor: f64) -> Spectrum {
    let (omega, density) = s
        .omega
        .iter()
        .zip(&s.density)
        .filter(|(_, &d)| d >= 2.0 * floor)
        .map(|(&w, &d)| (w, d - floor))
        .unzip();
    Spectrum {
        omega,
        density,
        ..s.clone()
    }
}

/// The variance under a spectrum (`∫ S dω` over both signs of `ω`).
pub fn variance(s: &Spectrum) -> f64 {
    let dw = if s.omega.len() > 1 {
        s.omega[1] - s.omega[0]
    } else {
        0.0
    };
    2.0 * s.density.iter().sum::<f64>() * dw
}

/// Lowest frequency bins left out of the fit.
pub const SKIP_LOW_BINS: usize = 3;

/// Fit `A`, `B` to an estimated spectrum by least squares on the log density (golden
/// section over `ln B`, `A` in closed form for each `B`).
pub fn fit_ou(s: &Spectrum) -> OuFit {
    // The lowest bins are left out: removing each segment's mean under the Hann window
    // depresses them, which would bias B upwards.
    let skip = SKIP_LOW_BINS.min(s.omega.len().saturating_sub(8));
    let s = &Spectrum {
        omega: s.omega[skip..].to_vec(),
        density: s.density[skip..].to_vec(),
        segments: s.segments,
        segment_len: s.segment_len,
        sample_interval: s.sample_interval,
    };
    let dt = s.sample_interval;
    let logs: Vec<f64> = s.density.iter().map(|d| d.max(1e-300).ln()).collect();
    // For a given B, the best ln A² is the mean of ln Ŝ − ln shape(B).
    let cost = |b: f64| -> (f64, f64) {
        let shape: Vec<f64> = s
            .omega
            .iter()
            .map(|&w| sampled_ou_density(1.0, b, dt, w).ln())
            .collect();
        let la2 = logs.iter().zip(&shape).map(|(l, h)| l - h).sum::<f64>() / logs.len() as f64;
        let ss = logs.iter().zip(&shape).map(|(l, h)| (l - h - la2).powi(2)).sum::<f64>();
        (ss, la2)
    };
    let b = best_corner(s.omega[0], s.omega[s.omega.len() - 1], |b| cost(b).0);
    let (ss, la2) = cost(b);
    // E[ln] of an average of K periodograms is ln S − 1/(2K) − …: undo that bias.
    let k = s.segments.max(1) as f64;
    let la2 = la2 + 1.0 / (2.0 * k) + 1.0 / (12.0 * k * k);
    OuFit {
        a: (la2 / 2.0).exp(),
        b,
        rms_log_residual: (ss / logs.len() as f64).sqrt(),
        expected_rms: 1.0 / (s.segments.max(1) as f64).sqrt(),
    }
}

/// The density of spectra of parts of the data (one segment length) pooled, each part
/// weighing by its segments.
pub fn pooled_density<'a>(parts: impl IntoIterator<Item = &'a Spectrum>) -> Vec<f64> {
    let (mut d, mut k) = (Vec::new(), 0.0);
    for s in parts {
        d.resize(s.density.len(), 0.0);
        for (a, b) in d.iter_mut().zip(&s.density) {
            *a += b * s.segments as f64;
        }
        k += s.segments as f64;
    }
    d.iter().map(|a| a / f64::max(k, 1.0)).collect()
}

/// The corner `B` that minimises `cost` between `ω_lo/100` and `100·ω_hi`: a scan of
/// `ln B` in 200 steps, then a golden section around the best point.
fn best_corner(omega_lo: f64, omega_hi: f64, cost: impl Fn(f64) -> f64) -> f64 {
    let (mut lo, mut hi) = ((omega_lo / 100.0).ln(), (100.0 * omega_hi).ln());
    let mut best = lo;
    let mut best_cost = f64::INFINITY;
    for k in 0..=200 {
        let lb = lo + (hi - lo) * k as f64 / 200.0;
        let c = cost(lb.exp());
        if c < best_cost {
            best_cost = c;
            best = lb;
        }
    }
    let step = (hi - lo) / 200.0;
    lo = best - step;
    hi = best + step;
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..100 {
        let (m1, m2) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if cost(m1.exp()) < cost(m2.exp()) {
            hi = m2;
        } else {
            lo = m1;
        }
    }
    (0.5 * (lo + hi)).exp()
}

/// A white noise floor under a force's spectrum (a force cell's noise), estimated with
/// the rational density it sits on: `Ŝ(ω) ≈ A²·g_B(ω) + N`, `g_B` the sampled (3.20) shape
/// of unit `A`. For each `B`, `A²` and `N` follow by least squares on the relative
/// residuals `(Ŝ − A²g_B − N)/Ŝ` (each bin's scatter is the same share of it); `B` by a
/// scan and a golden section of that cost over `ln B`. The floor shows where the force's
/// density has fallen towards it, above the corner `B`; its standard error is the
/// delete-one jackknife over the `parts` (spectra of parts of the data, one segment length,
/// the first the whole). `None` without enough bins.
pub fn ou_noise_floor(parts: &[Spectrum]) -> Option<(f64, f64)> {
    let whole = parts.first()?;
    let skip = SKIP_LOW_BINS.min(whole.omega.len().saturating_sub(8));
    if whole.omega.len() < skip + 8 || whole.segments == 0 {
        return None;
    }
    let dt = whole.sample_interval;
    let floor_of = |density: &[f64]| -> f64 {
        let bins = skip..density.len();
        // (cost, N) for a B.
        let solve = |b: f64| -> (f64, f64) {
            let (mut sgg, mut sg1, mut s11, mut sgy, mut s1y) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for k in bins.clone() {
                let w = 1.0 / density[k].max(1e-300).powi(2);
                let g = sampled_ou_density(1.0, b, dt, whole.omega[k]);
                sgg += w * g * g;
                sg1 += w * g;
                s11 += w;
                sgy += w * g * density[k];
                s1y += w * density[k];
            }
            let det = sgg * s11 - sg1 * sg1;
            let (a2, n) = if det.abs() > 0.0 {
                ((sgy * s11 - sg1 * s1y) / det, (sgg * s1y - sg1 * sgy) / det)
            } else {
                (0.0, 0.0)
            };
            let cost = bins
                .clone()
                .map(|k| {
                    let g = sampled_ou_density(1.0, b, dt, whole.omega[k]);
                    ((density[k] - a2 * g - n) / density[k].max(1e-300)).powi(2)
                })
                .sum::<f64>();
            (cost, n)
        };
        solve(best_corner(
            whole.omega[skip],
            whole.omega[whole.omega.len() - 1],
            |b| solve(b).0,
        ))
        .1
    };
    let n = floor_of(&whole.density);
    // Leave-one-out densities from the parts (after the whole), by their segments.
    let rest = &parts[1..];
    if rest.len() < 3 {
        return Some((n, f64::NAN));
    }
    let reps: Vec<f64> = (0..rest.len())
        .map(|leave| {
            let d = pooled_density(rest.iter().enumerate().filter(|&(p, _)| p != leave).map(|(_, s)| s));
            floor_of(&d)
        })
        .collect();
    let g = reps.len() as f64;
    let mean = reps.iter().sum::<f64>() / g;
    let se = ((g - 1.0) / g * reps.iter().map(|r| (r - mean).powi(2)).sum::<f64>()).sqrt();
    Some((n, se))
}

/// Share of the response's variance left out of the band at each end (below and above).
pub const BAND_TAIL: f64 = 0.01;

/// The force's band: the bins about the response's band where its density is within this
/// factor of the level.
pub const FORCE_BAND: f64 = 0.1;

/// The white noise equivalent to a measured force over the band where the response has
/// its energy (docs/methods.md, "The force model").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BandLevel {
    /// Two-sided density of the equivalent white noise, unit²·s/rad (`σ² / 2π`).
    pub density: f64,
    /// The response's band, rad/s: the bins holding all but [`BAND_TAIL`] of its variance
    /// at either end.
    pub band: (f64, f64),
    /// The force's band, rad/s: where its density is within [`FORCE_BAND`] of the level;
    /// its lower edge is 0 where the force keeps its level down to the lowest frequency
    /// analysed (the data show no edge there).
    pub force_band: (f64, f64),
    /// The share of the system's gain outside the force's band (`∫|H|²` beyond its edges,
    /// over all of it): what a white force would have driven and this one does not. The
    /// level is corrected for it.
    pub edge_share: f64,
    /// RMS of `ln(Ŝ_F / S̄)` over the response's band, weighted by the response's density,
    /// `S̄` the band's own level: 0 for a force flat over the band.
    pub rms_log_residual: f64,
    /// What the averaging alone gives of that RMS, `≈ 1/√K`.
    pub expected_rms: f64,
}

/// The level of the white noise equivalent to the force of spectrum `force` for a response
/// (a velocity it drives) of spectrum `response` on the same bins. With the system's gain
/// `G = S_v / S_F = |H(ω)|²` measured over the force's band `F`, a white force of density
/// `S̄` gives the velocity the variance `S̄ ∫G`, and the measured force gives `∫_F S_v`; so
/// `S̄ = ∫_F S_v / ∫G`, the gain beyond `F` extrapolated as a velocity's above and below
/// its modes (`G ∝ ω⁻²` above: `∫_{ω_u}^∞ G = G(ω_u)·ω_u`; `G ∝ ω²` below:
/// `∫_0^{ω_l} G = G(ω_l)·ω_l/3`). For a linear system it is the one white level that gives
/// the response its measured variance, so the energy balance the FPK equation rests on
/// holds with it. `None` without bins, segments or force power where the response is.
pub fn band_level(force: &Spectrum, response: &Spectrum) -> Option<BandLevel> {
    let bins = force.omega.len().min(response.omega.len());
    let skip = SKIP_LOW_BINS.min(bins.saturating_sub(8));
    if bins < skip + 8 || force.segments == 0 || response.segments == 0 {
        return None;
    }
    let omega = &force.omega[skip..bins];
    let sv = &response.density[skip..bins];
    let sf = &force.density[skip..bins];
    let total: f64 = sv.iter().sum();
    if total <= 0.0 || !total.is_finite() {
        return None;
    }
    let (mut lo, mut hi, mut cum) = (None, 0, 0.0);
    for (k, &d) in sv.iter().enumerate() {
        cum += d;
        if lo.is_none() && cum >= BAND_TAIL * total {
            lo = Some(k);
        }
        if cum <= (1.0 - BAND_TAIL) * total {
            hi = k + 1;
        }
    }
    let lo = lo?;
    let hi = hi.max(lo).min(sv.len() - 1);
    if (lo..=hi).any(|k| sf[k] <= 0.0) {
        return None;
    }
    let level = |range: std::ops::RangeInclusive<usize>| {
        let v: f64 = range.clone().map(|k| sv[k]).sum();
        v / range.map(|k| sv[k] / sf[k]).sum::<f64>()
    };
    let own = level(lo..=hi);
    let rms = ((lo..=hi).map(|k| sv[k] * (sf[k] / own).ln().powi(2)).sum::<f64>()
        / (lo..=hi).map(|k| sv[k]).sum::<f64>())
    .sqrt();
    // The force's band: outwards from the response's while the force stays near its level.
    let near = |k: usize| sf[k] >= FORCE_BAND * own;
    let (mut fl, mut fu) = (lo, hi);
    while fl > 0 && near(fl - 1) {
        fl -= 1;
    }
    while fu + 1 < sf.len() && near(fu + 1) {
        fu += 1;
    }
    let dw = if omega.len() > 1 { omega[1] - omega[0] } else { 1.0 };
    let gain = |k: usize| sv[k] / sf[k];
    // The gain at an edge: the mean over its three outermost bins, against their scatter.
    let edge = |ks: [usize; 3]| ks.iter().map(|&k| gain(k)).sum::<f64>() / 3.0;
    let inside: f64 = (fl..=fu).map(gain).sum::<f64>() * dw;
    let upper = if fu + 1 < sf.len() && fu >= fl + 2 {
        edge([fu - 2, fu - 1, fu]) * omega[fu]
    } else {
        0.0
    };
    let lower = if fl > 0 && fu >= fl + 2 {
        edge([fl, fl + 1, fl + 2]) * omega[fl] / 3.0
    } else {
        0.0
    };
    let driven: f64 = (fl..=fu).map(|k| sv[k]).sum::<f64>() * dw;
    Some(BandLevel {
        density: driven / (inside + upper + lower),
        band: (omega[lo], omega[hi]),
        force_band: (if fl == 0 { 0.0 } else { omega[fl] }, omega[fu]),
        edge_share: (upper + lower) / (inside + upper + lower),
        rms_log_residual: rms,
        expected_rms: 1.0 / (force.segments as f64).sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values pushed in runs of one trajectory (runs that end mid-segment, span several
    /// segments, and alternate between trajectories) give the spectrum of pushing them one
    /// by one, bit for bit.
    #[test]
    fn runs_give_the_spectrum_of_single_values() {
        let x = |t: usize, k: usize| ((0.37 + 0.11 * t as f64) * k as f64).sin() + 1e-3 * (k % 7) as f64;
        let (mut one, mut runs) = (Welch::new(64, 0.1, 3), Welch::new(64, 0.1, 3));
        let mut next = [0usize; 3];
        for (step, len) in [5usize, 64, 1, 200, 31, 33, 0, 96]
            .into_iter()
            .cycle()
            .take(60)
            .enumerate()
        {
            let t = step % 3;
            let xs: Vec<f64> = (next[t]..next[t] + len).map(|k| x(t, k)).collect();
            next[t] += len;
            xs.iter().for_each(|&v| one.push(t, v));
            runs.push_run(t, &xs);
        }
        runs.push_run(3, &[1.0, 2.0]);
        let (a, b) = (one.spectrum(), runs.spectrum());
        assert!(a.density.iter().any(|&d| d > 0.0));
        assert_eq!(a.density, b.density);
        assert_eq!(one.segments, runs.segments);
    }

    /// A two-tone signal and its exact rate of change, sampled every 0.05 s.
    fn fit(pair: impl Fn(f64) -> (f64, f64)) -> Derivative {
        let mut w = CrossWelch::new(512, 0.05, 1);
        for k in 0..20_000 {
            let (q, r) = pair(0.05 * k as f64);
            w.push(0, q, r);
        }
        w.derivative_gain().unwrap()
    }

    #[test]
    fn a_derivative_leads_and_its_negative_or_a_swap_does_not() {
        let x = |t: f64| (1.3 * t).sin() + 0.5 * (3.1 * t).cos();
        let v = |t: f64| 1.3 * (1.3 * t).cos() - 1.55 * (3.1 * t).sin();
        let d = fit(|t| (x(t), v(t)));
        assert!((d.gain - 1.0).abs() < 0.05 && d.lead > 0.95, "{d:?}");
        let d = fit(|t| (x(t), -v(t)));
        assert!((d.gain - 1.0).abs() < 0.05 && d.lead < -0.95, "{d:?}");
        // Swapped: the displacement as the velocity's rate of change lags it and is
        // 1/ω² of its size.
        let d = fit(|t| (v(t), x(t)));
        assert!(d.lead < -0.95 && d.gain < 0.4, "{d:?}");
    }

    /// An oscillator's velocity gain `|H|² = ω² / ((ω_n² − ω²)² + (2ζω_nω)²)` on a grid.
    fn oscillator(force: impl Fn(f64) -> f64) -> (Spectrum, Spectrum) {
        let (wn, zeta) = (30.0, 0.05);
        let omega: Vec<f64> = (1..=512).map(|k| k as f64 * 0.25).collect();
        let sf: Vec<f64> = omega.iter().map(|&w| force(w)).collect();
        let sv = omega
            .iter()
            .zip(&sf)
            .map(|(&w, f)| f * w * w / ((wn * wn - w * w).powi(2) + (2.0 * zeta * wn * w).powi(2)))
            .collect();
        let spectrum = |density| Spectrum {
            omega: omega.clone(),
            density,
            segments: 100,
            segment_len: 1024,
            sample_interval: 0.01,
        };
        (spectrum(sf), spectrum(sv))
    }

    /// A force flat over the response's band is its own equivalent white noise, whatever
    /// it does far outside; one that falls inside the band is not flat there, and says so;
    /// one whose band ends inside the resonance leaves much of the gain undriven.
    #[test]
    fn the_equivalent_white_level_of_a_band_limited_force() {
        // Flat at 2 up to 3.3 times the mode, a trace above: the gain beyond the edge is a
        // velocity's tail, 2 % of it, which a white force of level 2 would drive and this
        // one does not; the equivalent level is 2 less that share, to within the tail's
        // extrapolation as ω⁻².
        let (f, v) = oscillator(|w| if w < 100.0 { 2.0 } else { 1e-9 });
        let l = band_level(&f, &v).unwrap();
        // ∫G over all ω is π/(2c), c = 2ζω_n; the tail above 100 rad/s numerically.
        let gain = |w: f64| w * w / ((900.0 - w * w).powi(2) + (3.0 * w).powi(2));
        let tail: f64 = (0..2_000_000)
            .map(|i| gain(99.875 + (i as f64 + 0.5) * 0.01) * 0.01)
            .sum::<f64>()
            + 1.0 / (99.875 + 20_000.0);
        let exact = 2.0 * (1.0 - tail / (std::f64::consts::PI / 6.0));
        assert!(
            (l.density / exact - 1.0).abs() < 0.005 && l.density < 1.99,
            "{l:?} against {exact}"
        );
        assert!(l.edge_share > 0.005 && l.edge_share < 0.05, "{l:?}");
        assert!(l.rms_log_residual < 1e-12);
        assert!(l.band.0 < 30.0 && l.band.1 > 30.0 && l.band.1 < 100.0, "{:?}", l.band);
        assert!(l.force_band.1 < 100.0 && l.force_band.1 > 99.0, "{:?}", l.force_band);
        assert!((l.expected_rms - 0.1).abs() < 1e-12);
        // Flat everywhere: no edge, the level exactly.
        let (f, v) = oscillator(|_| 2.0);
        let l = band_level(&f, &v).unwrap();
        assert!((l.density / 2.0 - 1.0).abs() < 1e-12 && l.edge_share == 0.0, "{l:?}");
        // Halved above 25 rad/s, inside the resonance: the misfit is about half of ln 2 (a
        // systematic misfit, which the check weighs against the averaging's `1/√K`).
        let (f, v) = oscillator(|w| if w < 25.0 { 2.0 } else { 1.0 });
        let l = band_level(&f, &v).unwrap();
        assert!(l.density > 1.0 && l.density < 2.0 && l.rms_log_residual > 0.15, "{l:?}");
        // Ending at the mode: the flat part is flat, but half the gain is beyond its edge.
        let (f, v) = oscillator(|w| if w < 30.0 { 2.0 } else { 1e-9 });
        let l = band_level(&f, &v).unwrap();
        assert!(l.edge_share > 0.3, "{l:?}");
    }

    /// An Ornstein–Uhlenbeck force (A = B = 5) sampled exactly every 0.1 s, 16 × 25,000
    /// samples, with white noise of 30 % of its std added: the floor `σ²h/(2π)` comes back
    /// within 10 % and three standard errors; without the noise, nothing beyond them.
    #[test]
    fn a_white_floor_under_a_rational_spectrum_is_found() {
        use crate::sim::sensors::normal;
        let (a, b, h, records, len) = (5.0f64, 5.0f64, 0.1f64, 16, 25_000);
        let phi = (-b * h).exp();
        let sd = (a * a / (2.0 * b)).sqrt();
        let floor_of = |noise: f64| {
            let mut whole = Welch::new(512, h, records);
            let mut parts = vec![whole.fresh(records); 8];
            for r in 0..records {
                let mut p = sd * normal(3, r as u64, 0, 0);
                for n in 0..len {
                    p = phi * p + sd * (1.0 - phi * phi).sqrt() * normal(3, r as u64, n as u64 + 1, 0);
                    let y = p + noise * sd * normal(4, r as u64, n as u64, 1);
                    whole.push(r, y);
                    parts[r % 8].push(r, y);
                }
            }
            let mut all = vec![whole.spectrum()];
            all.extend(parts.iter().map(|w| w.spectrum()));
            ou_noise_floor(&all).unwrap()
        };
        let (clean, clean_se) = floor_of(0.0);
        assert!(clean < 3.0 * clean_se, "{clean} ± {clean_se}");
        let truth = (0.3 * sd).powi(2) * h / (2.0 * PI);
        let (n, se) = floor_of(0.3);
        assert!(
            (n / truth - 1.0).abs() < 0.1 && (n - truth).abs() < 3.0 * se,
            "{n} ± {se} against {truth}"
        );
    }
}

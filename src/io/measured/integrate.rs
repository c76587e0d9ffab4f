//! Velocities and displacements from measured accelerations, for rigs that have
//! accelerometers and force cells only (docs/data.md, "Accelerations only").
//!
//! Each integral is the trapezoid rule over the samples (the velocity from accelerations
//! that are interval means, `(v_k − v_{k−1})/h` as fpkbench's own log holds them: the
//! rectangle rule, which is exact for them; [`AccelerationSamples`]), with its slow part
//! taken out: a centred triangular mean over `4·half + 1` samples (a running mean of a
//! running mean, each over `2·half + 1`), subtracted from the integral. That is a
//! zero-phase high-pass: it passes `1 − sinc²(ω·(2·half + 1)·h/2)`, so the motion keeps its phase and, well
//! above the corner, its amplitude to `(ω·W/2)⁻²`, `W` the window's half width in time
//! (a single running mean's sidelobes would leave `(ω·W/2)⁻¹`, a per cent at duffing2dof's
//! frequencies). What it takes out is the integration constant, the random walk an
//! accelerometer's noise and offset make of the velocity, and the motion's own content
//! below the corner. The velocity is ready `2·half` samples after its acceleration, the
//! displacement `4·half`; the first and last `4·half` samples of every record are not
//! handed over (their windows would reach past the record's ends).

pub use crate::scenario::AccelerationSamples;

impl AccelerationSamples {
    /// The rule's name, for the report.
    pub fn rule(self) -> &'static str {
        match self {
            AccelerationSamples::Instants => "trapezoid rule",
            AccelerationSamples::IntervalMeans => {
                "rectangle rule for the velocity, the accelerations being interval means; trapezoid rule for the \
                 displacement"
            }
        }
    }

    /// The velocity's gain from the acceleration at `ω`: the trapezoid rule's
    /// `(h/2)·cot(ωh/2)` or the rectangle rule's `|h/(1 − e^{−iωh})| = h/(2·sin(ωh/2))`.
    fn velocity_gain(self, w: f64, h: f64) -> f64 {
        let s = (0.5 * w * h).sin();
        match self {
            AccelerationSamples::Instants => 0.5 * h * (0.5 * w * h).cos() / s,
            AccelerationSamples::IntervalMeans => 0.5 * h / s,
        }
    }

    /// The displacement's gain from the acceleration at `ω`: the velocity's times the
    /// trapezoid rule's.
    fn displacement_gain(self, w: f64, h: f64) -> f64 {
        self.velocity_gain(w, h) * AccelerationSamples::Instants.velocity_gain(w, h)
    }
}

/// A running mean over the last `len` values, kept in one lane of a ring its chain's
/// four windows share ([`Chain`]).
#[derive(Debug, Clone)]
struct Window {
    next: usize,
    filled: usize,
    sum: f64,
    /// Pushes since the sum was last summed afresh (its rounding stays bounded).
    since: usize,
}

impl Window {
    const EMPTY: Window = Window {
        next: 0,
        filled: 0,
        sum: 0.0,
        since: 0,
    };

    /// Push `x` into lane `lane` of `ring` (`len` entries); the mean of the last `len`
    /// values once there are that many.
    #[inline(always)]
    fn push(&mut self, ring: &mut [[f64; LANES]], lane: usize, x: f64) -> Option<f64> {
        let len = ring.len();
        self.sum += x - ring[self.next][lane];
        ring[self.next][lane] = x;
        self.next += 1;
        if self.next == len {
            self.next = 0;
        }
        self.filled = (self.filled + 1).min(len);
        self.since += 1;
        if self.since >= len {
            self.sum = ring.iter().map(|r| r[lane]).sum();
            self.since = 0;
        }
        (self.filled == len).then(|| self.sum / len as f64)
    }

    /// The oldest value in a full window.
    fn oldest(&self, ring: &[[f64; LANES]], lane: usize) -> f64 {
        ring[self.next][lane]
    }
}

/// A chain's windows: the velocity's two running means, then the displacement's.
const LANES: usize = 4;
const V_MEAN: usize = 0;
const V_MEAN2: usize = 1;
const X_MEAN: usize = 2;
const X_MEAN2: usize = 3;

/// One mass's acceleration → velocity → displacement.
///
/// Its four windows keep their values side by side in one ring (lane `k` for window `k`):
/// each starts when the one before it is full, that is at its ring's start, so all four
/// step through the ring together and a sample touches one entry, not four rings far apart
/// (a rig's chains, one per mass and record, are stepped in turn and miss the cache).
#[derive(Debug, Clone)]
pub(super) struct Chain {
    h: f64,
    samples: AccelerationSamples,
    a_last: Option<f64>,
    v_raw: f64,
    v_last: Option<f64>,
    x_raw: f64,
    windows: [Window; LANES],
    ring: Vec<[f64; LANES]>,
}

impl Chain {
    /// A chain for accelerations `samples` every `h` with drift windows of `2·half + 1`
    /// samples.
    pub(super) fn new(h: f64, half: usize, samples: AccelerationSamples) -> Chain {
        Chain {
            h,
            samples,
            a_last: None,
            v_raw: 0.0,
            v_last: None,
            x_raw: 0.0,
            windows: [Window::EMPTY; LANES],
            ring: vec![[0.0; LANES]; 2 * half + 1],
        }
    }

    /// A new record starts.
    pub(super) fn reset(&mut self) {
        self.a_last = None;
        self.v_raw = 0.0;
        self.v_last = None;
        self.x_raw = 0.0;
        self.windows = [Window::EMPTY; LANES];
    }

    /// Push the acceleration of sample `n`: the velocity of sample `n − 2·half` and the
    /// displacement of sample `n − 4·half`, once they are ready.
    #[inline]
    pub(super) fn push(&mut self, a: f64) -> (Option<f64>, Option<f64>) {
        self.v_raw += match self.samples {
            AccelerationSamples::Instants => self.a_last.map_or(0.0, |p| 0.5 * self.h * (p + a)),
            AccelerationSamples::IntervalMeans => self.h * a,
        };
        self.a_last = Some(a);
        let (ring, w) = (&mut self.ring[..], &mut self.windows);
        let Some(m1) = w[V_MEAN].push(ring, V_MEAN, self.v_raw) else {
            return (None, None);
        };
        let v_raw = w[V_MEAN].oldest(ring, V_MEAN);
        let Some(m2) = w[V_MEAN2].push(ring, V_MEAN2, m1) else {
            return (None, None);
        };
        let v = v_raw - m2;
        self.x_raw += self.v_last.map_or(0.0, |p| 0.5 * self.h * (p + v));
        self.v_last = Some(v);
        let Some(n1) = w[X_MEAN].push(ring, X_MEAN, self.x_raw) else {
            return (Some(v), None);
        };
        let x_raw = w[X_MEAN].oldest(ring, X_MEAN);
        (Some(v), w[X_MEAN2].push(ring, X_MEAN2, n1).map(|n2| x_raw - n2))
    }
}

/// The window's half width in samples for a corner `period` seconds long: the triangular
/// mean spans `4·half + 1` samples, `2·period` in all.
pub(super) fn half_for(period: f64, h: f64) -> usize {
    ((period / (2.0 * h)).round() as usize).max(1)
}

/// The noise variance the integration leaves on the velocity and on the displacement per
/// unit variance of a white noise on the acceleration (independent from sample to sample,
/// as a sensor's noise and an ADC's rounding are): `(h/π) ∫₀^{π/h} |G(ω)|² dω`, with
/// `G = I·P` for the velocity and `I·J·P²` for the displacement, `J(ω) = (h/2)·cot(ωh/2)`
/// the trapezoid rule's gain, `I` the velocity's rule's (`J`, or the rectangle rule's for
/// interval means) and `P(ω) = 1 − D(ω)²` the drift removal's, `D` a running
/// mean's over `L = 2·half + 1` samples, `sin(Lωh/2) / (L·sin(ωh/2))`. The noise is
/// Gaussian and independent of the motion, so the weak form's moments can be corrected for
/// it like for a white sensor noise of that variance (docs/measurement.md).
pub(super) fn noise_gains(h: f64, half: usize, samples: AccelerationSamples) -> (f64, f64) {
    let l = (2 * half + 1) as f64;
    // |G|² of the velocity and of the displacement.
    let gain = |w: f64| {
        let s = (0.5 * w * h).sin();
        let d = (0.5 * l * w * h).sin() / (l * s);
        let p2 = (1.0 - d * d).powi(2);
        (
            samples.velocity_gain(w, h).powi(2) * p2,
            samples.displacement_gain(w, h).powi(2) * p2 * p2,
        )
    };
    // On a logarithmic grid from far below the corner (where `|G|²` vanishes as `ω²`) to
    // the Nyquist frequency, by the trapezoid rule in `ln ω`.
    let (lo, hi) = ((1e-4 / (l * h)).ln(), (std::f64::consts::PI / h).ln());
    let n = 200_000;
    let (mut v, mut x) = (0.0, 0.0);
    for k in 0..=n {
        let w = (lo + (hi - lo) * k as f64 / n as f64).exp();
        let (gv, gx) = gain(w);
        let weight = if k == 0 || k == n { 0.5 } else { 1.0 } * w;
        v += weight * gv;
        x += weight * gx;
    }
    let du = (hi - lo) / n as f64;
    (h / std::f64::consts::PI * v * du, h / std::f64::consts::PI * x * du)
}

/// The drift removal's power gain at `ω` on the velocity, `G(ω)² = (1 − sinc²(ωW/2))²`
/// with `W = (2·half + 1)·h` (the displacement, high-passed twice, gets `G⁴`).
pub(super) fn drift_gain(omega: f64, h: f64, half: usize) -> f64 {
    let x = 0.5 * omega * (2 * half + 1) as f64 * h;
    let sinc = if x.abs() < 1e-8 { 1.0 } else { x.sin() / x };
    (1.0 - sinc * sinc).powi(2)
}

/// The share of a displacement's variance the drift removal takes out, from the
/// integrated displacement's spectrum `s` (two-sided density) and variance `var`. Above 1.5
/// times the corner (`2π/W`, past the mean's first null, where `G⁴ ≥ 0.8`) the true
/// density is the integrated one over `G⁴`, so the sidelobes' loss there is
/// `S·(1/G⁴ − 1)`; below, a displacement's spectrum is flat at its static level, which the
/// bins between 1.5 and 3 times the corner show, and the removal takes that level times
/// `∫(1 − G⁴) dω`. `None` without such bins.
pub(super) fn drift_loss(s: &crate::ident::spectrum::Spectrum, var: f64, h: f64, half: usize) -> Option<f64> {
    let corner = 2.0 * std::f64::consts::PI / ((2 * half + 1) as f64 * h);
    let dw = if s.omega.len() > 1 {
        s.omega[1] - s.omega[0]
    } else {
        return None;
    };
    let g4 = |w: f64| drift_gain(w, h, half).powi(2);
    let level: Vec<f64> = s
        .omega
        .iter()
        .zip(&s.density)
        .filter(|(w, _)| (1.5 * corner..=3.0 * corner).contains(*w))
        .map(|(&w, &d)| d / g4(w))
        .collect();
    if level.is_empty() || var <= 0.0 {
        return None;
    }
    let plateau = level.iter().sum::<f64>() / level.len() as f64;
    // ∫₀^{1.5 corner} (1 − G⁴) dω.
    let n = 20_000;
    let step = 1.5 * corner / n as f64;
    let below: f64 = (0..n).map(|k| 1.0 - g4((k as f64 + 0.5) * step)).sum::<f64>() * step;
    let above: f64 = s
        .omega
        .iter()
        .zip(&s.density)
        .filter(|(w, _)| **w >= 1.5 * corner)
        .map(|(&w, &d)| d * (1.0 / g4(w) - 1.0))
        .sum::<f64>()
        * dw;
    // Both signs of ω.
    Some(2.0 * (plateau * below + above) / var)
}

/// Spectra of parts of the data (one segment length) pooled: each weighs by its segments.
pub(super) fn pooled(parts: &[crate::ident::spectrum::Spectrum]) -> crate::ident::spectrum::Spectrum {
    crate::ident::spectrum::Spectrum {
        density: crate::ident::spectrum::pooled_density(parts),
        segments: parts.iter().map(|s| s.segments).sum(),
        ..parts[0].clone()
    }
}

/// Parts of the data the accelerometer-noise estimate's jackknife leaves out in turn: the
/// records in turn when there are at least as many, else equal stretches of each record.
pub(super) const NOISE_PARTS: usize = 8;

/// The part of the jackknife sample `n` of record `record` (of `len` samples) is in.
pub(super) fn noise_part(records: usize, record: usize, n: usize, len: usize) -> usize {
    if records >= NOISE_PARTS {
        record % NOISE_PARTS
    } else {
        (n * NOISE_PARTS / len.max(1)).min(NOISE_PARTS - 1)
    }
}

/// An accelerometer's white noise, estimated from the displacement integrated from it
/// (docs/measurement.md, "An accelerometer's noise"): its variance as white
/// noise of the samples and that variance's standard error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AccelerometerNoise {
    pub variance: f64,
    pub std_error: f64,
    /// The band fitted, rad/s.
    pub band: (f64, f64),
}

impl AccelerometerNoise {
    /// Beyond three standard errors.
    pub fn detected(&self) -> bool {
        self.variance > 3.0 * self.std_error
    }
}

/// The accelerometer's noise from the spectra of the integrated displacement in the
/// jackknife's parts (Welch, one segment length). Below the modes a displacement's spectrum
/// is its static compliance's, smooth and even in `ω`: `S_x(ω) = c₀ + c₂ω² + c₄ω⁴`. White
/// noise of density `N` on the acceleration reaches the integrated displacement as
/// `N·|I(ω)J(ω)|²`, `J` the trapezoid rule's gain and `I` the velocity's rule's (both
/// `≈ 1/ω`; [`AccelerationSamples`]), the motion as `|IJ|²ω⁴·S_x`, and the
/// drift removal's power gain on the displacement ([`drift_gain`] squared) multiplies both
/// alike. So that gain and `|I|⁴` divided out, `z(ω) = N + ω⁴·S_x(ω)`: the noise is the
/// constant under a rise as `ω⁴`, and it stands out near the drift removal's corner
/// (for a mass of natural frequency `ω₀`, a noise of 1 % of the acceleration's std is as
/// large as the motion where `ω ≈ ω₀/10`). The fit: `1, ω⁴, ω⁶, ω⁸`, each times both
/// gains and smoothed by the Welch window's kernel (near the corner the gains change within
/// a few bins), to the estimated spectrum by least squares, each bin weighed by `1/Ŝ²` (its
/// relative scatter is the same, `1/√K`), over the
/// bins where the drift removal keeps at least [`NOISE_MIN_GAIN`] of the power and up to
/// [`NOISE_TOP`] of the mass's motion frequency `motion` (`σ_v/σ_x`). The variance is
/// `2πN/h`; the jackknife over the parts gives its standard error. A gain error of the
/// accelerometer scales motion and noise alike and does not bias the estimate relative to
/// the motion (which a comparison with a force cell could not say; docs/measurement.md).
pub(super) fn accelerometer_noise(
    parts: &[crate::ident::spectrum::Spectrum],
    h: f64,
    half: usize,
    samples: AccelerationSamples,
    roughness: f64,
    motion: f64,
) -> Result<AccelerometerNoise, String> {
    let parts: Vec<_> = parts.iter().filter(|s| s.segments > 0).collect();
    let first = parts
        .first()
        .ok_or("no record is long enough for the displacement's spectrum")?;
    let combine = |leave: Option<usize>| {
        crate::ident::spectrum::pooled_density(
            parts
                .iter()
                .enumerate()
                .filter(|&(p, _)| Some(p) != leave)
                .map(|(_, s)| *s),
        )
    };
    let integration = |w: f64| samples.displacement_gain(w, h).powi(2);
    let dw = first.omega[1] - first.omega[0];
    let response = |w: f64| {
        if w < 1e-12 * dw {
            0.0
        } else {
            drift_gain(w, h, half).powi(2) * integration(w)
        }
    };
    let corner = 2.0 * std::f64::consts::PI / ((2 * half + 1) as f64 * h);
    let band = |top: f64| -> Vec<usize> {
        (crate::ident::spectrum::SKIP_LOW_BINS..first.omega.len())
            .filter(|&k| {
                let w = first.omega[k];
                w <= top && drift_gain(w, h, half).powi(2) >= NOISE_MIN_GAIN
            })
            .collect()
    };
    let mut top = NOISE_TOP * motion;
    let mut bins = band(top);
    if bins.len() < 8 {
        // Strong noise swells the integrated displacement with slow noise, and `σ_v/σ_x`
        // reads the motion's frequency low: take the acceleration spectrum's peak above
        // twice the corner instead (the noise is flat there, the motion is not).
        let whole = combine(None);
        let accel = |k: usize| whole[k] / response(first.omega[k]).max(1e-300);
        let peak = (0..first.omega.len())
            .filter(|&k| (2.0 * corner..=0.5 * std::f64::consts::PI / h).contains(&first.omega[k]))
            .max_by(|&a, &b| accel(a).total_cmp(&accel(b)))
            .map(|k| first.omega[k]);
        if let Some(p) = peak.filter(|&p| p > motion) {
            top = NOISE_TOP * p;
            bins = band(top);
        }
    }
    if bins.len() < 8 || parts.len() < 3 {
        return Err(format!(
            "{} frequencies between the drift removal's corner ({corner:.4} rad/s) and {NOISE_TOP} of the motion's \
             frequency ({top:.4} rad/s) in {} parts: a longer drift window or longer records",
            bins.len(),
            parts.len()
        ));
    }
    // The model's terms as the Welch estimate sees them: through the drift removal's and
    // the trapezoid's gains, then smoothed by the Hann window's kernel (near the corner
    // these gains change within a few bins, and the smoothing would read as noise).
    let terms: Vec<[f64; 4]> = bins
        .iter()
        .map(|&k| {
            let mut out = [0.0; 4];
            for (j, o) in out.iter_mut().enumerate() {
                *o = hann_smoothed(
                    |w| {
                        let t = w / top;
                        response(w) * [1.0, t.powi(4), t.powi(6), t.powi(8)][j]
                    },
                    first.omega[k],
                    dw,
                    first.segment_len,
                );
            }
            out
        })
        .collect();
    // The displacement's random walk from the velocity's roughness ([`roughness`]): its
    // increments white of variance `q`, summed (`1/(4·sin²(ωh/2))`) and through both drift
    // removals (it is the sampled velocity's aliased floor, which the velocity's removal
    // sees too), as the Welch estimate sees it.
    let walk: Vec<f64> = bins
        .iter()
        .map(|&k| {
            if roughness <= 0.0 {
                return 0.0;
            }
            hann_smoothed(
                |w| {
                    let s = (0.5 * w * h).sin();
                    if s.abs() < 1e-12 {
                        0.0
                    } else {
                        roughness * h / (2.0 * std::f64::consts::PI) * drift_gain(w, h, half).powi(2) / (4.0 * s * s)
                    }
                },
                first.omega[k],
                dw,
                first.segment_len,
            )
        })
        .collect();
    let whole = combine(None);
    let fit = |density: &[f64]| -> Option<f64> {
        let mut normal = nalgebra::Matrix4::<f64>::zeros();
        let mut rhs = nalgebra::Vector4::<f64>::zeros();
        for (i, (&k, x)) in bins.iter().zip(&terms).enumerate() {
            let x = nalgebra::Vector4::from_row_slice(x);
            let w = 1.0 / whole[k].powi(2).max(1e-300);
            normal += w * x * x.transpose();
            rhs += w * (density[k] - walk[i]) * x;
        }
        normal.lu().solve(&rhs).map(|b| b[0] * 2.0 * std::f64::consts::PI / h)
    };
    let variance = fit(&whole).ok_or("the fit is singular")?;
    let replicates: Vec<f64> = (0..parts.len())
        .map(|p| fit(&combine(Some(p))).ok_or("the fit is singular"))
        .collect::<Result<_, _>>()?;
    let g = replicates.len() as f64;
    let mean = replicates.iter().sum::<f64>() / g;
    let std_error = ((g - 1.0) / g * replicates.iter().map(|r| (r - mean).powi(2)).sum::<f64>()).sqrt();
    Ok(AccelerometerNoise {
        variance,
        std_error,
        band: (first.omega[bins[0]], first.omega[*bins.last().expect("bins")]),
    })
}

/// The expectation of a Welch estimate (Hann window of `len` samples, bins `dw` apart) at
/// `omega` of an even spectrum `f`: `f` smoothed by the window's kernel `|W|²` over ±8
/// bins, normalised to keep a flat spectrum flat. `W` is the sum of three Dirichlet kernels
/// (`½D(θ) + ¼D(θ − 2π/L) + ¼D(θ + 2π/L)` for a long window).
fn hann_smoothed(f: impl Fn(f64) -> f64, omega: f64, dw: f64, len: usize) -> f64 {
    const SUB: i32 = 16;
    const SPAN: i32 = 8;
    let l = len as f64;
    let dirichlet = |bins: f64| {
        let half_theta = std::f64::consts::PI * bins / l;
        if half_theta.sin().abs() < 1e-12 {
            l
        } else {
            (l * half_theta).sin() / half_theta.sin()
        }
    };
    let (mut num, mut den) = (0.0, 0.0);
    for j in -SPAN * SUB..=SPAN * SUB {
        let d = j as f64 / SUB as f64;
        let k = (0.5 * dirichlet(d) + 0.25 * dirichlet(d - 1.0) + 0.25 * dirichlet(d + 1.0)).powi(2);
        num += k * f((omega + d * dw).abs());
        den += k;
    }
    num / den
}

/// The variance of the error the trapezoid rule makes in one interval's displacement
/// increment when the velocity is rough at the scale of a sample, as a white-forced mass's
/// is: for a velocity that diffuses with intensity `D` (its increments' variance `D·h`),
/// the integral of its Brownian bridge over the interval, `D·h³/12`. The second
/// differences `a_k − 2a_{k−1} + a_{k−2}` then have the variance `6D/h` (the smooth
/// motion's share is `(ωh)⁴` smaller; in first differences it would be `(ωh)²`, a bias of
/// tens of per cent at coarse sampling), so `q = h⁴·Var(Δ²a)/72` from `var_d2a`, that
/// variance. The errors are independent from interval to interval: a random walk in the
/// integrated displacement (spectrum `∝ 1/ω²`, not an accelerometer noise's `1/ω⁴`), which
/// the noise estimate must not read as noise. It is part of the motion the links feel
/// (correlated with it), so it is stated, not taken out of the moments
/// (docs/measurement.md). For an accelerometer behind an anti-alias filter the motion is
/// smooth at the sample's scale and `q` is negligible: the same formula bounds it, so it
/// holds whatever the table's accelerations are.
pub(super) fn roughness(h: f64, var_d2a: f64) -> f64 {
    h.powi(4) * var_d2a / 72.0
}

/// Second differences of each record's accelerations, for [`roughness`]: their sum of
/// squares and count, and per record its last two accelerations (records may interleave).
#[derive(Debug, Clone)]
pub(super) struct SecondDifferences {
    squares: f64,
    count: f64,
    last: Vec<[Option<f64>; 2]>,
}

impl SecondDifferences {
    pub(super) fn new(records: usize) -> SecondDifferences {
        SecondDifferences {
            squares: 0.0,
            count: 0.0,
            last: vec![[None; 2]; records],
        }
    }

    pub(super) fn push(&mut self, record: usize, a: f64) {
        let [older, old] = self.last[record];
        if let (Some(p2), Some(p1)) = (older, old) {
            self.squares += (a - 2.0 * p1 + p2).powi(2);
            self.count += 1.0;
        }
        self.last[record] = [old, Some(a)];
    }

    /// Their variance (about zero mean).
    pub(super) fn variance(&self) -> f64 {
        self.squares / self.count.max(1.0)
    }
}

/// The variance a displacement random walk of increments of unit variance keeps through
/// the drift removals: `(h/π) ∫₀^{π/h} D(ω)²/(4·sin²(ωh/2)) dω`, `D` the power gain
/// [`drift_gain`] of one (on a logarithmic grid as in [`noise_gains`]). The walk is the
/// trapezoid's sum of the sampled velocity's aliased floor (its roughness above the Nyquist
/// frequency folded down), so the velocity's removal takes it as well as the
/// displacement's.
pub(super) fn walk_gain(h: f64, half: usize) -> f64 {
    let l = (2 * half + 1) as f64;
    let (lo, hi) = ((1e-4 / (l * h)).ln(), (std::f64::consts::PI / h).ln());
    let n = 200_000;
    let mut sum = 0.0;
    for k in 0..=n {
        let w = (lo + (hi - lo) * k as f64 / n as f64).exp();
        let s = (0.5 * w * h).sin();
        let weight = if k == 0 || k == n { 0.5 } else { 1.0 } * w;
        sum += weight * drift_gain(w, h, half).powi(2) / (4.0 * s * s);
    }
    h / std::f64::consts::PI * sum * (hi - lo) / n as f64
}

/// The smallest power the drift removal keeps on the displacement (`D⁴`) at a frequency the
/// noise estimate uses.
const NOISE_MIN_GAIN: f64 = 0.05;
/// The noise estimate's band ends at this fraction of the motion's frequency.
const NOISE_TOP: f64 = 0.4;

#[cfg(test)]
mod tests {
    use super::*;

    /// White noise through the chain, by either rule: the variances of its velocity and
    /// displacement are [`noise_gains`]' (within the sampling spread of 2e6 samples, about
    /// 3 % for the displacement's slow noise).
    #[test]
    fn the_noise_left_by_the_integration_is_as_computed() {
        for samples in [AccelerationSamples::Instants, AccelerationSamples::IntervalMeans] {
            noise_through_the_chain(samples);
        }
    }

    fn noise_through_the_chain(samples: AccelerationSamples) {
        let (h, half) = (0.01, 100);
        let (gv, gx) = noise_gains(h, half, samples);
        let mut chain = Chain::new(h, half, samples);
        let (mut sv, mut sx, mut nv, mut nx) = (0.0, 0.0, 0.0, 0.0);
        for n in 0..2_000_000 {
            let (v, x) = chain.push(crate::sim::sensors::normal(7, 0, n, 0));
            if let Some(v) = v {
                sv += v * v;
                nv += 1.0;
            }
            if let Some(x) = x {
                sx += x * x;
                nx += 1.0;
            }
        }
        let (var_v, var_x) = (sv / nv, sx / nx);
        assert!(
            (var_v / gv - 1.0).abs() < 0.03,
            "{samples:?} velocity: {var_v} against {gv}"
        );
        assert!(
            (var_x / gx - 1.0).abs() < 0.06,
            "{samples:?} displacement: {var_x} against {gx}"
        );
    }

    /// A linear oscillator `m·a = p − k·x − c·v` under a white force, stepped `steps` times
    /// per sample of `h`, its acceleration logged as the simulator logs a white-forced
    /// mass's (the velocity's change over the interval) with white noise of `noise` times
    /// its std, then integrated as `samples` over 16 records of `len` samples with the
    /// drift window of ten periods: the noise estimate.
    fn oscillator_noise(
        noise: f64,
        (h, steps, len): (f64, usize, usize),
        samples: AccelerationSamples,
        allow_walk: bool,
    ) -> (AccelerometerNoise, f64) {
        let (m, k, c): (f64, f64, f64) = (2.0, 8.0, 0.4);
        let dt = h / steps as f64;
        let records = 16;
        let omega = (k / m).sqrt();
        let half = half_for(10.0 * 2.0 * std::f64::consts::PI / omega, h);
        let segment = (8 * (2 * half + 1)).next_power_of_two();
        let mut parts = vec![crate::ident::spectrum::Welch::new(segment, h, records); NOISE_PARTS];
        // The acceleration's std: the white force's `σ²/h` over `m²`, σ = 1.
        let std_a = (1.0 / h).sqrt() / m;
        let mut second = SecondDifferences::new(records);
        for r in 0..records {
            let mut chain = Chain::new(h, half, samples);
            let (mut x, mut v) = (0.0, 0.0);
            let mut n_x = 0;
            for n in 0..len {
                let v0 = v;
                for s in 0..steps {
                    let dw = dt.sqrt() * crate::sim::sensors::normal(5, r as u64, (n * steps + s) as u64, 9);
                    v += (-(k * x + c * v) * dt + dw) / m;
                    x += v * dt;
                }
                let a = (v - v0) / h + noise * std_a * crate::sim::sensors::normal(6, r as u64, n as u64, 1);
                second.push(r, a);
                if let (_, Some(xi)) = chain.push(a) {
                    parts[noise_part(records, r, n_x, len)].push(r, xi);
                    n_x += 1;
                }
            }
        }
        let spectra: Vec<_> = parts.iter().map(|w| w.spectrum()).collect();
        let rough = if allow_walk {
            roughness(h, second.variance())
        } else {
            0.0
        };
        (
            accelerometer_noise(&spectra, h, half, samples, rough, omega).expect("an estimate"),
            std_a,
        )
    }

    /// Noise of 1 % of the acceleration's std comes back within 10 % of its std and three
    /// standard errors; without noise, none is detected.
    #[test]
    fn an_accelerometers_noise_is_found_below_the_modes() {
        let fine = (0.01, 10, 400_000);
        let (clean, _) = oscillator_noise(0.0, fine, AccelerationSamples::Instants, true);
        assert!(!clean.detected(), "{clean:?}");
        let (noisy, std_a) = oscillator_noise(0.01, fine, AccelerationSamples::Instants, true);
        let truth = (0.01 * std_a).powi(2);
        let (s, t) = (noisy.variance.max(0.0).sqrt(), truth.sqrt());
        assert!(noisy.detected(), "{noisy:?}");
        assert!((s / t - 1.0).abs() < 0.1, "std {s} against {t}: {noisy:?}");
        assert!(
            (noisy.variance - truth).abs() < 3.0 * noisy.std_error,
            "{noisy:?} against {truth}"
        );
    }

    /// Clean interval means at a coarse interval (`ω·h` = 0.4, the oscillator sampled
    /// every 0.2 s): by either rule no noise is found, the estimate within three standard
    /// errors of zero and under 0.2 % of the acceleration's std. Without the allowance for
    /// the displacement's random walk ([`roughness`]) the same samples show a noise that
    /// is not there.
    #[test]
    fn clean_interval_means_show_no_noise() {
        let coarse = (0.2, 20, 20_000);
        for samples in [AccelerationSamples::IntervalMeans, AccelerationSamples::Instants] {
            let (clean, std_a) = oscillator_noise(0.0, coarse, samples, true);
            assert!(!clean.detected(), "{samples:?}: {clean:?}");
            assert!(clean.variance.abs() < 3.0 * clean.std_error, "{samples:?}: {clean:?}");
            assert!(
                clean.variance.abs().sqrt() < 0.002 * std_a,
                "{samples:?}: {clean:?} against {std_a}"
            );
        }
        let (walk, _) = oscillator_noise(0.0, coarse, AccelerationSamples::IntervalMeans, false);
        assert!(walk.detected(), "{walk:?}");
    }

    /// A sum of tones well above the corner, its acceleration integrated back: velocity
    /// and displacement to the `(ωW/2)⁻²` of the drift removal and the trapezoid's
    /// `(ωh)²/12`, with an offset and a ramp in the acceleration (a sensor's bias and drift
    /// on a random walk) taken out with the slow part.
    #[test]
    fn tones_come_back_from_their_acceleration() {
        let h = 0.01;
        let half = half_for(20.0, h);
        let tones = [(2.5, 0.7, 0.3), (4.0, 0.4, 1.1), (9.0, 0.05, 2.0)];
        let x = |t: f64| tones.iter().map(|&(w, a, p)| a * (w * t + p).sin()).sum::<f64>();
        let v = |t: f64| tones.iter().map(|&(w, a, p)| a * w * (w * t + p).cos()).sum::<f64>();
        let acc = |t: f64| {
            -tones
                .iter()
                .map(|&(w, a, p)| a * w * w * (w * t + p).sin())
                .sum::<f64>()
        };
        let mut chain = Chain::new(h, half, AccelerationSamples::Instants);
        let (mut worst_v, mut worst_x, mut n_v, mut n_x) = (0.0f64, 0.0f64, 0, 0);
        for n in 0..20_000 {
            let t = n as f64 * h;
            let (vv, xx) = chain.push(acc(t) + 0.3 + 1e-4 * t);
            if let Some(vv) = vv {
                let tv = (n - 2 * half) as f64 * h;
                worst_v = worst_v.max((vv - v(tv)).abs());
                n_v += 1;
            }
            if let Some(xx) = xx {
                let tx = (n - 4 * half) as f64 * h;
                worst_x = worst_x.max((xx - x(tx)).abs());
                n_x += 1;
            }
        }
        assert_eq!(n_v, 20_000 - 4 * half);
        assert_eq!(n_x, 20_000 - 8 * half);
        // Amplitudes 1.75 (velocity) and 0.7 (displacement): errors below 0.5 %.
        assert!(worst_v < 0.008, "velocity off by {worst_v}");
        assert!(worst_x < 0.0035, "displacement off by {worst_x}");
    }
}

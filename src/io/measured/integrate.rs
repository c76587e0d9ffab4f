//! Velocities and displacements from measured accelerations, for rigs that have
//! accelerometers and force cells only (docs/data.md, "Accelerations only").
//!
//! Each integral is the trapezoid rule over the samples, with its slow part taken out: a
//! centred triangular mean over `4·half + 1` samples (a running mean of a running mean,
//! each over `2·half + 1`), subtracted from the integral. That is a zero-phase high-pass:
//! it passes `1 − sinc²(ω·(2·half + 1)·h/2)`, so the motion keeps its phase and, well
//! above the corner, its amplitude to `(ω·W/2)⁻²`, `W` the window's half width in time
//! (a single running mean's sidelobes would leave `(ω·W/2)⁻¹`, a per cent at duffing2dof's
//! frequencies). What it takes out is the integration constant, the random walk an
//! accelerometer's noise and offset make of the velocity, and the motion's own content
//! below the corner. The velocity is ready `2·half` samples after its acceleration, the
//! displacement `4·half`; the first and last `4·half` samples of every record are not
//! handed over (their windows would reach past the record's ends).

/// A running mean over the last `len` values.
#[derive(Debug, Clone)]
struct Window {
    ring: Vec<f64>,
    next: usize,
    filled: usize,
    sum: f64,
    /// Pushes since the sum was last summed afresh (its rounding stays bounded).
    since: usize,
}

impl Window {
    fn new(len: usize) -> Window {
        Window {
            ring: vec![0.0; len],
            next: 0,
            filled: 0,
            sum: 0.0,
            since: 0,
        }
    }

    fn reset(&mut self) {
        self.next = 0;
        self.filled = 0;
        self.sum = 0.0;
        self.since = 0;
    }

    /// Push `x`; the mean of the last `len` values once there are that many.
    fn push(&mut self, x: f64) -> Option<f64> {
        let len = self.ring.len();
        self.sum += x - self.ring[self.next];
        self.ring[self.next] = x;
        self.next = (self.next + 1) % len;
        self.filled = (self.filled + 1).min(len);
        self.since += 1;
        if self.since >= len {
            self.sum = self.ring.iter().sum();
            self.since = 0;
        }
        (self.filled == len).then(|| self.sum / len as f64)
    }

    /// The oldest value in a full window.
    fn oldest(&self) -> f64 {
        self.ring[self.next]
    }
}

/// One mass's acceleration → velocity → displacement.
#[derive(Debug, Clone)]
pub(super) struct Chain {
    h: f64,
    a_last: Option<f64>,
    v_raw: f64,
    v_mean: Window,
    v_mean2: Window,
    v_last: Option<f64>,
    x_raw: f64,
    x_mean: Window,
    x_mean2: Window,
}

impl Chain {
    /// A chain for samples every `h` with drift windows of `2·half + 1` samples.
    pub(super) fn new(h: f64, half: usize) -> Chain {
        let w = Window::new(2 * half + 1);
        Chain {
            h,
            a_last: None,
            v_raw: 0.0,
            v_mean: w.clone(),
            v_mean2: w.clone(),
            v_last: None,
            x_raw: 0.0,
            x_mean: w.clone(),
            x_mean2: w,
        }
    }

    /// A new record starts.
    pub(super) fn reset(&mut self) {
        self.a_last = None;
        self.v_raw = 0.0;
        self.v_last = None;
        self.x_raw = 0.0;
        for w in [&mut self.v_mean, &mut self.v_mean2, &mut self.x_mean, &mut self.x_mean2] {
            w.reset();
        }
    }

    /// Push the acceleration of sample `n`: the velocity of sample `n − 2·half` and the
    /// displacement of sample `n − 4·half`, once they are ready.
    pub(super) fn push(&mut self, a: f64) -> (Option<f64>, Option<f64>) {
        self.v_raw += self.a_last.map_or(0.0, |p| 0.5 * self.h * (p + a));
        self.a_last = Some(a);
        let Some(m1) = self.v_mean.push(self.v_raw) else {
            return (None, None);
        };
        let v_raw = self.v_mean.oldest();
        let Some(m2) = self.v_mean2.push(m1) else {
            return (None, None);
        };
        let v = v_raw - m2;
        self.x_raw += self.v_last.map_or(0.0, |p| 0.5 * self.h * (p + v));
        self.v_last = Some(v);
        let Some(n1) = self.x_mean.push(self.x_raw) else {
            return (Some(v), None);
        };
        let x_raw = self.x_mean.oldest();
        (Some(v), self.x_mean2.push(n1).map(|n2| x_raw - n2))
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
/// `G = I·P` for the velocity and `(I·P)²` for the displacement, `I(ω) = (h/2)·cot(ωh/2)`
/// the trapezoid rule's gain and `P(ω) = 1 − D(ω)²` the drift removal's, `D` a running
/// mean's over `L = 2·half + 1` samples, `sin(Lωh/2) / (L·sin(ωh/2))`. The noise is
/// Gaussian and independent of the motion, so the weak form's moments can be corrected for
/// it like for a white sensor noise of that variance (docs/measurement.md).
pub(super) fn noise_gains(h: f64, half: usize) -> (f64, f64) {
    let l = (2 * half + 1) as f64;
    let gain = |w: f64| {
        let s = (0.5 * w * h).sin();
        let d = (0.5 * l * w * h).sin() / (l * s);
        let i = 0.5 * h * (0.5 * w * h).cos() / s;
        (i * (1.0 - d * d)).powi(2)
    };
    // On a logarithmic grid from far below the corner (where `|G|²` vanishes as `ω²`) to
    // the Nyquist frequency, by the trapezoid rule in `ln ω`.
    let (lo, hi) = ((1e-4 / (l * h)).ln(), (std::f64::consts::PI / h).ln());
    let n = 200_000;
    let (mut v, mut x) = (0.0, 0.0);
    for k in 0..=n {
        let w = (lo + (hi - lo) * k as f64 / n as f64).exp();
        let g = gain(w);
        let weight = if k == 0 || k == n { 0.5 } else { 1.0 } * w;
        v += weight * g;
        x += weight * g * g;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// White noise through the chain: the variances of its velocity and displacement are
    /// [`noise_gains`]' (within the sampling spread of 2e6 samples, about 3 % for the
    /// displacement's slow noise).
    #[test]
    fn the_noise_left_by_the_integration_is_as_computed() {
        let (h, half) = (0.01, 100);
        let (gv, gx) = noise_gains(h, half);
        let mut chain = Chain::new(h, half);
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
        assert!((var_v / gv - 1.0).abs() < 0.03, "velocity: {var_v} against {gv}");
        assert!((var_x / gx - 1.0).abs() < 0.06, "displacement: {var_x} against {gx}");
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
        let mut chain = Chain::new(h, half);
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

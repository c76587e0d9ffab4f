//! The sensors' low-pass filters between the simulated motion and the ADC: the
//! anti-alias filter (a Butterworth of `[measurement] anti_alias_order` with its corner at
//! `anti_alias` × the sampling rate) and each sensor's own bandwidth (a second-order
//! Butterworth at `bandwidth` Hz), as docs/measurement.md describes.
//!
//! An analogue filter acts on the continuous signal before it is sampled. The simulator
//! stands in for it by sampling the motion `R` times faster than the log (`R`, the
//! oversampling, is the smallest divisor of the integration steps per sample that is at
//! least [`crate::scenario::MIN_OVERSAMPLING`]), running the filters at that rate
//! (bilinear transform with the corners prewarped, so they sit exactly where stated), and
//! keeping every `R`-th output. The fast samples are the simulator's own (interval-mean accelerations and
//! white-force impulses over the fast interval), so a white force cell's logged variance is
//! exactly `σ²/h_fast · Σ g_n²` over the filter's impulse response `g`.
//!
//! Each lane's filter starts in the steady state of its first fast sample (the
//! response it would have to a constant input), so no start-up transient longer than the
//! filter's own memory (a few samples at the corner) reaches the log. The filters are
//! linear and the same on every channel: a common delay, which leaves the stationary
//! density unchanged, and an amplitude shaping, which matters only for content near the
//! corners.

use crate::scenario::Sensors;
use multiversion::multiversion;

/// One second-order section, transposed direct form II: `y = b0 u + s1`,
/// `s1' = b1 u − a1 y + s2`, `s2' = b2 u − a2 y`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Biquad {
    b: [f64; 3],
    a: [f64; 2],
}

impl Biquad {
    /// The state that holds the output at `u` for a constant input `u` (unit DC gain).
    fn steady(&self, u: f64) -> [f64; 2] {
        let s2 = (self.b[2] - self.a[1]) * u;
        [(self.b[1] - self.a[0]) * u + s2, s2]
    }

    fn step(&self, s: &mut [f64; 2], u: f64) -> f64 {
        let y = self.b[0] * u + s[0];
        s[0] = self.b[1] * u - self.a[0] * y + s[1];
        s[1] = self.b[2] * u - self.a[1] * y;
        y
    }

    /// The section's complex gain at `f` (a fraction of its sampling rate).
    fn gain(&self, f: f64) -> (f64, f64) {
        // z⁻¹ = e^{−iω}.
        let w = std::f64::consts::TAU * f;
        let (c1, s1, c2, s2) = (w.cos(), -w.sin(), (2.0 * w).cos(), -(2.0 * w).sin());
        let num = (
            self.b[0] + self.b[1] * c1 + self.b[2] * c2,
            self.b[1] * s1 + self.b[2] * s2,
        );
        let den = (1.0 + self.a[0] * c1 + self.a[1] * c2, self.a[0] * s1 + self.a[1] * s2);
        let d = den.0 * den.0 + den.1 * den.1;
        ((num.0 * den.0 + num.1 * den.1) / d, (num.1 * den.0 - num.0 * den.1) / d)
    }
}

/// A Butterworth low-pass of `order` with its −3 dB corner at `corner` (a fraction of the
/// sampling rate, below ½): bilinear transform with the corner prewarped; a first-order
/// section for an odd order.
pub(crate) fn butterworth(order: u32, corner: f64) -> Vec<Biquad> {
    debug_assert!(order >= 1 && corner > 0.0 && corner < 0.5);
    let k = (std::f64::consts::PI * corner).tan();
    let mut sections = Vec::new();
    for i in 0..order / 2 {
        // The analogue pair s² + a s + 1, a = 2 sin(π(2i+1)/(2N)).
        let a = 2.0 * (std::f64::consts::PI * (2 * i + 1) as f64 / (2 * order) as f64).sin();
        let norm = 1.0 / (1.0 + a * k + k * k);
        let b0 = k * k * norm;
        sections.push(Biquad {
            b: [b0, 2.0 * b0, b0],
            a: [2.0 * (k * k - 1.0) * norm, (1.0 - a * k + k * k) * norm],
        });
    }
    if order % 2 == 1 {
        let b0 = k / (1.0 + k);
        sections.push(Biquad {
            b: [b0, b0, 0.0],
            a: [(k - 1.0) / (k + 1.0), 0.0],
        });
    }
    sections
}

/// The sensors' filters of a run, at the fast rate.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SensorFilter {
    sections: Vec<Biquad>,
    /// Fast samples per logged sample.
    pub(crate) oversampling: usize,
}

impl SensorFilter {
    /// The filters `sensors` state for a log sampled every `interval` s with `steps` steps
    /// of `dt` per sample, each in `substeps`; `None` without filters. `Err`: the steps
    /// cannot carry the filters, or a corner is beyond what the fast rate resolves
    /// (`Sensors::filter_oversampling`).
    pub(crate) fn new(
        sensors: &Sensors,
        interval: f64,
        steps: usize,
        substeps: usize,
    ) -> Result<Option<SensorFilter>, String> {
        let Some(oversampling) = sensors.filter_oversampling(interval, steps, substeps)? else {
            return Ok(None);
        };
        let fast = oversampling as f64 / interval;
        let mut sections = Vec::new();
        if let Some(aa) = sensors.anti_alias {
            sections.extend(butterworth(aa.order, aa.corner / oversampling as f64));
        }
        if let Some(b) = sensors.bandwidth {
            sections.extend(butterworth(2, b / fast));
        }
        Ok(Some(SensorFilter { sections, oversampling }))
    }

    /// State values per filtered signal.
    pub(crate) fn state_len(&self) -> usize {
        2 * self.sections.len()
    }

    /// Filter one signal's `fast` samples, its state `state` (empty before the first
    /// block: then set to the steady state of the first sample), and write every
    /// `oversampling`-th output to `out(k)` for logged sample `k` of the block.
    pub(crate) fn run(
        &self,
        state: &mut [f64],
        started: bool,
        fast: impl Iterator<Item = f64>,
        mut out: impl FnMut(usize, f64),
    ) {
        let mut fast = fast.peekable();
        if !started {
            let Some(&u) = fast.peek() else { return };
            for (s, q) in state.chunks_exact_mut(2).zip(&self.sections) {
                s.copy_from_slice(&q.steady(u));
            }
        }
        for (i, u) in fast.enumerate() {
            let mut y = u;
            for (s, q) in state.chunks_exact_mut(2).zip(&self.sections) {
                let s: &mut [f64; 2] = s.try_into().expect("two values per section");
                y = q.step(s, y);
            }
            if (i + 1) % self.oversampling == 0 {
                out(i / self.oversampling, y);
            }
        }
    }

    /// [`SensorFilter::run`] on `act` signals side by side (the lanes of one group):
    /// `fast` holds `n` fast samples, sample `q`'s lanes at `fast[q·stride..][..act]`;
    /// `state` holds the sections' states lane by lane (`[section][2][lane]`, set to the
    /// steady state of the first sample unless `started`); every `oversampling`-th output
    /// goes to `out(k, lanes)` for logged sample `k`. Each lane sees the arithmetic of
    /// `run`, in its order, so the outputs are the same bit for bit; the lanes are
    /// independent, so the sections' recursions run side by side in vector registers
    /// instead of each waiting on the one before.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn run_lanes(
        &self,
        state: &mut [f64],
        started: bool,
        (fast, stride, n, act): (&[f64], usize, usize, usize),
        mut out: impl FnMut(usize, &[f64]),
    ) {
        debug_assert!(act <= super::LANES && state.len() == self.state_len() * act);
        if n == 0 {
            return;
        }
        if !started {
            for (s, q) in state.chunks_exact_mut(2 * act).zip(&self.sections) {
                let (s0, s1) = s.split_at_mut(act);
                for j in 0..act {
                    [s0[j], s1[j]] = q.steady(fast[j]);
                }
            }
        }
        let mut y = [0.0; super::LANES];
        for q in 0..n {
            let y = &mut y[..act];
            y.copy_from_slice(&fast[q * stride..q * stride + act]);
            cascade_lanes(&self.sections, state, y);
            if (q + 1) % self.oversampling == 0 {
                out(q / self.oversampling, y);
            }
        }
    }

    /// The cascade's power gain `|H|²` at `f`, a fraction of the fast rate.
    pub(crate) fn gain2(&self, f: f64) -> f64 {
        self.sections
            .iter()
            .map(|q| {
                let (re, im) = q.gain(f);
                re * re + im * im
            })
            .product()
    }

    /// The variance the filters take out of the velocity of a unit mass under a white force
    /// of unit intensity (`P dt = dW`), logged every `interval` s. Above its modes such a
    /// velocity is the force's integral, of density `1/ω²` (two-sided, per 2π), which is
    /// not smooth at any sampling rate: its fast samples fold it to
    /// `(h/2)²/sin²(ωh/2)` over the fast band (`h` the fast interval), and the filters keep
    /// `|H|²` of that, so the loss is `(h/4π)∫₀^π (1 − |H(θ)|²)/sin²(θ/2) dθ` — for a
    /// Butterworth of order N at `ω_c` ≪ the fast rate, `(1/πω_c)(π/2N)/sin(π(2N−1)/2N)`.
    /// A mass `m` under white forces of intensities `σ_e` loses `Σσ_e²/m²` times it; its
    /// displacement loses a fraction `(ω_mode/ω_c)²` smaller, left alone.
    pub(crate) fn white_velocity_loss(&self, interval: f64) -> f64 {
        let h = interval / self.oversampling as f64;
        let n = 20_000;
        let d = std::f64::consts::PI / n as f64;
        let mut sum = 0.0;
        for k in 0..n {
            let theta = (k as f64 + 0.5) * d;
            let kept = self.gain2(theta / std::f64::consts::TAU);
            sum += (1.0 - kept) / (0.5 * theta).sin().powi(2);
        }
        h / (4.0 * std::f64::consts::PI) * sum * d
    }

    #[cfg(test)]
    /// `Σ g_n²` over the cascade's impulse response at the fast rate: the variance ratio
    /// of white fast samples through it.
    pub fn noise_gain(&self) -> f64 {
        let mut state = vec![0.0; self.state_len()];
        let (mut sum, mut tail) = (0.0, 1.0f64);
        let mut u = 1.0;
        let mut n = 0;
        while n < 64 || (tail > 1e-18 * sum && n < 1 << 20) {
            let mut y = u;
            for (s, q) in state.chunks_exact_mut(2).zip(&self.sections) {
                let s: &mut [f64; 2] = s.try_into().expect("two values per section");
                y = q.step(s, y);
            }
            sum += y * y;
            tail = y * y;
            u = 0.0;
            n += 1;
        }
        sum
    }
}

/// One fast sample of every lane through the sections: `y` in, the output out; `state`
/// as in [`SensorFilter::run_lanes`]. Compiled for the widest vector unit the CPU has (the
/// lanes are explicit and no operation is fused, so the bits are the same on every CPU).
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
))]
fn cascade_lanes(sections: &[Biquad], state: &mut [f64], y: &mut [f64]) {
    let act = y.len();
    for (s, q) in state.chunks_exact_mut(2 * act).zip(sections) {
        let (s0, s1) = s.split_at_mut(act);
        for ((y, s0), s1) in y.iter_mut().zip(s0).zip(s1) {
            let u = *y;
            *y = q.b[0] * u + *s0;
            *s0 = q.b[1] * u - q.a[0] * *y + *s1;
            *s1 = q.b[2] * u - q.a[1] * *y;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cascade_gain(sections: &[Biquad], f: f64) -> f64 {
        sections
            .iter()
            .map(|q| {
                let (re, im) = q.gain(f);
                re * re + im * im
            })
            .product::<f64>()
            .sqrt()
    }

    /// The designs are Butterworth: gain 1 at DC, 1/√2 at the corner exactly (prewarped),
    /// and everywhere the analogue `1/√(1 + (f'/fc)^(2N))` at the frequency the bilinear
    /// map sends `f` to, `f' ∝ tan(π f)`; the steady state holds a constant input.
    #[test]
    fn butterworth_sections_have_the_stated_corner_and_roll_off() {
        for order in 1..=8 {
            let fc = 0.04;
            let s = butterworth(order, fc);
            assert!((cascade_gain(&s, 0.0) - 1.0).abs() < 1e-12, "order {order}: DC gain");
            let at = cascade_gain(&s, fc);
            assert!((at - 0.5f64.sqrt()).abs() < 1e-9, "order {order}: {at} at the corner");
            for r in [0.5f64, 1.5, 2.0] {
                let warped = (std::f64::consts::PI * r * fc).tan() / (std::f64::consts::PI * fc).tan();
                let analogue = 1.0 / (1.0 + warped.powi(2 * order as i32)).sqrt();
                let g = cascade_gain(&s, r * fc);
                assert!(
                    (g / analogue - 1.0).abs() < 1e-9,
                    "order {order}, {r} fc: {g} against {analogue}"
                );
            }
            let filter = SensorFilter {
                sections: s,
                oversampling: 1,
            };
            let mut state = vec![0.0; filter.state_len()];
            let mut last = 0.0;
            filter.run(&mut state, false, std::iter::repeat_n(2.5, 50), |_, y| last = y);
            assert!((last - 2.5).abs() < 1e-12, "order {order}: steady state gives {last}");
        }
    }

    /// The noise gain of a Butterworth of order N at fc ≪ ½ is its noise bandwidth,
    /// `2 fc (π/2N) / sin(π/2N)` (both sides of zero), and the decimation keeps every
    /// `R`-th output, aligned at the end of each logged interval.
    #[test]
    fn noise_gain_and_decimation() {
        let (order, fc) = (4, 0.01);
        let f = SensorFilter {
            sections: butterworth(order, fc),
            oversampling: 5,
        };
        let q = std::f64::consts::PI / (2 * order) as f64;
        let expected = 2.0 * fc * q / q.sin();
        assert!(
            (f.noise_gain() / expected - 1.0).abs() < 1e-3,
            "{} against {expected}",
            f.noise_gain()
        );
        let mut state = vec![0.0; f.state_len()];
        let mut got = Vec::new();
        f.run(&mut state, false, (0..20).map(|i| i as f64), |k, _| got.push(k));
        assert_eq!(got, vec![0, 1, 2, 3]);
    }

    /// The lanes side by side give each lane's `run` bit for bit, over blocks that carry
    /// the states on (odd order: a first-order section too; a narrow group of 5 lanes in
    /// a stride of 3 signals).
    #[test]
    fn lanes_side_by_side_give_each_lanes_run_bit_for_bit() {
        let f = SensorFilter {
            sections: butterworth(7, 0.04),
            oversampling: 4,
        };
        let (act, stride, n) = (5, 15, 48);
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        let fast: Vec<f64> = (0..2 * n * stride)
            .map(|_| {
                rng ^= rng << 13;
                rng ^= rng >> 7;
                rng ^= rng << 17;
                (rng >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect();
        let mut lanes = vec![0.0; f.state_len() * act];
        let mut got = vec![vec![0.0; 2 * n / 4]; act];
        for block in 0..2 {
            let part = (&fast[block * n * stride..], stride, n, act);
            f.run_lanes(&mut lanes, block > 0, part, |k, y| {
                for (j, &y) in y.iter().enumerate() {
                    got[j][block * n / 4 + k] = y;
                }
            });
        }
        for j in 0..act {
            let mut state = vec![0.0; f.state_len()];
            let mut want = Vec::new();
            for block in 0..2 {
                let part = (0..n).map(|q| fast[(block * n + q) * stride + j]);
                f.run(&mut state, block > 0, part, |_, y| want.push(y));
            }
            let same = want.iter().zip(&got[j]).all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "lane {j}: {want:?} against {:?}", got[j]);
        }
    }
}

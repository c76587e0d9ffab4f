//! Free-run simulation: a model driven by given force signals, with no noise — the way a
//! system-identification benchmark scores a model (docs/methods.md, "Prediction"): the
//! identified model is driven by the measured input of a test segment it never saw and its
//! output compared with the measured output, sample by sample.
//!
//! The forces are known at the samples only. Between them they are taken as band-limited
//! (a shaker's or a DAC's reconstructed signal is): a Kaiser-windowed sinc over
//! [`TAPS`] samples on each side reconstructs them at the integration's sub-steps, where a
//! linear interpolation would cut a force at a third of the sampling rate by a quarter.
//! The equations of motion `M ẍ = −Σ s F_ℓ(u, w) + f(t)` are integrated by the classical
//! fourth-order Runge–Kutta scheme, `substeps` steps per sample interval.

use crate::model::Model;

/// Samples each side of an instant that the reconstruction of a force reads.
pub const TAPS: usize = 32;

/// The Kaiser window's shape parameter: with [`TAPS`] it passes every frequency up to 0.4
/// of the sampling rate to 1e-6 (β = 8 over 16 samples each side left up to 3e-4, at low
/// frequencies too).
const KAISER_BETA: f64 = 13.0;

/// Why a free run stopped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FreeRunError {
    /// The response grew without bound: the driven model is unstable at this level.
    #[error("the driven response diverged at sample {sample} (t = {t:.6} s): {mass} = {value:.3e}")]
    Diverged {
        sample: usize,
        t: f64,
        mass: String,
        value: f64,
    },
    /// The inputs do not fit the model.
    #[error("{0}")]
    Input(String),
}

/// The displacements of a free run: `x[k·n + i]` of mass `i` at sample `k`.
#[derive(Debug, Clone, PartialEq)]
pub struct FreeRun {
    pub masses: usize,
    pub x: Vec<f64>,
}

impl FreeRun {
    /// Mass `i`'s displacement at every sample.
    pub fn displacement(&self, i: usize) -> impl Iterator<Item = f64> + '_ {
        self.x.iter().skip(i).step_by(self.masses).copied()
    }
}

/// `sinc(z)·kaiser(z / (TAPS + 1))`, the reconstruction kernel at `z` sample intervals.
fn kernel(z: f64) -> f64 {
    let half = TAPS as f64 + 1.0;
    if z.abs() >= half {
        return 0.0;
    }
    let sinc = if z == 0.0 {
        1.0
    } else {
        (std::f64::consts::PI * z).sin() / (std::f64::consts::PI * z)
    };
    let r = z / half;
    sinc * bessel_i0(KAISER_BETA * (1.0 - r * r).sqrt()) / bessel_i0(KAISER_BETA)
}

/// The modified Bessel function `I₀` by its power series (converges for every argument).
fn bessel_i0(x: f64) -> f64 {
    let (mut sum, mut term, q) = (1.0, 1.0, x * x / 4.0);
    for k in 1..200 {
        term *= q / (k * k) as f64;
        sum += term;
        if term < 1e-17 * sum {
            break;
        }
    }
    sum
}

/// The reconstruction's weights at fraction `tau` ∈ [0, 1) of an interval past a sample:
/// `2·TAPS` of them, for samples `k − TAPS + 1 ..= k + TAPS`, normalised to sum to 1 (a
/// constant force is reproduced exactly).
pub(crate) fn weights(tau: f64) -> Vec<f64> {
    let mut w = vec![0.0; 2 * TAPS];
    weights_into(tau, &mut w);
    w
}

/// [`weights`] into `w` (`2·TAPS` long).
pub(crate) fn weights_into(tau: f64, w: &mut [f64]) {
    for (j, wj) in w.iter_mut().enumerate() {
        *wj = kernel(tau - (j as f64 - TAPS as f64 + 1.0));
    }
    let s: f64 = w.iter().sum();
    w.iter_mut().for_each(|v| *v /= s);
}

/// The force signals reconstructed at the sub-steps' instants: per sample interval `k`,
/// per stage point `q` (the `2·substeps + 1` instants `k + q/(2·substeps)`), per mass.
struct Reconstruction<'a> {
    forces: &'a [Vec<f64>],
    len: usize,
    /// Per stage point in an interval: its weights (a stage point at a sample needs none).
    weights: Vec<Option<Vec<f64>>>,
}

impl Reconstruction<'_> {
    /// The force on every mass at stage point `q` of interval `k`, into `out`. Samples
    /// beyond the record's ends are taken as its first and last (no step at the edges).
    fn at(&self, k: usize, q: usize, out: &mut [f64]) {
        let points = self.weights.len() - 1;
        let (k, q) = (k + q / points, q % points);
        for (o, f) in out.iter_mut().zip(self.forces) {
            *o = match &self.weights[q] {
                None => f[k.min(self.len - 1)],
                Some(w) => w
                    .iter()
                    .enumerate()
                    .map(|(j, wj)| {
                        let s = (k + j) as isize - TAPS as isize + 1;
                        wj * f[s.clamp(0, self.len as isize - 1) as usize]
                    })
                    .sum(),
            };
        }
    }
}

/// Drive `model` (its links and masses; its excitations are ignored) by `forces` — per
/// mass, the external force at each of the same number of samples `h` apart — from the
/// state `x0`, `v0` at the first sample, `substeps` Runge–Kutta steps per interval. The
/// displacements at every sample (the first is `x0`).
pub fn free_run(
    model: &Model,
    forces: &[Vec<f64>],
    h: f64,
    substeps: usize,
    x0: &[f64],
    v0: &[f64],
) -> Result<FreeRun, FreeRunError> {
    let n = model.masses();
    if forces.len() != n || x0.len() != n || v0.len() != n {
        return Err(FreeRunError::Input(format!(
            "{n} masses, but {} force signals and {}/{} initial values",
            forces.len(),
            x0.len(),
            v0.len()
        )));
    }
    let len = forces.first().map_or(0, Vec::len);
    if len == 0 || forces.iter().any(|f| f.len() != len) {
        return Err(FreeRunError::Input(
            "the force signals are empty or of different lengths".into(),
        ));
    }
    if !(h > 0.0 && h.is_finite()) || substeps == 0 {
        return Err(FreeRunError::Input(format!("a step of {h} s in {substeps} sub-steps")));
    }
    let points = 2 * substeps;
    let rec = Reconstruction {
        forces,
        len,
        weights: (0..=points)
            .map(|q| (q % points != 0).then(|| weights(q as f64 / points as f64)))
            .collect(),
    };
    let dt = h / substeps as f64;
    let (mut x, mut v) = (x0.to_vec(), v0.to_vec());
    let mut out = Vec::with_capacity(len * n);
    out.extend_from_slice(&x);
    // The force at the stage points: a sub-step's start is the last one's end.
    let mut f = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    let mut rk = Rk4::new(n);
    rec.at(0, 0, &mut f[2]);
    for k in 0..len - 1 {
        for s in 0..substeps {
            f.rotate_left(2);
            rec.at(k, 2 * s + 1, &mut f[1]);
            rec.at(k, 2 * s + 2, &mut f[2]);
            rk.step(model, &mut x, &mut v, &f, dt);
        }
        if let Some(i) = (0..n).find(|&i| !(x[i].abs() < super::DIVERGENCE_LIMIT && v[i].is_finite())) {
            return Err(FreeRunError::Diverged {
                sample: k + 1,
                t: (k + 1) as f64 * h,
                mass: model.mass_names[i].clone(),
                value: x[i],
            });
        }
        out.extend_from_slice(&x);
    }
    Ok(FreeRun { masses: n, x: out })
}

/// The classical fourth-order Runge–Kutta step of `M ẍ = −Σ s F_ℓ(u, w) + f(t)`, with its
/// scratch (no allocation per step).
pub(crate) struct Rk4 {
    link: Vec<f64>,
    kx: [Vec<f64>; 4],
    kv: [Vec<f64>; 4],
    xs: Vec<f64>,
    vs: Vec<f64>,
}

impl Rk4 {
    pub(crate) fn new(n: usize) -> Rk4 {
        let z = || vec![0.0; n];
        Rk4 {
            link: z(),
            kx: [z(), z(), z(), z()],
            kv: [z(), z(), z(), z()],
            xs: z(),
            vs: z(),
        }
    }

    /// One step of `dt` from `(x, v)`, the external force on every mass `f[0]` at the
    /// step's start, `f[1]` at its middle and `f[2]` at its end.
    pub(crate) fn step(&mut self, model: &Model, x: &mut [f64], v: &mut [f64], f: &[Vec<f64>; 3], dt: f64) {
        let n = x.len();
        // Stage r at the step's start (0), middle (1, 2) and end (3).
        for r in 0..4 {
            let (back, scale) = match r {
                0 => (None, 0.0),
                1 | 2 => (Some(r - 1), 0.5 * dt),
                _ => (Some(2), dt),
            };
            for i in 0..n {
                let (dx, dv) = back.map_or((0.0, 0.0), |b| (self.kx[b][i], self.kv[b][i]));
                self.xs[i] = x[i] + scale * dx;
                self.vs[i] = v[i] + scale * dv;
            }
            model.link_forces(&self.xs, &self.vs, &mut self.link);
            let fr = &f[r.div_ceil(2)];
            for i in 0..n {
                self.kx[r][i] = self.vs[i];
                self.kv[r][i] = (self.link[i] + fr[i]) * model.inv_mass[i];
            }
        }
        let (kx, kv) = (&self.kx, &self.kv);
        for i in 0..n {
            x[i] += dt / 6.0 * (kx[0][i] + 2.0 * kx[1][i] + 2.0 * kx[2][i] + kx[3][i]);
            v[i] += dt / 6.0 * (kv[0][i] + 2.0 * kv[1][i] + 2.0 * kv[2][i] + kv[3][i]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Characteristic, Term};
    use crate::scenario::Scenario;

    fn oscillator(k1: f64, c1: f64, k3: f64) -> Model {
        let src = format!(
            "name = \"osc\"\n[[mass]]\nname = \"m1\"\nvalue = 2.0\n[[link]]\nends = [\"ground\", \"m1\"]\n\
             stiffness = {{ 1 = {k1}, 3 = {k3} }}\ndamping = {{ 1 = {c1} }}\n[[excitation]]\nkind = \"white\"\n\
             sigma = 1.0\nacts_on = [\"m1\"]\n[simulation]\ndt = 0.01\nrecord_length = 10.0\nsample_interval = 0.1\n"
        );
        Model::new(&Scenario::parse(&src, "osc.toml", "osc").unwrap())
    }

    /// A linear oscillator's free decay against its closed form: the integrator alone.
    #[test]
    fn a_free_decay_follows_the_closed_form() {
        let (m, k, c) = (2.0, 50.0, 0.8);
        let model = oscillator(k, c, 0.0);
        let h = 0.05;
        let run = free_run(&model, &[vec![0.0; 400]], h, 8, &[1.0], &[0.0]).unwrap();
        let (zw, wd) = (c / (2.0 * m), (k / m - (c / (2.0 * m)).powi(2)).sqrt());
        for (s, x) in run.displacement(0).enumerate() {
            let t = s as f64 * h;
            let exact = (-zw * t).exp() * ((wd * t).cos() + zw / wd * (wd * t).sin());
            assert!((x - exact).abs() < 1e-7, "t = {t}: {x} against {exact}");
        }
    }

    /// A sine force sampled at up to 2.5 samples a period (ω·h = 2.5), reconstructed
    /// between its samples, drives the linear oscillator to its exact steady state.
    #[test]
    fn a_sampled_sine_drives_the_exact_steady_state() {
        let (m, k, c) = (2.0, 50.0, 2.0);
        let model = oscillator(k, c, 0.0);
        for omega_h in [0.3, 1.0, 2.5] {
            let h = 0.04;
            let w = omega_h / h;
            let len = 4000;
            let force: Vec<f64> = (0..len).map(|s| (w * s as f64 * h).sin()).collect();
            let run = free_run(&model, &[force], h, 16, &[0.0], &[0.0]).unwrap();
            // x = Im[e^{iωt} / (k − mω² + icω)] once the transient (e^{−t/2}) has gone.
            let (re, im) = (k - m * w * w, c * w);
            let d = re * re + im * im;
            let (a, b) = (re / d, -im / d);
            let amp = (a * a + b * b).sqrt();
            let worst = run
                .displacement(0)
                .enumerate()
                .skip(len / 2)
                .take(len / 2 - 2 * TAPS)
                .map(|(s, x)| {
                    let t = s as f64 * h;
                    (x - (a * (w * t).sin() + b * (w * t).cos())).abs() / amp
                })
                .fold(0.0, f64::max);
            // Measured: 1.3e-6 at ω·h = 0.3, 2e-7 at 1 and 2.5 (the kernel and RK4).
            assert!(
                worst < 5e-6,
                "ω·h = {omega_h}: worst error {worst:.2e} of the amplitude"
            );
        }
    }

    /// A model that is not stable (a negative spring and damper): the run stops and says
    /// where.
    #[test]
    fn an_unstable_model_is_stopped_where_it_diverges() {
        // A scenario refuses it (no stationary density): the model is made unstable after.
        let mut model = oscillator(50.0, 1.0, 0.0);
        model.set_characteristic(0, Characteristic::Stiffness, &[(Term::Power(1), -50.0)]);
        model.set_characteristic(0, Characteristic::Damping, &[(Term::Power(1), -1.0)]);
        let e = free_run(&model, &[vec![0.0; 2000]], 0.05, 4, &[1e-3], &[0.0]).unwrap_err();
        assert!(matches!(e, FreeRunError::Diverged { .. }), "{e}");
        let msg = e.to_string();
        assert!(msg.contains("m1") && msg.contains("diverged at sample"), "{msg}");
    }
}

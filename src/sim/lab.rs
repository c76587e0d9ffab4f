//! Simulation under the excitations labs use (docs/excitations.md): each trajectory's
//! realisation of every [`Signal`] generated on the grid of the integration's stage
//! points, and the equations of motion integrated through it by the classical Runge–Kutta
//! scheme (the same step as the free run of `driven`).
//!
//! A realisation is a sum of cosines on the frequency grid of its period, made by one DFT:
//! - a multisine's lines have equal amplitudes and phases uniform on [0, 2π), drawn anew
//!   for every trajectory; its period is the scenario's;
//! - a noise's lines have independent Gaussian cosine and sine amplitudes of variance
//!   `2 S(ω_k) Δω` (`S` its two-sided density, `Δω` the grid's spacing): a Gaussian
//!   process whose spectrum is `S` on the grid, exactly, up to the grid's Nyquist
//!   frequency. Its period is at least the trajectory's whole length (burn-in and record;
//!   rounded up to a power of two of grid points), so it does not repeat within a
//!   trajectory;
//! - a recording (a table's column, the rig's own input) is taken as band-limited between
//!   its samples and reconstructed on the grid by the free run's Kaiser-windowed sinc;
//!   trajectory `j` is driven by its `j`-th stretch of burn-in and record.
//!
//! White or filtered noise beside them (an unmeasured disturbance of a shaker-driven rig,
//! say) is a realisation of its density on the same grid, up to the integration step's
//! Nyquist frequency (beyond it the scheme's Simpson weights would fold it onto the modes):
//! white noise as a flat Gaussian process there, far above any mode the step resolves.
//! Under it the accelerations and white forces are logged as interval means, as in runs
//! under white noise (white noise has no value at an instant). The sensors' filters run on
//! the motion sampled at their oversampling rate, as in `sim`'s kernels.
//!
//! The force is known at every stage point of the Runge–Kutta steps (the grid is half a
//! step fine), so nothing is interpolated. The response is sampled at the sample
//! instants: displacement, velocity, the acceleration of the force balance there, and the
//! force itself (a lab excitation is measured). Trajectories run in parallel (rayon), each
//! seeded from `(seed, trajectory)`, so the samples do not depend on the thread count;
//! memory holds every trajectory's realisations (bounded by [`MAX_GRID_VALUES`]) and one
//! block of samples.

use super::driven::{weights, weights_into, Rk4, TAPS};
use super::sensor_filters::SensorFilter;
use super::sensors::{channels, Channel};
use super::sinks::SampleSink;
use super::{block_samples, divergence_cause, trajectory_seed, RunStats, SimError, DIVERGENCE_LIMIT};
use crate::model::Model;
use crate::scenario::{Process, Recorded, Signal, Simulation};
use crate::stats::fft::real_signal;
use rand::rngs::Xoshiro256PlusPlus;
use rand::{Rng, RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use std::collections::HashMap;
use std::f64::consts::PI;

/// The most realisation values a run may hold (every trajectory's, every lab
/// excitation's): 2²⁸ values are 2 GiB.
pub const MAX_GRID_VALUES: usize = 1 << 28;

/// A separate stream of each trajectory's generator for the lab signals.
const SIGNAL_STREAM: u64 = 0x6c61_625f_7369_676e;

/// One realisation of `signal` on a grid of `n` points `delta` apart, periodic in
/// `n·delta` (a multisine's period must be that). Drawn from `rng`.
pub fn realisation(signal: &Signal, n: usize, delta: f64, rng: &mut impl Rng) -> Vec<f64> {
    match signal {
        // A recording has one realisation: itself, from its start.
        Signal::Recorded(r) => resampled(r, 0.0, n, delta),
        Signal::Multisine { .. } => {
            let mut c = vec![(0.0, 0.0); n / 2 + 1];
            for (k, amplitude) in signal.lines() {
                if k < c.len() {
                    let phase = 2.0 * PI * rng.random::<f64>();
                    c[k] = (amplitude * phase.cos(), amplitude * phase.sin());
                }
            }
            real_signal(&c, n)
        }
        _ => gaussian_realisation(|w| signal.density(w).expect("a noise has a density"), n, delta, rng),
    }
}

/// One realisation, periodic in `n·delta`, of a stationary Gaussian process of two-sided
/// density `density(ω)` (per rad/s): its line `k` has independent Gaussian cosine and sine
/// amplitudes of variance `2 S(ω_k) Δω`, so its spectrum on the grid is `S` exactly, up to
/// the grid's Nyquist frequency.
fn gaussian_realisation(density: impl Fn(f64) -> f64, n: usize, delta: f64, rng: &mut impl Rng) -> Vec<f64> {
    let dw = 2.0 * PI / (n as f64 * delta);
    let mut c = vec![(0.0, 0.0); n / 2 + 1];
    for (k, ck) in c.iter_mut().enumerate() {
        // The Nyquist line of an even grid has no sine part: left out.
        if 2 * k == n {
            continue;
        }
        let s = density(k as f64 * dw);
        let (a, b): (f64, f64) = (StandardNormal.sample(rng), StandardNormal.sample(rng));
        *ck = if k == 0 {
            ((s * dw).sqrt() * a, 0.0)
        } else {
            let sd = (2.0 * s * dw).sqrt();
            (sd * a, sd * b)
        };
    }
    real_signal(&c, n)
}

/// A disturbance beside the lab signals, as a realisation on the grid: white noise of
/// intensity `σ` as a Gaussian process of density `σ²/2π` up to the Runge–Kutta step's
/// Nyquist frequency `ω_c = π/(2·delta)` (its response lacks what lies beyond, about
/// `(2/π)(c/m)/ω_c` of a mass's velocity variance for a damper `c`), a filtered force
/// (3.20) with its density `A²/(2π(B² + ω²))` up to the same frequency. Content above it
/// would be folded onto the modes by the scheme's Simpson weights (1/6, 4/6, 1/6 of a step
/// alternate on the grid): a density flat to the grid's Nyquist frequency came out 11 %
/// stronger at the modes (`1 + (1/3)²`).
fn disturbance(process: &Process, n: usize, delta: f64, rng: &mut impl Rng) -> Vec<f64> {
    let cut = PI / (2.0 * delta);
    let below = |w: f64, s: f64| if w.abs() <= cut { s } else { 0.0 };
    match *process {
        Process::White { sigma } => gaussian_realisation(|w| below(w, sigma * sigma / (2.0 * PI)), n, delta, rng),
        Process::Filtered { a, b } => {
            gaussian_realisation(|w| below(w, a * a / (2.0 * PI * (b * b + w * w))), n, delta, rng)
        }
        Process::Lab(ref s) => realisation(s, n, delta, rng),
    }
}

/// A recording's stretch from `offset` s on, on a grid of `n` points `delta` apart, in the
/// force's unit (its `scale` applied): the samples taken as band-limited between them and
/// reconstructed by the free run's Kaiser-windowed sinc (`driven`, [`TAPS`] samples each
/// side); a grid point on a sample instant is that sample. Samples beyond the recording's
/// ends are its first and last.
pub fn resampled(r: &Recorded, offset: f64, n: usize, delta: f64) -> Vec<f64> {
    let h = r.interval.expect("a recording read has its sample interval");
    let (f, last) = (&r.samples, r.samples.len() as isize - 1);
    let at = |k: isize| r.scale * f[k.clamp(0, last) as usize];
    // The fractions of an interval the grid meets, a nanosample apart at most: a grid whose
    // spacing divides the recording's meets a few; any other, at most `CACHED` of them kept.
    const CACHED: usize = 4096;
    let mut cache: HashMap<u64, Vec<f64>> = HashMap::new();
    let mut w = vec![0.0; 2 * TAPS];
    (0..n)
        .map(|g| {
            let s = (offset + g as f64 * delta) / h;
            let (mut k, mut tau) = (s.floor() as isize, s - s.floor());
            if tau > 1.0 - 1e-9 {
                (k, tau) = (k + 1, 0.0);
            }
            if tau < 1e-9 {
                return at(k);
            }
            let q = (tau * 1e9).round() as u64;
            let weights = match cache.get(&q) {
                Some(c) => c,
                None if cache.len() < CACHED => cache.entry(q).or_insert_with(|| weights(q as f64 * 1e-9)),
                None => {
                    weights_into(tau, &mut w);
                    &w
                }
            };
            weights
                .iter()
                .enumerate()
                .map(|(j, wj)| wj * at(k + j as isize - TAPS as isize + 1))
                .sum()
        })
        .collect()
}

/// Why the recordings cannot drive `sim`, if they cannot: one unread (a scenario parsed
/// from text), sampled coarser than the run, or too short for its trajectories.
fn check_recordings(model: &Model, sim: &Simulation) -> Result<(), SimError> {
    let span = sim.trajectory_span();
    for (e, x) in model.excitations.iter().enumerate() {
        let Process::Lab(Signal::Recorded(r)) = &x.process else {
            continue;
        };
        let name = &model.excitation_names[e];
        let why = match r.interval {
            _ if r.samples.is_empty() => Some(format!(
                "excitation {name}'s recording {} was not read (a scenario is read with its recordings from \
                 its file)",
                r.file.display()
            )),
            Some(h) if sim.sample_interval > h * (1.0 + 1e-9) => Some(format!(
                "excitation {name}: the run samples every {} s, coarser than its recording's {h} s (the logged \
                 force would alias)",
                sim.sample_interval
            )),
            _ => r
                .too_short(sim.trajectories, span)
                .map(|w| format!("excitation {name}: {w}")),
        };
        if let Some(why) = why {
            return Err(SimError::Lab(why));
        }
    }
    Ok(())
}

/// The grid of the stage points: per excitation, the number of points of its periodic
/// realisation, and the spacing (half a Runge–Kutta step).
struct Grid {
    delta: f64,
    points: Vec<usize>,
}

impl Grid {
    fn new(model: &Model, sim: &Simulation) -> Result<Grid, SimError> {
        let delta = sim.dt / sim.substeps as f64 / 2.0;
        // The trajectory's stage points; a noise's period rounds them up to a power of two
        // (the radix-2 transform, in place, instead of Bluestein's three of twice the length).
        let exact =
            2 * (sim.burn_in_steps() + sim.samples_per_trajectory() * sim.steps_per_sample()) * sim.substeps + 1;
        let points: Vec<usize> = model
            .excitations
            .iter()
            .map(|e| match e.process {
                Process::Lab(Signal::Multisine { period, .. }) => (period / delta).round() as usize,
                Process::Lab(Signal::Recorded(_)) => exact,
                _ => exact.next_power_of_two(),
            })
            .collect();
        let values = points.iter().sum::<usize>() * sim.trajectories;
        if values > MAX_GRID_VALUES {
            return Err(SimError::Lab(format!(
                "the lab excitations' realisations would hold {values:.3e} values (every trajectory's, on a grid \
                 of half an integration step), beyond the {MAX_GRID_VALUES:.3e} this tool holds: use fewer \
                 trajectories, a shorter record, or a larger dt"
            )));
        }
        Ok(Grid { delta, points })
    }
}

/// One trajectory: its state, its realisations and where it is on them.
struct Trajectory {
    x: Vec<f64>,
    v: Vec<f64>,
    signals: Vec<Vec<f64>>,
    /// The grid index of the state's instant.
    at: usize,
    rk: Rk4,
    /// The external force on each mass at the stage points of the next step.
    f: [Vec<f64>; 3],
    /// Scratch: the state at the start of an advance (a divergence reports it), and the
    /// link and external forces of a sample.
    start: (Vec<f64>, Vec<f64>),
    link: Vec<f64>,
    external: Vec<f64>,
}

impl Trajectory {
    fn new(model: &Model, sim: &Simulation, grid: &Grid, j: usize) -> Trajectory {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(trajectory_seed(sim.seed, j) ^ SIGNAL_STREAM);
        let signals = model
            .excitations
            .iter()
            .zip(&grid.points)
            .map(|(e, &n)| match &e.process {
                // Trajectory `j` is driven by the recording's `j`-th stretch of `n` points.
                Process::Lab(Signal::Recorded(r)) => resampled(r, (j * (n - 1)) as f64 * grid.delta, n, grid.delta),
                p => disturbance(p, n, grid.delta, &mut rng),
            })
            .collect();
        let n = model.masses();
        Trajectory {
            x: vec![0.0; n],
            v: vec![0.0; n],
            signals,
            at: 0,
            rk: Rk4::new(n),
            f: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
            start: (vec![0.0; n], vec![0.0; n]),
            link: vec![0.0; n],
            external: vec![0.0; n],
        }
    }

    /// The external force on every mass at grid index `g` of `signals`, into `out`.
    fn force(signals: &[Vec<f64>], model: &Model, g: usize, out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        for (e, s) in model.excitations.iter().zip(signals) {
            let p = s[g % s.len()];
            for &i in &e.targets {
                out[i] += p;
            }
        }
    }

    /// `steps` Runge–Kutta steps of `2·delta`; the divergence error names `trajectory`
    /// and the times (negative during burn-in, `burn` grid points long).
    fn advance(&mut self, model: &Model, steps: usize, delta: f64, j: usize, burn: usize) -> Result<(), SimError> {
        self.start.0.copy_from_slice(&self.x);
        self.start.1.copy_from_slice(&self.v);
        let f = &mut self.f;
        Self::force(&self.signals, model, self.at, &mut f[2]);
        for _ in 0..steps {
            f.rotate_left(2);
            Self::force(&self.signals, model, self.at + 1, &mut f[1]);
            Self::force(&self.signals, model, self.at + 2, &mut f[2]);
            self.rk.step(model, &mut self.x, &mut self.v, f, 2.0 * delta);
            self.at += 2;
        }
        if self.x.iter().chain(&self.v).all(|y| y.abs() < DIVERGENCE_LIMIT) {
            return Ok(());
        }
        let (x0, v0) = (&self.start.0, &self.start.1);
        let t = |g: usize| (g as f64 - burn as f64) * delta;
        Err(SimError::Diverged {
            trajectory: j,
            t_from: t(self.at - 2 * steps),
            t_to: t(self.at),
            last_finite: model
                .mass_names
                .iter()
                .zip(x0)
                .map(|(m, x)| (format!("x_{m}"), *x))
                .chain(model.mass_names.iter().zip(v0).map(|(m, v)| (format!("v_{m}"), *v)))
                .collect(),
            cause: divergence_cause(model, 2.0 * delta, x0, v0),
        })
    }

    /// The sample at the state's instant: per column (`model.columns()`), into `out`.
    /// The sample interval is `points` grid intervals `delta`, since the state in `start`.
    /// Under a white disturbance (no value at an instant) the accelerations are the
    /// velocities' change over the interval and the white forces their interval means, as
    /// the runs under white noise log them.
    fn sample(&mut self, model: &Model, points: usize, delta: f64, out: &mut [f64]) {
        let cols = model.columns();
        let white = |e: usize| matches!(model.excitations[e].process, Process::White { .. });
        let interval_means = !logs_instant_accelerations(model);
        model.link_forces(&self.x, &self.v, &mut self.link);
        Self::force(&self.signals, model, self.at, &mut self.external);
        for i in 0..model.masses() {
            out[cols.x(i)] = self.x[i];
            out[cols.v(i)] = self.v[i];
            out[cols.a(i)] = if interval_means {
                (self.v[i] - self.start.1[i]) / (points as f64 * delta)
            } else {
                (self.link[i] + self.external[i]) * model.inv_mass[i]
            };
        }
        for (e, s) in self.signals.iter().enumerate() {
            out[cols.force(e)] = if white(e) {
                // The trapezoid rule over the interval's grid points.
                let at = |g: usize| s[g % s.len()];
                let inner: f64 = (self.at - points + 1..self.at).map(at).sum();
                (inner + 0.5 * (at(self.at - points) + at(self.at))) / points as f64
            } else {
                s[self.at % s.len()]
            };
        }
    }
}

impl Trajectory {
    /// A block of `b` samples through the sensors' filters: the motion sampled `r` times
    /// finer (`r` the filters' oversampling), each sensor channel filtered and decimated
    /// into `out`, a clean channel taken at the instant or as the interval's mean;
    /// `w` the trajectory's filter states (per column) and whether they have started.
    fn filtered_block(
        &mut self,
        model: &Model,
        f: &SensorFilter,
        channels: &[Channel],
        w: &mut (Vec<f64>, bool),
        (b, steps, delta, j, burn): (usize, usize, f64, usize, usize),
        out: &mut [f64],
    ) -> Result<(), SimError> {
        let (r, cols, sl) = (f.oversampling, model.columns().len(), f.state_len());
        let mut fast = vec![0.0; b * r * cols];
        for q in 0..b * r {
            self.advance(model, steps / r, delta, j, burn)?;
            self.sample(model, 2 * steps / r, delta, &mut fast[q * cols..(q + 1) * cols]);
        }
        for (c, channel) in channels.iter().enumerate() {
            let at = |q: usize| fast[q * cols + c];
            match channel {
                Channel::Sensor => {
                    let state = &mut w.0[c * sl..(c + 1) * sl];
                    f.run(state, w.1, (0..b * r).map(at), |k, y| out[k * cols + c] = y);
                }
                Channel::Instant => (0..b).for_each(|k| out[k * cols + c] = at(k * r + r - 1)),
                Channel::Mean => {
                    (0..b).for_each(|k| out[k * cols + c] = (0..r).map(|q| at(k * r + q)).sum::<f64>() / r as f64)
                }
            }
        }
        w.1 = true;
        Ok(())
    }
}

/// Per log column, what the rig's sensors make of it ([`channels`]), with one difference:
/// without white noise the lab scheme's accelerations are the force balance at the
/// instant, so a clean one is taken at the instant, not averaged.
fn lab_channels(model: &Model, sensors: &crate::scenario::Sensors) -> Vec<Channel> {
    let instants = logs_instant_accelerations(model);
    let cols = model.columns();
    let mut out = channels(model, sensors);
    for i in 0..model.masses() {
        if instants && out[cols.a(i)] == Channel::Mean {
            out[cols.a(i)] = Channel::Instant;
        }
    }
    out
}

/// Whether `model`'s run logs its accelerations at the sample instants (the force balance
/// the lab scheme computes there) rather than as the velocities' change over the interval:
/// a run under lab excitations without white noise.
pub fn logs_instant_accelerations(model: &Model) -> bool {
    is_lab(model)
        && !model
            .excitations
            .iter()
            .any(|e| matches!(e.process, Process::White { .. }))
}

/// Whether `model` is driven by lab excitations (then [`simulate_lab`] runs it).
pub fn is_lab(model: &Model) -> bool {
    model.excitations.iter().any(|e| matches!(e.process, Process::Lab(_)))
}

/// Simulate every trajectory of `sim` under the model's lab excitations (and any white or
/// filtered noise beside them, as realisations of their spectra on the grid) and hand the
/// samples to `sink` block by block, in (time, trajectory) order, as [`super::simulate`]
/// does; the sensors' noise and ADC of `[measurement]` are applied to the samples.
pub fn simulate_lab(
    model: &Model,
    sim: &Simulation,
    sink: &mut dyn SampleSink,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<RunStats, SimError> {
    check_recordings(model, sim)?;
    let grid = Grid::new(model, sim)?;
    let steps = sim.steps_per_sample() * sim.substeps;
    let burn_steps = sim.burn_in_steps() * sim.substeps;
    let burn = 2 * burn_steps;
    crate::interrupt::check()?;
    let mut trajectories: Vec<Trajectory> = (0..sim.trajectories)
        .into_par_iter()
        .map(|j| Trajectory::new(model, sim, &grid, j))
        .collect();
    trajectories
        .par_iter_mut()
        .enumerate()
        .try_for_each(|(j, t)| t.advance(model, burn_steps, grid.delta, j, burn))?;

    let cols = model.columns().len();
    let total = sim.samples_per_trajectory();
    let per_k = sim.trajectories;
    let block = block_samples(steps, cols * per_k, total);
    let mut sensors = super::sensors::SensorNoise::new(model, &sim.sensors, sim.seed);
    let filters = SensorFilter::new(&sim.sensors, sim.sample_interval, sim.steps_per_sample(), sim.substeps)
        .map_err(SimError::Lab)?
        .map(|f| (f, lab_channels(model, &sim.sensors)));
    let state_len = filters.as_ref().map_or(0, |f| f.0.state_len() * cols);
    let mut filtering: Vec<(Vec<f64>, bool)> = (0..per_k).map(|_| (vec![0.0; state_len], false)).collect();
    let mut done = 0;
    while done < total {
        crate::interrupt::check()?;
        let b = block.min(total - done);
        // Each trajectory's samples of the block, `b × cols`, then interleaved.
        let own: Vec<Vec<f64>> = trajectories
            .par_iter_mut()
            .zip(filtering.par_iter_mut())
            .enumerate()
            .map(|(j, (t, w))| {
                let mut out = vec![0.0; b * cols];
                match &filters {
                    None => {
                        for k in 0..b {
                            t.advance(model, steps, grid.delta, j, burn)?;
                            t.sample(model, 2 * steps, grid.delta, &mut out[k * cols..(k + 1) * cols]);
                        }
                    }
                    Some((f, channels)) => {
                        let run = (b, steps, grid.delta, j, burn);
                        t.filtered_block(model, f, channels, w, run, &mut out)?;
                    }
                }
                Ok(out)
            })
            .collect::<Result<_, SimError>>()?;
        let times = (1..=b).map(|k| (done + k) as f64 * sim.sample_interval);
        let mut batch = super::next_batch(sink, cols, per_k, times);
        for (j, o) in own.iter().enumerate() {
            for (kc, &y) in o.iter().enumerate() {
                batch.values[kc * per_k + j] = y;
            }
        }
        if let Some(s) = sensors.as_mut() {
            s.apply(&mut batch, done);
        }
        sink.write(batch).map_err(SimError::Sink)?;
        done += b;
        progress((done * per_k) as u64);
    }
    Ok(RunStats {
        samples: (total * per_k) as u64,
        steps: ((burn_steps + total * steps) * per_k) as u64,
        clipped: sensors.map_or(0, |s| s.clipped),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::fft::dft;

    fn rng(seed: u64) -> Xoshiro256PlusPlus {
        Xoshiro256PlusPlus::seed_from_u64(seed)
    }

    /// Over one period a multisine is its lines: the DFT holds each line's amplitude and
    /// nothing else, and its mean square is `rms²`, for any grid length.
    #[test]
    fn a_multisine_realisation_is_its_lines() {
        for (n, odd) in [(1000usize, false), (1024, true), (999, false)] {
            let s = Signal::Multisine {
                rms: 0.3,
                band: (2.0, 40.0),
                period: 1.0,
                odd,
                shape: None,
            };
            let x = realisation(&s, n, 1.0 / n as f64, &mut rng(7));
            let ms = x.iter().map(|v| v * v).sum::<f64>() / n as f64;
            assert!((ms - 0.09).abs() < 1e-12, "mean square {ms}");
            let (mut re, mut im) = (x.clone(), vec![0.0; n]);
            dft(&mut re, &mut im);
            let lines = s.lines();
            for k in 1..n / 2 {
                let amp = 2.0 * (re[k].hypot(im[k])) / n as f64;
                let want = lines.iter().find(|l| l.0 == k).map_or(0.0, |l| l.1);
                assert!((amp - want).abs() < 1e-12, "N = {n}, line {k}: {amp} against {want}");
            }
        }
    }

    /// A rig with an anti-alias filter under a multisine: after the filter's start, each
    /// line of the logged displacement is the response's line through the filter's gain at
    /// the fast rate, `Σ|H(ω_k)|²|G(ω_k)|²A_k²/2` (2.5e-8 off; the 4 Hz corner takes 16 %
    /// of it); the clean velocity and force are the unfiltered lines at the instants.
    #[test]
    fn a_filtered_rig_under_a_multisine_logs_each_line_through_the_filters_gain() {
        let src = "name = \"lab\"\n[[mass]]\nname = \"m1\"\nvalue = 2.0\n[[link]]\nends = [\"ground\", \"m1\"]\n\
                   stiffness = { 1 = 800.0 }\ndamping = { 1 = 4.0 }\n[[excitation]]\nname = \"p\"\n\
                   kind = \"multisine\"\nrms = 3.0\nband = [1.0, 9.0]\nperiod = 4.0\nlines = \"odd\"\n\
                   acts_on = [\"m1\"]\n[simulation]\ndt = 1.25e-3\nrecord_length = 8.0\nsample_interval = 0.02\n\
                   burn_in = 20.0\ntrajectories = 2\nseed = 4\n[measurement]\nanti_alias = 0.08\n\
                   [measurement.sensors]\nm1 = [\"displacement\"]\n";
        let s = crate::Scenario::parse(src, "lab.toml", "lab").unwrap();
        let model = Model::new(&s);
        let Process::Lab(signal) = &s.excitations[0].process else {
            panic!()
        };
        let f = SensorFilter::new(&s.simulation.sensors, 0.02, 16, 1).unwrap().unwrap();
        let fast = f.oversampling as f64 / 0.02;
        let (mut clean, mut filtered, mut v2_exact) = (0.0, 0.0, 0.0);
        for &(k, a) in &signal.lines() {
            let w = 2.0 * PI * k as f64 / 4.0;
            let h2 = 1.0 / ((800.0 - 2.0 * w * w).powi(2) + (4.0 * w).powi(2));
            clean += h2 * a * a / 2.0;
            v2_exact += w * w * h2 * a * a / 2.0;
            filtered += h2 * f.gain2(w / (2.0 * PI) / fast) * a * a / 2.0;
        }
        let mut c = super::super::Collect::default();
        simulate_lab(&model, &s.simulation, &mut c, &|_| {}).unwrap();
        let (mut x2, mut v2, mut p2, mut n) = (0.0, 0.0, 0.0, 0.0);
        let cols = model.columns();
        for b in &c.batches {
            b.for_each_sample(|_, t, row| {
                // The second period, after the filter's start (its memory: a few samples).
                if t > 4.0 + 1e-9 {
                    x2 += row[cols.x(0)].powi(2);
                    v2 += row[cols.v(0)].powi(2);
                    p2 += row[cols.force(0)].powi(2);
                    n += 1.0;
                }
            });
        }
        let (x2, v2, p2) = (x2 / n, v2 / n, p2 / n);
        assert!(filtered < 0.9 * clean, "the filter takes {filtered} of {clean}");
        assert!(
            (x2 / filtered - 1.0).abs() < 1e-6,
            "x² {x2} against {filtered} (unfiltered {clean})"
        );
        assert!((v2 / v2_exact - 1.0).abs() < 1e-6, "clean v² {v2} against {v2_exact}");
        assert!((p2 / 9.0 - 1.0).abs() < 1e-9, "clean p² {p2}");
    }

    /// A recording reconstructed between its samples: a sum of cosines up to 0.3 of its
    /// sampling rate is found again on a grid eight times finer, from any offset, to the
    /// kernel's accuracy (1e-6 of the amplitude), and exactly on the sample instants;
    /// the scale multiplies it.
    #[test]
    fn a_recording_is_reconstructed_between_its_samples() {
        let h = 0.01;
        let f = |t: f64| {
            [(3.0, 0.7, 0.3), (17.0, 0.4, 1.1), (30.0, 0.25, 2.0)]
                .iter()
                .map(|&(hz, a, ph): &(f64, f64, f64)| a * (2.0 * PI * hz * t + ph).cos())
                .sum::<f64>()
        };
        let r = Recorded {
            file: "r.csv".into(),
            column: "u".into(),
            time: None,
            interval: Some(h),
            scale: 2.0,
            samples: (0..2000).map(|k| f(k as f64 * h)).collect(),
            at: 0..0,
        };
        let mut worst = 0.0f64;
        for offset in [0.0, 3.0, 4.567] {
            let (n, delta) = (4000, h / 8.0);
            let x = resampled(&r, offset, n, delta);
            // Away from the ends, where the kernel reads beyond the recording.
            for (g, &xg) in x.iter().enumerate().skip(8 * (TAPS + 8)) {
                let want = 2.0 * f(offset + g as f64 * delta);
                worst = worst.max((xg - want).abs() / 2.7);
                let _ = g;
            }
            if offset == 3.0 {
                for g in (0..n).step_by(8) {
                    assert_eq!(x[g], 2.0 * r.samples[300 + g / 8], "point {g} on a sample");
                }
            }
        }
        // Measured: 7.8e-7 of the amplitude.
        assert!(worst < 2e-6, "reconstruction error {worst:.2e} of the amplitude");
        // A spacing that does not divide the recording's: the same accuracy.
        let x = resampled(&r, 1.0, 3000, h / std::f64::consts::E);
        for (g, &xg) in x.iter().enumerate().skip(3 * (TAPS + 8)) {
            let want = 2.0 * f(1.0 + g as f64 * h / std::f64::consts::E);
            assert!((xg - want).abs() < 2e-6 * 2.7, "point {g}: {xg} against {want}");
        }
    }

    /// Band-limited and Kanai–Tajimi noise: the variance over many realisations is the
    /// closed-form integral of the density, and the averaged periodogram follows the
    /// density line by line within its sampling scatter.
    #[test]
    fn a_noise_realisation_has_its_spectrum() {
        let signals = [
            Signal::BandLimited {
                sigma: 1.0,
                band: (0.0, 20.0),
                order: 4,
            },
            Signal::BandLimited {
                sigma: 2.0,
                band: (10.0, 30.0),
                order: 2,
            },
            Signal::KanaiTajimi {
                sigma: 1.0,
                omega_g: 60.0,
                zeta_g: 0.4,
            },
        ];
        let (n, delta, reps) = (4096usize, 1e-3, 200);
        for s in signals {
            let mut g = rng(11);
            let mut power = vec![0.0; n / 2];
            let mut var = 0.0;
            for _ in 0..reps {
                let x = realisation(&s, n, delta, &mut g);
                var += x.iter().map(|v| v * v).sum::<f64>() / (n * reps) as f64;
                let (mut re, mut im) = (x, vec![0.0; n]);
                dft(&mut re, &mut im);
                for k in 1..n / 2 {
                    power[k] += (re[k] * re[k] + im[k] * im[k]) / reps as f64;
                }
            }
            // The grid stops at Nyquist (500 Hz): the tails beyond are not in the variance.
            let want = s.rms().powi(2);
            let tail = if matches!(s, Signal::KanaiTajimi { .. }) {
                0.03
            } else {
                0.0
            };
            assert!(
                (var / want - 1.0).abs() < 0.03 + tail,
                "{s:?}: variance {var} against {want}"
            );
            // E|X_k|² = N² · S(ω_k) Δω for the two-sided density: the band's lines pooled
            // in groups of 16 (the scatter of a mean of 3200 exponentials is 1.8 %).
            let dw = 2.0 * PI / (n as f64 * delta);
            let peak = (1..n / 2)
                .map(|k| s.density(k as f64 * dw).unwrap())
                .fold(0.0, f64::max);
            let in_band = |k: usize| s.density(k as f64 * dw).unwrap() > 1e-3 * peak;
            for group in (16..n / 2 - 16).step_by(16).filter(|&k| in_band(k)) {
                let (got, want): (f64, f64) = (group..group + 16)
                    .map(|k| (power[k], (n * n) as f64 * s.density(k as f64 * dw).unwrap() * dw))
                    .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
                assert!(
                    (got / want - 1.0).abs() < 0.08,
                    "{s:?}, lines {group}+: {got} against {want}"
                );
            }
        }
    }
}

//! Stochastic simulation of a [`Model`]: semi-implicit or explicit Euler–Maruyama steps,
//! exact Ornstein–Uhlenbeck transitions, burn-in, sampling, parallel trajectories.
//!
//! Performance design: trajectories are stepped [`LANES`] at a time in struct-of-arrays
//! lanes, so the CPU always has independent work while one lane waits on its state's
//! dependency chain, and the per-link polynomial loop is amortised over the lanes. The
//! shaped kernel (`advance_shaped`, up to four masses and four excitations) separates the
//! two kinds of work: the normals of a block of steps are drawn first, every lane's
//! generator stepped side by side (`fill_noise`, module `normals`), then the steps run over them as straight-line vector arithmetic,
//! 16 lanes at a time in registers, with every link's ends known at compile time (the
//! links are rewritten as one per pair of ends, `LaneModel::complete_links`). Larger
//! systems run on the blocked kernel (`advance_blocked`), which works the same way with the
//! shape read at run time. Each
//! lane has its own xoshiro256++ generator (`rand`'s `Xoshiro256PlusPlus`), seeded from `(seed, trajectory)`, so the output is
//! bit-identical whatever the number of threads. Time advances in blocks of samples: in a
//! block every lane group runs in parallel (rayon), then the block's samples are handed,
//! in (time, trajectory) order, to a [`SampleSink`] — memory is bounded by one block.
//!
//! This module knows nothing of files: sinks (the MCAP writer, moment accumulators in
//! tests) are supplied by the caller.

mod blocked;
pub mod driven;
pub mod lab;
mod lanes;
mod normals;
pub(crate) mod sensor_filters;
pub(crate) mod sensors;
mod shaped;
mod sinks;

pub use normals::LaneNormals;
pub use sinks::{Collect, Discard, ForEach, Moments, SampleBatch, SampleSink};

use crate::model::Model;
use crate::scenario::Simulation;
use lanes::{advance_generic, no_kernel, run_group, zero, Group, LaneModel, Stepper};
use rayon::prelude::*;
use shaped::shaped_kernel;

/// Trajectories stepped together in one group (a group is the unit of parallel work:
/// multiples of `2 × LANES` trajectories keep two cores busy).
pub const LANES: usize = 32;

pub(crate) type Lane = [f64; LANES];

/// States whose magnitude passes this are taken as diverged.
pub const DIVERGENCE_LIMIT: f64 = 1e10;

/// Errors of a simulation run.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The state became non-finite or exploded: when, the last finite state, and a cause
    /// that fits it ([`divergence_cause`]).
    #[error(
        "simulation diverged in trajectory {trajectory} between t = {t_from:.6} s and t = {t_to:.6} s \
         (time after burn-in; negative = during burn-in). Last finite state, at t = {t_from:.6} s: {}. {cause}",
        .last_finite.iter().map(|(n, v)| format!("{n} = {v:.6e}")).collect::<Vec<_>>().join(", ")
    )]
    Diverged {
        trajectory: usize,
        t_from: f64,
        t_to: f64,
        last_finite: Vec<(String, f64)>,
        cause: String,
    },
    /// The sink refused a batch (e.g. the log file could not be written).
    #[error("writing samples failed")]
    Sink(#[source] Box<dyn std::error::Error + Send + Sync>),
    /// The sensors' filters cannot run on this simulation's steps
    /// (`sensor_sensor_filters::SensorFilter::new`).
    #[error("[measurement]: {0}")]
    Sensors(String),
    /// The lab excitations cannot run on this simulation (module `lab`).
    #[error("lab excitations: {0}")]
    Lab(String),
    /// A stop was requested (`crate::interrupt`).
    #[error(transparent)]
    Interrupted(#[from] crate::interrupt::Interrupted),
}

/// Above this `ω·h` (or `γ·h`) at the last finite state, a divergence is put down to the
/// step: the semi-implicit scheme is unstable beyond 2, and a state that reached 1 is one
/// sample interval's growth away from it.
const STEP_LIMIT_NEAR: f64 = 1.0;

/// Why a simulation that left the state `(x, v)` finite one sample interval earlier
/// diverged: the integration step against the local stiffness and damping there (each
/// mass's `ω = √(Σ|K'(u)|/m)` and `γ = Σ|C'(w)|/m` over its links), or otherwise an escape.
pub fn divergence_cause(m: &Model, h: f64, x: &[f64], v: &[f64]) -> String {
    let mut worst = (0.0f64, String::new());
    for i in 0..m.masses() {
        let (mut k, mut c, mut largest, mut name) = (0.0f64, 0.0f64, 0.0f64, "");
        for l in 0..m.links() {
            if m.sign(l, i) == 0.0 {
                continue;
            }
            let (u, w) = (m.relative(l, x), m.relative(l, v));
            let du = 1e-6 * u.abs().max(1.0);
            let dw = 1e-6 * w.abs().max(1.0);
            let kl = ((m.link_force(l, u + du, w) - m.link_force(l, u - du, w)) / (2.0 * du)).abs();
            let cl = ((m.link_force(l, u, w + dw) - m.link_force(l, u, w - dw)) / (2.0 * dw)).abs();
            let own = ((kl / m.mass[i]).sqrt() * h).max(cl / m.mass[i] * h);
            if own >= largest {
                (largest, name) = (own, &m.link_names[l]);
            }
            k += kl;
            c += cl;
        }
        let number = ((k / m.mass[i]).sqrt() * h).max(c / m.mass[i] * h);
        if number > worst.0 || number.is_nan() {
            worst = (number, format!("mass {} (mostly link {name})", m.mass_names[i]));
        }
    }
    // Numbers as a reader takes them: 12.35, or 1.000e97 rather than ninety-eight digits.
    let readable = |x: f64, digits: usize| match x.abs() < 1e6 {
        true => format!("{x:.digits$}"),
        false => format!("{x:.3e}"),
    };
    if worst.0 >= STEP_LIMIT_NEAR || !worst.0.is_finite() {
        let factor = (2.0 * worst.0).ceil().max(2.0);
        let advice = match factor <= 1e6 {
            true => format!(
                "The polynomial characteristics stiffen with amplitude, so rare large excursions reach this; \
                 reduce dt (or raise substeps) by a factor of at least {factor:.0}"
            ),
            false => format!(
                "No step could carry it (dt would have to shrink {}-fold): check the stiffness and damping \
                 coefficients and their units",
                readable(factor, 0)
            ),
        };
        format!(
            "Cause: the step is too large for the stiffness or damping the response reached: at the last finite \
             state ω·h (or γ·h) = {} for {} with h = {h:e} s, and the scheme is unstable beyond 2. {advice}",
            readable(worst.0, 2),
            worst.1,
        )
    } else {
        format!(
            "Cause: not the step (ω·h = {:.2} at the last finite state, far below the limit 2): the state escaped \
             within one sample interval — check the signs of the stiffness and damping coefficients and the \
             excitation's intensity; reducing dt will not help",
            worst.0
        )
    }
}

/// What a finished run did.
#[derive(Debug, Clone, Copy)]
pub struct RunStats {
    pub samples: u64,
    /// Integration steps summed over trajectories (including burn-in and sub-steps).
    pub steps: u64,
    /// Values the sensors' ADC clipped (`[measurement]`).
    pub clipped: u64,
}

/// The seed of trajectory `j`'s generator: a SplitMix64 mix of the master seed and `j`.
pub fn trajectory_seed(seed: u64, j: usize) -> u64 {
    let mut z = seed ^ (j as u64).wrapping_add(1).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_133f_11eb);
    z ^ (z >> 31)
}

/// Instants per block: a group's block is at most about `2e5` steps (cheap
/// synchronisation), and a batch at most about 2 MB of values (it stays in the caches
/// between the simulator and the sink, and recycled batches come back quickly).
pub(crate) fn block_samples(steps_per_sample: usize, values_per_instant: usize, total: usize) -> usize {
    (200_000 / steps_per_sample.max(1))
        .min((1 << 18) / values_per_instant.max(1))
        .clamp(1, 4096)
        .min(total.max(1))
}

/// The batch of the next block's instants `times`: one the sink has finished with, refilled
/// as it is (every value is overwritten), or a new one of lazily zeroed memory, its pages
/// first touched by whoever writes the samples into it.
pub(crate) fn next_batch(
    sink: &mut dyn SampleSink,
    columns: usize,
    trajectories: usize,
    times: impl Iterator<Item = f64>,
) -> SampleBatch {
    let mut batch = sink.recycle().unwrap_or_default();
    batch.time.clear();
    batch.time.extend(times);
    let len = batch.time.len() * columns * trajectories;
    if batch.values.len() >= len {
        batch.values.truncate(len);
    } else {
        batch.values = vec![0.0; len];
    }
    batch.columns = columns;
    batch.trajectories = trajectories;
    batch
}

/// Simulate every trajectory of `sim` and hand the samples to `sink`, block by block, in
/// (time, trajectory) order. `progress` is called with the number of samples written so far.
pub fn simulate(
    model: &Model,
    sim: &Simulation,
    sink: &mut dyn SampleSink,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<RunStats, SimError> {
    simulate_stepping(model, sim, sink, progress, Stepping::Fastest)
}

/// [`simulate`] with the generic stepper only (no shaped or blocked kernel, but the same
/// rewritten links): the reference the kernels are tested against, bit for bit.
pub fn simulate_generic(
    model: &Model,
    sim: &Simulation,
    sink: &mut dyn SampleSink,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<RunStats, SimError> {
    simulate_stepping(model, sim, sink, progress, Stepping::Generic)
}

/// Which stepper advances the lane groups (all give the same samples, bit for bit).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stepping {
    /// The shaped kernel where one fits the model, else the blocked kernel.
    Fastest,
    /// The blocked kernel whatever the model (for the bench's comparison).
    Blocked,
    /// The generic stepper (the reference).
    Generic,
    /// The generic stepper at the simulation's step on the Brownian paths of the run at
    /// twice that step ([`Stepping::Fastest`] with half the `substeps`): the pair differs
    /// by the integrator's error alone. `substeps` must be even.
    Refined,
}

/// [`simulate`] with the stepper chosen (the bench compares them; the samples are the same).
pub fn simulate_stepping(
    model: &Model,
    sim: &Simulation,
    sink: &mut dyn SampleSink,
    progress: &(dyn Fn(u64) + Sync),
    stepping: Stepping,
) -> Result<RunStats, SimError> {
    // Lab excitations are deterministic signals: integrated by their own scheme.
    if lab::is_lab(model) {
        return lab::simulate_lab(model, sim, sink, progress);
    }
    let degree = (0..model.links())
        .map(|l| model.k_len[l].max(model.c_len[l]))
        .max()
        .unwrap_or(1);
    // One monomorphised stepper per padded degree.
    match degree {
        0 | 1 => simulate_padded::<1>(model, sim, sink, progress, stepping, shaped_kernel),
        2 | 3 => simulate_padded::<3>(model, sim, sink, progress, stepping, shaped_kernel),
        4 | 5 => simulate_padded::<5>(model, sim, sink, progress, stepping, shaped_kernel),
        6 | 7 => simulate_padded::<7>(model, sim, sink, progress, stepping, no_kernel),
        _ => simulate_padded::<15>(model, sim, sink, progress, stepping, no_kernel),
    }
}

pub(crate) fn simulate_padded<const D: usize>(
    model: &Model,
    sim: &Simulation,
    sink: &mut dyn SampleSink,
    progress: &(dyn Fn(u64) + Sync),
    stepping: Stepping,
    shaped: fn(&LaneModel<D>) -> Option<Stepper<D>>,
) -> Result<RunStats, SimError> {
    let lm = match stepping {
        Stepping::Fastest => LaneModel::<D>::new(model, sim, shaped),
        Stepping::Blocked => LaneModel::<D>::new(model, sim, no_kernel),
        Stepping::Generic | Stepping::Refined => {
            let mut lm = LaneModel::<D>::new(model, sim, shaped);
            lm.advance = advance_generic::<D>;
            lm.refined = stepping == Stepping::Refined;
            assert!(
                !lm.refined || sim.substeps.is_multiple_of(2),
                "a refined run halves the step of its pair"
            );
            lm
        }
    };
    let steps = sim.steps_per_sample() * sim.substeps;
    let interval = sim.sample_interval;
    let total = sim.samples_per_trajectory();
    let cols = model.columns().len();
    let mut groups: Vec<Group> = (0..sim.trajectories.div_ceil(LANES))
        .map(|g| Group::new(model, sim.seed, g * LANES, (sim.trajectories - g * LANES).min(LANES)))
        .collect();

    // Burn-in, in whole sample intervals (plus the remainder) so divergence is caught early.
    let burn_steps = sim.burn_in_steps() * sim.substeps;
    let burn_intervals = burn_steps / steps;
    let burn_rest = burn_steps % steps;
    let t_burn = -(burn_steps as f64) * lm.h;
    crate::interrupt::check()?;
    groups.par_iter_mut().try_for_each(|g| {
        run_group(g, model, &lm, steps, burn_intervals, interval, t_burn, &mut [])?;
        let t_rest = t_burn + burn_intervals as f64 * interval;
        run_group(g, model, &lm, burn_rest, 1, burn_rest as f64 * lm.h, t_rest, &mut [])?;
        // The first sample's Δv and impulse start here.
        g.v_mark.copy_from_slice(&g.v[..model.masses()]);
        for (e, p) in g.p.iter_mut().enumerate() {
            if lm.is_white[e] {
                *p = zero();
            }
        }
        Ok::<(), SimError>(())
    })?;

    let mut sensors = sensors::SensorNoise::new(model, &sim.sensors, sim.seed);
    let channels = sensors::channels(model, &sim.sensors);
    // The sensors' filters run on the motion sampled `r` times faster (module `sensor_filters`):
    // each group keeps its lanes' filter states and a block of fast samples.
    let filter = sensor_filters::SensorFilter::new(&sim.sensors, interval, sim.steps_per_sample(), sim.substeps)
        .map_err(SimError::Sensors)?;
    let r = filter.as_ref().map_or(1, |f| f.oversampling);
    let block = (block_samples(steps / r, cols * sim.trajectories, total * r) / r).max(1);
    let mut filtering: Vec<Filtering> = match &filter {
        Some(f) => groups
            .iter()
            .map(|g| Filtering {
                state: vec![0.0; cols * g.active * f.state_len()],
                started: false,
                fast: vec![0.0; block * r * cols * g.active],
            })
            .collect(),
        None => Vec::new(),
    };
    let mut done = 0usize;
    while done < total {
        crate::interrupt::check()?;
        let b = block.min(total - done);
        let t0 = done as f64 * interval;
        let per_k = sim.trajectories;
        let mut batch = next_batch(sink, cols, per_k, (1..=b).map(|k| (done + k) as f64 * interval));
        // Each group's lanes of each column at each instant: contiguous, so the batch
        // splits into disjoint slices, `b × cols` per group.
        let mut parts: Vec<Vec<&mut [f64]>> = groups.iter().map(|_| Vec::with_capacity(b * cols)).collect();
        for column in batch.values.chunks_exact_mut(per_k) {
            let mut rest = column;
            for (g, part) in groups.iter().zip(parts.iter_mut()) {
                let (mine, tail) = rest.split_at_mut(g.active);
                part.push(mine);
                rest = tail;
            }
        }
        let results: Vec<Result<(), SimError>> = match &filter {
            None => groups
                .par_iter_mut()
                .zip(parts.par_iter_mut())
                .map(|(g, out)| run_group(g, model, &lm, steps, b, interval, t0, out))
                .collect(),
            Some(f) => groups
                .par_iter_mut()
                .zip(parts.par_iter_mut())
                .zip(filtering.par_iter_mut())
                .map(|((g, out), w)| run_filtered_group(g, model, &lm, f, &channels, w, (b, steps, interval, t0), out))
                .collect(),
        };
        drop(parts);
        // The first failing group in trajectory order, whatever the thread count.
        results.into_iter().collect::<Result<Vec<()>, SimError>>()?;
        if let Some(s) = sensors.as_mut() {
            s.apply(&mut batch, done);
        }
        sink.write(batch).map_err(SimError::Sink)?;
        done += b;
        progress((done * sim.trajectories) as u64);
    }
    let steps_total = (groups.len() * LANES) as u64 * (burn_steps + total * steps) as u64;
    Ok(RunStats {
        samples: (total * sim.trajectories) as u64,
        steps: steps_total,
        clipped: sensors.map_or(0, |s| s.clipped),
    })
}

/// One group's block of `b` samples through the sensors' filters: the motion stepped `r`
/// times finer into the group's fast samples, each sensor channel filtered and decimated
/// into `out`, a clean channel taken at the instant or as the interval's mean.
#[allow(clippy::too_many_arguments)]
fn run_filtered_group<const D: usize>(
    g: &mut Group,
    model: &Model,
    lm: &LaneModel<D>,
    f: &sensor_filters::SensorFilter,
    channels: &[sensors::Channel],
    w: &mut Filtering,
    (b, steps, interval, t0): (usize, usize, f64, f64),
    out: &mut [&mut [f64]],
) -> Result<(), SimError> {
    let (r, cols) = (f.oversampling, model.columns().len());
    let fast = &mut w.fast[..b * r * cols * g.active];
    let mut slices: Vec<&mut [f64]> = fast.chunks_exact_mut(g.active).collect();
    run_group(g, model, lm, steps / r, b * r, interval / r as f64, t0, &mut slices)?;
    drop(slices);
    let (act, sl) = (g.active, f.state_len());
    let at = |k: usize, c: usize, j: usize| w.fast[(k * cols + c) * act + j];
    for c in 0..cols {
        match channels[c] {
            sensors::Channel::Sensor => {
                // The group's lanes side by side, their states `[section][2][lane]`.
                let state = &mut w.state[c * act * sl..(c + 1) * act * sl];
                let fast = (&w.fast[c * act..], cols * act, b * r, act);
                f.run_lanes(state, w.started, fast, |k, y| out[k * cols + c].copy_from_slice(y));
            }
            // A clean state the rig does not measure: unfiltered.
            sensors::Channel::Instant => {
                for k in 0..b {
                    for j in 0..act {
                        out[k * cols + c][j] = at(k * r + r - 1, c, j);
                    }
                }
            }
            sensors::Channel::Mean => {
                for k in 0..b {
                    for j in 0..act {
                        out[k * cols + c][j] = (0..r).map(|q| at(k * r + q, c, j)).sum::<f64>() / r as f64;
                    }
                }
            }
        }
    }
    w.started = true;
    Ok(())
}

/// One group's sensor filters: per column the lanes' filter states (`[section][2][lane]`,
/// set from the first fast sample), and the block's fast samples, `instants × columns ×
/// lanes`.
struct Filtering {
    state: Vec<f64>,
    started: bool,
    fast: Vec<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::Scenario;

    /// A system whose terms are evaluated one by one (the path of a term without a
    /// polynomial form, here taken by powers) gives the samples of its polynomial form to
    /// rounding: the generic stepper and `Model::link_force` evaluate every [`Term`] kind,
    /// and the fast kernels step aside when a model has such terms.
    #[test]
    fn terms_evaluated_one_by_one_step_as_their_polynomial() {
        let file = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/duffing2dof.toml");
        let mut s = Scenario::parse(&std::fs::read_to_string(file).unwrap(), file, "t").unwrap();
        s.simulation.record_length = 20.0;
        s.simulation.trajectories = 9;
        let poly = Model::new(&s);
        let terms = poly.with_powers_as_other_terms();
        assert!(terms.coefs.iter().all(|&c| c == 0.0) && terms.other_terms.len() == 9);
        for (u, w) in [(0.3, -1.2), (-2.0, 0.7), (0.0, 0.0)] {
            for l in 0..poly.links() {
                let (a, b) = (poly.link_force(l, u, w), terms.link_force(l, u, w));
                assert!((a - b).abs() <= 1e-12 * a.abs().max(1.0), "link {l}: {a} against {b}");
            }
        }
        let (mut a, mut b) = (sinks::Collect::default(), sinks::Collect::default());
        simulate(&poly, &s.simulation, &mut a, &|_| {}).unwrap();
        simulate(&terms, &s.simulation, &mut b, &|_| {}).unwrap();
        let values = |c: &sinks::Collect| -> Vec<f64> { c.batches.iter().flat_map(|b| b.values.clone()).collect() };
        let (va, vb) = (values(&a), values(&b));
        assert_eq!(va.len(), vb.len());
        let scale = va.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = va.iter().zip(&vb).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(
            worst <= 1e-9 * scale,
            "largest difference {worst:e} against a scale of {scale}"
        );
        // Not bit-identical: the fused kernel's Horner is not the term-by-term sum.
        assert!(va != vb, "the term-by-term path was not taken");
    }
}

#[cfg(test)]
mod filter_tests {
    use super::*;
    use crate::scenario::Scenario;

    fn sdof(measurement: &str) -> Scenario {
        let file = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/sdof_duffing.toml");
        let text = format!(
            "{}\n[measurement]\n{measurement}\n",
            std::fs::read_to_string(file).unwrap()
        );
        let mut s = Scenario::parse(&text, file, "t").unwrap();
        s.simulation.record_length = 200.0;
        s.simulation.trajectories = 64;
        s
    }

    /// Per column: variance and lag-1 correlation over every trajectory.
    fn variances(s: &Scenario) -> Vec<(f64, f64)> {
        let model = Model::new(s);
        let mut c = sinks::Collect::default();
        simulate(&model, &s.simulation, &mut c, &|_| {}).unwrap();
        let cols = model.columns().len();
        let per_k = s.simulation.trajectories;
        let instants: Vec<&[f64]> = c
            .batches
            .iter()
            .flat_map(|b| (0..b.instants()).map(move |k| b.instant(k)))
            .collect();
        (0..cols)
            .map(|col| {
                let (mut n, mut s1, mut s2, mut lag) = (0.0, 0.0, 0.0, 0.0);
                for (k, inst) in instants.iter().enumerate() {
                    for j in 0..per_k {
                        let y = inst[col * per_k + j];
                        n += 1.0;
                        s1 += y;
                        s2 += y * y;
                        if k > 0 {
                            lag += y * instants[k - 1][col * per_k + j];
                        }
                    }
                }
                let var = s2 / n - (s1 / n).powi(2);
                (var, (lag / (n - per_k as f64) - (s1 / n).powi(2)) / var)
            })
            .collect()
    }

    /// The anti-alias filter on a white force cell: its logged variance is the fast
    /// samples' `σ²/h_fast` times the filter's noise gain (exact for white input; within
    /// 3 % = 6 standard errors of 2e5 correlated samples), neighbouring samples become
    /// correlated. The displacement, far below the corner, keeps its variance (the same
    /// motion: the filters draw no random numbers); the velocity of a mass under a white
    /// force has a tail `S_v ≈ σ²/(m²ω²)` above its modes, and the filter takes out
    /// `(σ²/πm²)∫(1 − |H|²)/ω² dω = (σ²/πm²ω_c)·(π/2N)/sin(π(2N−1)/2N)` of it, 1.30 % of
    /// this oscillator's `σ²/2c` at ω_c = 2π·4 Hz.
    #[test]
    fn the_anti_alias_filter_band_limits_a_white_force_and_leaves_the_motion() {
        let plain = sdof("");
        let filtered = sdof("anti_alias = 0.4\nanti_alias_order = 4");
        let sim = &filtered.simulation;
        let f =
            sensor_filters::SensorFilter::new(&sim.sensors, sim.sample_interval, sim.steps_per_sample(), sim.substeps)
                .unwrap()
                .unwrap();
        assert_eq!(f.oversampling, 10);
        let (a, b) = (variances(&plain), variances(&filtered));
        let cols = Model::new(&plain).columns();
        let h_fast = sim.sample_interval / f.oversampling as f64;
        let expected = 1.0 / h_fast * f.noise_gain();
        let (force, rho) = b[cols.force(0)];
        assert!(
            (force / expected - 1.0).abs() < 0.03,
            "force variance {force} against {expected}"
        );
        assert!(
            (a[cols.force(0)].1).abs() < 0.02,
            "unfiltered white force correlated: {}",
            a[cols.force(0)].1
        );
        assert!(rho > 0.05, "the filtered force's lag-1 correlation is {rho}");
        let x = b[cols.x(0)].0 / a[cols.x(0)].0;
        assert!((x - 1.0).abs() < 0.002, "displacement variance ratio {x}");
        let n = 4.0;
        let q = std::f64::consts::PI / (2.0 * n);
        let omega_c = std::f64::consts::TAU * 0.4 / sim.sample_interval;
        let tail = q / ((2.0 * n - 1.0) * q).sin() / (std::f64::consts::PI * omega_c);
        // The discrete filter's own loss (what the identification puts back) within 1 %
        // of the continuous formula's at 10 fast samples per logged one.
        let loss = f.white_velocity_loss(sim.sample_interval);
        assert!((loss / tail - 1.0).abs() < 0.01, "loss {loss} against {tail}");
        let v = b[cols.v(0)].0 / a[cols.v(0)].0;
        assert!(
            (v - (1.0 - loss / a[cols.v(0)].0)).abs() < 0.002,
            "velocity variance ratio {v}, expected {}",
            1.0 - loss
        );
        // A sensor bandwidth at the oscillator's own frequency (≈ 0.6 Hz) takes out
        // much of the velocity's variance.
        let slow = sdof("bandwidth = 0.6");
        let c = variances(&slow);
        assert!(
            c[cols.v(0)].0 < 0.8 * a[cols.v(0)].0,
            "{} against {}",
            c[cols.v(0)].0,
            a[cols.v(0)].0
        );
    }
}

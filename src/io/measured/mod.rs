//! Measured tables mapped onto a model's quantities by its `[data]` section, as a stream of
//! samples in the log's column layout that the identification reads once per pass.
//!
//! Nothing row-sized is kept: a scan pass checks every value (finite, not constant, no
//! outlier), finds the records (files, or the record column, in the order of their ids)
//! and the time base (even steps, gaps), keeping per record only its length, its sums and
//! the places where its time step changes. Every later pass reads the rows again (a CSV
//! file from disk) in the file's order, a block at a time, and hands each block's rows on
//! record by record (`reading`), each sample with its record and its time in the record;
//! it derives the missing velocities and accelerations through a window of four rows per
//! record, or integrates velocities and displacements from accelerations through a window
//! of the drift removal's length (`integrate`). The memory of each method is in docs/data.md
//! ("Memory").

pub mod differentiate;
mod integrate;
mod look;
pub mod period_cut;
pub mod periods;
mod reading;
mod scan;
mod sources;

use super::table::{err, DataError, Labels, Source};
use super::units;
use crate::ident::spectrum::Welch;
use crate::scenario::{DataMapping, Scenario};
use differentiate::derive_notes;
use scan::{check_values, interval_of, pieces, scan, Columns};
use sources::{plan_sources, Sources};
use std::collections::HashMap;
use std::path::PathBuf;

/// `ω·h` above which differentiating displacements is too coarse (a 0.17 % smoothing of
/// the velocity's amplitude; the weak form's moments amplify it).
pub const DERIVE_LIMIT: f64 = 0.1;

/// `ω·dt` of a re-simulation of measured data at the motion's RMS frequency: the bias of
/// the scheme's stationary variances is then far below the validation's sampling spread
/// (the shipped scenarios step at 0.003–0.015).
pub const STEP_OMEGA: f64 = 0.01;

/// How many interquartile ranges from its column's median a value may lie: 40 standard
/// deviations of a normal variable (a chance below 10^-300), far beyond any stationary
/// response's tail, while a lost decimal point or a logger's glitch lands further out.
pub const OUTLIER: f64 = 30.0;

/// A step of at least this many sample intervals is a gap in the record (lost samples, a
/// paused logger), not uneven sampling.
pub const GAP: f64 = 1.5;

/// Measured data mapped onto a model: the records (trajectories of the identification)
/// and how to read their samples again ([`Measured::for_each_sample`]).
#[derive(Debug, Clone)]
pub struct Measured {
    pub files: Vec<PathBuf>,
    pub width: usize,
    pub sample_interval: f64,
    /// Samples per record, in the order the identification numbers them.
    pub lengths: Vec<usize>,
    /// Per column of the layout: whether the samples hold it (mapped or derived).
    pub present: Vec<bool>,
    /// (the layout's column, the table's column name) of every mapped quantity.
    pub table_columns: Vec<(usize, String)>,
    /// What the reading did that a user should know (e.g. derived velocities).
    pub notes: Vec<String>,
    /// The table columns whose mean was taken out (`[data] remove_mean`), with that mean in
    /// the table's units: held-out data are read with the same offsets.
    pub removed_means: Vec<(String, f64)>,
    /// The records were found to be periods of a periodic excitation (cut from records
    /// that hold several end to end, or averaged where they repeat one realisation): each
    /// is now one realisation, whose stretches are not independent draws.
    pub periodic: bool,
    /// The highest RMS frequency of the measured motion (rad/s): over the masses, of each
    /// velocity's spectrum (else the displacement's) up to the Nyquist frequency, in the
    /// longest record. A re-simulation of the data's model steps finely enough for it.
    pub motion_frequency: f64,
    plans: Vec<(Source, Plan)>,
    derive: Vec<Step>,
    /// Velocities and displacements integrated from accelerations (a rig with
    /// accelerometers only), if the model file asks to derive them.
    integrate: Option<Integration>,
    /// Per column integrated from an acceleration: how an accelerometer's noise reaches it.
    pub integrated_noise: Vec<IntegratedNoise>,
    /// Per velocity differenced from a measured displacement: the displacement's noise
    /// and the differences chosen against it.
    pub differenced: Vec<DifferencedNoise>,
}

/// A velocity differenced from a measured displacement ([`differentiate`]): the layout
/// columns, and what the displacement's autocovariance showed.
#[derive(Debug, Clone, Copy)]
pub struct DifferencedNoise {
    pub displacement: usize,
    pub velocity: usize,
    pub found: differentiate::Differencing,
}

/// How the white noise of an accelerometer reaches a velocity or displacement integrated
/// from it: as noise of `gain` times its variance, Gaussian and independent of the motion
/// (`integrate::noise_gains`).
#[derive(Debug, Clone)]
pub struct IntegratedNoise {
    /// The integrated column and the acceleration's (layout columns).
    pub column: usize,
    pub acceleration: usize,
    pub gain: f64,
    /// The acceleration's standard deviation over the data (relative noise levels).
    pub acceleration_std: f64,
    /// The integrated column's variance, noise included.
    pub variance: f64,
    /// The accelerometer's noise as the integrated displacement shows it, or why not.
    pub estimated: Result<integrate::AccelerometerNoise, String>,
}

/// Which masses' velocities and displacements come from their accelerations, and the
/// drift window ([`integrate`]).
#[derive(Debug, Clone)]
struct Integration {
    /// Per such mass: its (x, v, a) layout columns.
    masses: Vec<(usize, usize, usize)>,
    /// Half the width of each running mean, in samples.
    half: usize,
    /// What the accelerations' samples are, and so the velocity's rule.
    samples: integrate::AccelerationSamples,
}

impl Integration {
    /// Samples not handed over at each end of a record.
    fn margin(&self) -> usize {
        4 * self.half
    }
}

/// How one source's rows become samples.
#[derive(Debug, Clone)]
struct Plan {
    /// The table columns read, in order: the mapped ones, then the time, then the record.
    wanted: Vec<usize>,
    /// Per mapped column (the first of `wanted`): its layout column, scale and the offset
    /// taken out before the scale (`[data] remove_mean`).
    mapped: Vec<(usize, f64, f64)>,
    /// Where in `wanted` the record column is.
    record_at: Option<usize>,
    /// A record id's key ([`key`]) → its slot.
    slots: HashMap<u64, usize>,
    /// Per slot: its first trajectory and the lengths of its pieces (one each, unless split
    /// at gaps).
    pieces: Vec<(u32, Vec<usize>)>,
}

/// A column derived by central differences over `±half` rows from another, final `lag`
/// rows after the measured ones.
#[derive(Debug, Clone, Copy)]
struct Step {
    from: usize,
    to: usize,
    lag: usize,
    half: usize,
    /// The exact central difference of order `2·half` (coarse sampling, no noise), not the
    /// least-squares cubic's slope (`differentiate::stencil`).
    exact: bool,
    /// An acceleration as the second derivative of the displacement `from` (the exact
    /// second central difference, where the sampling is coarse and the displacement shows no
    /// noise: differencing the derived velocity again would square the stencil's loss at
    /// the band edge), with the derived velocity's column, whose central difference stands
    /// in near a record's ends. `None`: the first derivative of `from`.
    second: Option<usize>,
}

/// A record id as a map key (text ids are numbered by [`Labels`]).
fn key(id: f64) -> u64 {
    (id + 0.0).to_bits()
}

impl Measured {
    /// Integration steps per sample interval for re-simulating the data's model: `ω·dt ≤`
    /// [`STEP_OMEGA`] at [`Measured::motion_frequency`], and at least 10. (A fixed 10 made
    /// the bushing's validation step at `ω·dt ≈ 0.12`, and its standard deviations differ
    /// from the data's by up to 0.8 % where the log path's differ by 0.2 %.)
    pub fn steps_per_sample(&self) -> usize {
        let wh = self.motion_frequency * self.sample_interval;
        if wh.is_finite() {
            ((wh / STEP_OMEGA).ceil() as usize).clamp(10, 100_000)
        } else {
            10
        }
    }

    /// Whether layout column `c` is derived from another (by differences, or integrated
    /// from accelerations), not measured.
    pub fn derived(&self, c: usize) -> bool {
        self.derive.iter().any(|s| s.to == c)
            || self
                .integrate
                .iter()
                .any(|i| i.masses.iter().any(|&(x, v, _)| x == c || v == c))
    }

    pub fn samples(&self) -> u64 {
        self.lengths.iter().map(|&n| n as u64).sum()
    }

    /// The longest record (s).
    pub fn record_length(&self) -> f64 {
        self.lengths
            .iter()
            .map(|&n| n as f64 * self.sample_interval)
            .fold(0.0, f64::max)
    }

    /// Call `f(record, t, row)` for every sample: `t` its time from the record's start
    /// (the first sample at one interval), `row` its values in the log's layout (NaN where
    /// the data hold nothing). The order is the files' and, within a file, its rows' read
    /// in blocks, each block's rows record by record (each record's samples in time order:
    /// module `reading`); a stop requested meanwhile (`crate::interrupt`) ends the pass
    /// early. The number of samples handed over.
    pub fn for_each_sample(&self, f: &mut dyn FnMut(u32, f64, &[f64])) -> Result<u64, DataError> {
        reading::for_each_sample(self, f, false)
    }

    /// [`Measured::for_each_sample`] with each file decoded on a thread of its own
    /// ([`Source::for_each_row_ahead`]), for the passes that look at the data before the
    /// identification's own: the same samples in the same order.
    fn for_each_sample_ahead(&self, f: &mut dyn FnMut(u32, f64, &[f64])) -> Result<u64, DataError> {
        reading::for_each_sample(self, f, true)
    }

    /// One record's samples: its times and its rows (row-major, [`Measured::width`]
    /// values each), read by a pass over the data.
    pub fn record(&self, trajectory: u32) -> Result<(Vec<f64>, Vec<f64>), DataError> {
        let (mut times, mut rows) = (Vec::new(), Vec::new());
        self.for_each_sample(&mut |j, t, row| {
            if j == trajectory {
                times.push(t);
                rows.extend_from_slice(row);
            }
        })?;
        Ok((times, rows))
    }
}

/// Row `s` of a record's ring of rows gets column `step.to` as the derivative of
/// `step.from` by `stencil` (`differentiate::stencil` of the step), or the central
/// difference (of the derived velocity, for a second derivative) where the stencil would
/// reach past the record's ends (one-sided at the ends; `len` its rows).
#[allow(clippy::too_many_arguments)]
fn difference(rows: &mut [f64], ring: usize, w: usize, h: f64, step: Step, stencil: &[f64], s: usize, len: usize) {
    let at = |q: usize, k: usize| (q % ring) * w + k;
    if s >= step.half && s + step.half < len {
        let x = |q: usize| rows[at(q, step.from)];
        rows[at(s, step.to)] = match step.second {
            Some(_) => {
                let mut a = stencil[0] * x(s);
                for (k, wk) in stencil[1..].iter().enumerate() {
                    a += wk * (x(s + k + 1) + x(s - k - 1));
                }
                a / (h * h)
            }
            None => {
                let mut v = 0.0;
                for (k, wk) in stencil.iter().enumerate() {
                    v += wk * (x(s + k + 1) - x(s - k - 1));
                }
                v / h
            }
        };
        return;
    }
    let from = step.second.unwrap_or(step.from);
    let (a, b) = (s.saturating_sub(1), (s + 1).min(len - 1));
    rows[at(s, step.to)] = (rows[at(b, from)] - rows[at(a, from)]) / ((b - a) as f64 * h);
}

/// The columns a mass's measured motion lacks, each a central difference of the one before
/// it (velocity from displacement, acceleration from velocity, or from a displacement
/// alone its second derivative until the stencils are chosen); `present` marks them.
fn difference_steps(m: &crate::model::Model, present: &mut [bool]) -> Vec<Step> {
    let layout = m.columns();
    let mut derive = Vec::new();
    let mut lag = vec![0usize; present.len()];
    for i in 0..m.masses() {
        let (x, v, a) = (layout.x(i), layout.v(i), layout.a(i));
        // An acceleration from a displacement alone: its second derivative, until the
        // stencils are chosen (`choose_stencils`).
        let from_x = !present[v] && !present[a] && present[x];
        for (from, to) in [(x, v), (v, a)] {
            if present[to] || !present[from] {
                continue;
            }
            lag[to] = lag[from] + 1;
            let second = (from_x && to == a).then_some(v);
            derive.push(Step {
                from: if second.is_some() { x } else { from },
                to,
                lag: lag[to],
                half: 1,
                exact: false,
                second,
            });
            present[to] = true;
        }
    }
    derive
}

/// Map the sources onto `model`'s quantities by its `[data]`: scale, split into records
/// (files, or the record column), check the time base and every value, derive what the
/// model file asks to, and check the units of the mapped columns against each other.
/// Records that repeat one realisation (a periodic excitation's periods) are averaged
/// period by period first (`periods.rs`, docs/data.md "Periodic records"), and the notes
/// say so.
pub fn measured(model: &Scenario, sources: Vec<Source>) -> Result<Measured, DataError> {
    let d = model.data.as_ref().expect("a model file");
    // The scan that checks every value also keeps each record's first values for the
    // searches: one pass over the tables for the three, unless a search finds periods
    // (new tables, in memory, scanned again).
    let names = crate::model::Model::new(model).column_names();
    let compared = periods::compared_head(d);
    let mut scans = Vec::new();
    for source in &sources {
        let c = Columns::of(source, d, &names)?;
        let head = compared.and_then(|(column, n)| Some((d.columns.iter().position(|(_, c)| c == column)?, n)));
        scans.push(scan(source, &c, d, head)?);
    }
    let heads = periods::heads_of(&mut scans);
    let (sources, cut) = period_cut::cut_periods(sources, d, Some(&heads))?;
    let (sources, repeated) = periods::average_repeated(sources, d, cut.is_none().then_some(heads))?;
    let unchanged = cut.is_none() && repeated.is_none();
    let mut m = measured_from(model, sources, None, unchanged.then_some(scans))?;
    m.periodic = !unchanged;
    m.notes.extend(cut.map(|c| c.note()));
    m.notes.extend(repeated.map(|r| r.note()));
    Ok(m)
}

/// [`measured`], the columns of `[data] remove_mean` offset by the given `means` (those
/// of the data a model was identified from: held-out data read the same way) where given.
pub fn measured_with(
    model: &Scenario,
    sources: Vec<Source>,
    means: Option<&[(String, f64)]>,
) -> Result<Measured, DataError> {
    measured_from(model, sources, means, None)
}

/// [`measured_with`] from the sources' scans where they were made before.
fn measured_from(
    model: &Scenario,
    sources: Vec<Source>,
    means: Option<&[(String, f64)]>,
    scanned: Option<Vec<scan::Scanned>>,
) -> Result<Measured, DataError> {
    let d: &DataMapping = model.data.as_ref().expect("a model file");
    let m = crate::model::Model::new(model);
    let layout = m.columns();
    let names = m.column_names();
    let width = layout.len();
    let Sources {
        interval,
        notes,
        plans,
        lengths,
        crossings,
        removed_means,
    } = plan_sources(sources, d, &names, means, scanned)?;
    let Some(sample_interval) = interval.filter(|_| !lengths.is_empty()) else {
        return Err(err(
            plans.first().map_or(std::path::Path::new("<data>"), |p| p.0.path()),
            "the data hold no samples",
        ));
    };
    let mapped: Vec<(usize, String)> = d
        .columns
        .iter()
        .map(|(q, c)| (names.iter().position(|n| n == q).expect("a quantity"), c.clone()))
        .collect();
    let mut present = vec![false; width];
    for &(k, _) in &mapped {
        present[k] = true;
    }
    // A mass measured by its acceleration alone: velocity and displacement integrated.
    let integrated: Vec<(usize, usize, usize)> = (0..m.masses())
        .map(|i| (layout.x(i), layout.v(i), layout.a(i)))
        .filter(|&(x, v, a)| d.derive && present[a] && !present[x] && !present[v])
        .collect();
    for &(x, v, _) in &integrated {
        present[x] = true;
        present[v] = true;
    }
    let derive = match d.derive {
        true => difference_steps(&m, &mut present),
        false => Vec::new(),
    };
    let raw_lengths = lengths.clone();
    let mut data = Measured {
        files: plans.iter().map(|p| p.0.path().to_path_buf()).collect(),
        width,
        sample_interval,
        lengths,
        present,
        table_columns: mapped.clone(),
        notes,
        removed_means,
        periodic: false,
        motion_frequency: f64::NAN,
        plans,
        derive,
        integrate: None,
        integrated_noise: Vec::new(),
        differenced: Vec::new(),
    };
    let mut integration = None;
    if !integrated.is_empty() {
        if let Some(step) = data.derive.first() {
            return Err(err(
                &data.files[0],
                format!(
                    "{} would be differenced from {} while other masses' motion is integrated from their \
                     accelerations: one model file does one or the other (map every mass's acceleration alone, or \
                     its displacement)",
                    names[step.to], names[step.from]
                ),
            ));
        }
        integration = Some(data.integrate_from_accelerations(integrated, d, &raw_lengths)?);
    }
    let masses: Vec<_> = (0..m.masses())
        .map(|i| (layout.x(i), layout.v(i), layout.a(i)))
        .collect();
    // Each mapped column's period in samples, from its crossings.
    let rows = data.samples() as f64;
    let periods: Vec<(usize, Option<f64>)> = mapped
        .iter()
        .zip(&crossings)
        .map(|(&(k, _), &c)| (k, (c > 0).then(|| 2.0 * rows / c as f64)))
        .collect();
    // The integration's gathering rides on the look's pass over the samples.
    let mut look = data.look(&mapped, &masses, &periods, &mut |j, t, row| {
        if let Some(g) = integration.as_mut() {
            g.push(j, t, row);
        }
    })?;
    if crate::interrupt::requested() {
        return Err(err(&data.files[0], "stopped: an interrupt was requested"));
    }
    if let Some(g) = integration {
        data.integration_noted(g, &names);
    }
    data.motion_frequency = look.motion_frequency;
    data.choose_stencils(&mut look, width);
    for (k, (step, r)) in data.derive.iter().zip(&look.derived).enumerate() {
        let noisy_source = data
            .differenced
            .iter()
            .any(|d| d.velocity == step.from && d.found.detected());
        let notes = derive_notes(
            &names[step.from],
            &names[step.to],
            sample_interval,
            *r,
            look.differencing[k],
            noisy_source,
            (step.half, step.exact),
        );
        data.notes.extend(notes);
    }
    let check = units::Mapped {
        columns: &mapped,
        names: &names,
        derivatives: &look.derivatives,
    };
    let path = data.files[0].clone();
    units::check_units(&check, &masses).map_err(|(k, e)| {
        let column = mapped.iter().find(|g| g.0 == k).map_or("?", |g| g.1.as_str());
        err(&path, e).in_column(column)
    })?;
    Ok(data)
}

impl Measured {
    /// The slowest motion's frequency over `masses`' integrated motion, `σ_v/σ_x` (rad/s),
    /// in one pass.
    fn slowest_motion(&self, masses: &[(usize, usize, usize)]) -> Result<f64, DataError> {
        let mut sums = vec![[0.0f64; 4]; masses.len()];
        self.for_each_sample_ahead(&mut |_, _, row| {
            for (s, &(x, v, _)) in sums.iter_mut().zip(masses) {
                s[0] += row[x];
                s[1] += row[x] * row[x];
                s[2] += row[v];
                s[3] += row[v] * row[v];
            }
        })?;
        let n = self.samples() as f64;
        let slowest = sums
            .iter()
            .map(|s| {
                let var = |m: f64, q: f64| (q / n - (m / n).powi(2)).max(0.0);
                (var(s[2], s[3]) / var(s[0], s[1])).sqrt()
            })
            .filter(|w| w.is_finite() && *w > 0.0)
            .fold(f64::INFINITY, f64::min);
        if !slowest.is_finite() {
            return Err(err(
                &self.files[0],
                "the integrated accelerations do not move: no motion to identify",
            ));
        }
        Ok(slowest)
    }

    /// Set the integration of `masses`' accelerations up: the drift window from
    /// `[data] drift_period` or, without it, from the data (a first integration with a window of
    /// [`PROVISIONAL_DRIFT`] sample intervals gives each mass's `σ_v/σ_x`, its motion's
    /// frequency; the window then spans [`DRIFT_PERIODS`] periods of the slowest), and the
    /// records' lengths shortened by the window at both ends; what the integration's pass
    /// is to gather ([`IntegrationGather`]).
    fn integrate_from_accelerations(
        &mut self,
        masses: Vec<(usize, usize, usize)>,
        d: &DataMapping,
        raw_lengths: &[usize],
    ) -> Result<IntegrationGather, DataError> {
        let (h, samples) = (self.sample_interval, d.acceleration_samples);
        let set = |data: &mut Measured, half: usize| -> Result<(), DataError> {
            let i = Integration {
                masses: masses.clone(),
                half,
                samples,
            };
            let drop = 2 * i.margin();
            if let Some(j) = raw_lengths.iter().position(|&n| n <= drop + 1) {
                return Err(err(
                    &data.files[0],
                    format!(
                        "record {} has {} samples: integrating accelerations drops {} at each end (the drift \
                         window, {} s; docs/data.md): give longer records (a scenario's rig: \
                         simulation.record_length) or, in a model file, a shorter [data] drift_period",
                        j + 1,
                        raw_lengths[j],
                        drop / 2,
                        drop as f64 / 2.0 * h
                    ),
                ));
            }
            data.lengths = raw_lengths.iter().map(|&n| n - drop).collect();
            data.integrate = Some(i);
            Ok(())
        };
        let (period, how) = match d.drift_period {
            Some(p) => (p, "as [data] drift_period gives".to_string()),
            None => {
                set(self, integrate::half_for(PROVISIONAL_DRIFT * h, h))?;
                let slowest = self.slowest_motion(&masses)?;
                (
                    DRIFT_PERIODS * 2.0 * std::f64::consts::PI / slowest,
                    format!("{DRIFT_PERIODS} periods of the slowest motion, ω = σ_v/σ_x = {slowest:.3} rad/s"),
                )
            }
        };
        let half = integrate::half_for(period, h);
        set(self, half)?;
        Ok(IntegrationGather::new(self, masses, (half, samples), (period, how)))
    }

    /// The integration's notes and each integrated column's noise, from what its pass
    /// gathered.
    fn integration_noted(&mut self, g: IntegrationGather, names: &[String]) {
        let (h, half, samples, period) = (self.sample_interval, g.half, g.samples, g.period);
        let masses = g.masses.clone();
        let pass = g.finish();
        let lost: Vec<String> = masses
            .iter()
            .enumerate()
            .filter_map(|(k, &(x, _, _))| {
                integrate::drift_loss(&integrate::pooled(&pass.spectra[k]), pass.var(k, 1), h, half)
                    .map(|l| format!("{} {:.2} %", names[x], 100.0 * l))
            })
            .collect();
        let walks = self.integrated_noise_of(&masses, &pass, (h, half, samples), names);
        let list: Vec<String> = masses.iter().map(|&(_, _, a)| names[a].clone()).collect();
        self.notes.push(format!(
            "velocity and displacement integrated from {} ({}), their drift taken out by a centred \
             triangular mean over {:.1} s ({}; zero phase, corner about {:.3} rad/s); the first and last {:.1} s \
             of every record are not used (docs/data.md)",
            list.join(", "),
            samples.rule(),
            (4 * half + 1) as f64 * h,
            pass.how,
            2.0 * std::f64::consts::PI / period,
            (4 * half) as f64 * h
        ));
        if !walks.is_empty() {
            self.notes.push(format!(
                "the trapezoid rule's error on the displacement from the velocity's roughness within an interval (a \
                 random walk, variance ∝ h³) is about {} of the displacements' variance: not taken out (it is \
                 correlated with the motion), the noise estimate allows for it; a finer sample interval reduces it \
                 (docs/measurement.md)",
                walks.join(", ")
            ));
        }
        if !lost.is_empty() {
            self.notes.push(format!(
                "the drift removal takes about {} of the displacements' variance (their static level below its \
                 corner, read from the spectrum above it), which the stiffnesses read as about as much too stiff \
                 (docs/data.md)",
                lost.join(", ")
            ));
        }
    }
}

/// The integration's gathering over the samples, run in the look's pass
/// ([`Measured::look`]): per integrated mass, each acceleration's std, for noise levels
/// relative to it; each integrated displacement's variance and spectrum in the jackknife's
/// parts, for what the drift removal took and for the accelerometer's noise; each
/// velocity's variance, for the motion's frequency.
struct IntegrationGather {
    masses: Vec<(usize, usize, usize)>,
    half: usize,
    samples: integrate::AccelerationSamples,
    period: f64,
    how: String,
    h: f64,
    lengths: Vec<usize>,
    sums: Vec<[f64; 6]>,
    n: f64,
    welch: Vec<Vec<Welch>>,
    second: Vec<integrate::SecondDifferences>,
}

impl IntegrationGather {
    fn new(
        data: &Measured,
        masses: Vec<(usize, usize, usize)>,
        (half, samples): (usize, integrate::AccelerationSamples),
        (period, how): (f64, String),
    ) -> IntegrationGather {
        let h = data.sample_interval;
        let shortest = data.lengths.iter().copied().min().unwrap_or(0);
        let records = data.lengths.len();
        let stretch = if records >= integrate::NOISE_PARTS {
            shortest
        } else {
            shortest / integrate::NOISE_PARTS
        };
        let segment = ((8 * (2 * half + 1)).next_power_of_two())
            .min((stretch / 2).next_power_of_two() / 2)
            .max(16);
        IntegrationGather {
            sums: vec![[0.0f64; 6]; masses.len()],
            n: 0.0,
            welch: vec![vec![Welch::new(segment, h, records); integrate::NOISE_PARTS]; masses.len()],
            second: vec![integrate::SecondDifferences::new(records); masses.len()],
            masses,
            half,
            samples,
            period,
            how,
            h,
            lengths: data.lengths.clone(),
        }
    }

    fn push(&mut self, j: u32, t: f64, row: &[f64]) {
        let (j, len, records) = (j as usize, self.lengths[j as usize], self.lengths.len());
        let part = integrate::noise_part(records, j, (t / self.h).round() as usize, len);
        for (k, &(x, v, a)) in self.masses.iter().enumerate() {
            for (q, c) in [a, x, v].into_iter().enumerate() {
                self.sums[k][2 * q] += row[c];
                self.sums[k][2 * q + 1] += row[c] * row[c];
            }
            self.welch[k][part].push(j, row[x]);
            self.second[k].push(j, row[a]);
        }
        self.n += 1.0;
    }

    fn finish(self) -> IntegrationPass {
        IntegrationPass {
            sums: self.sums,
            n: self.n,
            spectra: self
                .welch
                .iter()
                .map(|w| w.iter().map(|p| p.spectrum()).collect())
                .collect(),
            second: self.second,
            how: self.how,
        }
    }
}

impl Measured {
    /// Each integrated mass's accelerometer noise, estimated from its displacement's
    /// spectra with the trapezoid's random walk allowed for ([`integrate::roughness`]),
    /// recorded per integrated column with the integration's gains; returns the walk's
    /// share of each displacement's variance where it passes 1 %.
    fn integrated_noise_of(
        &mut self,
        masses: &[(usize, usize, usize)],
        pass: &IntegrationPass,
        (h, half, samples): (f64, usize, integrate::AccelerationSamples),
        names: &[String],
    ) -> Vec<String> {
        let (gain_v, gain_x) = integrate::noise_gains(h, half, samples);
        let (walk_gain, mut walks) = (integrate::walk_gain(h, half), Vec::new());
        for (k, &(x, v, a)) in masses.iter().enumerate() {
            let var = |q: usize| pass.var(k, q);
            let motion = (var(2) / var(1)).sqrt();
            let rough = integrate::roughness(h, pass.second[k].variance());
            let spectra = &pass.spectra[k];
            let mut estimated = integrate::accelerometer_noise(spectra, h, half, samples, rough, motion);
            // The noise found, the motion's frequency from the variances without it.
            if let Some(e) = estimated.as_ref().ok().filter(|e| e.detected()) {
                let clean = ((var(2) - gain_v * e.variance) / (var(1) - gain_x * e.variance)).sqrt();
                if clean.is_finite() && (clean / motion - 1.0).abs() > 0.05 {
                    estimated = integrate::accelerometer_noise(spectra, h, half, samples, rough, clean);
                }
            }
            if walk_gain * rough > 0.01 * var(1) {
                walks.push(format!("{} {:.1} %", names[x], 100.0 * walk_gain * rough / var(1)));
            }
            for (column, gain, q) in [(v, gain_v, 2), (x, gain_x, 1)] {
                self.integrated_noise.push(IntegratedNoise {
                    column,
                    acceleration: a,
                    gain,
                    acceleration_std: var(0).sqrt(),
                    variance: var(q),
                    estimated: estimated.clone(),
                });
            }
        }
        walks
    }
}

/// What the integration's pass over the samples gathered, per integrated mass: the sums
/// and sums of squares of its acceleration, displacement and velocity over `n` samples,
/// its displacement's spectra in the jackknife's parts and its accelerations' second
/// differences.
struct IntegrationPass {
    /// How the drift window was chosen, for the note.
    how: String,
    sums: Vec<[f64; 6]>,
    n: f64,
    spectra: Vec<Vec<crate::ident::spectrum::Spectrum>>,
    second: Vec<integrate::SecondDifferences>,
}

impl IntegrationPass {
    /// Mass `k`'s variance of its acceleration (`q` = 0), displacement (1) or velocity (2).
    fn var(&self, k: usize, q: usize) -> f64 {
        let (s, n) = (&self.sums[k], self.n);
        (s[2 * q + 1] / n - (s[2 * q] / n).powi(2)).max(0.0)
    }
}

/// The drift window, in sample intervals, of the first integration that finds the
/// motion's frequency.
const PROVISIONAL_DRIFT: f64 = 2000.0;

/// Periods of the slowest motion the drift window spans when the data choose it.
const DRIFT_PERIODS: f64 = 10.0;

#[cfg(test)]
mod tests;

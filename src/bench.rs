//! The bench's main job: identify the unknowns of a run log with the requested methods,
//! measure the accuracy against the truth stored in the log, check dissipativity, and
//! validate by re-simulating the identified model (DESIGN §7). Its first half, a scenario
//! simulated into a log, is [`simulate_log`].
//!
//! Two streaming passes over the log, constant memory: pass 1 accumulates raw moments per
//! time batch and the links' observed ranges (weak form); pass 2 fills the density grid
//! (strong forms) and the histograms behind the plots.

use crate::ident::data::StationaryData;
use crate::ident::disturbance::SingleMass;
use crate::ident::poly::Poly;
use crate::ident::strong::{DensityGrid, GridOptions};
use crate::ident::{
    self, disturbance, lsq::Diagnostics, spectrum, spectrum::Welch, weak, Filter, IdentError, Problem, Unknown,
};
use crate::io::log::{read_info, read_samples, Compression, LogError, LogInfo, LogWriter};
use crate::model::{Characteristic, Coefficient, Model};
use crate::scenario::{Method, Polynomial, Process, Scenario, DIRECT_FORCE, ITERATED_FORCE};
use crate::sim::{simulate, SampleBatch, SampleSink, SimError};
use crate::stats;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Errors of the bench pipeline.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Log(#[from] LogError),
    #[error(transparent)]
    Ident(#[from] IdentError),
    #[error(transparent)]
    Sim(#[from] SimError),
}

/// Settings of an identification.
#[derive(Debug, Clone)]
pub struct Options {
    /// Methods to run; empty: the scenario's `[identify] methods`.
    pub methods: Vec<Method>,
    /// Strong-form grid; `None`: automatic.
    pub grid: Option<GridOptions>,
    /// Batches (groups of the fine trajectory-group × time batches) for standard errors and
    /// the identifiability spread.
    pub batches: usize,
    /// Re-simulate the identified model for the validation table.
    pub validate: bool,
    /// Override `[identify.disturbance] max_steps` of the iterative procedure.
    pub max_steps: Option<usize>,
    /// Override `[identify.disturbance] tolerance` of the iterative procedure.
    pub tolerance: Option<f64>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            methods: Vec::new(),
            grid: None,
            batches: 8,
            validate: true,
            max_steps: None,
            tolerance: None,
        }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct Parameter {
    pub name: String,
    pub true_value: f64,
    pub estimate: f64,
    pub std_error: f64,
    pub rel_error: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Curve {
    pub link: String,
    pub kind: &'static str,
    pub rel_l2_error: f64,
    /// Observed range of the relative displacement or velocity.
    pub range: [f64; 2],
    /// `(power, coefficient)` of the identified characteristic.
    pub identified: Vec<(u32, f64)>,
}

/// A filtered excitation's `A`, `B`: the fit to the measured force spectrum (3.20) and
/// what the identifier used.
#[derive(Debug, Clone, Serialize)]
pub struct FilterReport {
    pub excitation: String,
    /// `fitted` or `known`.
    pub used: &'static str,
    pub a: f64,
    pub b: f64,
    pub fitted_a: f64,
    pub fitted_b: f64,
    pub true_a: f64,
    pub true_b: f64,
    pub rms_log_residual: f64,
    pub expected_rms_log_residual: f64,
    pub segments: usize,
    pub segment_len: usize,
}

#[derive(Debug, Clone, Serialize)]
pub struct MethodReport {
    pub method: String,
    /// Whether this method has an acceptance gate (baselines and comparisons do not).
    pub gated: bool,
    pub parameters: Vec<Parameter>,
    pub curves: Vec<Curve>,
    pub worst_rel_error: f64,
    pub threshold: f64,
    pub passed: bool,
    pub diagnostics: Option<Diagnostics>,
    pub weakly_determined: bool,
    pub facts: BTreeMap<String, String>,
    pub dissipativity: Vec<stats::Dissipativity>,
    /// Why the method gave no estimate (then `passed` is false).
    pub error: Option<String>,
    pub seconds: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct ValidationRow {
    pub variable: String,
    pub data_std: f64,
    pub model_std: f64,
    pub data_kurtosis: f64,
    pub model_kurtosis: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Validation {
    /// The method whose model was re-simulated.
    pub method: &'static str,
    pub record_length_s: f64,
    pub trajectories: usize,
    pub seed: u64,
    pub rows: Vec<ValidationRow>,
    /// Set when the identified model could not be simulated (e.g. not dissipative).
    pub error: Option<String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Timings {
    pub simulate: f64,
    pub identify: f64,
    pub total: f64,
}

/// Histogram over `[lo, hi]`.
#[derive(Debug, Clone, Serialize)]
pub struct Histogram {
    pub lo: f64,
    pub hi: f64,
    pub counts: Vec<f64>,
}

impl Histogram {
    pub fn new(lo: f64, hi: f64, bins: usize) -> Histogram {
        let (lo, hi) = if hi > lo { (lo, hi) } else { (lo - 0.5, lo + 0.5) };
        Histogram {
            lo,
            hi,
            counts: vec![0.0; bins],
        }
    }
    pub fn push(&mut self, z: f64) {
        let q = (z - self.lo) / (self.hi - self.lo) * self.counts.len() as f64;
        if let Some(b) = stats::bin(q, self.counts.len()) {
            self.counts[b] += 1.0;
        }
    }
    /// Probability density per bin (normalised by the count given).
    pub fn density(&self, total: f64) -> Vec<f64> {
        let w = (self.hi - self.lo) / self.counts.len() as f64;
        self.counts.iter().map(|c| c / (total * w)).collect()
    }
}

/// What the plots need beyond the report.
#[derive(Debug, Clone, Default)]
pub struct PlotData {
    /// Per link: histograms of `u` and `w`.
    pub link_hist: Vec<(Histogram, Histogram)>,
    /// Per state variable: (name, unit, data histogram, re-simulated model histogram).
    pub marginals: Vec<(String, String, Histogram, Option<Histogram>)>,
    pub samples: f64,
    pub model_samples: f64,
    /// Per filtered excitation: name, estimated spectrum, fit, true (A, B).
    pub spectra: Vec<(String, spectrum::Spectrum, spectrum::OuFit, (f64, f64))>,
}

/// The result of identifying one log.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub scenario: String,
    pub log: String,
    pub record_length_s: f64,
    pub total_record_s: f64,
    pub samples: u64,
    pub sample_interval_s: f64,
    pub trajectories: usize,
    pub seed: u64,
    pub scheme: String,
    pub dt_s: f64,
    pub timings_s: Timings,
    /// Filtered excitations: fitted and used `A`, `B`.
    pub filters: Vec<FilterReport>,
    pub methods: Vec<MethodReport>,
    pub validation: Option<Validation>,
    /// The iterative procedure for an unmeasured disturbance (paper section 4): the
    /// paper's sequence (spectral single-mass step, method `iterated`), then the one with
    /// the measured-force step (`iterated-force`). Empty without `[identify.disturbance]`.
    pub iterations: Vec<IterationReport>,
    pub passed: bool,
    #[serde(skip)]
    pub plot: PlotData,
    #[serde(skip)]
    pub scenario_def: Option<Scenario>,
}

/// Per-variable sums for std and kurtosis plus a histogram, from any sample source.
struct Marginals {
    cols: Vec<usize>,
    s1: Vec<f64>,
    s2: Vec<f64>,
    s3: Vec<f64>,
    s4: Vec<f64>,
    n: f64,
    hist: Vec<Histogram>,
}

impl Marginals {
    fn new(cols: Vec<usize>, hist: Vec<Histogram>) -> Marginals {
        let d = cols.len();
        Marginals {
            cols,
            s1: vec![0.0; d],
            s2: vec![0.0; d],
            s3: vec![0.0; d],
            s4: vec![0.0; d],
            n: 0.0,
            hist,
        }
    }
    fn push(&mut self, row: &[f64]) {
        for (j, &c) in self.cols.iter().enumerate() {
            let z = row[c];
            self.s1[j] += z;
            self.s2[j] += z * z;
            self.s3[j] += z * z * z;
            self.s4[j] += z * z * z * z;
            self.hist[j].push(z);
        }
        self.n += 1.0;
    }
    /// (std, kurtosis) of variable `j`.
    fn std_kurtosis(&self, j: usize) -> (f64, f64) {
        let n = self.n;
        let m = self.s1[j] / n;
        let m2 = self.s2[j] / n;
        let m3 = self.s3[j] / n;
        let m4 = self.s4[j] / n;
        let var = m2 - m * m;
        let c4 = m4 - 4.0 * m * m3 + 6.0 * m * m * m2 - 3.0 * m.powi(4);
        (var.max(0.0).sqrt(), c4 / (var * var))
    }
}

impl SampleSink for Marginals {
    fn write(&mut self, b: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
        b.for_each_sample(|_, _, row| self.push(row));
        Ok(())
    }
}

const HIST_BINS: usize = 80;

/// What [`simulate_log`] wrote.
#[derive(Debug, Clone)]
pub struct Simulated {
    /// The complete log.
    pub log: PathBuf,
    /// Samples (trajectories × instants).
    pub samples: u64,
    /// The log's size.
    pub bytes: u64,
    /// Integration steps over all trajectories, burn-in included.
    pub steps: u64,
    /// Wall-clock time from the start to the renamed log.
    pub seconds: f64,
}

/// The bench's first half: simulate `scenario` into a log at `path` (written as
/// `<path>.partial` and renamed only when complete), calling `progress` with the samples
/// written so far.
pub fn simulate_log(
    scenario: &Scenario,
    path: &Path,
    compression: Compression,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Simulated, BenchError> {
    let start = Instant::now();
    let model = Model::new(scenario);
    let mut writer = LogWriter::create_with(path, scenario, &model, compression)?;
    let stats = simulate(&model, &scenario.simulation, &mut writer, progress)?;
    let summary = writer.finish()?;
    Ok(Simulated {
        log: summary.path,
        samples: stats.samples,
        bytes: summary.bytes,
        steps: stats.steps,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Identify the log at `path`.
pub fn identify_log(path: &Path, options: &Options) -> Result<Report, BenchError> {
    let start = Instant::now();
    let info = read_info(path)?;
    identify_info(&info, options, start)
}

fn identify_info(info: &LogInfo, options: &Options, start: Instant) -> Result<Report, BenchError> {
    let s = &info.scenario;
    if let Some(d) = &s.identify.disturbance {
        let mut d = d.clone();
        d.max_steps = options.max_steps.unwrap_or(d.max_steps);
        d.tolerance = options.tolerance.unwrap_or(d.tolerance);
        return identify_disturbed(info, &d, options, start);
    }
    let sim = &s.simulation;
    let methods = if options.methods.is_empty() {
        s.identify.methods.clone()
    } else {
        options.methods.clone()
    };
    // Measured filtered excitations: their A, B come from the force spectrum unless known.
    let filtered: Vec<usize> = (0..s.excitations.len())
        .filter(|&e| s.excitations[e].measured && matches!(s.excitations[e].process, Process::Filtered { .. }))
        .collect();
    // The problem's structure (state, columns, moments needed) does not depend on A and B.
    let placeholder: Vec<Filter> = filtered
        .iter()
        .map(|&e| Filter {
            excitation: e,
            a: 1.0,
            b: 1.0,
        })
        .collect();
    let structure = Problem::with_filters(s, &placeholder)?;
    let naive_scenario = (!filtered.is_empty()).then(|| whitened(s, &placeholder));
    let naive_structure = naive_scenario.as_ref().map(Problem::new).transpose()?;

    // Pass 1: moments per batch, link ranges, lag-1 correlation of each filtered force.
    let mut data = StationaryData::new(
        &structure,
        weak::moment_degree(&structure),
        sim.record_length,
        options.batches,
    );
    let mut naive_data = naive_structure
        .as_ref()
        .map(|p| StationaryData::new(p, weak::moment_degree(p), sim.record_length, options.batches));
    let mut forces = ForceSpectra::new(s, &filtered);
    read_samples(info, |traj, t, row| {
        data.push(traj, t, row);
        if let Some(d) = naive_data.as_mut() {
            d.push(traj, t, row);
        }
        forces.push_lag(traj, row);
    })?;
    data.finish();
    if let Some(d) = naive_data.as_mut() {
        d.finish();
    }
    let total = data.total();

    // Pass 2: grid, histograms, force spectra.
    let want_grid = methods
        .iter()
        .any(|m| matches!(m, Method::Strong | Method::StrongMarginals));
    let mut grid = match want_grid {
        true => Some(DensityGrid::new(
            &structure,
            &total,
            options.grid.unwrap_or_else(|| GridOptions::auto(structure.dim())),
        )),
        false => None,
    };
    let mut dist = Distributions::new(s, &structure, &data);
    forces.start_welch(sim);
    read_samples(info, |traj, _, row| {
        if let Some(Ok(g)) = grid.as_mut() {
            g.push(row);
        }
        dist.push(row);
        forces.push(traj, row);
    })?;

    // Filters: fitted to the spectra, or known.
    let (filters, filter_reports, spectra) = forces.filters(s);
    let problem = Problem::with_filters(s, &filters)?;
    let typical = problem.typical(&total);
    // Identifiability is a property of the unknowns and the data: measured once, with the
    // weak form's batches, whatever methods were asked for (no estimates on failure).
    let bilinear = problem.unknowns.iter().any(|u| matches!(u, Unknown::Corner(_)));
    let weak_estimate = if bilinear {
        ident::identify_weak_bilinear(&problem, &data)
    } else {
        ident::identify_weak(&problem, &data)
    };
    // What the reports are about: with an unknown corner, the physical coefficients and corners.
    let reported = if bilinear { problem.physical() } else { problem.clone() };
    if let Err(e @ IdentError::NotIdentifiable { .. }) = weak_estimate {
        return Err(e.into());
    }

    // Methods.
    let mut reports = Vec::new();
    let mut first_ok: Option<Vec<f64>> = None;
    let mut first_method = "";
    for m in &methods {
        let t = Instant::now();
        let est = match (m, &grid) {
            (Method::Weak, _) => weak_estimate.clone(),
            (Method::Strong | Method::StrongMarginals, Some(Err(e))) => Err(e.clone()),
            (Method::Strong | Method::StrongMarginals, _) if bilinear => Err(IdentError::Unsupported(
                "an unknown corner B makes the drift bilinear; the strong form here solves linear problems only".into(),
            )),
            (Method::Strong, Some(Ok(g))) => ident::identify_strong(&problem, g, false, &typical),
            (Method::StrongMarginals, Some(Ok(g))) => ident::identify_strong(&problem, g, true, &typical),
            (_, None) => unreachable!("grid requested"),
        };
        if let Err(e @ IdentError::NotIdentifiable { .. }) = est {
            return Err(e.into());
        }
        if let (Ok(e), None) = (&est, &first_ok) {
            first_ok = Some(e.values.clone());
            first_method = m.name();
        }
        reports.push(method_report(
            m.name(),
            Some(s.accept.threshold(m.name())),
            est,
            s,
            &reported,
            &data.link_ranges,
            t,
        ));
    }
    // The naive baseline: the white-noise identification applied to filtered data, with
    // each filtered force taken as white of the same low-frequency density (σ = A/B).
    if let (Some(d), false) = (&naive_data, filtered.is_empty()) {
        let t = Instant::now();
        let naive = Problem::new(&whitened(s, &filters))?;
        let est = ident::identify_weak(&naive, d);
        reports.push(method_report(
            "weak-white-naive",
            None,
            est,
            s,
            &naive,
            &data.link_ranges,
            t,
        ));
    }
    // Alternative models for comparison (e.g. the paper's linear case 1).
    for (name, links) in &s.identify.compare {
        let t = Instant::now();
        let mut alt = s.clone();
        alt.identify.links = links.clone();
        let p = Problem::with_filters(&alt, &filters)?;
        let est = ident::identify_weak(&p, &data);
        reports.push(method_report(
            &format!("weak [{name}]"),
            None,
            est,
            s,
            &p,
            &data.link_ranges,
            t,
        ));
    }

    // Validation by re-simulation of the first identified model.
    let validation = match (&first_ok, options.validate) {
        (Some(values), true) => Some(dist.validate(s, &reported, values, first_method)),
        _ => None,
    };
    Ok(assemble(
        info,
        data.samples(),
        start,
        filter_reports,
        reports,
        validation,
        Vec::new(),
        dist.into_plot(spectra),
    ))
}

/// The iterative procedure's sequence with its accuracy at every step.
#[derive(Debug, Clone, Serialize)]
pub struct IterationReport {
    /// The report method of the final iterate (`iterated`, `iterated-force`).
    pub method: String,
    #[serde(flatten)]
    pub iteration: disturbance::Iteration,
    /// Per step: the relative error of every parameter (as in `methods[]`).
    pub step_rel_errors: Vec<Vec<f64>>,
    /// Per step: the worst relative error, curves included.
    pub step_worst_rel_error: Vec<f64>,
    pub step0_worst_rel_error: f64,
    pub final_worst_rel_error: f64,
    /// The report method of this sequence's bound: the identification given the
    /// disturbance as if it were measured, in the same model of the forces.
    pub bound: String,
    /// The bound's worst error (NaN when it failed).
    pub bound_worst_rel_error: f64,
}

/// One level of a disturbance-strength sweep.
#[derive(Debug, Clone, Serialize)]
pub struct SweepPoint {
    /// Standard deviation of the disturbance over that of the measured force.
    pub level: f64,
    pub step0_worst_rel_error: f64,
    /// Per sequence (the paper's, then the measured-force one): its final iterate and bound.
    pub sequences: Vec<SweepSequence>,
    pub step0: Vec<f64>,
    /// The one-step solve of (4.8) (`direct-force`): worst error (NaN when it failed) and
    /// estimates.
    pub direct_worst_rel_error: f64,
    pub direct: Vec<f64>,
}

/// One sequence's outcome at one sweep level.
#[derive(Debug, Clone, Serialize)]
pub struct SweepSequence {
    /// `iterated` or `iterated-force`.
    pub method: String,
    pub steps: usize,
    pub stopped_by: String,
    pub monotone: bool,
    pub final_worst_rel_error: f64,
    #[serde(rename = "final")]
    pub last: Vec<f64>,
    /// The sequence's bound (the disturbance given as measured) and its worst error.
    pub bound_method: String,
    pub bound_worst_rel_error: f64,
    pub bound: Vec<f64>,
}

/// A disturbance-strength sweep: the procedure's accuracy against the disturbance level.
#[derive(Debug, Clone, Serialize)]
pub struct Sweep {
    pub scenario: String,
    pub names: Vec<String>,
    pub truth: Vec<f64>,
    pub points: Vec<SweepPoint>,
}

impl SweepPoint {
    /// The sweep's entry for a report of the disturbed scenario at `level`.
    pub fn from_report(level: f64, r: &Report) -> Option<SweepPoint> {
        let first = r.iterations.first()?;
        let values = |m: &str| {
            r.methods
                .iter()
                .find(|x| x.method == m)
                .map(|x| x.parameters.iter().map(|p| p.estimate).collect())
                .unwrap_or_default()
        };
        Some(SweepPoint {
            level,
            step0_worst_rel_error: first.step0_worst_rel_error,
            sequences: r
                .iterations
                .iter()
                .map(|it| SweepSequence {
                    method: it.method.clone(),
                    steps: it.iteration.steps.len() - 1,
                    stopped_by: it.iteration.stopped_by.clone(),
                    monotone: it.iteration.monotone,
                    final_worst_rel_error: it.final_worst_rel_error,
                    last: values(&it.method),
                    bound_method: it.bound.clone(),
                    bound_worst_rel_error: it.bound_worst_rel_error,
                    bound: values(&it.bound),
                })
                .collect(),
            step0: values("step-0"),
            direct_worst_rel_error: r
                .methods
                .iter()
                .find(|x| x.method == DIRECT_FORCE)
                .map_or(f64::NAN, |x| x.worst_rel_error),
            direct: values(DIRECT_FORCE),
        })
    }
}

/// Identify a log of the paper's structure with an unmeasured disturbance by its
/// iterative procedure ([`disturbance`]): step 0, every step, the final estimate (gated)
/// and the bound with the disturbance given as measured.
fn identify_disturbed(
    info: &LogInfo,
    settings: &crate::scenario::Disturbance,
    options: &Options,
    start: Instant,
) -> Result<Report, BenchError> {
    let s = &info.scenario;
    if options.methods.iter().any(|m| *m != Method::Weak) {
        return Err(IdentError::Unsupported(
            "the iterative procedure ([identify.disturbance]) uses the weak form in every step; other methods do not apply".into(),
        )
        .into());
    }
    let sim = &s.simulation;
    let st = settings.structure;
    let n = s.masses.len();
    let force_col = |e: usize| 3 * n + e;
    let filtered = |e: usize| matches!(s.excitations[e].process, Process::Filtered { .. });
    // Forces whose spectra are fitted: P2 (if filtered), and the filtered disturbances
    // (for the bound only).
    let fitted: Vec<usize> = (0..s.excitations.len()).filter(|&e| filtered(e)).collect();
    let placeholder = |e: usize| Filter {
        excitation: e,
        a: 1.0,
        b: 1.0,
    };
    let p2_placeholder = filtered(st.measured).then(|| placeholder(st.measured));
    let white_structure = Problem::new(&disturbance::step0_scenario(s, &st, p2_placeholder))?;
    let driven_structure = Problem::with_filters(&disturbance::driven_scenario(s, &st, 1.0, 1.0), &[placeholder(0)])?;
    let mut white = StationaryData::with_all_moments(
        &white_structure,
        weak::moment_degree(&white_structure),
        sim.record_length,
        options.batches,
    );
    let data_for = |p: &Problem| StationaryData::new(p, weak::moment_degree(p), sim.record_length, options.batches);
    let mut driven = data_for(&driven_structure);
    let force_structure = disturbance::force_problem(s, &st, 1.0)?;
    let force_bound = disturbance::force_bound_problem(s, &st)?;
    let mut bound_data = data_for(&force_bound);
    let mut force = data_for(&force_structure);
    let (x1, x2) = (3 * st.free, 3 * st.driven);
    let mut forces = ForceSpectra::new(s, &fitted);
    read_samples(info, |traj, t, row| {
        white.push(traj, t, row);
        driven.push(traj, t, &row[x2..x2 + 3]);
        force.push(traj, t, &disturbance::force_row(s, &st, row));
        bound_data.push(traj, t, row);
        forces.push_lag(traj, row);
    })?;
    white.finish();
    driven.finish();
    force.finish();
    bound_data.finish();
    let total = white.total();

    // Pass 2: force spectra, P3's pieces, histograms.
    forces.start_welch(sim);
    // P3's spectrum must resolve the responses' frequencies: 32 bins below the lowest
    // apparent frequency √(E[ẋ²]/E[x²]) of x2 and of x1 − x2.
    let apparent = |x: Poly, v: Poly| {
        let ex = x.mul(&x).expectation(|e| total.moment(e));
        let ev = v.mul(&v).expectation(|e| total.moment(e));
        (ev / ex).sqrt()
    };
    let (wx1, wv1, wx2, wv2) = (
        white_structure.x(st.free),
        white_structure.v(st.free),
        white_structure.x(st.driven),
        white_structure.v(st.driven),
    );
    let w_low = apparent(ident::y(wx2), ident::y(wv2)).min(apparent(
        Poly::linear(&[(wx1, 1.0), (wx2, -1.0)]),
        Poly::linear(&[(wv1, 1.0), (wv2, -1.0)]),
    ));
    let mut p3 = spectrum::CrossWelch::new(
        Welch::segment_for(w_low, sim.sample_interval, sim.samples_per_trajectory()),
        sim.sample_interval,
        sim.trajectories,
    );
    let m1 = s.masses[st.free].value;
    let mut dist = Distributions::new(s, &white_structure, &white);
    read_samples(info, |traj, _, row| {
        forces.push(traj, row);
        p3.push(
            traj as usize,
            row[force_col(st.measured)] + m1 * row[x1 + 2],
            row[x1] - row[x2],
        );
        dist.push(row);
    })?;

    // Filters: P2 as the identifier uses it; the disturbances' for the bound.
    let (filters, filter_reports, mut spectra) = forces.filters(s);
    let p2 = filters.iter().copied().find(|f| f.excitation == st.measured);
    let inputs = disturbance::Inputs {
        scenario: s,
        settings,
        p2,
        white: &white,
        driven: &driven,
        p3: &p3,
        force: &force,
    };
    let paper = disturbance::iterate(&inputs, SingleMass::Spectral)?;
    let measured_force = disturbance::iterate(&inputs, SingleMass::Force)?;
    let problem = paper.problem.clone();
    if let Some(last) = paper.steps.last().filter(|l| l.step > 0) {
        let k1 = last.p3_k1.expect("steps >= 1 have one");
        spectra.push((
            format!("3 (step {}, k1 = {k1:.4})", last.step),
            p3.spectrum_of(2.0 * k1),
            last.p3_fit.expect("spectral steps have one"),
            (f64::NAN, f64::NAN),
        ));
    }

    // Reports: step 0, the final iterate of each sequence (gated), the bound.
    let ranges = &white.link_ranges;
    let t = Instant::now();
    // The bounds: the disturbance given as if measured, in the paper's white-noise model
    // of the forces (as step 0 sees them) and in the measured-force weak form.
    let bound_problem = Problem::new(&disturbance::bound_scenario(s, &st, &filters))?;
    let mut bounds = [
        method_report(
            "pz-measured",
            None,
            ident::identify_weak(&bound_problem, &white),
            s,
            &bound_problem,
            ranges,
            t,
        ),
        method_report(
            "pz-measured-force",
            None,
            ident::identify_weak(&force_bound, &bound_data),
            s,
            &force_bound,
            ranges,
            t,
        ),
    ];
    bounds[0].facts.insert(
        "P_z".into(),
        "given as if measured, filtered forces as white noise of their low-frequency density (the paper's model): the bound of the paper's sequence".into(),
    );
    bounds[1].facts.insert(
        "P_z".into(),
        "given as if measured, every filtered force a measured input of the weak form: the bound of the measured-force sequence".into(),
    );
    let mut reports = vec![method_report(
        "step-0",
        None,
        Ok(paper.step0.clone()),
        s,
        &problem,
        ranges,
        t,
    )];
    reports[0]
        .facts
        .insert("P_z".into(), "ignored (the paper's step 0)".into());
    let mut iterations = Vec::new();
    for ((method, it), bound) in [("iterated", paper), (ITERATED_FORCE, measured_force)]
        .into_iter()
        .zip(&bounds)
    {
        let at = |values: &[f64]| ident::Estimate {
            values: values.to_vec(),
            std_error: vec![f64::NAN; values.len()],
            ..it.step0.clone()
        };
        let step_reports: Vec<MethodReport> = it
            .steps
            .iter()
            .map(|st_| method_report("step", None, Ok(at(&st_.values)), s, &problem, ranges, t))
            .collect();
        let mut final_est = at(it.last());
        final_est.facts = vec![
            ("single-mass step".into(), it.single_mass.name().into()),
            ("steps".into(), (it.steps.len() - 1).to_string()),
            ("stopped by".into(), it.stopped_by.clone()),
            ("monotone differences".into(), it.monotone.to_string()),
        ];
        let rep = method_report(
            method,
            Some(s.accept.threshold(method)),
            Ok(final_est),
            s,
            &problem,
            ranges,
            t,
        );
        iterations.push(IterationReport {
            method: method.into(),
            step_rel_errors: step_reports
                .iter()
                .map(|r| r.parameters.iter().map(|p| p.rel_error).collect())
                .collect(),
            step_worst_rel_error: step_reports.iter().map(|r| r.worst_rel_error).collect(),
            step0_worst_rel_error: reports[0].worst_rel_error,
            final_worst_rel_error: rep.worst_rel_error,
            bound: bound.method.clone(),
            bound_worst_rel_error: bound.worst_rel_error,
            iteration: it,
        });
        reports.push(rep);
    }
    // No iteration: k1, K2, C2 in one solve of the subtracted equation (4.8).
    let mut direct = method_report(
        DIRECT_FORCE,
        Some(s.accept.threshold(DIRECT_FORCE)),
        disturbance::direct(&inputs, &problem),
        s,
        &problem,
        ranges,
        t,
    );
    direct.facts.insert(
        "P_z".into(),
        "eliminated by (4.8); k1, K2, C2 in one linear solve of the measured-force weak form of (x2, v2), no iteration"
            .into(),
    );
    reports.push(direct);
    reports.extend(bounds);

    let validation = options
        .validate
        .then(|| dist.validate(s, &problem, iterations[1].iteration.last(), ITERATED_FORCE));
    Ok(assemble(
        info,
        white.samples(),
        start,
        filter_reports,
        reports,
        validation,
        iterations,
        dist.into_plot(spectra),
    ))
}

/// The measured forces whose spectra are fitted: lag-1 sums in pass 1 (an AR(1) guess of
/// the corner sets the Welch segment length), Welch estimates in pass 2.
struct ForceSpectra {
    excitations: Vec<usize>,
    columns: Vec<usize>,
    /// Per force: `Σ p²`, `Σ p·p_prev`, the last value per trajectory.
    lag: Vec<(f64, f64, Vec<f64>)>,
    welch: Vec<Welch>,
}

impl ForceSpectra {
    fn new(s: &Scenario, excitations: &[usize]) -> ForceSpectra {
        let n = s.masses.len();
        ForceSpectra {
            excitations: excitations.to_vec(),
            columns: excitations.iter().map(|e| 3 * n + e).collect(),
            lag: vec![(0.0, 0.0, vec![f64::NAN; s.simulation.trajectories]); excitations.len()],
            welch: Vec::new(),
        }
    }

    fn push_lag(&mut self, traj: u32, row: &[f64]) {
        for (k, &c) in self.columns.iter().enumerate() {
            let p = row[c];
            let (s0, s1, last) = &mut self.lag[k];
            if let Some(prev) = last.get_mut(traj as usize) {
                if prev.is_finite() {
                    *s0 += p * p;
                    *s1 += p * *prev;
                }
                *prev = p;
            }
        }
    }

    fn start_welch(&mut self, sim: &crate::scenario::Simulation) {
        self.welch = self
            .lag
            .iter()
            .map(|(s0, s1, _)| {
                let phi = (s1 / s0).clamp(1e-6, 1.0 - 1e-9);
                let b_guess = -phi.ln() / sim.sample_interval;
                Welch::new(
                    Welch::segment_for(b_guess, sim.sample_interval, sim.samples_per_trajectory()),
                    sim.sample_interval,
                    sim.trajectories,
                )
            })
            .collect();
    }

    fn push(&mut self, traj: u32, row: &[f64]) {
        for (w, &c) in self.welch.iter_mut().zip(&self.columns) {
            w.push(traj as usize, row[c]);
        }
    }

    /// Fit (3.20) to every spectrum: the filters the identifier uses (the fit, or the true
    /// values where the scenario declares them known), their reports and the plot data.
    #[allow(clippy::type_complexity)]
    fn filters(
        &self,
        s: &Scenario,
    ) -> (
        Vec<Filter>,
        Vec<FilterReport>,
        Vec<(String, spectrum::Spectrum, spectrum::OuFit, (f64, f64))>,
    ) {
        let mut filters = Vec::new();
        let mut reports = Vec::new();
        let mut spectra = Vec::new();
        for (&e, w) in self.excitations.iter().zip(&self.welch) {
            let spec = w.spectrum();
            let fit = spectrum::fit_ou(&spec);
            let Process::Filtered { a: ta, b: tb } = s.excitations[e].process else {
                unreachable!("only filtered forces are fitted")
            };
            let known = s.identify.known_filters.contains(&e);
            let (a, b) = if known { (ta, tb) } else { (fit.a, fit.b) };
            filters.push(Filter { excitation: e, a, b });
            reports.push(FilterReport {
                excitation: s.excitations[e].name.clone(),
                used: match (s.excitations[e].measured, known) {
                    (false, _) => "fitted (disturbance: the bound only)",
                    (true, true) => "known",
                    (true, false) => "fitted",
                },
                a,
                b,
                fitted_a: fit.a,
                fitted_b: fit.b,
                true_a: ta,
                true_b: tb,
                rms_log_residual: fit.rms_log_residual,
                expected_rms_log_residual: fit.expected_rms,
                segments: spec.segments,
                segment_len: spec.segment_len,
            });
            spectra.push((s.excitations[e].name.clone(), spec, fit, (ta, tb)));
        }
        (filters, reports, spectra)
    }
}

/// The report of an identification of `info`'s log; passed when there is a gated method
/// and every gated method passed.
#[allow(clippy::too_many_arguments)]
fn assemble(
    info: &LogInfo,
    samples: u64,
    start: Instant,
    filters: Vec<FilterReport>,
    methods: Vec<MethodReport>,
    validation: Option<Validation>,
    iterations: Vec<IterationReport>,
    plot: PlotData,
) -> Report {
    let s = &info.scenario;
    let sim = &s.simulation;
    let passed = methods.iter().any(|r| r.gated) && methods.iter().filter(|r| r.gated).all(|r| r.passed);
    let identify_s = start.elapsed().as_secs_f64();
    Report {
        scenario: s.name.clone(),
        log: info.path.display().to_string(),
        record_length_s: sim.record_length,
        total_record_s: sim.record_length * sim.trajectories as f64,
        samples,
        sample_interval_s: sim.sample_interval,
        trajectories: sim.trajectories,
        seed: sim.seed,
        scheme: sim.scheme.name().to_string(),
        dt_s: sim.dt,
        timings_s: Timings {
            simulate: 0.0,
            identify: identify_s,
            total: identify_s,
        },
        filters,
        methods,
        validation,
        iterations,
        passed,
        plot,
        scenario_def: Some(s.clone()),
    }
}

/// The data's distributions behind the plots and the validation, filled in pass 2:
/// histograms of every link's relative displacement and velocity, and moments and
/// histograms of every state variable of `problem`; after [`Distributions::validate`],
/// the re-simulated model's too.
struct Distributions {
    model: Model,
    xs: Vec<f64>,
    vs: Vec<f64>,
    link_hist: Vec<(Histogram, Histogram)>,
    /// Empty histograms over the data's ranges (the validation fills copies).
    state_hist: Vec<Histogram>,
    marg: Marginals,
    /// Per state variable: name, unit, data histogram, model histogram.
    names: Vec<(String, String)>,
    model_marg: Option<Marginals>,
}

impl Distributions {
    fn new(s: &Scenario, problem: &Problem, data: &StationaryData) -> Distributions {
        let total = data.total();
        let state_hist: Vec<Histogram> = (0..problem.dim())
            .map(|j| Histogram::new(total.min[j], total.max[j], HIST_BINS))
            .collect();
        let units = s.motion.units();
        let names = problem
            .state_names
            .iter()
            .map(|name| {
                let unit = units[if name.starts_with("x_") {
                    0
                } else if name.starts_with("v_") {
                    1
                } else {
                    2
                }];
                (name.clone(), unit.to_string())
            })
            .collect();
        Distributions {
            model: problem.model.clone(),
            xs: vec![0.0; problem.n],
            vs: vec![0.0; problem.n],
            link_hist: data
                .link_ranges
                .iter()
                .map(|r| {
                    (
                        Histogram::new(r[0], r[1], HIST_BINS),
                        Histogram::new(r[2], r[3], HIST_BINS),
                    )
                })
                .collect(),
            marg: Marginals::new(problem.columns.clone(), state_hist.clone()),
            state_hist,
            names,
            model_marg: None,
        }
    }

    fn push(&mut self, row: &[f64]) {
        for i in 0..self.xs.len() {
            self.xs[i] = row[3 * i];
            self.vs[i] = row[3 * i + 1];
        }
        for (l, h) in self.link_hist.iter_mut().enumerate() {
            h.0.push(self.model.relative(l, &self.xs));
            h.1.push(self.model.relative(l, &self.vs));
        }
        self.marg.push(row);
    }

    /// The validation table for `values` (keeping the re-simulated distributions).
    fn validate(&mut self, s: &Scenario, problem: &Problem, values: &[f64], method: &'static str) -> Validation {
        match validate(
            s,
            problem,
            &coefficients_of(problem),
            values,
            method,
            &self.marg,
            &self.state_hist,
        ) {
            Ok((val, m)) => {
                self.model_marg = Some(m);
                val
            }
            Err(e) => Validation {
                method,
                record_length_s: 0.0,
                trajectories: 0,
                seed: 0,
                rows: Vec::new(),
                error: Some(format!("the identified model could not be simulated: {e}")),
            },
        }
    }

    fn into_plot(self, spectra: Vec<(String, spectrum::Spectrum, spectrum::OuFit, (f64, f64))>) -> PlotData {
        let model_hist = |j: usize| self.model_marg.as_ref().map(|m| m.hist[j].clone());
        PlotData {
            marginals: self
                .names
                .iter()
                .enumerate()
                .map(|(j, (name, unit))| (name.clone(), unit.clone(), self.marg.hist[j].clone(), model_hist(j)))
                .collect(),
            samples: self.marg.n,
            model_samples: self.model_marg.as_ref().map_or(0.0, |m| m.n),
            link_hist: self.link_hist,
            spectra,
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn fill_accuracy(
    rep: &mut MethodReport,
    s: &Scenario,
    problem: &Problem,
    coef_of: &[Option<Coefficient>],
    values: &[f64],
    std_error: &[f64],
    ranges: &[[f64; 4]],
) {
    let range = |c: Coefficient| match c.kind {
        Characteristic::Stiffness => (ranges[c.link][0], ranges[c.link][1]),
        Characteristic::Damping => (ranges[c.link][2], ranges[c.link][3]),
    };
    let mut worst: f64 = 0.0;
    for (k, name) in problem.names.iter().enumerate() {
        let t = problem.truth[k];
        let rel = match coef_of[k] {
            Some(c) => {
                let (lo, hi) = range(c);
                stats::coefficient_error(
                    values[k],
                    t,
                    c.power,
                    &stats::true_characteristic(s, c.link, c.kind),
                    lo,
                    hi,
                )
            }
            None => ((values[k] - t) / t).abs(),
        };
        worst = worst.max(rel);
        rep.parameters.push(Parameter {
            name: name.clone(),
            true_value: t,
            estimate: values[k],
            std_error: std_error[k],
            rel_error: rel,
        });
    }
    for l in 0..s.links.len() {
        for kind in [Characteristic::Stiffness, Characteristic::Damping] {
            let (est, unknown) = stats::estimated_characteristic(s, coef_of, values, l, kind);
            if !unknown {
                continue;
            }
            let truth = stats::true_characteristic(s, l, kind);
            let (lo, hi) = range(Coefficient {
                link: l,
                kind,
                power: 1,
            });
            let e = stats::rel_l2(&est, &truth, lo, hi);
            worst = worst.max(e);
            rep.curves.push(Curve {
                link: s.links[l].name.clone(),
                kind: kind.name(),
                rel_l2_error: e,
                range: [lo, hi],
                identified: est.terms.clone(),
            });
            rep.dissipativity
                .push(stats::dissipativity(&s.links[l].name, kind, &est, lo, hi));
        }
    }
    rep.worst_rel_error = worst;
    rep.passed = worst <= rep.threshold;
}

/// The coefficient behind each unknown (`None` for masses and intensities).
fn coefficients_of(problem: &Problem) -> Vec<Option<Coefficient>> {
    problem
        .unknowns
        .iter()
        .map(|u| {
            if let Unknown::Coefficient(c) = u {
                Some(*c)
            } else {
                None
            }
        })
        .collect()
}

/// The scenario with every filtered excitation replaced by white noise of the same
/// low-frequency density (`σ = A/B`): what ignoring the filter amounts to.
fn whitened(s: &Scenario, filters: &[Filter]) -> Scenario {
    let mut w = s.clone();
    w.identify.unknown_corners.clear();
    for f in filters {
        w.excitations[f.excitation].process = Process::White { sigma: f.a / f.b };
    }
    w
}

/// One method's report: estimates, accuracy, dissipativity; `threshold` `None` for an
/// ungated baseline or comparison.
fn method_report(
    method: &str,
    threshold: Option<f64>,
    est: Result<ident::Estimate, IdentError>,
    s: &Scenario,
    problem: &Problem,
    ranges: &[[f64; 4]],
    started: Instant,
) -> MethodReport {
    let mut rep = MethodReport {
        method: method.to_string(),
        gated: threshold.is_some(),
        parameters: Vec::new(),
        curves: Vec::new(),
        worst_rel_error: f64::NAN,
        threshold: threshold.unwrap_or(f64::NAN),
        passed: false,
        diagnostics: None,
        weakly_determined: false,
        facts: BTreeMap::new(),
        dissipativity: Vec::new(),
        error: None,
        seconds: 0.0,
    };
    match est {
        Err(e) => rep.error = Some(e.to_string()),
        Ok(e) => {
            fill_accuracy(
                &mut rep,
                s,
                problem,
                &coefficients_of(problem),
                &e.values,
                &e.std_error,
                ranges,
            );
            if threshold.is_none() {
                rep.passed = true;
            }
            rep.diagnostics = Some(e.diagnostics.clone());
            rep.weakly_determined = e.weakly_determined;
            rep.facts = e.facts.into_iter().collect();
            for (name, direct, from_product) in problem.recovered(&e.values) {
                rep.facts.insert(
                    format!("physical {name}"),
                    format!("{direct:.6} directly, {from_product:.6} from (B*{name})/B"),
                );
            }
        }
    }
    rep.seconds = started.elapsed().as_secs_f64();
    rep
}

/// The scenario with the identified values in place of the unknowns.
pub fn identified_scenario(
    s: &Scenario,
    problem: &Problem,
    coef_of: &[Option<Coefficient>],
    values: &[f64],
) -> Scenario {
    let mut out = s.clone();
    for l in 0..s.links.len() {
        for kind in [Characteristic::Stiffness, Characteristic::Damping] {
            let (est, unknown) = stats::estimated_characteristic(s, coef_of, values, l, kind);
            if unknown {
                let est = Polynomial {
                    terms: est.terms.into_iter().filter(|t| t.1 != 0.0).collect(),
                };
                match kind {
                    Characteristic::Stiffness => out.links[l].stiffness = est,
                    Characteristic::Damping => out.links[l].damping = est,
                }
            }
        }
    }
    for (k, u) in problem.unknowns.iter().enumerate() {
        match *u {
            Unknown::Mass(i) => out.masses[i].value = values[k],
            Unknown::Intensity(e) => {
                if let crate::scenario::Process::White { sigma } = &mut out.excitations[e].process {
                    *sigma = values[k];
                }
            }
            Unknown::Corner(e) => {
                if let Process::Filtered { b, .. } = &mut out.excitations[e].process {
                    *b = values[k];
                }
            }
            Unknown::Coefficient(_) | Unknown::CornerProduct(..) | Unknown::Monomial(..) | Unknown::InputGain(_) => {}
        }
    }
    out
}

/// Re-simulate the identified model with the same excitation (another seed) and compare
/// std and kurtosis of every response with the data's.
fn validate(
    s: &Scenario,
    problem: &Problem,
    coef_of: &[Option<Coefficient>],
    values: &[f64],
    method: &'static str,
    data: &Marginals,
    hist: &[Histogram],
) -> Result<(Validation, Marginals), SimError> {
    let mut sc = identified_scenario(s, problem, coef_of, values);
    // At most 1e5 s of trajectory time: enough for std and kurtosis to a few per cent.
    let traj = sc.simulation.trajectories;
    sc.simulation.record_length = sc
        .simulation
        .record_length
        .min(1e5 / traj as f64)
        .max(sc.simulation.sample_interval);
    sc.simulation.seed = sc.simulation.seed.wrapping_add(1_000_003);
    let model = Model::new(&sc);
    let mut m = Marginals::new(
        problem.columns.clone(),
        hist.iter()
            .map(|h| Histogram::new(h.lo, h.hi, h.counts.len()))
            .collect(),
    );
    simulate(&model, &sc.simulation, &mut m, &|_| {})?;
    let rows = (0..problem.dim())
        .map(|j| {
            let (ds, dk) = data.std_kurtosis(j);
            let (ms, mk) = m.std_kurtosis(j);
            ValidationRow {
                variable: problem.state_names[j].clone(),
                data_std: ds,
                model_std: ms,
                data_kurtosis: dk,
                model_kurtosis: mk,
            }
        })
        .collect();
    Ok((
        Validation {
            method,
            record_length_s: sc.simulation.record_length,
            trajectories: traj,
            seed: sc.simulation.seed,
            rows,
            error: None,
        },
        m,
    ))
}

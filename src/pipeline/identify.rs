//! The ordinary path: every requested method on one log, the naive white-noise baseline
//! for filtered forces, the `[identify.compare]` alternatives, and the validation.

use super::disturbed::identify_disturbed;
use super::grading::{assemble, method_report, Grader};
use super::spectra::ForceSpectra;
use super::validation::Distributions;
use super::{Options, PipelineError};
use crate::ident::baseline::{self, Increments, KramersMoyal};
use crate::ident::data::StationaryData;
use crate::ident::kernel::{FluxLattice, KernelOptions};
use crate::ident::strong::{self, DensityGrid, GridOptions};
use crate::ident::Specification;
use crate::ident::{self, weak, Filter, IdentError, Problem, Unknown};
use crate::io::log::{read_samples, LogInfo};
use crate::report::{MethodReport, Report};
use crate::scenario::{Method, Process, ReportMethod, Scenario};
use std::time::Instant;

/// The measured filtered excitations at placeholder `A`, `B`: the problem's structure
/// (state, columns, moments needed, symmetries) does not depend on them.
fn placeholder_filters(s: &Scenario) -> Vec<Filter> {
    (0..s.excitations.len())
        .filter(|&e| s.excitations[e].measured && matches!(s.excitations[e].process, Process::Filtered { .. }))
        .map(|e| Filter {
            excitation: e,
            a: 1.0,
            b: 1.0,
        })
        .collect()
}

/// What can be refused from the scenario alone, before any simulation or reading: unknowns
/// no data can separate (parallel links, exact symmetries of the stationary density) and
/// problems the identifier does not support.
pub fn preflight(s: &Scenario) -> Result<(), IdentError> {
    s.check_separable().map_err(IdentError::Inseparable)?;
    if s.identify.disturbance.is_none() {
        Problem::from_spec(&Specification::from_scenario(s), &placeholder_filters(s))?;
    }
    Ok(())
}

/// Measured data: every quantity the identification reads is in the data (mapped, or
/// derived), named by its log column and what needs it.
pub fn check_measured(info: &LogInfo) -> Result<(), String> {
    let Some(m) = &info.measured else {
        return Ok(());
    };
    let s = &info.scenario;
    let structure =
        Problem::from_spec(&Specification::from_scenario(s), &placeholder_filters(s)).map_err(|e| e.to_string())?;
    let mut needed: Vec<(usize, &str)> = structure
        .columns
        .iter()
        .map(|&c| (c, "the identification's state"))
        .collect();
    let layout = structure.model.columns();
    for f in placeholder_filters(s) {
        if !s.identify.known_filters.contains(&f.excitation) {
            needed.push((layout.force(f.excitation), "the spectral fit of its filter (3.20)"));
        }
    }
    let Some((_, first)) = m.records.first() else {
        return Err("the data hold no samples".into());
    };
    for (c, why) in needed {
        if first[c].is_nan() {
            return Err(format!(
                "the data have no {} (needed for {why}): map a column to it in the model file's [data.columns]{}",
                info.columns[c],
                if info.columns[c].starts_with("v_") || info.columns[c].starts_with("a_") {
                    ", or set derive = true"
                } else {
                    ""
                }
            ));
        }
    }
    let unknowns = structure.unknowns.len() as u64;
    if m.samples() < 100 * unknowns {
        return Err(format!(
            "{} samples for {unknowns} unknowns: at least 100 per unknown are needed (and far more for useful accuracy)",
            m.samples()
        ));
    }
    Ok(())
}

pub(crate) fn identify_info(info: &LogInfo, options: &Options, start: Instant) -> Result<Report, PipelineError> {
    let s = &info.scenario;
    s.check_separable().map_err(IdentError::Inseparable)?;
    if let Some(d) = &s.identify.disturbance {
        let mut d = d.clone();
        d.max_steps = options.max_steps.unwrap_or(d.max_steps);
        d.tolerance = options.tolerance.unwrap_or(d.tolerance);
        return identify_disturbed(info, &d, options, start);
    }
    let grader = Grader::of_log(info)?;
    let sim = &s.simulation;
    let methods = if options.methods.is_empty() {
        s.identify.methods.clone()
    } else {
        options.methods.clone()
    };
    // Measured filtered excitations: their A, B come from the force spectrum unless known.
    let placeholder = placeholder_filters(s);
    let filtered: Vec<usize> = placeholder.iter().map(|f| f.excitation).collect();
    let spec = Specification::from_scenario(s);
    let structure = Problem::from_spec(&spec, &placeholder)?;
    let naive_structure = (!filtered.is_empty())
        .then(|| Problem::from_spec(&spec.whitened(&placeholder), &[]))
        .transpose()?;

    // Pass 1: moments per batch, link ranges, lag-1 correlation of each filtered force.
    let mut data = StationaryData::new(
        &structure,
        weak::moment_degree(&structure),
        sim.record_length,
        sim.trajectories,
        options.batches,
    );
    let mut naive_data = naive_structure.as_ref().map(|p| {
        StationaryData::new(
            p,
            weak::moment_degree(p),
            sim.record_length,
            sim.trajectories,
            options.batches,
        )
    });
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
    let kernel_density = options.density == super::StrongDensity::Kernel;
    let want_grid = methods
        .iter()
        .any(|m| *m == Method::StrongMarginals || (*m == Method::Strong && !kernel_density));
    let want_lattice = kernel_density && methods.contains(&Method::Strong);
    // The strong forms' grid: automatic from the sample count unless given, and not
    // applicable when even the coarsest automatic grid would be too sparse.
    let mut grid = want_grid.then(|| {
        let grid_options = match options.grid {
            Some(g) => g,
            None => {
                strong::applicable(structure.dim(), total.count).map_err(IdentError::NotApplicable)?;
                GridOptions::auto(structure.dim(), total.count)
            }
        };
        // Only the product of the marginals wanted: the joint histogram is not counted.
        let joint = methods.contains(&Method::Strong) && !kernel_density;
        DensityGrid::new(&structure, &total, grid_options)
            .map(|g| if joint { g } else { g.marginals_only() }.with_batches(data.batch_count()))
    });
    let mut dist = Distributions::new(s, &structure, &data);
    // The baselines on the same samples (white-noise problems only).
    let baseline_ok = baseline::applicable(&structure);
    let wants = |m: Method| methods.contains(&m) && baseline_ok.is_ok();
    let mut increments =
        wants(Method::Increments).then(|| Increments::new(&structure, sim.sample_interval, data.batch_count()));
    // The force regression: on the mechanical problem (filtered forces are measured like
    // white ones, so their filters' states are not needed), when every force is measured.
    let force_problem = match &naive_structure {
        Some(p) if p.unknowns != structure.unknowns => Err(IdentError::NotApplicable(
            "the force regression estimates the mechanical coefficients only, and this problem has filter unknowns"
                .into(),
        )),
        Some(p) => Ok(p),
        None => Ok(&structure),
    };
    // fpkbench logs a white force as its mean over the sample interval; measured data and
    // filtered forces hold values at the sample instants.
    let interval_means: Vec<bool> = s
        .excitations
        .iter()
        .map(|e| info.measured.is_none() && matches!(e.process, crate::scenario::Process::White { .. }))
        .collect();
    let force_ok = force_problem
        .and_then(|p| baseline::applicable(p).map(|()| p))
        .and_then(|p| baseline::force_columns(p, &interval_means).map(|c| (p, c)));
    let mut force_regression = match (&force_ok, methods.contains(&Method::ForceRegression)) {
        (Ok((p, cols)), true) => Some(Increments::with_forces(
            p,
            sim.sample_interval,
            data.batch_count(),
            cols.clone(),
        )),
        _ => None,
    };
    let mut kramers_moyal = wants(Method::KramersMoyal).then(|| {
        let g = GridOptions::auto(structure.dim(), total.count);
        let mean: Vec<f64> = (0..structure.dim()).map(|j| total.mean(j)).collect();
        let std: Vec<f64> = (0..structure.dim()).map(|j| total.std(j)).collect();
        KramersMoyal::new(
            &structure,
            sim.sample_interval,
            data.batch_count(),
            (&mean, &std),
            g.bins,
            g.span_std,
        )
    });
    // The kernel lattice over a problem's state (the strong form's fluxes).
    let new_lattice = |p: &Problem| {
        let o = options
            .kernel
            .unwrap_or_else(|| KernelOptions::auto(p.dim(), total.count));
        let mean: Vec<f64> = (0..p.dim()).map(|j| total.mean(j)).collect();
        let std: Vec<f64> = (0..p.dim()).map(|j| total.std(j)).collect();
        FluxLattice::new(p, &mean, &std, o, data.batch_count())
    };
    // Without filtered excitations the problem is known now: the lattice fills in this pass.
    let mut lattice = (want_lattice && filtered.is_empty()).then(|| new_lattice(&structure));
    forces.start_welch(sim);
    let keep_dist = options.validate || options.plots;
    read_samples(info, |traj, t, row| {
        let batch = data.batch_of(traj, t);
        if let Some(Ok(g)) = grid.as_mut() {
            g.push_in(batch, row);
        }
        if let Some(Ok(l)) = lattice.as_mut() {
            l.push_in(batch, row);
        }
        if let Some(b) = increments.as_mut() {
            b.push(traj as usize, t, batch, row);
        }
        if let Some(b) = kramers_moyal.as_mut() {
            b.push(traj as usize, t, batch, row);
        }
        if let Some(b) = force_regression.as_mut() {
            b.push(traj as usize, t, batch, row);
        }
        if keep_dist {
            dist.push(traj as usize, row);
        }
        forces.push(traj, row);
    })?;

    if let Some(Ok(g)) = grid.as_mut() {
        g.finish();
    }
    if let Some(Ok(l)) = lattice.as_mut() {
        l.finish();
    }
    if let Some(b) = kramers_moyal.as_mut() {
        b.finish();
    }
    for b in [increments.as_mut(), force_regression.as_mut()].into_iter().flatten() {
        b.finish();
    }
    // Filters: fitted to the spectra, or known.
    let (filters, filter_reports, spectra) = forces.filters(s);
    let problem = Problem::from_spec(&spec, &filters)?;
    let typical = problem.typical(&total);
    // Pass 3 (strong form from kernel estimates): the fluxes are the drift's parts, known
    // only now that the filters are (without filtered excitations, in pass 2 already).
    if want_lattice && lattice.is_none() {
        lattice = Some(match new_lattice(&problem) {
            Ok(mut l) => {
                read_samples(info, |traj, t, row| l.push_in(data.batch_of(traj, t), row))?;
                l.finish();
                Ok(l)
            }
            Err(e) => Err(e),
        });
    }
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

    let (mut reports, first) = estimator_reports(
        &methods,
        &Estimators {
            problem: &problem,
            reported: &reported,
            weak: &weak_estimate,
            grid: grid.as_ref(),
            lattice: lattice.as_ref(),
            typical: &typical,
            baseline: |m: Method| match (m, &baseline_ok) {
                (Method::ForceRegression, _) => match (&force_ok, &force_regression) {
                    (Err(e), _) => Err(e.clone()),
                    (Ok(_), b) => b.as_ref().map_or_else(|| unreachable!(), |b| b.estimate(&typical)),
                },
                (_, Err(e)) => Err(e.clone()),
                (Method::Increments, _) => increments
                    .as_ref()
                    .map_or_else(|| unreachable!(), |b| b.estimate(&typical)),
                (_, _) => kramers_moyal
                    .as_ref()
                    .map_or_else(|| unreachable!(), |b| b.estimate(&typical)),
            },
        },
        &grader,
        &data.link_ranges,
    )?;
    let naive = naive_data.as_ref().filter(|_| !filtered.is_empty());
    reports.extend(comparison_reports(&spec, &filters, naive, &data, &grader)?);

    // Validation by re-simulation of the first identified model.
    let validation = match (first, options.validate) {
        (Some((values, method)), true) => Some(dist.validate(s, &reported, &values, method)),
        _ => None,
    };
    Ok(assemble(
        info,
        &grader,
        data.samples(),
        start,
        filter_reports,
        reports,
        validation,
        Vec::new(),
        dist.into_plot(spectra),
    ))
}

/// What the gated estimators work from: the problem, the problem the reports are about
/// (the physical one of a bilinear problem), the weak form's estimate (computed first, as
/// it measures identifiability), the density grid if one was asked for.
struct Estimators<'a, B: Fn(Method) -> Result<ident::Estimate, IdentError>> {
    problem: &'a Problem,
    reported: &'a Problem,
    weak: &'a Result<ident::Estimate, IdentError>,
    grid: Option<&'a Result<DensityGrid, IdentError>>,
    /// The strong form's kernel lattice, if the kernel density was asked for.
    lattice: Option<&'a Result<FluxLattice, IdentError>>,
    typical: &'a [f64],
    /// A baseline's estimate (computed on demand).
    baseline: B,
}

/// The gated rows: one per requested method, and the first estimate that succeeded (what
/// the validation re-simulates). Unknowns that cannot be separated end the identification.
#[allow(clippy::type_complexity)]
fn estimator_reports<B: Fn(Method) -> Result<ident::Estimate, IdentError>>(
    methods: &[Method],
    e: &Estimators<B>,
    grader: &Grader,
    ranges: &[[f64; 4]],
) -> Result<(Vec<MethodReport>, Option<(Vec<f64>, ReportMethod)>), PipelineError> {
    let s = grader.scenario;
    let bilinear = e.problem.unknowns.iter().any(|u| matches!(u, Unknown::Corner(_)));
    let mut reports = Vec::new();
    let mut first = None;
    for m in methods {
        let t = Instant::now();
        let est = match (m, e.grid) {
            (Method::Increments | Method::KramersMoyal | Method::ForceRegression, _) => (e.baseline)(*m),
            (Method::Weak, _) => e.weak.clone(),
            (Method::Strong, _) if bilinear && e.lattice.is_some() => Err(IdentError::Unsupported(
                "an unknown corner B makes the drift bilinear; the strong form here solves linear problems only".into(),
            )),
            (Method::Strong, _) if e.lattice.is_some() => match e.lattice {
                Some(Ok(l)) => ident::identify_kernel(e.problem, l, e.typical),
                Some(Err(err)) => Err(err.clone()),
                None => unreachable!("lattice requested"),
            },
            (Method::Strong | Method::StrongMarginals, Some(Err(err))) => Err(err.clone()),
            (Method::Strong | Method::StrongMarginals, _) if bilinear => Err(IdentError::Unsupported(
                "an unknown corner B makes the drift bilinear; the strong form here solves linear problems only".into(),
            )),
            (Method::Strong, Some(Ok(g))) => ident::identify_strong(e.problem, g, false, e.typical),
            (Method::StrongMarginals, Some(Ok(g))) => ident::identify_strong(e.problem, g, true, e.typical),
            (_, None) => unreachable!("grid requested"),
        };
        if let (Err(err @ IdentError::NotIdentifiable { .. }), false) = (&est, m.is_baseline()) {
            return Err(err.clone().into());
        }
        let method = ReportMethod::Estimator(*m);
        if let (Ok(est), None, false) = (&est, &first, m.is_baseline()) {
            first = Some((est.values.clone(), method.clone()));
        }
        // Baselines are compared, never gated.
        let threshold = (!m.is_baseline()).then(|| s.accept.threshold(&method));
        reports.push(method_report(method, threshold, est, grader, e.reported, ranges, t));
    }
    Ok((reports, first))
}

/// The ungated rows: the naive baseline (the white-noise identification applied to
/// filtered data, each filtered force taken as white of the same low-frequency density
/// `σ = A/B`; `naive` holds its data when there are filtered forces) and the alternative
/// models of `[identify.compare]` (e.g. the paper's linear case 1).
fn comparison_reports(
    spec: &Specification,
    filters: &[Filter],
    naive: Option<&StationaryData>,
    data: &StationaryData,
    grader: &Grader,
) -> Result<Vec<MethodReport>, PipelineError> {
    let ranges = &data.link_ranges;
    let mut reports = Vec::new();
    if let Some(d) = naive {
        let t = Instant::now();
        let p = Problem::from_spec(&spec.whitened(filters), &[])?;
        let est = ident::identify_weak(&p, d);
        reports.push(method_report(
            ReportMethod::WeakWhiteNaive,
            None,
            est,
            grader,
            &p,
            ranges,
            t,
        ));
    }
    for (name, links) in &grader.scenario.identify.compare {
        let t = Instant::now();
        let p = Problem::from_spec(&Specification::with_links(grader.scenario, links), filters)?;
        let est = ident::identify_weak(&p, data);
        reports.push(method_report(
            ReportMethod::Compare(name.clone()),
            None,
            est,
            grader,
            &p,
            ranges,
            t,
        ));
    }
    Ok(reports)
}

//! The ordinary path: every requested method's estimator on one sample source, the naive
//! white-noise baseline for filtered forces, the `[identify.compare]` alternatives, and
//! the validation.

use super::disturbed::identify_disturbed;
use super::grading::{assemble, method_report, Grader};
use super::source::Input;
use super::spectra::ForceSpectra;
use super::validation::Distributions;
use super::{Options, PipelineError};
use crate::estimators::{Context, Estimator, Method, Setup};
use crate::ident::data::StationaryData;
use crate::ident::Specification;
use crate::ident::{self, weak, Filter, IdentError, Problem, Unknown};
use crate::model::Quantity;
use crate::report::{MethodReport, Report};
use crate::scenario::{Process, ReportMethod, Scenario, Select};
use std::time::Instant;

/// The comparison row of a selection: the weak form with the terms `[identify.links]`
/// declares.
pub const DECLARED: &str = "declared terms";

/// The comparison row of the baseline selection (STLSQ on the same equations).
pub const THRESHOLDED: &str = "STLSQ selection";

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
pub fn preflight(s: &Scenario, select: Option<&Select>) -> Result<(), IdentError> {
    s.check_separable().map_err(IdentError::Inseparable)?;
    let select = selection(s, select)?;
    if s.identify.disturbance.is_none() {
        Problem::from_spec(&accumulated(s, select.as_ref()), &placeholder_filters(s))?;
    }
    Ok(())
}

/// The structure selection asked for: the CLI's `--select` over the scenario's
/// `[identify.select]` (candidate lists given on the command line replace the file's);
/// refused where selection does not apply.
pub(crate) fn selection(s: &Scenario, cli: Option<&Select>) -> Result<Option<Select>, IdentError> {
    let select = match (cli, &s.identify.select) {
        (Some(c), Some(f)) => Some(Select {
            stiffness: c.stiffness.clone().or_else(|| f.stiffness.clone()),
            damping: c.damping.clone().or_else(|| f.damping.clone()),
        }),
        (Some(c), None) => Some(c.clone()),
        (None, f) => f.clone(),
    };
    if select.is_some() {
        if let Some(why) = s.identify.select_unsupported(&s.excitations) {
            return Err(IdentError::NotApplicable(why));
        }
    }
    Ok(select)
}

/// What the first pass accumulates for: the scenario's unknowns, or with a selection the
/// candidate model (every candidate term unknown).
fn accumulated(s: &Scenario, select: Option<&Select>) -> Specification {
    match select {
        Some(sel) => Specification::with_links(s, &sel.candidates(&s.links, &s.identify.links)),
        None => Specification::from_scenario(s),
    }
}

/// Measured data: every quantity the identification reads is in the data (mapped, or
/// derived), named by its log column and what needs it.
pub fn check_measured(input: &Input) -> Result<(), String> {
    let Some(m) = input.measured() else {
        return Ok(());
    };
    let info = &input.info;
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
    for (c, why) in needed {
        if !m.present[c] {
            return Err(format!(
                "the data have no {} (needed for {why}): map a column to it in the model file's [data.columns]{}",
                info.columns[c],
                if matches!(layout.at(c).0, Quantity::Velocity | Quantity::Acceleration) {
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

pub(crate) fn identify_info(input: &Input, options: &Options, start: Instant) -> Result<Report, PipelineError> {
    let s = &input.info.scenario;
    s.check_separable().map_err(IdentError::Inseparable)?;
    if let Some(d) = &s.identify.disturbance {
        let mut d = d.clone();
        d.max_steps = options.max_steps.unwrap_or(d.max_steps);
        d.tolerance = options.tolerance.unwrap_or(d.tolerance);
        return identify_disturbed(input, &d, options, start);
    }
    let grader = Grader::of_log(&input.info)?;
    let sim = &s.simulation;
    let methods = if options.methods.is_empty() {
        s.identify.methods.clone()
    } else {
        options.methods.clone()
    };
    // Measured filtered excitations: their A, B come from the force spectrum unless known.
    let placeholder = placeholder_filters(s);
    let filtered: Vec<usize> = placeholder.iter().map(|f| f.excitation).collect();
    let select = selection(s, options.select.as_ref())?;
    let mut spec = accumulated(s, select.as_ref());
    let mut structure = Problem::from_spec(&spec, &placeholder)?;
    let naive_structure = (!filtered.is_empty())
        .then(|| Problem::from_spec(&spec.whitened(&placeholder), &[]))
        .transpose()?;

    // Pass 1: moments per batch, link ranges, lag-1 correlation of each filtered force.
    // With a selection, also those of the declared model it is compared with, and those of
    // the `[identify.compare]` models over the same atoms; a comparison model with other
    // atoms (other non-polynomial terms) gathers its own moments.
    let declared = (select.is_some())
        .then(|| Problem::from_spec(&Specification::from_scenario(s), &placeholder))
        .transpose()?;
    let mut comparisons: Vec<Comparison> = s
        .identify
        .compare
        .iter()
        .map(|(name, links)| Comparison::new(name, links, s, &placeholder, &structure, options.batches))
        .collect();
    // A profiled term's position: the model at every position gathers its moments.
    let mut profile = super::profile::Candidates::new(s, &spec, &placeholder, options.batches);
    let also: Vec<&Problem> = declared
        .iter()
        .chain(
            comparisons
                .iter()
                .filter(|c| c.own.is_none())
                .filter_map(|c| c.problem.as_ref().ok()),
        )
        .collect();
    let mut data = match also.is_empty() {
        false => {
            StationaryData::for_weak_forms(&structure, &also, sim.record_length, sim.trajectories, options.batches)
        }
        true => StationaryData::new(
            &structure,
            weak::moment_degree(&structure),
            sim.record_length,
            sim.trajectories,
            options.batches,
        ),
    };
    // The naive white-noise row shows what ignoring the filters costs against the truth;
    // measured data have none to show it against, and nobody asked for it there.
    let mut naive_data = naive_structure
        .as_ref()
        .filter(|_| input.measured().is_none())
        .map(|p| {
            StationaryData::new(
                p,
                weak::moment_degree(p),
                sim.record_length,
                sim.trajectories,
                options.batches,
            )
        });
    let mut forces = ForceSpectra::new(s, &filtered);
    let mut floor = super::sensors::noise_floor(input, &structure, data.batch_count());
    input.for_each_sample(|traj, t, row| {
        if let Some(f) = floor.as_mut() {
            f.push(traj, t, data.batch_of(traj, t), row);
        }
        data.push(traj, t, row);
        if let Some(d) = naive_data.as_mut() {
            d.push(traj, t, row);
        }
        for d in comparisons.iter_mut().filter_map(|c| c.own.as_mut()) {
            d.push(traj, t, row);
        }
        if let Some(p) = profile.as_mut() {
            p.push(traj, t, row);
        }
        forces.push_lag(traj, row);
    })?;
    data.finish();
    if let Some(d) = naive_data.as_mut() {
        d.finish();
    }
    for d in comparisons.iter_mut().filter_map(|c| c.own.as_mut()) {
        d.finish();
    }
    // The profiled position of least misfit is the model from here on, with its moments.
    let profiled = match profile {
        Some(mut p) => {
            crate::interrupt::check()?;
            let t = Instant::now();
            p.finish();
            let mut chosen = p.choose(s, &grader.truth, t)?;
            chosen.refine(s, input, &placeholder, options.batches)?;
            spec = chosen.spec;
            structure = Problem::from_spec(&spec, &placeholder)?;
            data = chosen.data;
            Some(chosen.report)
        }
        None => None,
    };
    // Sensor noise: estimated, and taken out of the weak form's moments.
    // The sensors' filters: the velocities' tail they took out, put back.
    let loss = super::sensors::filter_loss(s, &structure);
    let (sensor_noise, taken_out) = match (floor.as_ref(), &loss) {
        (Some(f), _) => {
            let (report, taken_out) = super::sensors::correct(
                f,
                s,
                input.measured(),
                &structure,
                &mut data,
                naive_data.as_mut(),
                loss.as_ref(),
            );
            (Some(report), taken_out)
        }
        (None, Some(l)) => (
            Some(super::sensors::put_back_filter_loss(
                l,
                s,
                &mut data,
                naive_data.as_mut(),
            )),
            Vec::new(),
        ),
        (None, None) => (None, Vec::new()),
    };
    // Structure selection: the candidate model's moments choose the terms, and the
    // selected model is what every method then identifies.
    let selection = match &select {
        Some(_) => {
            crate::interrupt::check()?;
            let t = Instant::now();
            let chosen = ident::select::select(&structure, &data)?;
            // The baseline's (STLSQ's) model, identified beside it.
            let baseline = Specification::with_links(
                s,
                &ident::select::model_links(&chosen.thresholded.selected, &structure, &spec.links),
            );
            spec = Specification::with_links(s, &chosen.links(&structure, &spec.links));
            structure = Problem::from_spec(&spec, &placeholder)?;
            Some((chosen, baseline, t.elapsed().as_secs_f64()))
        }
        None => None,
    };
    let total = data.total();

    // Pass 2: every requested estimator's accumulators, the force spectra, the histograms.
    let setup = Setup {
        scenario: s,
        structure: &structure,
        whitened: naive_structure.as_ref(),
        data: &data,
        total: &total,
        settings: &options.estimators,
        arenas: &options.arenas,
        measured: input.measured().is_some(),
    };
    let mut estimators: Vec<(Method, Box<dyn Estimator>)> = methods.iter().map(|&m| (m, m.estimator(&setup))).collect();
    let mut dist = Distributions::new(s, &structure, &data);
    forces.start_welch(sim);
    if s.identify.sensor_noise == crate::scenario::NoiseHandling::Estimate
        && (s.simulation.sensors.noisy() || input.measured().is_some())
    {
        forces.estimate_floors(sim.trajectories);
    }
    let keep_dist = options.validate || options.plots;
    // The Cramér–Rao bound beside every standard error, where it applies.
    let mut fisher = crate::ident::fisher::FisherInformation::new(&structure).ok();
    input.for_each_sample(|traj, t, row| {
        let batch = data.batch_of(traj, t);
        for (_, e) in estimators.iter_mut() {
            e.push(traj, t, batch, row);
        }
        if let Some(f) = fisher.as_mut() {
            f.push(row);
        }
        if keep_dist {
            dist.push(traj as usize, row);
        }
        forces.push(traj, row);
    })?;
    for (_, e) in estimators.iter_mut() {
        e.finish();
    }
    // Filters: fitted to the spectra, or known.
    let (filters, filter_reports, spectra) = forces.filters(s);
    let problem = Problem::from_spec(&spec, &filters)?;
    let typical = problem.typical(&total);
    // Pass 3, for accumulators that depend on the filters (the kernel strong form's fluxes
    // are the drift's parts, known only now that the filters are).
    let third: Vec<usize> = (0..estimators.len())
        .filter(|&i| estimators[i].1.needs_pass(&problem, &setup))
        .collect();
    if !third.is_empty() {
        input.for_each_sample(|traj, t, row| {
            let batch = data.batch_of(traj, t);
            for &i in &third {
                estimators[i].1.push(traj, t, batch, row);
            }
        })?;
        for &i in &third {
            estimators[i].1.finish();
        }
    }
    // With an unknown corner the drift is bilinear, and the reports are about the physical
    // coefficients and corners.
    let bilinear = problem.unknowns.iter().any(|u| matches!(u, Unknown::Corner(_)));
    let reported = if bilinear { problem.physical() } else { problem.clone() };
    let context = Context {
        problem: &problem,
        data: &data,
        typical: &typical,
        bilinear,
    };
    let (mut reports, first) = estimator_reports(&estimators, &context, &reported, &grader, data.observed())?;
    if let Some(bound) = fisher.and_then(|f| f.bound(data.samples() as f64 * setup.sample_interval())) {
        for rep in &mut reports {
            for p in &mut rep.parameters {
                if let Some(k) = problem.names.iter().position(|n| *n == p.name) {
                    p.cramer_rao_std = Some(bound[k]);
                }
            }
        }
    }
    let naive = naive_data.as_ref().filter(|_| !filtered.is_empty());
    reports.extend(comparison_reports(
        &spec,
        &filters,
        naive,
        &data,
        &comparisons,
        &grader,
    )?);
    if let Some((chosen, baseline, _)) = &selection {
        // The model as declared, on the same samples: what the selection is measured
        // against (for a simulation, the true structure unless [identify.links] says
        // otherwise); and the baseline selection's model.
        for (name, spec, selected) in [
            (DECLARED, Specification::from_scenario(s), None),
            (THRESHOLDED, baseline.clone(), Some(chosen.thresholded_names())),
        ] {
            let t = Instant::now();
            let p = Problem::from_spec(&spec, &filters)?;
            let est = ident::identify_weak(&p, &data);
            let mut row = method_report(
                ReportMethod::Compare(name.into()),
                None,
                est,
                &grader,
                &p,
                data.observed(),
                t,
            );
            row.selected = selected.map(|names| names.iter().map(|n| n.to_string()).collect());
            reports.push(row);
        }
    }

    // Validation by re-simulation of the first identified model.
    crate::interrupt::check()?;
    let validation = match (first, options.validate) {
        (Some((values, method)), true) => {
            let noisy = super::sensors::for_validation(s, &taken_out);
            // A response integrated from accelerations carries the integrated accelerometer
            // noise, slow and coloured, and lacks the motion below the drift removal's corner:
            // its spectrum is not compared (the white noise the re-simulation adds matches its
            // variance, not its spectrum); its std and kurtosis are.
            let integrated = |c: &usize| {
                input
                    .measured()
                    .is_some_and(|d| d.integrated_noise.iter().any(|n| n.column == *c))
            };
            let spectra: Vec<bool> = reported.columns.iter().map(|c| !integrated(c)).collect();
            Some(dist.validate(noisy.as_ref().unwrap_or(s), &reported, &values, method, &spectra))
        }
        _ => None,
    };
    let mut report = assemble(
        input,
        &grader,
        data.samples(),
        start,
        filter_reports,
        reports,
        validation,
        Vec::new(),
        dist.into_plot(spectra),
    );
    if let Some(n) = &sensor_noise {
        super::sensors::warn_uncorrected(n, &mut report.methods);
    }
    report.sensor_noise = sensor_noise;
    report.profile = profiled;
    if let Some((chosen, _, seconds)) = selection {
        let names: Vec<String> = chosen.selected_names().iter().map(|n| n.to_string()).collect();
        for m in &mut report.methods {
            if !matches!(m.method, ReportMethod::WeakWhiteNaive | ReportMethod::Compare(_)) {
                m.selected = Some(names.clone());
            }
        }
        report.selection = Some(crate::report::SelectionReport {
            selection: chosen,
            seconds,
        });
    }
    Ok(report)
}

/// One row per requested method, each with its own outcome (a refusal is that method's
/// row), and the first estimate of an FPK estimator that succeeded (what the validation
/// re-simulates); rows are about `reported` (the physical problem of a bilinear one).
#[allow(clippy::type_complexity)]
fn estimator_reports(
    estimators: &[(Method, Box<dyn Estimator>)],
    cx: &Context,
    reported: &Problem,
    grader: &Grader,
    observed: crate::ident::data::Observed,
) -> Result<(Vec<MethodReport>, Option<(Vec<f64>, ReportMethod)>), PipelineError> {
    let s = grader.scenario;
    let mut reports = Vec::new();
    let mut first = None;
    for (m, estimator) in estimators {
        crate::interrupt::check()?;
        let t = Instant::now();
        let est = estimator.estimate(cx);
        let method = ReportMethod::Estimator(*m);
        if let (Ok(est), None, false) = (&est, &first, m.is_baseline()) {
            first = Some((est.values.clone(), method.clone()));
        }
        // Baselines and known-biased comparisons are compared, never gated.
        let threshold = m.is_gated().then(|| s.accept.threshold(&method));
        reports.push(method_report(method, threshold, est, grader, reported, observed, t));
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
    comparisons: &[Comparison],
    grader: &Grader,
) -> Result<Vec<MethodReport>, PipelineError> {
    let observed = data.observed();
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
            observed,
            t,
        ));
    }
    for c in comparisons {
        let t = Instant::now();
        let spec = Specification::with_links(grader.scenario, &c.links);
        let (p, est) = match Problem::from_spec(&spec, filters) {
            Ok(p) => {
                let est = ident::identify_weak(&p, c.own.as_ref().unwrap_or(data));
                (p, est)
            }
            // The row says why (a symmetry of the comparison model); its problem, built
            // without that check, only lays out the row.
            Err(e) => (Problem::from_spec_unchecked(&spec, filters)?, Err(e)),
        };
        let observed = c.own.as_ref().map_or(observed, |d| d.observed());
        reports.push(method_report(
            ReportMethod::Compare(c.name.clone()),
            None,
            est,
            grader,
            &p,
            observed,
            t,
        ));
    }
    Ok(reports)
}

/// One model of `[identify.compare]` before pass 1: its problem over the placeholder
/// filters, and its own moments when its atoms differ from the identified structure's
/// (their moments are other variables' moments); otherwise it reads the shared data.
struct Comparison {
    name: String,
    links: Vec<crate::scenario::IdentifyLink>,
    problem: Result<Problem, IdentError>,
    own: Option<StationaryData>,
}

impl Comparison {
    fn new(
        name: &str,
        links: &[crate::scenario::IdentifyLink],
        s: &Scenario,
        placeholder: &[Filter],
        structure: &Problem,
        batches: usize,
    ) -> Comparison {
        let problem = Problem::from_spec(&Specification::with_links(s, links), placeholder);
        let own = match &problem {
            // With a profile the shared moments are replaced by the chosen position's.
            Ok(p) if p.atoms != structure.atoms || s.identify.profile.is_some() => Some(StationaryData::new(
                p,
                weak::moment_degree(p),
                s.simulation.record_length,
                s.simulation.trajectories,
                batches,
            )),
            _ => None,
        };
        Comparison {
            name: name.to_string(),
            links: links.to_vec(),
            problem,
            own,
        }
    }
}

//! The report of an identification put together from what its stages produced: the run's
//! facts (scenario, records, sampling, scheme), the method rows, the validation and
//! whether it passed.

use super::grading::Grader;
use super::source::Input;
use crate::report::{
    FilterReport, IterationReport, MethodReport, PlotData, Provenance, Records, Report, Timings, Validation,
};
use std::time::Instant;

/// The report of an identification of `input`; passed when there is a gated method and
/// every gated method passed.
#[allow(clippy::too_many_arguments)]
pub(crate) fn assemble(
    input: &Input,
    grader: &Grader,
    samples: u64,
    start: Instant,
    filters: Vec<FilterReport>,
    methods: Vec<MethodReport>,
    validation: Option<Validation>,
    iterations: Vec<IterationReport>,
    plot: PlotData,
) -> Report {
    let info = &input.info;
    let s = &info.scenario;
    let sim = &s.simulation;
    let applicable = || {
        methods
            .iter()
            .filter(|r| r.gated && r.outcome.not_applicable().is_none())
    };
    let passed = match applicable().next() {
        Some(_) => applicable().all(|r| r.passed == Some(true)),
        // Nothing graded (measured data without a truth, or a hysteretic truth that no
        // one-argument model has): every method gave an estimate.
        None => {
            (input.measured().is_some() || s.links.iter().any(|l| l.hysteresis.is_some()))
                && methods.iter().all(|r| r.outcome.error().is_none())
        }
    };
    let identify_s = start.elapsed().as_secs_f64();
    let records = input.measured().map(|m| {
        let lengths: Vec<f64> = m.lengths.iter().map(|&n| n as f64 * m.sample_interval).collect();
        Records {
            count: lengths.len(),
            total_s: lengths.iter().sum(),
            shortest_s: lengths.iter().copied().fold(f64::INFINITY, f64::min),
            longest_s: lengths.iter().copied().fold(0.0, f64::max),
        }
    });
    Report {
        provenance: Provenance::of_scenario(&s.source),
        scenario: s.name.clone(),
        log: info.path.display().to_string(),
        record_length_s: sim.record_length,
        total_record_s: records
            .as_ref()
            .map_or(sim.record_length * sim.trajectories as f64, |r| r.total_s),
        samples,
        expected_samples: input.expected_samples(),
        sample_interval_s: sim.sample_interval,
        trajectories: sim.trajectories,
        seed: sim.seed,
        // Lab excitations are integrated by their own scheme (sim::lab), whatever `scheme` says.
        scheme: if s
            .excitations
            .iter()
            .any(|e| matches!(e.process, crate::scenario::Process::Lab(_)))
        {
            "runge-kutta (lab excitations)".to_string()
        } else {
            sim.scheme.name().to_string()
        },
        dt_s: sim.dt,
        timings_s: Timings {
            simulate: 0.0,
            identify: identify_s,
            total: identify_s,
            stages: Vec::new(),
        },
        data_notes: input
            .measured()
            .map(|m| m.notes.clone())
            .unwrap_or_default()
            .into_iter()
            .chain(super::units::units(input).note)
            .collect(),
        records,
        filters,
        white_levels: Vec::new(),
        force_models: input.force_models.clone(),
        sensor_noise: None,
        selection: None,
        profile: None,
        methods,
        validation,
        prediction: None,
        integrator_bias: None,
        figures: true,
        iterations,
        passed,
        failed_checks: Vec::new(),
        plot,
        scenario_def: Some(s.clone()),
        truth: grader.truth.clone(),
    }
}

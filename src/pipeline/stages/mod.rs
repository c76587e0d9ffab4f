//! Identification as named stages over one [`Identification`] state (docs/architecture.md,
//! "Stages and passes"). Each stage is a file with one `run` that reads what earlier
//! stages left in the state and writes its own part; [`ORDINARY`] lists them in order, and
//! [`identify`] runs them, timing each (`report.json`'s `timings_s.stages`, `--verbose`).
//!
//! | stage | reads | writes |
//! |---|---|---|
//! | plan ([`plan`]) | the scenario, the options | the specification, the structure, every first-pass accumulator |
//! | first pass ([`first_pass`]) | the samples | moments, ranges, noise floor, the forces' lag sums, the profile's moments, the Fisher information of a settled structure |
//! | profile ([`profile`]) | the profile's moments | the chosen position's specification and moments |
//! | sensor correction ([`sensors`]) | the noise floor, the moments | corrected moments, the sensor-noise report |
//! | selection ([`selection`]) | the candidate model's moments | the selected specification |
//! | second pass ([`second_pass`]) | the samples (unless nothing in it reads them) | every estimator's accumulators, the Fisher information of a profiled or selected structure, distributions, force spectra |
//! | excitation fit ([`excitation`]) | the force spectra | the filters, the complete problem |
//! | later passes ([`later_passes`]) | the samples, the filters | the accumulators that need the filters |
//! | rows and grading ([`rows`]) | every accumulator | one report row per method and comparison |
//! | validation ([`validation`]) | the first FPK estimate, the distributions | the validation table |
//! | prediction ([`prediction`]) | every estimate, the held-out records (`--predict`) | the free-run simulation errors |
//! | verdict ([`verdict`]) | the rows, the validation | the failed checks of the method's premises |
//! | report ([`Identification::into_report`]) | everything | the [`Report`] |
//!
//! A new computation over the samples is one type implementing
//! [`Accumulator`](crate::ident::accumulate::Accumulator) added to a pass's list in the
//! stage that needs it; a new step is a file here and one line of [`ORDINARY`].

mod excitation;
mod first_pass;
mod later_passes;
mod plan;
mod prediction;
mod profile;
mod rows;
mod second_pass;
mod selection;
mod sensors;
mod validation;
mod verdict;

pub(crate) use excitation::REJECT;
pub(crate) use plan::{structure_of, Comparison};

use super::assemble::assemble;
use super::grading::Grader;
use super::source::Input;
use super::spectra::ForceSpectra;
use super::validation::Distributions;
use super::{Options, PipelineError};
use crate::estimators::{Estimator, Method};
use crate::ident::data::StationaryData;
use crate::ident::fisher::FisherInformation;
use crate::ident::moments::RawMoments;
use crate::ident::noise::NoiseFloor;
use crate::ident::select::Selection;
use crate::ident::{Filter, Problem, Specification};
use crate::report::{FilterReport, MethodReport, ProfileReport, Report, SensorNoiseReport, StageTime, Validation};
use crate::scenario::{ReportMethod, Select};
use std::time::Instant;

/// A stage: what it reads and writes is in its module's doc.
pub(crate) type Stage = for<'a> fn(&mut Identification<'a>) -> Result<(), PipelineError>;

/// The ordinary path's stages after [`plan`], in order.
pub(crate) const ORDINARY: &[(&str, Stage)] = &[
    ("first pass", first_pass::run),
    ("profile", profile::run),
    ("sensor correction", sensors::run),
    ("selection", selection::run),
    ("second pass", second_pass::run),
    ("excitation fit", excitation::run),
    ("later passes", later_passes::run),
    ("rows and grading", rows::run),
    ("validation", validation::run),
    ("prediction", prediction::run),
    ("verdict", verdict::run),
];

/// The fitted excitation: the filters the identifier uses, their reports and what the
/// spectra figure draws, and the problem complete with them.
pub(crate) struct Fitted {
    pub filters: Vec<Filter>,
    pub reports: Vec<FilterReport>,
    pub spectra: Vec<(
        String,
        crate::ident::spectrum::Spectrum,
        crate::ident::spectrum::OuFit,
        (f64, f64),
    )>,
    /// The forces read as their equivalent white noise, at their measured level `σ`.
    pub levels: Vec<(usize, f64)>,
    /// Their levels in each jackknife replicate (`excitation::jackknife_levels`).
    pub level_replicates: Vec<(usize, Vec<f64>)>,
    pub white_reports: Vec<crate::report::WhiteLevelReport>,
    /// The problem with the fitted (or known) filters and the measured levels.
    pub problem: Problem,
    /// Typical magnitudes of its unknowns (the least squares' column scaling).
    pub typical: Vec<f64>,
    /// Why the data reject a fitted force model ([`excitation::REJECT`]), if they do.
    pub rejected: Option<String>,
}

/// The structure selection's outcome: the selection, the baseline's (STLSQ's) model and
/// the seconds it took.
pub(crate) struct Selected {
    pub selection: Selection,
    pub baseline: Specification,
    pub seconds: f64,
}

/// One identification's state, from the plan to the report.
pub(crate) struct Identification<'a> {
    pub input: &'a Input,
    pub options: &'a Options,
    pub grader: Grader<'a>,
    /// The methods to run (the options', else the scenario's).
    pub methods: Vec<Method>,
    /// The measured filtered excitations at placeholder `A`, `B`.
    pub placeholder: Vec<Filter>,
    /// The structure selection asked for.
    pub select: Option<Select>,
    /// What is identified: the scenario's unknowns, a selection's candidate model, then the
    /// chosen profile position's or the selected model.
    pub spec: Specification,
    /// `spec`'s problem over the placeholder filters.
    pub structure: Problem,
    /// The exact symmetry of the force model, where the methods that read the measured
    /// force go on without it (`plan::structure_of`): every other method is refused with it.
    pub symmetric: Option<crate::ident::IdentError>,
    /// With filtered forces: the problem with each taken as white.
    pub naive_structure: Option<Problem>,
    /// The `[identify.compare]` models.
    pub comparisons: Vec<Comparison>,
    /// With a selection: the declared model's own moments, where its atoms differ from the
    /// candidate model's (else it reads `data`).
    pub declared_own: Option<StationaryData>,
    /// The profiled term's candidate positions, until the profile stage chooses one.
    pub profile_candidates: Option<super::profile::Candidates>,
    /// The first pass's moments per batch and link ranges (the weak form's data).
    pub data: StationaryData,
    /// The naive white-noise row's moments (simulated filtered forces only).
    pub naive_data: Option<StationaryData>,
    /// The measured filtered forces' spectra.
    pub forces: ForceSpectra,
    /// The checks of measured samples for a rig's faults (first pass).
    pub sample_checks: Vec<Box<dyn super::sample_checks::SampleCheck>>,
    /// The sensor-noise estimator, where the samples may carry noise.
    pub floor: Option<NoiseFloor>,
    pub profiled: Option<ProfileReport>,
    pub sensor_noise: Option<SensorNoiseReport>,
    /// The noise variance taken out of each log column.
    pub taken_out: Vec<f64>,
    /// What was taken out of the first pass's moments, for the estimators with their own.
    pub deconvolution: Option<crate::ident::data::Deconvolution>,
    pub selected: Option<Selected>,
    /// The first pass's moments over all samples (after corrections).
    pub total: Option<RawMoments>,
    pub estimators: Vec<(Method, Box<dyn Estimator>)>,
    pub dist: Option<Distributions>,
    /// Whether the plan's structure is the one identified (no profile or selection stage
    /// replaces it): the Fisher information is then gathered in the first pass.
    pub settled: bool,
    /// The Fisher information, where its bound applies (`second_pass::fisher`).
    pub fisher: Option<FisherInformation>,
    /// The masses the measured forces imply (measured data, every force measured).
    pub force_scale: Option<super::force_scale::ForceScale>,
    pub fitted: Option<Fitted>,
    /// One row per method and comparison.
    pub rows: Vec<MethodReport>,
    /// The first FPK estimate that succeeded, which the validation re-simulates.
    pub first: Option<(Vec<f64>, ReportMethod)>,
    /// Every method's estimate that succeeded (the prediction drives each).
    pub estimates: Vec<(ReportMethod, Vec<f64>)>,
    /// The problem the rows are about (the physical one of a bilinear problem).
    pub reported: Option<Problem>,
    pub validation: Option<Validation>,
    pub prediction: Option<crate::report::PredictionReport>,
    /// The checks of the method's premises that failed.
    pub failed_checks: Vec<crate::report::FailedCheck>,
}

impl Identification<'_> {
    /// The fitted excitation (set by the excitation-fit stage).
    pub(crate) fn fitted(&self) -> &Fitted {
        self.fitted.as_ref().expect("the excitation fit runs before")
    }

    /// The report of everything the stages left.
    fn into_report(self, start: Instant) -> Report {
        let Identification {
            input,
            options,
            grader,
            data,
            fitted,
            dist,
            rows,
            validation,
            prediction,
            sensor_noise,
            profiled,
            selected,
            failed_checks,
            ..
        } = self;
        let (filter_reports, white_levels, spectra) = fitted
            .map(|f| (f.reports, f.white_reports, f.spectra))
            .unwrap_or_default();
        let plot = dist
            .expect("the second pass makes the distributions")
            .into_plot(spectra);
        let mut report = assemble(
            input,
            &grader,
            data.samples(),
            start,
            filter_reports,
            rows,
            validation,
            Vec::new(),
            plot,
        );
        if let Some(n) = &sensor_noise {
            super::sensors::warn_uncorrected(n, &mut report.methods);
        }
        report.figures = options.plots;
        report.white_levels = white_levels;
        report.prediction = prediction;
        report.sensor_noise = sensor_noise;
        report.profile = profiled;
        report.passed &= failed_checks.is_empty();
        report.failed_checks = failed_checks;
        if let Some(Selected { selection, seconds, .. }) = selected {
            let names: Vec<String> = selection.selected_names().iter().map(|n| n.to_string()).collect();
            for m in &mut report.methods {
                if !matches!(m.method, ReportMethod::WeakWhiteNaive | ReportMethod::Compare(_)) {
                    m.selected = Some(names.clone());
                }
            }
            report.selection = Some(crate::report::SelectionReport { selection, seconds });
        }
        report
    }
}

/// Stage timers: each lap notes the time since the last under a stage's name.
pub(crate) struct Clock {
    pub timings: Vec<StageTime>,
    last: Instant,
}

impl Clock {
    pub(crate) fn start() -> Clock {
        Clock {
            timings: Vec::new(),
            last: Instant::now(),
        }
    }

    /// The stage `name` ended now.
    pub(crate) fn lap(&mut self, name: &str) {
        let now = Instant::now();
        self.timings.push(StageTime {
            stage: name.to_string(),
            s: (now - self.last).as_secs_f64(),
        });
        self.last = now;
    }
}

/// The ordinary identification of `input`: [`plan`], then every stage of [`ORDINARY`],
/// then the report.
pub(crate) fn identify(input: &Input, options: &Options, start: Instant) -> Result<Report, PipelineError> {
    let mut clock = Clock::start();
    let mut id = plan::run(input, options)?;
    clock.lap("plan");
    for &(name, stage) in ORDINARY {
        stage(&mut id)?;
        clock.lap(name);
    }
    let mut report = id.into_report(start);
    clock.lap("report");
    report.timings_s.stages = clock.timings;
    Ok(report)
}

//! The bench's pipeline: a scenario simulated into a complete log ([`simulate_log`]), and a
//! log identified with the requested methods and graded against the truth it carries
//! ([`identify_log`]). See `docs/methods.md` for what a run reports.
//!
//! Streaming passes over the samples, constant memory: pass 1 accumulates raw moments per
//! time batch and the links' observed ranges (the weak form's data, and what every other
//! estimator is built from); pass 2 hands every sample to each requested estimator's
//! accumulators (`estimators`), to the force spectra and to the histograms behind the
//! plots; a third pass runs only for estimators whose accumulators depend on fitted
//! filters. The numerics live in `ident` and `sim`; this module only wires them to the
//! samples and to the report types.

mod assemble;
pub mod bias;
mod disturbed;
mod force_choice;
mod force_scale;
mod grading;
mod identify;
mod pass;
mod profile;
mod sample_checks;
mod sensors;
mod source;
mod spectra;
mod stages;
pub mod study;
mod units;
mod validation;

pub use bias::{integrator_bias, BIAS_SHARE};
pub use identify::{check_measured, preflight};
pub use sensors::CLIPPED;
pub use source::{Input, LogFile, SampleSource, Simulation, Tables};
pub use validation::identified_model;

use self::identify::identify_info;
use crate::estimators::Method;
pub use crate::estimators::{GridSettings, Settings, StrongDensity};
use crate::ident::{Arenas, IdentError};
use crate::io::log::{read_info, Compression, LogError, LogWriter};
use crate::model::Model;
use crate::report::Report;
use crate::scenario::Scenario;
use crate::sim::{simulate, SimError};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// Errors of the bench pipeline.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    #[error(transparent)]
    Log(#[from] LogError),
    #[error(transparent)]
    Ident(#[from] IdentError),
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The log's truth record names a parameter that does not exist.
    #[error("the log's truth record (`fpkbench.truth`): {0}")]
    Truth(String),
    /// A study item's scenario is not valid.
    #[error("{0}")]
    Study(String),
    /// Measured data that could not be read again.
    #[error(transparent)]
    Data(#[from] crate::io::table::DataError),
    /// A stop was requested (`crate::interrupt`).
    #[error(transparent)]
    Interrupted(#[from] crate::interrupt::Interrupted),
    /// The identification would need more memory than it may take ([`memory_budget`]).
    #[error("{0}")]
    Memory(String),
}

/// The memory an identification may plan for: `FPKBENCH_MEMORY_BUDGET` (bytes) where set,
/// else half the machine's (`MemTotal` of /proc/meminfo), else 8 GiB.
pub fn memory_budget() -> u64 {
    if let Some(b) = std::env::var("FPKBENCH_MEMORY_BUDGET")
        .ok()
        .and_then(|v| v.trim().parse().ok())
    {
        return b;
    }
    let total_kib = std::fs::read_to_string("/proc/meminfo").ok().and_then(|m| {
        m.lines()
            .find(|l| l.starts_with("MemTotal:"))
            .and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
    });
    total_kib.map_or(8 << 30, |k| k * 1024 / 2)
}

/// Settings of an identification.
#[derive(Debug, Clone)]
pub struct Options {
    /// Methods to run; empty: the scenario's `[identify] methods`.
    pub methods: Vec<Method>,
    /// The estimators' settings: how `strong` estimates the density (kernel estimates of
    /// the density and its fluxes by default, or the paper's histogram), the kernel's width,
    /// the histogram grid; what is not set follows from the problem's own state.
    pub estimators: Settings,
    /// Batches (groups of the fine trajectory-group × time batches) for the jackknife's
    /// standard errors and the identifiability spread.
    pub batches: usize,
    /// Re-simulate the identified model for the validation table.
    pub validate: bool,
    /// Gather what the plots draw (histograms, response spectra); a study, which plots
    /// none of it, skips that work.
    pub plots: bool,
    /// Override `[identify.disturbance] max_steps` of the iterative procedure.
    pub max_steps: Option<usize>,
    /// Override `[identify.disturbance] tolerance` of the iterative procedure.
    pub tolerance: Option<f64>,
    /// `--select`: choose the model's terms from candidates (docs/selection.md), over or
    /// instead of the scenario's `[identify.select]`; candidate lists given here replace
    /// the scenario's.
    pub select: Option<crate::scenario::Select>,
    /// Large tables kept from one identification for the next (a study passes every item
    /// the same).
    pub arenas: Arc<Arenas>,
    /// `--predict`: held-out records (mapped by the same model file) that every identified
    /// model is driven by, its response compared with theirs (stage "prediction").
    pub predict: Option<Arc<crate::io::table::Measured>>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            methods: Vec::new(),
            estimators: Settings::default(),
            batches: 32,
            validate: true,
            plots: true,
            max_steps: None,
            tolerance: None,
            select: None,
            arenas: Arc::default(),
            predict: None,
        }
    }
}

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
    /// Values the sensors' ADC clipped.
    pub clipped: u64,
}

/// The bench's first half: simulate `scenario` into a log at `path` (written to a
/// temporary name and renamed only when complete), calling `progress` with the samples
/// written so far.
pub fn simulate_log(
    scenario: &Scenario,
    path: &Path,
    compression: Compression,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Simulated, PipelineError> {
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
        clipped: stats.clipped,
    })
}

/// Identify the log at `path`.
pub fn identify_log(path: &Path, options: &Options) -> Result<Report, PipelineError> {
    identify(&Input::log(read_info(path)?), options)
}

/// Identify the samples of `input`: a log (described by [`read_info`]; set
/// [`LogInfo::accept_truncated`](crate::io::log::LogInfo::accept_truncated) to use what
/// a truncated log still holds), measured tables, or a simulation in memory.
pub fn identify(input: &Input, options: &Options) -> Result<Report, PipelineError> {
    let start = Instant::now();
    let sensors = sensors::rig::through_sensors(input)?;
    let input = sensors.as_ref().unwrap_or(input);
    let chosen = force_choice::choose(input)?;
    identify_info(chosen.as_ref().unwrap_or(input), options, start)
}

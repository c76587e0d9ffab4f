//! The bench's pipeline: a scenario simulated into a complete log ([`simulate_log`]), and a
//! log identified with the requested methods and graded against the truth it carries
//! ([`identify_log`]). See `docs/methods.md` for what a run reports.
//!
//! Two streaming passes over the log, constant memory: pass 1 accumulates raw moments per
//! time batch and the links' observed ranges (weak form); pass 2 fills the density grid
//! (strong forms) and the histograms behind the plots. The numerics live in `ident` and
//! `sim`; this module only wires them to the log and to the report types.

mod disturbed;
mod grading;
mod identify;
mod spectra;
pub mod study;
mod validation;

pub use identify::{check_measured, preflight};
pub use validation::identified_model;

use self::identify::identify_info;
use crate::ident::kernel::KernelOptions;
use crate::ident::strong::GridOptions;
use crate::ident::IdentError;
use crate::io::log::{read_info, Compression, LogError, LogInfo, LogWriter};
use crate::model::Model;
use crate::report::Report;
use crate::scenario::{Method, Scenario};
use crate::sim::{simulate, SimError};
use std::path::{Path, PathBuf};
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
}

/// The strong form's density estimate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StrongDensity {
    /// Gaussian kernel estimates of the density and of every probability flux
    /// (`ident::kernel`, docs/methods.md).
    #[default]
    Kernel,
    /// The paper's procedure as written: a histogram and central differences
    /// (`ident::strong`).
    Histogram,
}

/// Settings of an identification.
#[derive(Debug, Clone)]
pub struct Options {
    /// Methods to run; empty: the scenario's `[identify] methods`.
    pub methods: Vec<Method>,
    /// How `strong` estimates the density: kernel estimates of the density and its
    /// fluxes (default) or the paper's histogram (`--density histogram`).
    pub density: StrongDensity,
    /// Strong form's kernel; `None`: automatic.
    pub kernel: Option<KernelOptions>,
    /// Strong-form histogram grid (`--density histogram`, `strong-marginals`); `None`:
    /// automatic.
    pub grid: Option<GridOptions>,
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
}

impl Default for Options {
    fn default() -> Self {
        Options {
            methods: Vec::new(),
            density: StrongDensity::Kernel,
            kernel: None,
            grid: None,
            batches: 32,
            validate: true,
            plots: true,
            max_steps: None,
            tolerance: None,
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
    })
}

/// Identify the log at `path`.
pub fn identify_log(path: &Path, options: &Options) -> Result<Report, PipelineError> {
    identify(&read_info(path)?, options)
}

/// Identify the log `info` describes (read with [`read_info`]; set
/// [`LogInfo::accept_truncated`] to use what a truncated log still holds).
pub fn identify(info: &LogInfo, options: &Options) -> Result<Report, PipelineError> {
    identify_info(info, options, Instant::now())
}

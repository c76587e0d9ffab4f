//! Where an identification's samples come from: a log file, measured tables, or a
//! simulation run in memory. Each is a [`SampleSource`]; an [`Input`] pairs one with the
//! description of what it holds (scenario, columns, truth). Every pass of the
//! identification reads the source again, and a source hands over the same samples in
//! the same order each time. `io` only reads files; the in-memory simulation lives here.

use super::PipelineError;
use crate::ident::Arenas;
use crate::io::log::{read_samples, LogInfo};
use crate::io::table::Measured;
use crate::scenario::Scenario;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};

/// A stream of stationary samples, read as often as the identification needs.
pub trait SampleSource: Send + Sync {
    /// Call `f(trajectory, t, row)` for every sample, in the source's order; the number of
    /// samples. `row` holds the description's columns.
    fn for_each_sample(&self, info: &LogInfo, f: &mut dyn FnMut(u32, f64, &[f64])) -> Result<u64, PipelineError>;

    /// The measured tables behind the samples, if they are measured data.
    fn measured(&self) -> Option<&Measured> {
        None
    }

    /// Whether the samples are a log file's, read from it on every pass.
    fn is_log_file(&self) -> bool {
        false
    }

    /// How many samples the source holds, or was to hold (a log: what its run promised).
    fn expected_samples(&self, info: &LogInfo) -> u64 {
        let s = &info.scenario.simulation;
        (s.trajectories as u64).saturating_mul(s.samples_per_trajectory() as u64)
    }

    /// No pass after the next is expected to read the samples: a source that keeps them
    /// for later passes (a simulation in memory) keeps none in its next read. A pass may
    /// still come; the source then makes its samples anew.
    fn no_later_pass(&self) {}
}

/// A log file's samples (`io::log::read_samples`: damage found, a truncated log refused
/// unless [`LogInfo::accept_truncated`]).
pub struct LogFile;

impl SampleSource for LogFile {
    fn for_each_sample(&self, info: &LogInfo, f: &mut dyn FnMut(u32, f64, &[f64])) -> Result<u64, PipelineError> {
        Ok(read_samples(info, f)?)
    }

    fn is_log_file(&self) -> bool {
        true
    }
}

/// Measured tables, each record an independent trajectory, read again on every pass.
pub struct Tables(pub Arc<Measured>);

impl SampleSource for Tables {
    fn for_each_sample(&self, _: &LogInfo, f: &mut dyn FnMut(u32, f64, &[f64])) -> Result<u64, PipelineError> {
        Ok(self.0.for_each_sample(f)?)
    }

    fn measured(&self) -> Option<&Measured> {
        Some(&self.0)
    }

    fn expected_samples(&self, _: &LogInfo) -> u64 {
        self.0.samples()
    }
}

/// The run of a scenario that is not written anywhere: the first pass keeps the samples
/// in memory when they fit in [`Simulation::BUDGET`] and later passes replay them;
/// otherwise every pass runs the simulation again (deterministic by its seed, whatever
/// the thread count), so memory stays bounded either way. An identification whose later
/// passes read no samples (the weak form alone, no validation or figures) says so first
/// ([`SampleSource::no_later_pass`]), and nothing is kept.
pub struct Simulation {
    kept: OnceLock<Vec<f64>>,
    /// Whether the next read keeps the samples for later ones (unless told otherwise by
    /// [`SampleSource::no_later_pass`], which holds for that one read).
    keep: AtomicBool,
    /// How the simulator steps ([`crate::sim::Stepping::Refined`] for the half-step pair
    /// of an integrator-bias estimate).
    stepping: crate::sim::Stepping,
    /// Where the kept samples' buffer comes from and goes back to.
    arenas: Arc<Arenas>,
}

impl Simulation {
    /// Bytes of samples kept for replay, at most (`(2 + columns) × 8` bytes per sample: a
    /// 3.2e6-sample run of duffing2dof takes 282 MB). Above it, passes re-simulate.
    pub const BUDGET: u64 = 512 << 20;

    /// A simulation whose kept samples' buffer is taken from, and given back to,
    /// `arenas` (a study hands every item the same: touching fresh pages cost a tenth of
    /// an item's time).
    pub fn new(arenas: Arc<Arenas>) -> Simulation {
        Simulation {
            kept: OnceLock::new(),
            keep: AtomicBool::new(true),
            stepping: crate::sim::Stepping::Fastest,
            arenas,
        }
    }
}

impl Drop for Simulation {
    fn drop(&mut self) {
        if let Some(v) = self.kept.take() {
            self.arenas.samples.give(v);
        }
    }
}

impl SampleSource for Simulation {
    fn for_each_sample(&self, info: &LogInfo, f: &mut dyn FnMut(u32, f64, &[f64])) -> Result<u64, PipelineError> {
        let width = 2 + info.columns.len();
        if let Some(kept) = self.kept.get() {
            for s in kept.chunks_exact(width) {
                f(s[0] as u32, s[1], &s[2..]);
            }
            return Ok((kept.len() / width) as u64);
        }
        let bytes = self.expected_samples(info).saturating_mul(8 * width as u64);
        // The hint is for this read: a later identification of the same input keeps again.
        let keep = self.keep.swap(true, Ordering::Relaxed) && bytes <= Simulation::BUDGET;
        let mut kept = if keep {
            self.arenas.samples.empty(bytes as usize / 8)
        } else {
            Vec::new()
        };
        let model = crate::model::Model::new(&info.scenario);
        let mut n = 0u64;
        let mut sink = crate::sim::ForEach(|j: u32, t: f64, row: &[f64]| {
            n += 1;
            if keep {
                kept.push(j as f64);
                kept.push(t);
                crate::ident::accumulate::append_row(&mut kept, row);
            }
            f(j, t, row)
        });
        crate::sim::simulate_stepping(&model, &info.scenario.simulation, &mut sink, &|_| {}, self.stepping)?;
        if keep {
            let _ = self.kept.set(kept);
        }
        Ok(n)
    }

    fn no_later_pass(&self) {
        self.keep.store(false, Ordering::Relaxed);
    }
}

/// A source read with the description it was written with, whatever the input that holds
/// it says of the samples ([`Input::with_chosen_forces`]).
struct AsWritten {
    source: Arc<dyn SampleSource>,
    info: LogInfo,
}

impl SampleSource for AsWritten {
    fn for_each_sample(&self, _: &LogInfo, f: &mut dyn FnMut(u32, f64, &[f64])) -> Result<u64, PipelineError> {
        self.source.for_each_sample(&self.info, f)
    }

    fn measured(&self) -> Option<&Measured> {
        self.source.measured()
    }

    fn is_log_file(&self) -> bool {
        self.source.is_log_file()
    }

    fn expected_samples(&self, _: &LogInfo) -> u64 {
        self.source.expected_samples(&self.info)
    }

    fn no_later_pass(&self) {
        self.source.no_later_pass()
    }
}

/// What an identification reads: the description of the samples and their source.
pub struct Input {
    pub info: LogInfo,
    pub source: Arc<dyn SampleSource>,
    /// Samples handed over so far, over every pass (for a progress display).
    read: Arc<AtomicU64>,
    /// The forces whose model was chosen from their spectra before `info`'s scenario was
    /// completed with the choice (`pipeline::force_choice`).
    pub force_models: Vec<crate::report::ForceModelChoice>,
    /// The forces' processes as the samples were made with, where `force_models` rewrote
    /// them (`None`: the scenario's).
    pub logged: Option<Vec<crate::scenario::Process>>,
}

impl Input {
    /// How many samples pass between two looks at the interrupt flag and two updates of
    /// [`Input::samples_read`] ([`crate::interrupt::LOOK_EVERY`]).
    pub const LOOK_EVERY: usize = crate::interrupt::LOOK_EVERY;

    /// `source`'s samples, described by `info`.
    pub fn new(info: LogInfo, source: Box<dyn SampleSource>) -> Input {
        Input {
            info,
            source: Arc::from(source),
            read: Arc::default(),
            force_models: Vec::new(),
            logged: None,
        }
    }

    /// The same samples described by `scenario`, `info`'s with the measured forces' models
    /// `choices` chose (`super::force_choice`); the source still reads them as `info`
    /// describes them (a simulation runs the scenario as written).
    pub(crate) fn with_chosen_forces(
        &self,
        scenario: Scenario,
        choices: Vec<crate::report::ForceModelChoice>,
    ) -> Input {
        let source = AsWritten {
            source: self.source.clone(),
            info: self.info.clone(),
        };
        Input {
            info: LogInfo {
                scenario,
                ..self.info.clone()
            },
            source: Arc::new(source),
            read: self.read.clone(),
            force_models: choices,
            logged: Some(
                self.info
                    .scenario
                    .excitations
                    .iter()
                    .map(|x| x.process.clone())
                    .collect(),
            ),
        }
    }

    /// A log file described by `info` (`io::log::read_info`).
    pub fn log(info: LogInfo) -> Input {
        Input::new(info, Box::new(LogFile))
    }

    /// Measured data on a model file (`LogInfo::of_measured`).
    pub fn tables(model: Scenario, data: Measured) -> Input {
        let data = Arc::new(data);
        Input::new(LogInfo::of_measured(model, &data), Box::new(Tables(data)))
    }

    /// `scenario` simulated in memory, no log written.
    pub fn simulation(scenario: Scenario) -> Input {
        Input::simulation_in(scenario, Arc::default())
    }

    /// `scenario` simulated in memory at half its step on the same Brownian paths (twice
    /// its `substeps`, [`crate::sim::Stepping::Refined`]): the pair of an integrator-bias
    /// estimate ([`super::bias`]).
    pub fn refined_simulation(mut scenario: Scenario) -> Input {
        scenario.simulation.substeps *= 2;
        let mut source = Simulation::new(Arc::default());
        source.stepping = crate::sim::Stepping::Refined;
        Input::new(LogInfo::of_simulation(scenario), Box::new(source))
    }

    /// `scenario` simulated in memory, its kept samples' buffer from `arenas`.
    pub fn simulation_in(scenario: Scenario, arenas: Arc<Arenas>) -> Input {
        Input::new(LogInfo::of_simulation(scenario), Box::new(Simulation::new(arenas)))
    }

    /// Every sample, in the source's order; the number of samples. A stop requested
    /// meanwhile (`crate::interrupt`) ends the pass with `PipelineError::Interrupted`:
    /// from then on `f` is no longer called, and the source stops at its next look.
    pub fn for_each_sample(&self, mut f: impl FnMut(u32, f64, &[f64])) -> Result<u64, PipelineError> {
        crate::interrupt::check()?;
        let (mut n, mut stopped) = (0usize, false);
        let result = self.source.for_each_sample(&self.info, &mut |j, t, row| {
            n += 1;
            if n % Input::LOOK_EVERY == 0 {
                self.read.fetch_add(Input::LOOK_EVERY as u64, Ordering::Relaxed);
                stopped = crate::interrupt::requested();
            }
            if !stopped {
                f(j, t, row)
            }
        });
        self.read.fetch_add((n % Input::LOOK_EVERY) as u64, Ordering::Relaxed);
        crate::interrupt::check()?;
        result
    }

    /// Samples handed over so far, over every pass (updated every
    /// [`Input::LOOK_EVERY`] samples).
    pub fn samples_read(&self) -> u64 {
        self.read.load(Ordering::Relaxed)
    }

    /// The measured tables, if the samples are measured data.
    pub fn measured(&self) -> Option<&Measured> {
        self.source.measured()
    }

    /// How many samples the source holds, or was to hold.
    pub fn expected_samples(&self) -> u64 {
        self.source.expected_samples(&self.info)
    }

    /// No pass after the next is expected to read the samples
    /// ([`SampleSource::no_later_pass`]).
    pub fn no_later_pass(&self) {
        self.source.no_later_pass()
    }
}

//! Estimators as types. Each identification method is one type implementing [`Estimator`]:
//! what it accumulates from the samples (in the pipeline's second pass, or a third one
//! once the filters are fitted) and how it turns that into an [`Estimate`]. A method is
//! named once, in the registry of `method.rs` ([`Method`], its name, kind and terms); the
//! constructor of its estimator ([`Method::estimator`]) is made here from the same list.
//!
//! Adding a method is one file here and one line of the registry (docs/architecture.md).
//! The numerics stay in `ident`; an estimator only holds accumulators and calls them.

mod force_regression;
mod increments;
mod kramers_moyal;
mod local_linear;
mod marginals;
mod strong;
mod weak;
mod weak_measured_force;

pub(crate) use force_regression::regression as force_regression;

use crate::ident::accumulate::{Accumulator, Sample};
use crate::ident::data::{Deconvolution, StationaryData};
use crate::ident::moments::RawMoments;
use crate::ident::strong_histogram::GridOptions;
use crate::ident::strong_kernel::KernelOptions;
use crate::ident::{Arenas, Estimate, IdentError, Problem};
pub use crate::method::{Kind, Method, Terms};
use crate::scenario::Scenario;
use std::sync::Arc;

/// How `strong` estimates the density.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StrongDensity {
    /// Gaussian kernel estimates of the density and of every probability flux
    /// (`ident::strong_kernel`, docs/methods.md).
    #[default]
    Kernel,
    /// The paper's procedure as written: a histogram and central differences
    /// (`ident::strong_histogram`).
    Histogram,
}

/// A strong form's histogram grid as the user set it: what is not given is chosen from
/// the problem's own state dimension and sample count ([`GridOptions::auto`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GridSettings {
    /// Bins per dimension.
    pub bins: Option<usize>,
    /// Half-width of the grid box in standard deviations.
    pub span_std: Option<f64>,
    /// Smallest count of every cell in a difference stencil.
    pub min_count: Option<u32>,
}

impl GridSettings {
    /// Whether anything is set.
    pub fn is_set(&self) -> bool {
        self.bins.is_some() || self.span_std.is_some() || self.min_count.is_some()
    }

    /// The grid for a `dim`-dimensional state of `samples` samples.
    pub fn resolve(&self, dim: usize, samples: u64) -> GridOptions {
        let auto = GridOptions::auto(dim, samples);
        GridOptions {
            bins: self.bins.unwrap_or(auto.bins),
            span_std: self.span_std.unwrap_or(auto.span_std),
            min_count: self.min_count.unwrap_or(auto.min_count),
        }
    }
}

/// The estimators' settings (the CLI's and the Python binding's overrides; `None` and
/// unset fields: automatic, from the problem's own dimension).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Settings {
    /// How `strong` estimates the density.
    pub density: StrongDensity,
    /// The kernel's width in standard deviations of each state variable (`strong`, kernel).
    pub smoothing: Option<f64>,
    /// The histogram grid (`strong` with the histogram, `strong-marginals`).
    pub grid: GridSettings,
}

impl Settings {
    /// The kernel options for a `dim`-dimensional state of `samples` samples.
    pub fn kernel(&self, dim: usize, samples: u64) -> KernelOptions {
        let auto = KernelOptions::auto(dim, samples);
        KernelOptions {
            smoothing: self.smoothing.unwrap_or(auto.smoothing),
            ..auto
        }
    }
}

/// What an estimator is built from, after the first pass over the samples.
pub struct Setup<'a> {
    pub scenario: &'a Scenario,
    /// The problem's structure (state, columns, unknowns); a measured filtered force's
    /// `A`, `B` are placeholders until the spectral fit.
    pub structure: &'a Problem,
    /// With filtered forces: the mechanical problem with each taken as white (the state
    /// without the filters'); `None` without.
    pub whitened: Option<&'a Problem>,
    /// The first pass: moments per batch and the links' observed ranges.
    pub data: &'a StationaryData,
    /// The first pass's moments over all samples.
    pub total: &'a RawMoments,
    pub settings: &'a Settings,
    /// The tables kept between identifications, for the accumulators that take them.
    pub arenas: &'a Arc<Arenas>,
    /// Measured data: per log column, whether the samples hold it (mapped or derived);
    /// `None` for an fpkbench log, which holds a white force as its mean over the sample
    /// interval where measured data hold values at the sample instants.
    pub measured: Option<&'a [bool]>,
    /// What was taken out of the first pass's moments (sensor noise, less a filter's loss
    /// put back): for an estimator with moments of its own.
    pub deconvolution: Option<&'a Deconvolution>,
    /// The forces' processes as the samples were made with, where the identifier chose a
    /// force's model from its spectrum (`pipeline::force_choice`): an fpkbench log holds a
    /// white force as its interval mean and a lab signal at the instants, whatever model
    /// the identification reads them with. `None`: the scenario's.
    pub logged: Option<&'a [crate::scenario::Process]>,
}

impl Setup<'_> {
    /// The sample interval (s).
    pub fn sample_interval(&self) -> f64 {
        self.scenario.simulation.sample_interval
    }

    /// The mean and standard deviation of each of `dim` state variables over all samples.
    pub fn mean_std(&self, dim: usize) -> (Vec<f64>, Vec<f64>) {
        (
            (0..dim).map(|j| self.total.mean(j)).collect(),
            (0..dim).map(|j| self.total.std(j)).collect(),
        )
    }
}

/// What every estimator is handed to estimate, after its accumulation.
pub struct Context<'a> {
    /// The problem with the fitted (or known) filters.
    pub problem: &'a Problem,
    /// The first pass: moments per batch (the weak form's data).
    pub data: &'a StationaryData,
    /// Typical magnitudes of the unknowns (the least squares' column scaling).
    pub typical: &'a [f64],
    /// Whether an unknown filter corner makes the drift bilinear.
    pub bilinear: bool,
    /// Forces read as white at a level measured from their spectrum: per force, its noise
    /// source in `problem.white` and its level in each jackknife replicate of `data` (the
    /// level without that replicate's records), for the weak form's replicates to read the
    /// force as they read the moments. Empty: the level is held.
    pub level_replicates: &'a [(usize, Vec<f64>)],
}

/// One identification method: an [`Accumulator`] filled from the samples of the second
/// pass (and of a later one, where it asks), then an estimate.
pub trait Estimator: Accumulator {
    /// The filters are fitted and `problem` is complete; `true` asks for the samples once
    /// more (`push`, then `finish`), as an accumulator that depends on the filters needs.
    fn needs_pass(&mut self, _problem: &Problem, _setup: &Setup) -> bool {
        false
    }
    /// The estimate from what was accumulated.
    fn estimate(&self, cx: &Context) -> Result<Estimate, IdentError>;
}

/// An estimator that cannot be built: its method's row reports why.
pub(crate) fn refused(e: IdentError) -> Box<dyn Estimator> {
    struct Refused(IdentError);
    impl Accumulator for Refused {
        fn push(&mut self, _: &Sample) {}
        fn reads_samples(&self) -> bool {
            false
        }
    }
    impl Estimator for Refused {
        fn estimate(&self, _: &Context) -> Result<Estimate, IdentError> {
            Err(self.0.clone())
        }
    }
    Box::new(Refused(e))
}

/// The constructor part of the registry (`method.rs`): each method's estimator, made by
/// the `build` of the module its registry line names.
macro_rules! constructors {
    ($( $(#[doc = $doc:literal])+ $variant:ident = $name:literal, $kind:ident, $terms:ident, $module:ident; )+) => {
        impl Method {
            /// Its estimator, ready for the second pass (one that reports why not where
            /// the problem has terms it does not take).
            pub fn estimator(self, setup: &Setup) -> Box<dyn Estimator> {
                let atoms = &setup.structure.atoms;
                if self.terms() == Terms::Polynomial && !atoms.is_empty() {
                    let names: Vec<String> = atoms
                        .iter()
                        .filter(|a| !a.slope)
                        .map(|a| {
                            let c = crate::model::Coefficient { link: a.link, kind: a.kind, term: a.term };
                            setup.structure.model.coefficient_name(c).to_string()
                        })
                        .collect();
                    return refused(IdentError::NotApplicable(format!(
                        "{} evaluates the characteristics as polynomials, and {} multiply terms without a \
                         polynomial form; the weak and strong forms and the increment and force regressions take them",
                        self.name(),
                        names.join(", ")
                    )));
                }
                match self { $(Method::$variant => $module::build(setup),)+ }
            }
        }
    };
}

crate::method::registry!(constructors);

#[cfg(test)]
mod tests {
    use super::*;

    /// On a problem with terms entered as atoms (the way of a term without a polynomial
    /// form), the weak and strong forms estimate and every method that evaluates
    /// polynomials reports not-applicable, naming the terms.
    #[test]
    fn methods_that_take_polynomials_only_step_aside_for_other_terms() {
        use crate::ident::{weak, Specification};
        use crate::sim::{simulate, Collect};
        let path = format!("{}/scenarios/sdof_duffing.toml", env!("CARGO_MANIFEST_DIR"));
        let mut s = Scenario::parse(&std::fs::read_to_string(&path).unwrap(), &path, "t").unwrap();
        s.simulation.record_length = 1000.0;
        s.simulation.trajectories = 16;
        let mut samples = Collect::default();
        simulate(&crate::Model::new(&s), &s.simulation, &mut samples, &|_| {}).unwrap();
        let problem = Problem::with_terms_as_atoms(&Specification::from_scenario(&s), &[], &[0]).unwrap();
        let mut data = StationaryData::new(&problem, weak::moment_degree(&problem), 1000.0, 16, 8);
        for b in &samples.batches {
            b.for_each_sample(|j, t, row| data.push(j, t, row));
        }
        data.finish();
        let total = data.total();
        let (settings, arenas) = (Settings::default(), Arc::new(Arenas::default()));
        let setup = Setup {
            scenario: &s,
            structure: &problem,
            whitened: None,
            data: &data,
            total: &total,
            settings: &settings,
            arenas: &arenas,
            measured: None,
            deconvolution: None,
            logged: None,
        };
        let typical = problem.typical(&total);
        let cx = Context {
            problem: &problem,
            data: &data,
            typical: &typical,
            bilinear: false,
            level_replicates: &[],
        };
        for &m in Method::REGISTERED {
            let mut estimator = m.estimator(&setup);
            for b in &samples.batches {
                b.for_each_sample(|trajectory, t, row| {
                    estimator.push(&Sample {
                        trajectory,
                        t,
                        batch: data.batch_of(trajectory, t),
                        row,
                    })
                });
            }
            estimator.finish();
            let result = estimator.estimate(&cx);
            match m.terms() {
                Terms::Any => {
                    assert!(result.is_ok(), "{m}: {result:?}");
                    // What the plan counts on to keep no samples for a later pass.
                    assert_eq!(estimator.reads_samples(), m.reads_samples(), "{m}");
                }
                Terms::Polynomial => match result {
                    Err(IdentError::NotApplicable(why)) => {
                        assert!(
                            why.contains("k3[ground-m1]") && why.contains("the weak and strong forms"),
                            "{m}: {why}"
                        )
                    }
                    other => panic!("{m}: {other:?}"),
                },
            }
        }
    }
}

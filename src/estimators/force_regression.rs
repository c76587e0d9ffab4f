//! Oracle bound, not FPK: the equation error of the equations of motion with the measured
//! excitation forces, information the FPK methods never use. It estimates the mechanical
//! problem (a filtered force is measured like a white one, so the filters' states are not
//! needed) and needs every force measured.

use super::{refused, Context, Estimator, Setup};
use crate::ident::accumulate::{Accumulator, Sample};
use crate::ident::baseline::{self, DriftRule, Increments};
use crate::ident::{Estimate, IdentError, Problem};
use crate::scenario::{Process, Scenario, Scheme};

/// The increment regression with the forces as known drift.
struct ForceRegression(Increments);

pub(super) fn build(setup: &Setup) -> Box<dyn Estimator> {
    let problem = match setup.whitened {
        Some(p) if p.unknowns != setup.structure.unknowns => {
            return refused(IdentError::NotApplicable(
                "the force regression estimates the mechanical coefficients only, and this problem has filter \
                 unknowns"
                    .into(),
            ))
        }
        Some(p) => p,
        None => setup.structure,
    };
    match regression(setup, problem) {
        Ok(r) => Box::new(ForceRegression(r)),
        Err(e) => refused(e),
    }
}

/// The force regression of `problem` (the mechanical one: a filtered force is measured
/// like a white one) on `setup`'s samples, or why it cannot run: a force not measured.
pub(crate) fn regression(setup: &Setup, problem: &Problem) -> Result<Increments, IdentError> {
    // fpkbench logs a white force as its mean over the sample interval, and so does a
    // table whose accelerations are interval means (its own export: the acceleration is
    // the force balance with that mean; docs/data.md); other measured data and filtered
    // forces hold values at the sample instants.
    let means = match setup.measured {
        None => true,
        Some(_) => (setup.scenario.data.as_ref())
            .is_some_and(|d| d.acceleration_samples == crate::scenario::AccelerationSamples::IntervalMeans),
    };
    let interval_means: Vec<bool> = setup
        .scenario
        .excitations
        .iter()
        .enumerate()
        .map(|(k, e)| means && matches!(setup.logged.map_or(&e.process, |l| &l[k]), Process::White { .. }))
        .collect();
    // A force declared white noise of a given level has no value at an instant (an
    // fpkbench log's is its mean over the interval, and its acceleration column the force
    // balance with that mean): such a record keeps the interval rule.
    let s = setup.scenario;
    let band_limited = (0..s.excitations.len()).all(|e| {
        !matches!(s.excitations[e].process, Process::White { .. }) || s.identify.equivalent_white.contains(&e)
    });
    let rule = match setup.measured {
        // Measured forces and accelerations at the same instants: the equation of motion
        // there, where no interval mean of a force is needed.
        Some(present) if band_limited && (0..problem.n).all(|i| present[problem.model.columns().a(i)]) => {
            DriftRule::Instant
        }
        Some(_) => DriftRule::GaussLegendre,
        None => own_step(setup.scenario),
    };
    baseline::applicable(problem, true)?;
    let columns = baseline::force_columns(problem, &interval_means)?;
    Ok(Increments::with_forces(
        problem,
        setup.sample_interval(),
        setup.data.batch_count(),
        columns,
        rule,
    ))
}

/// The Euler step's own rule where fpkbench's log of `scenario` holds every integration
/// step of white-forced states as the simulator took them (no sensors, no hysteretic state
/// the regression cannot see); else Gauss–Legendre over the interval.
fn own_step(scenario: &Scenario) -> DriftRule {
    let sim = &scenario.simulation;
    let sensors = &sim.sensors;
    let every_step = sim.substeps == 1 && sim.steps_per_sample() == 1;
    let clean = !sensors.noisy() && sensors.anti_alias.is_none() && sensors.bandwidth.is_none();
    let white = scenario
        .excitations
        .iter()
        .all(|e| matches!(e.process, Process::White { .. }));
    let hysteretic = scenario.links.iter().any(|l| l.hysteresis.is_some());
    match sim.scheme {
        Scheme::SemiImplicit | Scheme::EulerMaruyama if every_step && clean && white && !hysteretic => {
            DriftRule::EulerStep {
                semi_implicit: sim.scheme == Scheme::SemiImplicit,
            }
        }
        _ => DriftRule::GaussLegendre,
    }
}

impl Accumulator for ForceRegression {
    fn push(&mut self, s: &Sample) {
        let Sample {
            trajectory,
            t,
            batch,
            row,
            ..
        } = *s;
        self.0.push(trajectory as usize, t, batch, row);
    }

    fn finish(&mut self) {
        self.0.finish();
    }
}

impl Estimator for ForceRegression {
    fn estimate(&self, cx: &Context) -> Result<Estimate, IdentError> {
        self.0.estimate(cx.typical)
    }
}

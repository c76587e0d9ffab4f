//! The weak form with the measured forces as inputs (`ident::measured_force`): every force
//! that is not white — filtered, a lab signal, one read as its equivalent white noise —
//! enters through its measured column instead of a model of its spectrum. Its moments, of
//! the masses' state and those forces, are its own, gathered in the second pass.

use super::{refused, Context, Estimator, Setup};
use crate::ident::accumulate::{Accumulator, Sample};
use crate::ident::data::{Deconvolution, StationaryData};
use crate::ident::{self, Estimate, IdentError, Problem};
use crate::scenario::{Process, Scenario};

struct WeakMeasuredForce {
    problem: Problem,
    data: StationaryData,
    /// The first pass's sensor-noise correction, applied to these moments too.
    deconvolution: Option<Deconvolution>,
}

pub(super) fn build(setup: &Setup) -> Box<dyn Estimator> {
    let mechanical = setup.whitened.unwrap_or(setup.structure);
    if mechanical.unknowns != setup.structure.unknowns {
        return refused(IdentError::NotApplicable(
            "the measured forces replace the filters, and this problem has filter unknowns".into(),
        ));
    }
    let inputs = inputs(setup.scenario);
    if inputs.is_empty() {
        return refused(IdentError::NotApplicable(
            "every force is white noise, which the weak form reads as noise: this method reads forces that are \
             not white (filtered, a multisine, band-limited noise) from their measured columns"
                .into(),
        ));
    }
    match ident::measured_force::problem(mechanical, &inputs) {
        Ok(problem) => {
            let sim = &setup.scenario.simulation;
            let data = StationaryData::for_weak_forms(
                &problem,
                &[],
                sim.record_length,
                sim.trajectories,
                setup.data.batch_count(),
            );
            Box::new(WeakMeasuredForce {
                problem,
                data,
                deconvolution: setup.deconvolution.cloned(),
            })
        }
        Err(e) => refused(e),
    }
}

/// The excitations whose measured force enters as an input: every measured one that is
/// not white noise of a declared or unknown level.
fn inputs(s: &Scenario) -> Vec<usize> {
    (0..s.excitations.len())
        .filter(|&e| {
            let x = &s.excitations[e];
            x.measured && (!matches!(x.process, Process::White { .. }) || s.identify.equivalent_white.contains(&e))
        })
        .collect()
}

impl Accumulator for WeakMeasuredForce {
    fn push(&mut self, s: &Sample) {
        self.data.push(s.trajectory, s.t, s.row);
    }

    fn finish(&mut self) {
        self.data.finish();
        if let Some(d) = &self.deconvolution {
            self.data.deconvolve_by(d);
        }
    }
}

impl Estimator for WeakMeasuredForce {
    fn estimate(&self, _: &Context) -> Result<Estimate, IdentError> {
        let total = self.data.total();
        if let Some(j) = (self.problem.dynamic_dim()..self.problem.dim()).find(|&j| !total.mean(j).is_finite()) {
            return Err(IdentError::NotApplicable(format!(
                "the force {} is not in the data: map its column in [data.columns]",
                self.problem.state_names[j]
            )));
        }
        let mut est = ident::identify_weak(&self.problem, &self.data)?;
        est.method = "weak-measured-force";
        let p = &self.problem;
        est.facts.push((
            "forces".into(),
            format!(
                "measured, entering as inputs (no model of their spectrum): {}",
                p.state_names[p.dynamic_dim()..p.dim()].join(", ")
            ),
        ));
        Ok(est)
    }
}

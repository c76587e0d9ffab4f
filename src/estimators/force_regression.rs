//! Oracle bound, not FPK: the equation error of the equations of motion with the measured
//! excitation forces, information the FPK methods never use. It estimates the mechanical
//! problem (a filtered force is measured like a white one, so the filters' states are not
//! needed) and needs every force measured.

use super::{refused, Context, Estimator, Setup};
use crate::ident::baseline::{self, Increments};
use crate::ident::{Estimate, IdentError};
use crate::scenario::Process;

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
    // fpkbench logs a white force as its mean over the sample interval; measured data and
    // filtered forces hold values at the sample instants.
    let interval_means: Vec<bool> = setup
        .scenario
        .excitations
        .iter()
        .map(|e| !setup.measured && matches!(e.process, Process::White { .. }))
        .collect();
    match baseline::applicable(problem).and_then(|()| baseline::force_columns(problem, &interval_means)) {
        Ok(columns) => Box::new(ForceRegression(Increments::with_forces(
            problem,
            setup.sample_interval(),
            setup.data.batch_count(),
            columns,
        ))),
        Err(e) => refused(e),
    }
}

impl Estimator for ForceRegression {
    fn push(&mut self, trajectory: u32, t: f64, batch: usize, row: &[f64]) {
        self.0.push(trajectory as usize, t, batch, row);
    }

    fn finish(&mut self) {
        self.0.finish();
    }

    fn estimate(&self, cx: &Context) -> Result<Estimate, IdentError> {
        self.0.estimate(cx.typical)
    }
}

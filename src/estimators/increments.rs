//! Baseline, not FPK: regression of the velocity increments between consecutive samples
//! on the drift (the Euler–Maruyama pseudo-likelihood, `ident::baseline`).

use super::{refused, Context, Estimator, Setup};
use crate::ident::accumulate::{Accumulator, Sample};
use crate::ident::baseline::{self, Increments};
use crate::ident::{Estimate, IdentError};

pub(super) fn build(setup: &Setup) -> Box<dyn Estimator> {
    match baseline::applicable(setup.structure, false) {
        Ok(()) => Box::new(Increments::new(
            setup.structure,
            setup.sample_interval(),
            setup.data.batch_count(),
        )),
        Err(e) => refused(e),
    }
}

impl Accumulator for Increments {
    fn push(&mut self, s: &Sample) {
        let Sample {
            trajectory,
            t,
            batch,
            row,
            ..
        } = *s;
        Increments::push(self, trajectory as usize, t, batch, row);
    }

    fn finish(&mut self) {
        Increments::finish(self);
    }
}

impl Estimator for Increments {
    fn estimate(&self, cx: &Context) -> Result<Estimate, IdentError> {
        Increments::estimate(self, cx.typical)
    }
}

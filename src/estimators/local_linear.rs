//! Baseline, not FPK: the local-linearisation (Shoji–Ozaki) quasi-likelihood of the sample
//! pairs, consistent at any sample interval for a linear system (`ident::local_linear`).

use super::{refused, Context, Estimator, Setup};
use crate::ident::accumulate::{Accumulator, Sample};
use crate::ident::baseline;
use crate::ident::local_linear::LocalLinear;
use crate::ident::{Estimate, IdentError};

pub(super) fn build(setup: &Setup) -> Box<dyn Estimator> {
    match baseline::applicable(setup.structure, false) {
        Ok(()) => Box::new(LocalLinear::new(
            setup.structure,
            setup.sample_interval(),
            setup.data.batch_count(),
        )),
        Err(e) => refused(e),
    }
}

impl Accumulator for LocalLinear {
    fn push(&mut self, s: &Sample) {
        let Sample {
            trajectory,
            t,
            batch,
            row,
            ..
        } = *s;
        LocalLinear::push(self, trajectory as usize, t, batch, row);
    }
}

impl Estimator for LocalLinear {
    fn estimate(&self, cx: &Context) -> Result<Estimate, IdentError> {
        LocalLinear::estimate(self, cx.typical)
    }
}

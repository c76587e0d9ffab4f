//! Baseline, not FPK: the local-linearisation (Shoji–Ozaki) quasi-likelihood of the sample
//! pairs, consistent at any sample interval for a linear system (`ident::local_linear`).

use super::{refused, Context, Estimator, Setup};
use crate::ident::baseline;
use crate::ident::local_linear::LocalLinear;
use crate::ident::{Estimate, IdentError};

pub(super) fn build(setup: &Setup) -> Box<dyn Estimator> {
    match baseline::applicable(setup.structure) {
        Ok(()) => Box::new(LocalLinear::new(
            setup.structure,
            setup.sample_interval(),
            setup.data.batch_count(),
        )),
        Err(e) => refused(e),
    }
}

impl Estimator for LocalLinear {
    fn push(&mut self, trajectory: u32, t: f64, batch: usize, row: &[f64]) {
        LocalLinear::push(self, trajectory as usize, t, batch, row);
    }

    fn finish(&mut self) {}

    fn estimate(&self, cx: &Context) -> Result<Estimate, IdentError> {
        LocalLinear::estimate(self, cx.typical)
    }
}

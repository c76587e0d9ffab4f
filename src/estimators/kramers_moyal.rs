//! Baseline, not FPK: conditional mean increments on a grid (the first Kramers–Moyal
//! coefficient), then least squares of the drift (`ident::baseline`).

use super::{refused, Context, Estimator, Setup};
use crate::ident::accumulate::{Accumulator, Sample};
use crate::ident::baseline::{self, KramersMoyal};
use crate::ident::strong_histogram::GridOptions;
use crate::ident::{Estimate, IdentError};

pub(super) fn build(setup: &Setup) -> Box<dyn Estimator> {
    if let Err(e) = baseline::applicable(setup.structure, false) {
        return refused(e);
    }
    let dim = setup.structure.dim();
    let g = GridOptions::auto(dim, setup.total.count);
    let (mean, std) = setup.mean_std(dim);
    Box::new(KramersMoyal::new(
        setup.structure,
        setup.sample_interval(),
        setup.data.batch_count(),
        (&mean, &std),
        g.bins,
        g.span_std,
        setup.arenas,
    ))
}

impl Accumulator for KramersMoyal {
    fn push(&mut self, s: &Sample) {
        let Sample {
            trajectory,
            t,
            batch,
            row,
            ..
        } = *s;
        KramersMoyal::push(self, trajectory as usize, t, batch, row);
    }

    fn finish(&mut self) {
        KramersMoyal::finish(self);
    }
}

impl Estimator for KramersMoyal {
    fn estimate(&self, cx: &Context) -> Result<Estimate, IdentError> {
        KramersMoyal::estimate(self, cx.typical)
    }
}

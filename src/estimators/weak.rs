//! The weak form (docs/theory.md §5). It needs no accumulator of its own: its equations
//! come from the first pass's raw moments per batch. With an unknown filter corner the
//! drift is bilinear: monomials first, then the corner and the coefficients.

use super::{Context, Estimator, Setup};
use crate::ident::accumulate::{Accumulator, Sample};
use crate::ident::{self, Estimate, IdentError};

struct WeakForm;

pub(super) fn build(_: &Setup) -> Box<dyn Estimator> {
    Box::new(WeakForm)
}

/// It reads the first pass's moments, never the samples themselves.
impl Accumulator for WeakForm {
    fn push(&mut self, _: &Sample) {}
    fn reads_samples(&self) -> bool {
        false
    }
}

impl Estimator for WeakForm {
    fn estimate(&self, cx: &Context) -> Result<Estimate, IdentError> {
        if cx.bilinear {
            ident::identify_weak_bilinear(cx.problem, cx.data)
        } else {
            ident::identify_weak_with_levels(cx.problem, cx.data, cx.level_replicates)
        }
    }
}

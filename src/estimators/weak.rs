//! The weak form (docs/theory.md §5). It needs no accumulator of its own: its equations
//! come from the first pass's raw moments, and the pipeline solves them first, whatever
//! was asked for, because they measure identifiability.

use super::{Context, Estimator, Setup};
use crate::ident::{Estimate, IdentError};

struct WeakForm;

pub(super) fn build(_: &Setup) -> Box<dyn Estimator> {
    Box::new(WeakForm)
}

impl Estimator for WeakForm {
    fn push(&mut self, _: u32, _: f64, _: usize, _: &[f64]) {}

    fn estimate(&self, cx: &Context) -> Result<Estimate, IdentError> {
        cx.weak.clone()
    }
}

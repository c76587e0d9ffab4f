//! The pass driver: one streaming pass over an [`Input`]'s samples hands each sample, with
//! its jackknife batch, to every [`Accumulator`] of a list, in the list's order, and
//! finishes each when the source is exhausted. Stages (`super::stages`) gather their
//! accumulators into as few passes as their dependencies allow: what needs nothing but
//! the samples goes into the first, what needs the first pass's moments (the estimators'
//! grids, the force spectra's segment lengths) into the second, what needs the fitted
//! filters into a third (docs/architecture.md, "Stages and passes").
//!
//! A source hands its samples over in one fixed order, so every accumulator sees the same
//! sequence whatever the thread count; accumulators that sum in parallel do so over their
//! own fixed blocks (the weak form's moments per batch).

use super::source::Input;
use super::PipelineError;
use crate::ident::accumulate::{Accumulator, Sample};
use crate::ident::data::Batching;

/// One pass over `input`: every sample to each of `accumulators`, then `finish` on each;
/// the number of samples read.
pub(crate) fn run(
    input: &Input,
    batching: Batching,
    accumulators: &mut [&mut dyn Accumulator],
) -> Result<u64, PipelineError> {
    let n = input.for_each_sample(|trajectory, t, row| {
        let sample = Sample {
            trajectory,
            t,
            batch: batching.batch_of(trajectory, t),
            row,
        };
        for a in accumulators.iter_mut() {
            a.push(&sample);
        }
    })?;
    for a in accumulators.iter_mut() {
        a.finish();
    }
    Ok(n)
}

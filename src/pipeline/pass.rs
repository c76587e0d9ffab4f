//! The pass driver: one streaming pass over an [`Input`]'s samples hands each sample, with
//! its jackknife batch, to every [`Accumulator`] of a list, and finishes each when the
//! source is exhausted. Stages (`super::stages`) gather their accumulators into as few
//! passes as their dependencies allow: what needs nothing but the samples goes into the
//! first, what needs the first pass's moments (the estimators' grids, the force spectra's
//! segment lengths) into the second, what needs the fitted filters into a third
//! (docs/architecture.md, "Stages and passes").
//!
//! The source is read in one fixed order into blocks of [`BLOCK`] samples, and the
//! accumulators of a list run on a block in parallel, each over the whole block in order.
//! So every accumulator sees the same sequence of samples whatever the thread count and
//! nothing is reduced across threads: the results are those of a sequential pass, bit for
//! bit. The parallelism is across the accumulators (a pass of the default methods has a
//! dozen: the estimators, the Fisher information, the force spectra, the distributions),
//! and a pass with one accumulator runs it on the reading thread.

use super::source::Input;
use super::PipelineError;
use crate::ident::accumulate::{Accumulator, Sample};
use crate::ident::data::Batching;
use rayon::prelude::*;

/// Samples read before the accumulators run on them: large enough that handing a block to
/// the threads costs nothing next to the work on it, small enough to stay in the cache
/// (4096 samples of 10 columns: 320 KiB).
pub(crate) const BLOCK: usize = 4096;

/// A block of samples as read: each sample's trajectory, time and batch, and the rows one
/// after another.
struct Block {
    heads: Vec<(u32, f64, usize)>,
    rows: Vec<f64>,
    width: usize,
}

impl Block {
    /// Every accumulator over every sample of the block, the accumulators in parallel.
    fn hand_over(&mut self, accumulators: &mut [&mut dyn Accumulator]) {
        let (heads, rows, width) = (&self.heads, &self.rows, self.width);
        let feed = |a: &mut &mut dyn Accumulator| {
            for (k, &(trajectory, t, batch)) in heads.iter().enumerate() {
                a.push(&Sample {
                    trajectory,
                    t,
                    batch,
                    row: &rows[k * width..(k + 1) * width],
                });
            }
        };
        if accumulators.len() > 1 {
            // One task per accumulator: their costs differ tenfold, and the threads balance
            // them by taking the next when one is done.
            accumulators.par_iter_mut().with_max_len(1).for_each(feed);
        } else {
            accumulators.iter_mut().for_each(feed);
        }
        self.heads.clear();
        self.rows.clear();
    }
}

/// One pass over `input`: every sample to each of `accumulators`, then `finish` on each;
/// the number of samples read.
pub(crate) fn run(
    input: &Input,
    batching: Batching,
    accumulators: &mut [&mut dyn Accumulator],
) -> Result<u64, PipelineError> {
    let mut block = Block {
        heads: Vec::with_capacity(BLOCK),
        rows: Vec::new(),
        width: 0,
    };
    let n = input.for_each_sample(|trajectory, t, row| {
        if block.heads.is_empty() {
            block.width = row.len();
            block.rows.reserve(BLOCK * row.len());
        }
        debug_assert_eq!(row.len(), block.width, "rows of one width");
        block.heads.push((trajectory, t, batching.batch_of(trajectory, t)));
        block.rows.extend_from_slice(row);
        if block.heads.len() == BLOCK {
            block.hand_over(accumulators);
        }
    })?;
    block.hand_over(accumulators);
    accumulators.par_iter_mut().for_each(|a| a.finish());
    Ok(n)
}

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
//! and a pass with one accumulator runs it on the thread that hands the block over. Off the
//! thread pool (a `run` or `identify`) the accumulators take the blocks a block behind the
//! reading, on a thread of their own, so the decoding of a log or a table overlaps their
//! work; a study's items, on the pool, read and hand over in turn.

use super::source::Input;
use super::PipelineError;
use crate::ident::accumulate::{append_row, Accumulator, Samples};
use crate::ident::data::Batching;
use rayon::prelude::*;
use std::sync::mpsc;

/// Samples read before the accumulators run on them: large enough that handing a block to
/// the threads costs nothing next to the work on it, small enough to stay in the cache
/// (4096 samples of 10 columns: 320 KiB).
pub(crate) const BLOCK: usize = 4096;

/// A block of samples as read: each sample's trajectory, time and batch, and the rows one
/// after another.
#[derive(Default)]
struct Block {
    heads: Vec<(u32, f64, usize)>,
    rows: Vec<f64>,
    width: usize,
}

impl Block {
    /// Add a sample; whether the block is full.
    fn add(&mut self, batching: Batching, trajectory: u32, t: f64, row: &[f64]) -> bool {
        if self.heads.is_empty() {
            self.width = row.len();
            self.rows.reserve(BLOCK * row.len());
        }
        debug_assert_eq!(row.len(), self.width, "rows of one width");
        self.heads.push((trajectory, t, batching.batch_of(trajectory, t)));
        append_row(&mut self.rows, row);
        self.heads.len() == BLOCK
    }

    /// Every accumulator over every sample of the block, the accumulators in parallel.
    fn hand_over(&mut self, accumulators: &mut [&mut dyn Accumulator]) {
        let samples = Samples {
            heads: &self.heads,
            rows: &self.rows,
            width: self.width,
        };
        // One call per block: each accumulator's own loop over it, no call per sample.
        let feed = |a: &mut &mut dyn Accumulator| a.push_all(&samples);
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

/// One pass over `input`: every sample to each of `accumulators` that reads samples
/// ([`Accumulator::reads_samples`]), then `finish` on each; the number of samples read
/// (none when no accumulator reads them: the source is not read).
pub(crate) fn run(
    input: &Input,
    batching: Batching,
    accumulators: &mut [&mut dyn Accumulator],
) -> Result<u64, PipelineError> {
    let mut readers: Vec<&mut dyn Accumulator> = accumulators
        .iter_mut()
        .filter(|a| a.reads_samples())
        .map(|a| -> &mut dyn Accumulator { &mut **a })
        .collect();
    let n = if readers.is_empty() {
        0
    } else {
        feed(input, batching, &mut readers)?
    };
    drop(readers);
    accumulators.par_iter_mut().for_each(|a| a.finish());
    Ok(n)
}

/// Every sample of `input` to each of `accumulators`, in blocks; the number read.
fn feed(input: &Input, batching: Batching, accumulators: &mut [&mut dyn Accumulator]) -> Result<u64, PipelineError> {
    Ok(match rayon::current_thread_index() {
        None => read_ahead(input, batching, accumulators)?,
        // On the pool (a study's item), a worker must not wait for a reader that may need
        // the pool itself (a simulated source simulates on it): read and hand over in turn.
        Some(_) => {
            let mut block = Block::default();
            let n = input.for_each_sample(|trajectory, t, row| {
                if block.add(batching, trajectory, t, row) {
                    block.hand_over(accumulators);
                }
            })?;
            block.hand_over(accumulators);
            n
        }
    })
}

/// [`run`]'s reading and handing over, the accumulators a block behind the reading on a
/// thread of their own: decoding a log or a table overlaps the work on the block before.
/// The blocks go over in the order read, so the results do not depend on it. The source is
/// read on the calling thread, so what it allocates comes from where it did before (a
/// thread's own heap would hold memory the caller's has freed: the peak grows).
fn read_ahead(
    input: &Input,
    batching: Batching,
    accumulators: &mut [&mut dyn Accumulator],
) -> Result<u64, PipelineError> {
    // Blocks in flight: one being read, one waiting, one handed over.
    const IN_FLIGHT: usize = 3;
    let (full_tx, full_rx) = mpsc::sync_channel::<Block>(IN_FLIGHT);
    let (empty_tx, empty_rx) = mpsc::channel::<Block>();
    for _ in 0..IN_FLIGHT {
        empty_tx.send(Block::default()).expect("the receiver is here");
    }
    std::thread::scope(|scope| {
        scope.spawn(move || {
            for mut block in full_rx.iter() {
                block.hand_over(accumulators);
                let _ = empty_tx.send(block);
            }
        });
        let mut block = empty_rx.recv().expect("a block to start with");
        let n = input.for_each_sample(|trajectory, t, row| {
            if block.add(batching, trajectory, t, row) {
                // The accumulators' thread gives every block back; it has gone only after
                // a panic, which the scope passes on.
                let next = empty_rx.recv().unwrap_or_default();
                let _ = full_tx.send(std::mem::replace(&mut block, next));
            }
        });
        let _ = full_tx.send(block);
        drop(full_tx);
        n
    })
}

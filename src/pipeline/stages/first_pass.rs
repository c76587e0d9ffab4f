//! Stage "first pass": the plan's accumulators over every sample — the weak form's raw
//! moments per batch and the links' observed ranges, the naive row's and the comparison
//! models' moments, the profile positions' moments, the noise floor's lagged products and
//! the filtered forces' lag-1 correlations, the checks of measured samples for a rig's
//! faults, and the Fisher information where the structure is settled.

use super::super::pass;
use super::super::PipelineError;
use super::Identification;
use crate::ident::accumulate::Accumulator;

pub(crate) fn run(id: &mut Identification) -> Result<(), PipelineError> {
    let batching = id.data.batching();
    if !super::second_pass::samples_read_later(id) {
        id.input.no_later_pass();
    }
    let mut own: Vec<&mut dyn Accumulator> = id
        .comparisons
        .iter_mut()
        .filter_map(|c| c.own.as_mut().map(|d| d as &mut dyn Accumulator))
        .chain(id.declared_own.as_mut().map(|d| d as &mut dyn Accumulator))
        .collect();
    let mut list: Vec<&mut dyn Accumulator> = vec![&mut id.floor, &mut id.data, &mut id.naive_data];
    list.append(&mut own);
    list.push(&mut id.forces);
    list.push(&mut id.profile_candidates);
    list.push(&mut id.sample_checks);
    list.push(&mut id.fisher);
    pass::run(id.input, batching, &mut list)?;
    Ok(())
}

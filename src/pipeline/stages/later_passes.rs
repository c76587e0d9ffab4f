//! Stage "later passes": the samples once more for the accumulators that depend on the
//! fitted filters (the kernel strong form's fluxes are the drift's parts, known only now).

use super::super::pass;
use super::super::PipelineError;
use super::second_pass::setup;
use super::Identification;
use crate::ident::accumulate::Accumulator;

pub(crate) fn run(id: &mut Identification) -> Result<(), PipelineError> {
    let mut estimators = std::mem::take(&mut id.estimators);
    let again: Vec<bool> = {
        let setup = setup(id);
        let problem = &id.fitted().problem;
        estimators
            .iter_mut()
            .map(|(_, e)| e.needs_pass(problem, &setup))
            .collect()
    };
    let mut list: Vec<&mut dyn Accumulator> = estimators
        .iter_mut()
        .zip(&again)
        .filter(|(_, &a)| a)
        .map(|((_, e), _)| e as &mut dyn Accumulator)
        .collect();
    let result = match list.is_empty() {
        true => Ok(0),
        false => pass::run(id.input, id.data.batching(), &mut list),
    };
    drop(list);
    id.estimators = estimators;
    result.map(|_| ())
}

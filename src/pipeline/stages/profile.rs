//! Stage "profile" (`[identify.profile]`, docs/methods.md): the profiled term's position of
//! least misfit, refined at the parabola's vertex, becomes the specification, the
//! structure and the moments from here on.

use super::super::PipelineError;
use super::Identification;
use crate::ident::Problem;
use std::time::Instant;

pub(crate) fn run(id: &mut Identification) -> Result<(), PipelineError> {
    let Some(p) = id.profile_candidates.take() else {
        return Ok(());
    };
    crate::interrupt::check()?;
    let s = &id.input.info.scenario;
    let mut chosen = p.choose(s, &id.grader.truth, Instant::now())?;
    chosen.refine(s, id.input, &id.placeholder, id.options.batches)?;
    id.spec = chosen.spec;
    id.structure = Problem::from_spec(&id.spec, &id.placeholder)?;
    id.data = chosen.data;
    id.profiled = Some(chosen.report);
    Ok(())
}

//! Stage "selection" (docs/selection.md): with candidates, the candidate model's moments
//! choose the terms, and the selected model is what every method then identifies; the
//! baseline selection's (STLSQ's) model is kept for its comparison row.

use super::super::PipelineError;
use super::{Identification, Selected};
use crate::ident::{self, Problem, Specification};
use std::time::Instant;

pub(crate) fn run(id: &mut Identification) -> Result<(), PipelineError> {
    if id.select.is_none() {
        return Ok(());
    }
    crate::interrupt::check()?;
    let s = &id.input.info.scenario;
    let t = Instant::now();
    let chosen = ident::select::select(&id.structure, &id.data)?;
    let baseline = Specification::with_links(
        s,
        &ident::select::model_links(&chosen.thresholded.selected, &id.structure, &id.spec.links),
    );
    id.spec = Specification::with_links(s, &chosen.links(&id.structure, &id.spec.links));
    id.structure = Problem::from_spec(&id.spec, &id.placeholder)?;
    id.selected = Some(Selected {
        selection: chosen,
        baseline,
        seconds: t.elapsed().as_secs_f64(),
    });
    Ok(())
}

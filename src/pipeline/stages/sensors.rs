//! Stage "sensor correction" (docs/measurement.md): the sensors' noise estimated from the
//! first pass's noise floor and taken out of the weak form's moments, and the velocity
//! tail the sensors' anti-alias filters removed put back.

use super::super::sensors::{correct, filter_loss, put_back_filter_loss};
use super::super::PipelineError;
use super::Identification;

pub(crate) fn run(id: &mut Identification) -> Result<(), PipelineError> {
    let s = &id.input.info.scenario;
    let loss = filter_loss(s, &id.structure);
    match (id.floor.as_ref(), &loss) {
        (Some(f), _) => {
            let (report, taken_out, deconvolution) = correct(
                f,
                s,
                id.input.measured(),
                &id.structure,
                &mut id.data,
                id.naive_data.as_mut(),
                loss.as_ref(),
            );
            id.sensor_noise = Some(report);
            id.taken_out = taken_out;
            id.deconvolution = deconvolution;
        }
        (None, Some(l)) => {
            id.sensor_noise = Some(put_back_filter_loss(l, s, &mut id.data, id.naive_data.as_mut()));
        }
        (None, None) => {}
    }
    Ok(())
}

//! Stage "validation": the first identified FPK model re-simulated with the excitation as
//! identified (and the sensor noise taken out, put back), its distributions and spectra
//! compared with the data's (docs/methods.md, "Validation").

use super::super::sensors::for_validation;
use super::super::PipelineError;
use super::Identification;

pub(crate) fn run(id: &mut Identification) -> Result<(), PipelineError> {
    crate::interrupt::check()?;
    if !id.options.validate {
        return Ok(());
    }
    let Some((values, method)) = id.first.clone() else {
        return Ok(());
    };
    let s = &id.input.info.scenario;
    let input = id.input;
    let noisy = for_validation(s, &id.taken_out);
    let reported = id.reported.as_ref().expect("the rows stage sets it");
    // A response integrated from accelerations carries the integrated accelerometer noise,
    // slow and coloured, and lacks the motion below the drift removal's corner: its
    // spectrum is not compared (the white noise the re-simulation adds matches its
    // variance, not its spectrum); its std and kurtosis are.
    let integrated = |c: &usize| {
        input
            .measured()
            .is_some_and(|d| d.integrated_noise.iter().any(|n| n.column == *c))
    };
    let spectra: Vec<bool> = reported.columns.iter().map(|c| !integrated(c)).collect();
    // The measured band of every force read as its equivalent white noise: re-simulated
    // over it (validation::over_their_bands).
    let bands: Vec<(usize, (f64, f64))> = id
        .fitted
        .iter()
        .flat_map(|f| &f.white_reports)
        .filter_map(|w| {
            Some((
                s.excitations.iter().position(|e| e.name == w.excitation)?,
                w.force_band_hz,
            ))
        })
        .collect();
    let dist = id.dist.as_mut().expect("the second pass makes the distributions");
    id.validation = Some(dist.validate(noisy.as_ref().unwrap_or(s), reported, &values, method, &spectra, &bands));
    Ok(())
}

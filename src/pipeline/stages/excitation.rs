//! Stage "excitation fit": the rational spectrum (3.20) fitted to every measured filtered
//! force's Welch estimate (or its known `A`, `B`), the problem completed with the filters,
//! and the fit judged: a first-order spectrum that misses the measured one by more than
//! [`REJECT`] times what averaging alone explains is a force model the data reject, and
//! every method that needs it is refused (docs/methods.md, "Checks").

use super::super::PipelineError;
use super::{Fitted, Identification};
use crate::ident::Problem;
use crate::report::FilterReport;

/// A fitted filter whose log residual RMS exceeds this multiple of what the averaging
/// alone gives is rejected. On the shipped filtered scenarios the ratio is 0.98–1.03 (one
/// seed each of silentblock, filtered2dof, disturbed2dof); a band-limited input read as a
/// first-order filter gives 120 (Silverbox); 3 leaves room for a slightly shaped force
/// and none for a wrong model.
pub const REJECT: f64 = 3.0;

pub(crate) fn run(id: &mut Identification) -> Result<(), PipelineError> {
    let (filters, reports, spectra) = id.forces.filters(&id.input.info.scenario);
    let problem = Problem::from_spec(&id.spec, &filters)?;
    let typical = problem.typical(id.total.as_ref().expect("set in the second pass"));
    let rejected = rejected(&reports);
    id.fitted = Some(Fitted {
        filters,
        reports,
        spectra,
        problem,
        typical,
        rejected,
    });
    Ok(())
}

/// Why the fitted force models are rejected, if any is.
fn rejected(reports: &[FilterReport]) -> Option<String> {
    let why: Vec<String> = reports
        .iter()
        .filter(|f| f.used == "fitted" && f.rms_log_residual > REJECT * f.expected_rms_log_residual)
        .map(|f| {
            format!(
                "the first-order spectrum (3.20) fitted to {} misses it by an RMS log ratio of {:.3}, {:.0} times \
                 what averaging alone gives ({:.3}; the limit is {REJECT} times): the force is not an \
                 Ornstein–Uhlenbeck process (a band-limited or multisine input is not)",
                f.excitation,
                f.rms_log_residual,
                f.rms_log_residual / f.expected_rms_log_residual,
                f.expected_rms_log_residual
            )
        })
        .collect();
    (!why.is_empty()).then(|| {
        why.join("; ")
            + ". Every method that needs the force model is refused; the force regression, which uses the \
               measured force itself, stands"
    })
}

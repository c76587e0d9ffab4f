//! Stage "verdict": the checks of the method's own premises, which fail a run (exit 1)
//! whatever its gates say (docs/methods.md, "Checks"):
//! - **dissipativity**: a gated FPK estimate whose stiffness or damping is not dissipative
//!   over the observed range (3.4), (3.16)–(3.17) describes a system with no stationary
//!   density, which the method assumed to identify it;
//! - **validation**, on measured data (where no truth grades the estimates): the identified
//!   model re-simulated does not reproduce the data's distributions and spectra. On
//!   simulations the gates grade the estimates against the truth, and the validation's
//!   verdict stays a finding (a hysteretic truth or an unmeasured disturbance is expected
//!   to miss).

use super::super::PipelineError;
use super::Identification;
use crate::report::{FailedCheck, Outcome};

pub(crate) fn run(id: &mut Identification) -> Result<(), PipelineError> {
    for row in id.rows.iter().filter(|r| r.gated && r.outcome == Outcome::Estimated) {
        for d in row.dissipativity.iter().filter(|d| !d.holds) {
            id.failed_checks.push(FailedCheck {
                check: "dissipativity",
                method: row.method.to_string(),
                message: format!(
                    "{} {}: {} — an estimate with no stationary density contradicts the premise it was \
                     identified on",
                    d.link, d.kind, d.message
                ),
            });
        }
    }
    if id.input.measured().is_some() {
        if let Some(v) = id.validation.as_ref().filter(|v| v.reproduces == Some(false)) {
            id.failed_checks.push(FailedCheck {
                check: "validation",
                method: v.method.to_string(),
                message: v.verdict().unwrap_or_default(),
            });
        }
    }
    Ok(())
}

//! Stage "verdict": the checks of the method's own premises and of the measured samples,
//! which fail a run (exit 1) whatever its gates say (docs/methods.md, "Checks"):
//! - the first pass's **checks of the samples** for a rig's faults (`pipeline::sample_checks`,
//!   e.g. a dead stretch: a column that holds one value over a long stretch of a record);
//! - **dissipativity**: an FPK estimate (of a method a gate may hold, graded or not: measured
//!   data carry no gate) whose stiffness or damping is not dissipative over the observed
//!   range (3.4), (3.16)–(3.17) describes a system with no stationary density, which the
//!   method assumed to identify it;
//! - **validation**, on measured data (where no truth grades the estimates): the identified
//!   model re-simulated does not reproduce the data's distributions and spectra. On
//!   simulations the gates grade the estimates against the truth, and the validation's
//!   verdict stays a finding (a hysteretic truth or an unmeasured disturbance is expected
//!   to miss);
//! - **clipping**, on measured data: a channel whose samples pile up at its smallest or
//!   largest value (a sensor's or converter's limit, steady or jittering: more than
//!   `CLIPPED` samples there) biases every moment, and nothing undoes it;
//! - **force scale**, on measured data whose every force is measured: the masses the forces
//!   and the accelerations imply (`pipeline::force_scale`) are not the declared ones, by a
//!   factor beyond [`super::super::force_scale::SCALE_FACTOR`] — a unit slip or a sensor
//!   mounted the other way, which every estimate inherits;
//! - **agreement**, on measured data where the force regression ran beside a gated FPK
//!   estimate: a coefficient of the FPK estimate differs from the regression's on the same
//!   samples by more than [`AGREEMENT_SE`] combined standard errors and [`AGREEMENT_SHARE`]
//!   of the regression's value ([`AGREEMENT_SHARE_MEASURED_FORCE`] for an estimate that reads
//!   the measured force itself). Both read the same model; the regression reads the measured
//!   force sample by sample, the FPK estimate the stationary moments (with the force's
//!   spectral model, or with the measured force as an input), so one of them does not
//!   describe the data (most often the force is not the noise declared, and the density
//!   the FPK estimate stands on does not follow from it).

use super::super::PipelineError;
use super::Identification;
use crate::method::Method;
use crate::report::{FailedCheck, MethodReport};
use crate::scenario::ReportMethod;

/// The log's columns as a message names them: with measured data, the table's column
/// beside a mapped quantity (`v_m1 (column "omega")`).
fn column_labels(id: &Identification) -> Vec<String> {
    let mapped = id.input.measured().map_or(&[][..], |m| &m.table_columns[..]);
    let columns = &id.input.info.columns;
    (0..columns.len())
        .map(|k| match mapped.iter().find(|c| c.0 == k) {
            Some((_, name)) => format!("{} (column {name:?})", columns[k]),
            None => columns[k].clone(),
        })
        .collect()
}

/// Combined standard errors a coefficient's difference must exceed to fail the agreement
/// check: for unbiased estimates the chance of one such difference is about 6·10⁻⁵.
pub const AGREEMENT_SE: f64 = 4.0;

/// Share of the force regression's value a difference must also exceed: above the two
/// methods' known systematic differences on a right model (the weak form's −2 % on the
/// stiffness under a band edge at three times the mode, the regression's −10 % on the
/// damping from derived accelerations at coarse sampling; docs/methods.md, "Checks").
pub const AGREEMENT_SHARE: f64 = 0.15;

/// The share for an estimate that reads the measured force itself (`weak-measured-force`):
/// it and the regression read the same equation with the same force, the one through the
/// state's moments, the other sample by sample, and on a right model they differ by far
/// less than a spectral model's bias: on the Silverbox twin read as its record is (the
/// displacement and the force only, differentiated at nine samples a period; 60 seeds)
/// by at most 5.5 % (`k3`, 3.2 standard errors; docs/methods.md, "Checks").
pub const AGREEMENT_SHARE_MEASURED_FORCE: f64 = 0.10;

pub(crate) fn run(id: &mut Identification) -> Result<(), PipelineError> {
    let columns = column_labels(id);
    for check in &id.sample_checks {
        for message in check.findings(&columns) {
            id.failed_checks.push(FailedCheck {
                check: check.name(),
                method: "data".into(),
                message,
            });
        }
    }
    for row in id.rows.iter().filter(|r| fpk_estimate(r)) {
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
        clipping(id);
        agreement(id);
        if let Some(f) = &id.force_scale {
            let fitted = id.fitted();
            id.failed_checks.extend(f.verdict((&fitted.problem, &fitted.typical)));
        }
    }
    Ok(())
}

/// The clipping check: every channel of measured data whose samples pile up at a limit.
fn clipping(id: &mut Identification) {
    let Some(noise) = &id.sensor_noise else { return };
    let clipped: Vec<String> = noise
        .channels
        .iter()
        .filter(|c| c.at_limits > super::super::sensors::CLIPPED)
        .map(|c| format!("{} ({} samples)", c.column, c.at_limits))
        .collect();
    if !clipped.is_empty() {
        id.failed_checks.push(FailedCheck {
            check: "clipping",
            method: "data".into(),
            message: format!(
                "samples pile up at a channel's smallest or largest value (exactly, or within a thousandth of its \
                 std): {} — a clipped sensor or converter, which biases every moment and which no correction \
                 undoes: measure with a range that holds the signal (docs/measurement.md)",
                clipped.join(", ")
            ),
        });
    }
}

/// Whether a row is an estimate of a gated FPK method — whether or not a truth grades it
/// (measured data have none, and their rows carry no gate).
fn fpk_estimate(row: &MethodReport) -> bool {
    matches!(row.method, ReportMethod::Estimator(m) if m.is_gated()) && row.outcome.is_estimated()
}

/// The agreement check: every gated FPK estimate's coefficients against the force
/// regression's on the same samples.
fn agreement(id: &mut Identification) {
    let estimated = |m: &MethodReport| m.outcome.is_estimated();
    let Some(regression) = id
        .rows
        .iter()
        .find(|r| r.method == ReportMethod::Estimator(Method::ForceRegression) && estimated(r))
    else {
        return;
    };
    let mut failed = Vec::new();
    for row in id.rows.iter().filter(|r| fpk_estimate(r)) {
        let share = match row.method {
            ReportMethod::Estimator(m) if m.reads_measured_force() => AGREEMENT_SHARE_MEASURED_FORCE,
            _ => AGREEMENT_SHARE,
        };
        let differences: Vec<String> = row
            .parameters
            .iter()
            .filter_map(|p| {
                let q = regression.parameters.iter().find(|q| q.name == p.name)?;
                let (d, se) = (p.estimate - q.estimate, p.std_error.hypot(q.std_error));
                (se.is_finite() && d.abs() > AGREEMENT_SE * se && d.abs() > share * q.estimate.abs()).then(|| {
                    format!(
                        "{} {:.5e} ± {:.2e} against {:.5e} ± {:.2e} ({:+.1} %, {:.1} standard errors)",
                        p.name,
                        p.estimate,
                        p.std_error,
                        q.estimate,
                        q.std_error,
                        100.0 * d / q.estimate.abs(),
                        d.abs() / se
                    )
                })
            })
            .collect();
        if !differences.is_empty() {
            failed.push(FailedCheck {
                check: "agreement",
                method: row.method.to_string(),
                message: format!(
                    "the estimate contradicts the force regression on the same samples: {} — {}",
                    differences.join("; "),
                    match row.method {
                        ReportMethod::Estimator(m) if m.reads_measured_force() => {
                            "both read the same equation with the same measured force, the regression sample by \
                             sample through the acceleration, this estimate through the stationarity of the state's \
                             moments, which on a right model agree within a few per cent (docs/methods.md, \
                             \"Checks\"); so the model does not describe these data as both read them: a term or a \
                             dynamics it lacks (which the two weigh differently), an offset in a measured column \
                             (`[data] remove_mean`), or an acceleration the sampling or the sensors' noise bias"
                        }
                        _ => {
                            "both read the same model, the regression with the measured force, this estimate with \
                             the force's spectral model, so one of them does not describe these data: a force that is \
                             not the white or filtered noise declared, an offset in a measured column (`[data] \
                             remove_mean`), or a term the model lacks"
                        }
                    }
                ),
            });
        }
    }
    id.failed_checks.extend(failed);
}

//! Stage "excitation fit": the rational spectrum (3.20) fitted to every measured filtered
//! force's Welch estimate (or its known `A`, `B`), the level of every force read as its
//! equivalent white noise taken over the band where the response has its energy, the
//! problem completed with both, and the fits judged: a first-order spectrum that misses the
//! measured one by more than [`REJECT`] times what averaging alone explains, or a force not
//! flat over the response's band, is a force model the data reject, and every method that
//! needs it is refused (docs/methods.md, "The force model" and "Checks").

use super::super::spectra::{EDGE_LIMIT, REJECT_WHITE};
use super::super::{force_choice, PipelineError};
use super::{Fitted, Identification};
use crate::ident::{Problem, Specification};
use crate::report::{FilterReport, WhiteLevelReport};
use crate::scenario::Process;

/// A fitted filter whose log residual RMS exceeds this multiple of what the averaging
/// alone gives is rejected. On the shipped filtered scenarios the ratio is 0.98–1.03 (one
/// seed each of silentblock, filtered2dof, disturbed2dof); a band-limited input read as a
/// first-order filter gives 120 (Silverbox); 3 leaves room for a slightly shaped force
/// and none for a wrong model.
pub const REJECT: f64 = 3.0;

pub(crate) fn run(id: &mut Identification) -> Result<(), PipelineError> {
    let s = &id.input.info.scenario;
    let (filters, reports, spectra) = id.forces.filters(s);
    let white = id.forces.white_levels(s);
    let levels: Vec<(usize, f64)> = white.iter().filter_map(|&(e, sigma, _, _)| Some((e, sigma?))).collect();
    let level_replicates = jackknife_levels(id, &white);
    let chosen = &id.input.force_models;
    let white_reports: Vec<WhiteLevelReport> = white
        .into_iter()
        .map(|(_, _, r, _)| WhiteLevelReport {
            true_sigma: force_choice::true_sigma(chosen, &r.excitation).unwrap_or(r.true_sigma),
            ..r
        })
        .collect();
    id.spec = with_levels(&id.spec, &levels);
    let problem = match id.symmetric {
        None => Problem::from_spec(&id.spec, &filters)?,
        Some(_) => Problem::from_spec_unchecked(&id.spec, &filters)?,
    };
    let typical = problem.typical(id.total.as_ref().expect("set in the second pass"));
    // A force whose chosen model is refused is refused for that reason alone.
    let refused: Vec<&str> = chosen.iter().filter_map(|c| c.refused.as_deref()).collect();
    let read_white: Vec<WhiteLevelReport> = white_reports
        .iter()
        .filter(|w| {
            !chosen
                .iter()
                .any(|c| c.excitation == w.excitation && c.refused.is_some())
        })
        .cloned()
        .collect();
    let why: Vec<String> = refused
        .into_iter()
        .map(str::to_string)
        .chain(rejected(&reports))
        .chain(rejected_white(&read_white))
        .collect();
    let rejected = (!why.is_empty()).then(|| {
        why.join("; ")
            + ". Every method that needs the force model is refused; those that read the measured force itself \
               (weak-measured-force, force-regression) stand: list them in [identify] methods (or --method) \
               where they are not"
    });
    id.fitted = Some(Fitted {
        filters,
        reports,
        spectra,
        levels,
        level_replicates,
        white_reports,
        problem,
        typical,
        rejected,
    });
    Ok(())
}

/// The levels of the forces read as white in each jackknife replicate, as
/// [`crate::estimators::Context::level_replicates`] takes them: where the jackknife's
/// units are the 8 groups of records (`trajectory mod 8`, `super::super::units`) and the
/// levels' parts are the same groups, replicate `b` reads each force's level without group
/// `b`, as it reads the moments; otherwise none (the level from all the records is held in
/// every replicate, and its scatter is not in the standard errors).
#[allow(clippy::type_complexity)]
fn jackknife_levels(
    id: &Identification,
    white: &[(usize, Option<f64>, WhiteLevelReport, Vec<f64>)],
) -> Vec<(usize, Vec<f64>)> {
    use crate::ident::data::TRAJECTORY_GROUPS;
    let model = &id.spec.model;
    // An empty group leaves the jackknife fewer replicates than the level has parts, and
    // the weak form then holds the level (`ident::identify_weak_with_levels`).
    let aligned = id.data.batch_count() == TRAJECTORY_GROUPS;
    white
        .iter()
        .filter(|(_, sigma, _, without)| aligned && sigma.is_some() && without.len() == TRAJECTORY_GROUPS)
        .map(|(e, _, _, without)| {
            // The problem's noise sources are the measured excitations, in order.
            let source = model.excitations[..*e].iter().filter(|x| x.measured).count();
            (source, without.clone())
        })
        .collect()
}

/// `spec` with the white forces of `levels` at their measured level.
pub(crate) fn with_levels(spec: &Specification, levels: &[(usize, f64)]) -> Specification {
    let mut spec = spec.clone();
    for &(e, sigma) in levels {
        spec.model.excitations[e].process = Process::White { sigma };
    }
    spec
}

/// Why the forces read as white are rejected, if any is.
fn rejected_white(reports: &[WhiteLevelReport]) -> Option<String> {
    let why: Vec<String> = reports
        .iter()
        .filter(|w| !w.accepted)
        .map(|w| {
            if w.sigma.is_finite() && w.edge_share > EDGE_LIMIT {
                format!(
                    "{}'s band ({:.4}–{:.4} Hz) ends where the system still responds: {:.0} % of its gain lies \
                     beyond it (the limit is {:.0} %), which no white noise leaves undriven; drive the rig over a \
                     band that covers its modes with room to spare",
                    w.excitation,
                    w.force_band_hz.0,
                    w.force_band_hz.1,
                    100.0 * w.edge_share,
                    100.0 * EDGE_LIMIT
                )
            } else if w.sigma.is_finite() {
                format!(
                    "{} is not white over the band where the response has its energy ({:.4}–{:.4} Hz): its \
                     log density scatters about the level by an RMS of {:.3}, {:.1} times what averaging alone \
                     gives ({:.3}; the limit is {REJECT_WHITE} times)",
                    w.excitation,
                    w.band_hz.0,
                    w.band_hz.1,
                    w.rms_log_residual,
                    w.rms_log_residual / w.expected_rms_log_residual,
                    w.expected_rms_log_residual,
                )
            } else {
                format!(
                    "{}'s level cannot be read from its spectrum (no Welch segment, or no power where the \
                     response has its energy)",
                    w.excitation
                )
            }
        })
        .collect();
    (!why.is_empty()).then(|| why.join("; "))
}

/// Why the fitted first-order force models are rejected, if any is.
fn rejected(reports: &[FilterReport]) -> Option<String> {
    let why: Vec<String> = reports
        .iter()
        .filter(|f| f.used == "fitted" && f.rms_log_residual > REJECT * f.expected_rms_log_residual)
        .map(|f| {
            format!(
                "the first-order spectrum (3.20) fitted to {} misses it by an RMS log ratio of {:.3}, {:.0} times \
                 what averaging alone gives ({:.3}; the limit is {REJECT} times): the force is not an \
                 Ornstein–Uhlenbeck process (a band-limited or multisine input is not: the method \
                 weak-measured-force reads it from its column with no model of its spectrum; flat over the \
                 response's band, it can be read as its equivalent white noise, kind = \"white\" with \
                 [identify] equivalent_white = [{:?}])",
                f.excitation,
                f.rms_log_residual,
                f.rms_log_residual / f.expected_rms_log_residual,
                f.expected_rms_log_residual,
                f.excitation
            )
        })
        .collect();
    (!why.is_empty()).then(|| why.join("; "))
}

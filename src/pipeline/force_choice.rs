//! Choosing a measured force's model from its spectrum (`[identify] choose_force_model`,
//! docs/methods.md "Choosing the force model"). One pass gathers the Welch estimates of
//! each listed force and of the velocity it drives; three candidates are fitted and each
//! judged by its misfit against what the averaging alone gives (the limit
//! [`REJECT`] times, as for a declared model):
//!
//! 1. white over the band where the response has its energy, at its equivalent level
//!    ([`crate::ident::spectrum::band_level`]; its band must also cover the system's gain);
//! 2. first-order (3.20), fitted to the whole spectrum;
//! 3. the second-order rational spectrum ([`crate::ident::rational`]), fitted likewise.
//!
//! Of the two models the FPK equations take, white and first-order, the simpler the data
//! accept — unless the other fits clearly better ([`PREFER`]) — is written into the
//! scenario the stages identify with: a white force is read as its equivalent white noise,
//! a first-order one has its filter fitted again in the second pass. A force neither fits
//! is named second-order where that form fits it and, like a force no candidate fits,
//! refused to every method that needs the force model; the methods that read the measured
//! force itself stand (the excitation-fit stage).

use super::identify::check_measured;
use super::source::Input;
use super::spectra::ForceSpectra;
use super::stages::REJECT;
use super::PipelineError;
use crate::ident::spectrum::{fit_ou, OuFit};
use crate::ident::{rational, IdentError};
use crate::report::{ForceModelChoice, WhiteLevelReport};
use crate::scenario::Process;

/// `input` with the models of its listed forces chosen, or `None` where none is listed (or
/// the iterative procedure runs, which the scenario's checks keep apart).
pub(crate) fn choose(input: &Input) -> Result<Option<Input>, PipelineError> {
    let s = &input.info.scenario;
    let listed = &s.identify.choose_force_model;
    if listed.is_empty() || s.identify.disturbance.is_some() {
        return Ok(None);
    }
    let mut spectra = ForceSpectra::for_choice(s, listed);
    input.for_each_sample(|trajectory, _, row| spectra.push(trajectory, row))?;
    let mut scenario = s.clone();
    let mut choices = Vec::new();
    for ((e, _, white, _), force) in spectra.white_levels(s).into_iter().zip(spectra.white_force_spectra()) {
        let first_order = fit_ou(&force);
        let second_order = rational::fit_rational2(&force);
        let choice = judge(white, first_order, second_order);
        let x = &mut scenario.excitations[e];
        let truth = match x.process {
            Process::White { sigma } if s.data.is_none() => sigma,
            _ => f64::NAN,
        };
        if choice.chosen == "first-order" {
            // Its filter is fitted in the second pass; the placeholders are not a truth.
            x.process = Process::Filtered {
                a: f64::NAN,
                b: f64::NAN,
            };
        } else {
            // Read as white (refused, if the choice is not white, in the excitation fit).
            let sigma = Some(choice.white.sigma).filter(|s| s.is_finite() && *s > 0.0);
            x.process = Process::White {
                sigma: sigma.unwrap_or(1.0),
            };
            scenario.identify.equivalent_white.push(e);
        }
        choices.push(ForceModelChoice {
            white: WhiteLevelReport {
                true_sigma: truth,
                ..choice.white
            },
            ..choice
        });
    }
    scenario.identify.choose_force_model.clear();
    let chosen = input.with_chosen_forces(scenario, choices);
    check_measured(&chosen)
        .map_err(|why| IdentError::NotApplicable(format!("with the force models chosen from the spectra, {why}")))?;
    Ok(Some(chosen))
}

/// White, accepted, is chosen over first-order unless its misfit is more than this many
/// times first-order's: a right model's misfit ratio
/// scatters by a few per cent (0.98–1.03 for (3.20) on the shipped filtered scenarios),
/// so one 1.5 times another's is a shape the simpler model misses, however tolerated (an
/// Ornstein–Uhlenbeck force with its corner near the mode, read as white over the
/// response's band: 1.9 against first-order's 1.04).
const PREFER: f64 = 1.5;

/// Whether a fit's misfit is within [`REJECT`] times what the averaging alone gives.
fn fits(rms: f64, expected: f64) -> bool {
    rms.is_finite() && rms <= REJECT * expected
}

/// The choice among the candidates, and why the force model is refused where it is not
/// white or first-order.
fn judge(
    white: WhiteLevelReport,
    first_order: OuFit,
    second_order: Option<rational::Rational2Fit>,
) -> ForceModelChoice {
    let name = white.excitation.clone();
    let ratio = |rms: f64, expected: f64| rms / expected;
    let white_misfit = ratio(white.rms_log_residual, white.expected_rms_log_residual);
    let first_misfit = ratio(first_order.rms_log_residual, first_order.expected_rms);
    let tried = format!(
        "white over the response's band misfits {white_misfit:.1} times what averaging alone gives{}, \
         first-order (3.20) {first_misfit:.1} times",
        if white.edge_share.is_finite() && white.edge_share > super::spectra::EDGE_LIMIT {
            format!(
                " and leaves {:.0} % of the system's gain beyond its band",
                100.0 * white.edge_share
            )
        } else {
            String::new()
        }
    );
    // The models the FPK equations take; the second-order form only names a force neither
    // of them fits.
    let usable = [
        (white.accepted, white_misfit),
        (
            fits(first_order.rms_log_residual, first_order.expected_rms),
            first_misfit,
        ),
    ];
    let best = usable
        .iter()
        .filter(|(ok, _)| *ok)
        .map(|&(_, m)| m)
        .fold(f64::INFINITY, f64::min);
    let (chosen, refused) = match usable.iter().position(|&(ok, m)| ok && m <= PREFER * best) {
        Some(0) => ("white", None),
        Some(_) => ("first-order", None),
        None => match second_order {
            Some(f) if fits(f.rms_log_residual, f.expected_rms) => (
                "second-order",
                Some(format!(
                    "{name}'s spectrum is second-order rational (poles at {:.4} Hz, damping ratio {:.3}, misfit \
                     {:.1} times what averaging alone gives; {tried}): the FPK equations here take a white or \
                     first-order force, and a second-order one would need its rate of change as a state",
                    f.omega / (2.0 * std::f64::consts::PI),
                    f.zeta,
                    ratio(f.rms_log_residual, f.expected_rms),
                )),
            ),
            f => (
                "none",
                Some(format!(
                    "no model fits {name}'s spectrum: {tried}, second-order rational {}",
                    f.map_or("could not be fitted".to_string(), |f| format!(
                        "{:.1} times",
                        ratio(f.rms_log_residual, f.expected_rms)
                    ))
                )),
            ),
        },
    };
    ForceModelChoice {
        excitation: name,
        chosen,
        white,
        first_order,
        second_order,
        refused,
    }
}

/// The scenario's white levels' truth where its force model was chosen: the declared
/// `sigma` of a simulated white force, else none (what the choice wrote is no truth).
pub(crate) fn true_sigma(choices: &[ForceModelChoice], excitation: &str) -> Option<f64> {
    choices
        .iter()
        .find(|c| c.excitation == excitation)
        .map(|c| c.white.true_sigma)
}

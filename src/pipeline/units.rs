//! The jackknife's independent units (docs/methods.md, "Standard errors"): what the
//! standard errors take as independent draws of the stationary density.
//!
//! By default the jackknife goes over 32 batches, 8 groups of records × 4 stretches of
//! time: under stationary random excitation a stretch much longer than the motion's
//! correlation time is a draw of its own. A record that is one realisation of a periodic
//! excitation — a random-phase multisine's block — is not made of such draws: its
//! stretches share the realisation's line phases (which set, e.g., how far its amplitude
//! distribution's tails reach), and over its whole periods the weak form's equations hold
//! exactly while over parts of one they do not. On the Silverbox twin (ten blocks of one
//! period, 60 seeds) the stretches' jackknife gave the weak form's `k3` 0.70 of its spread
//! over seeds and `k2` ten times it. There the units are the records: the jackknife goes
//! over their 8 groups only.

use super::source::Input;
use crate::ident::data::TRAJECTORY_GROUPS;
use crate::scenario::{Independent, Process, Signal};

/// The jackknife's batches for `input` (`None`: the identification's own), with the note
/// that says why, where the records are the units.
pub(crate) struct Units {
    pub batches: Option<usize>,
    pub note: Option<String>,
}

/// Why the records of `input` are the units, if they are.
fn records_are_units(input: &Input) -> Option<&'static str> {
    let s = &input.info.scenario;
    let declared = s.data.as_ref().and_then(|d| d.independent);
    match (declared, input.measured()) {
        (Some(Independent::Stretches), _) => return None,
        (Some(Independent::Records), _) => return Some("`[data] independent = \"records\"`"),
        (None, Some(m)) if m.periodic => {
            return Some("the records were found to be periods of a periodic excitation, one realisation each")
        }
        _ => {}
    }
    let processes: Vec<&Process> = match &input.logged {
        Some(p) => p.iter().collect(),
        None => s.excitations.iter().map(|e| &e.process).collect(),
    };
    processes
        .iter()
        .any(|p| matches!(p, Process::Lab(Signal::Multisine { .. })))
        .then_some("each record is a realisation of the scenario's multisine")
}

/// The units of `input`: whole records where [`records_are_units`] says so and there are
/// at least [`TRAJECTORY_GROUPS`] of them; with fewer, the stretches stand in, and the
/// note says so.
pub(crate) fn units(input: &Input) -> Units {
    let Some(why) = records_are_units(input) else {
        return Units {
            batches: None,
            note: None,
        };
    };
    let records = input.info.scenario.simulation.trajectories;
    if records >= TRAJECTORY_GROUPS {
        Units {
            batches: Some(TRAJECTORY_GROUPS),
            note: Some(format!(
                "standard errors: the delete-one jackknife over {TRAJECTORY_GROUPS} groups of whole records, never \
                 stretches of one ({why}: a realisation's stretches share its lines' phases, and its whole periods \
                 hold the equations exactly where parts of one do not; docs/methods.md, \"Standard errors\")"
            )),
        }
    } else {
        Units {
            batches: None,
            note: Some(format!(
                "standard errors: {why}, but {records} records are fewer than the {TRAJECTORY_GROUPS} the jackknife \
                 needs as its units: it takes stretches of them as well, and its standard errors may not hold a new \
                 realisation's spread (docs/methods.md, \"Standard errors\")"
            )),
        }
    }
}

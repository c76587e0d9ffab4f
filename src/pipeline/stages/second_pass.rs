//! Stage "second pass": every requested method's estimator built from the first pass
//! (its grid, its kernel's width) and fed every sample, with the Fisher information (the
//! Cramér–Rao bound beside every standard error) where the first pass could not gather
//! it (the structure chosen after it), the force spectra's Welch estimates (and
//! a force cell's noise floor, where it is estimated) and the distributions the
//! validation and the figures compare.

use super::super::force_scale::ForceScale;
use super::super::pass;
use super::super::validation::Distributions;
use super::super::PipelineError;
use super::Identification;
use crate::estimators::Setup;
use crate::ident::accumulate::Accumulator;
use crate::ident::fisher::FisherInformation;
use crate::ident::Problem;
use crate::scenario::{NoiseHandling, Scenario};

/// What the estimators are built from, once the first pass's moments are final.
pub(super) fn setup<'a>(id: &'a Identification) -> Setup<'a> {
    Setup {
        scenario: &id.input.info.scenario,
        structure: &id.structure,
        whitened: id.naive_structure.as_ref(),
        data: &id.data,
        total: id.total.as_ref().expect("set before the second pass"),
        settings: &id.options.estimators,
        arenas: &id.options.arenas,
        measured: id.input.measured().map(|m| m.present.as_slice()),
        deconvolution: id.deconvolution.as_ref(),
        logged: id.input.logged.as_deref(),
    }
}

pub(crate) fn run(id: &mut Identification) -> Result<(), PipelineError> {
    let s = &id.input.info.scenario;
    id.total = Some(id.data.total());
    let (estimators, force_scale) = {
        let setup = setup(id);
        let estimators = id.methods.iter().map(|&m| (m, m.estimator(&setup))).collect();
        (estimators, ForceScale::new(&setup, &id.spec, &id.placeholder))
    };
    id.estimators = estimators;
    let mut force_scale = force_scale;
    let mut dist = Distributions::new(s, &id.structure, &id.data);
    id.forces.start_welch(&s.simulation);
    if s.identify.sensor_noise == NoiseHandling::Estimate
        && (s.simulation.sensors.noisy() || id.input.measured().is_some())
    {
        id.forces.estimate_floors(s.simulation.trajectories);
    }
    // A settled structure's was gathered in the first pass.
    let mut fisher = match id.settled {
        true => None,
        false => fisher(s, &id.structure),
    };
    let batching = id.data.batching();
    let mut list: Vec<&mut dyn Accumulator> = id
        .estimators
        .iter_mut()
        .map(|(_, e)| e as &mut dyn Accumulator)
        .collect();
    list.push(&mut fisher);
    list.push(&mut force_scale);
    // The distributions are gathered only for what shows them (the validation, the figures).
    if id.options.validate || id.options.plots {
        list.push(&mut dist);
    }
    list.push(&mut id.forces);
    pass::run(id.input, batching, &mut list)?;
    id.dist = Some(dist);
    if !id.settled {
        id.fisher = fisher;
    }
    id.force_scale = force_scale;
    Ok(())
}

/// The Fisher information's accumulator for `structure`, where its bound applies: the bound
/// is of white forces; a measured force read as its equivalent white noise is not one, and
/// its level is not known before the second pass.
pub(super) fn fisher(s: &Scenario, structure: &Problem) -> Option<FisherInformation> {
    FisherInformation::new(structure)
        .ok()
        .filter(|_| s.identify.equivalent_white.is_empty())
}

/// Whether a pass after the first will read the samples, as the plan knows it: every
/// method's estimator but the weak form's reads them ([`crate::estimators::Method::reads_samples`]), as do an
/// unsettled structure's Fisher information, the force scale of measured data, the
/// distributions (the validation, the figures), the forces' spectra and a profile's
/// refinement. Where none will, a simulation in memory keeps no samples for replay
/// ([`super::super::source::Input::no_later_pass`]).
pub(super) fn samples_read_later(id: &Identification) -> bool {
    id.methods.iter().any(|m| m.reads_samples())
        || !id.settled
        || id.input.measured().is_some()
        || id.options.validate
        || id.options.plots
        || id.forces.reads_samples()
}

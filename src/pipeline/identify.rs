//! What is checked before an identification starts (unknowns no data can separate, the
//! selection asked for, the quantities measured data must hold), and the choice between
//! the iterative procedure of section 4 and the ordinary stages (`super::stages`).

use super::disturbed::identify_disturbed;
use super::source::Input;
use super::{Options, PipelineError};
use crate::estimators::Method;
use crate::ident::Specification;
use crate::ident::{Filter, IdentError, Problem};
use crate::model::Quantity;
use crate::report::Report;
use crate::scenario::{Process, Scenario, Select};
use std::time::Instant;

/// The measured filtered excitations at placeholder `A`, `B`: the problem's structure
/// (state, columns, moments needed, symmetries) does not depend on them.
pub(crate) fn placeholder_filters(s: &Scenario) -> Vec<Filter> {
    (0..s.excitations.len())
        .filter(|&e| s.excitations[e].measured && matches!(s.excitations[e].process, Process::Filtered { .. }))
        .map(|e| Filter {
            excitation: e,
            a: 1.0,
            b: 1.0,
        })
        .collect()
}

/// What can be refused from the scenario alone, before any simulation or reading: unknowns
/// no data can separate (parallel links, exact symmetries of the stationary density) and
/// problems the identifier does not support. `methods` are the methods to run (empty: the
/// scenario's): a symmetry of the force model refuses the run only when none of them
/// reads the measured force (the plan stage's `structure_of`).
pub fn preflight(s: &Scenario, select: Option<&Select>, methods: &[Method]) -> Result<(), IdentError> {
    s.check_separable().map_err(IdentError::Inseparable)?;
    let select = selection(s, select)?;
    if s.identify.disturbance.is_none() {
        let methods = if methods.is_empty() {
            &s.identify.methods
        } else {
            methods
        };
        super::stages::structure_of(&accumulated(s, select.as_ref()), &placeholder_filters(s), methods)?;
    }
    Ok(())
}

/// The structure selection asked for: the CLI's `--select` over the scenario's
/// `[identify.select]` (candidate lists given on the command line replace the file's);
/// refused where selection does not apply.
pub(crate) fn selection(s: &Scenario, cli: Option<&Select>) -> Result<Option<Select>, IdentError> {
    let select = match (cli, &s.identify.select) {
        (Some(c), Some(f)) => Some(Select {
            stiffness: c.stiffness.clone().or_else(|| f.stiffness.clone()),
            damping: c.damping.clone().or_else(|| f.damping.clone()),
        }),
        (Some(c), None) => Some(c.clone()),
        (None, f) => f.clone(),
    };
    if select.is_some() {
        if let Some(why) = s.identify.select_unsupported(&s.excitations) {
            return Err(IdentError::NotApplicable(why));
        }
    }
    Ok(select)
}

/// What the first pass accumulates for: the scenario's unknowns, or with a selection the
/// candidate model (every candidate term unknown).
pub(crate) fn accumulated(s: &Scenario, select: Option<&Select>) -> Specification {
    match select {
        Some(sel) => Specification::with_links(s, &sel.candidates(&s.links, &s.identify.links)),
        None => Specification::from_scenario(s),
    }
}

/// Measured data: every quantity the identification reads is in the data (mapped, or
/// derived), named by its log column and what needs it.
pub fn check_measured(input: &Input) -> Result<(), String> {
    let Some(m) = input.measured() else {
        return Ok(());
    };
    let info = &input.info;
    let s = &info.scenario;
    // The columns and unknowns only: a symmetry is the preflight's to refuse.
    let structure = Problem::from_spec_unchecked(&Specification::from_scenario(s), &placeholder_filters(s))
        .map_err(|e| e.to_string())?;
    let mut needed: Vec<(usize, &str)> = structure
        .columns
        .iter()
        .map(|&c| (c, "the identification's state"))
        .collect();
    let layout = structure.model.columns();
    for f in placeholder_filters(s) {
        if !s.identify.known_filters.contains(&f.excitation) {
            needed.push((layout.force(f.excitation), "the spectral fit of its filter (3.20)"));
        }
    }
    for (c, why) in needed {
        if !m.present[c] {
            return Err(format!(
                "the data have no {} (needed for {why}): map a column to it in the model file's [data.columns]{}",
                info.columns[c],
                if matches!(layout.at(c).0, Quantity::Velocity | Quantity::Acceleration) {
                    ", or set derive = true"
                } else {
                    ""
                }
            ));
        }
    }
    let unknowns = structure.unknowns.len() as u64;
    if m.samples() < 100 * unknowns {
        return Err(format!(
            "{} samples for {unknowns} unknowns: at least 100 per unknown are needed (and far more for useful accuracy)",
            m.samples()
        ));
    }
    Ok(())
}

pub(crate) fn identify_info(input: &Input, options: &Options, start: Instant) -> Result<Report, PipelineError> {
    let s = &input.info.scenario;
    s.check_separable().map_err(IdentError::Inseparable)?;
    // Whole records as the jackknife's units where each is a realisation of a periodic
    // excitation (`units`).
    let with_units;
    let options = match super::units::units(input).batches {
        Some(b) if b != options.batches => {
            with_units = Options {
                batches: b,
                ..options.clone()
            };
            &with_units
        }
        _ => options,
    };
    if let Some(d) = &s.identify.disturbance {
        let mut d = d.clone();
        d.max_steps = options.max_steps.unwrap_or(d.max_steps);
        d.tolerance = options.tolerance.unwrap_or(d.tolerance);
        return identify_disturbed(input, &d, options, start);
    }
    super::stages::identify(input, options, start)
}

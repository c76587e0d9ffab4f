//! Stage "plan" (read and check): the methods to run, the structure selection asked for,
//! the specification and its problem over placeholder filters, and every accumulator of
//! the first pass — the weak form's moments (with those of the declared and comparison
//! models that share its atoms), the naive white-noise row's, the comparison models' and
//! the profile positions' own, the force spectra's lag sums, the sensor-noise floor and,
//! where the structure is settled before the samples are read, the Fisher information.

use super::super::grading::Grader;
use super::super::identify::{accumulated, placeholder_filters, selection};
use super::super::source::Input;
use super::super::spectra::ForceSpectra;
use super::super::{Options, PipelineError};
use super::Identification;
use crate::ident::data::StationaryData;
use crate::ident::{weak, Filter, IdentError, Problem, Specification};
use crate::scenario::Scenario;

/// The plan of an identification of `input`.
pub(crate) fn run<'a>(input: &'a Input, options: &'a Options) -> Result<Identification<'a>, PipelineError> {
    let s = &input.info.scenario;
    let grader = Grader::of_log(&input.info)?;
    let sim = &s.simulation;
    let methods = if options.methods.is_empty() {
        s.identify.methods.clone()
    } else {
        options.methods.clone()
    };
    // Measured filtered excitations: their A, B come from the force spectrum unless known.
    let placeholder = placeholder_filters(s);
    let filtered: Vec<usize> = placeholder.iter().map(|f| f.excitation).collect();
    let select = selection(s, options.select.as_ref())?;
    let spec = accumulated(s, select.as_ref());
    let (structure, symmetric) = structure_of(&spec, &placeholder, &methods)?;
    let naive_structure = (!filtered.is_empty())
        .then(|| match symmetric {
            None => Problem::from_spec(&spec.whitened(&placeholder), &[]),
            Some(_) => Problem::from_spec_unchecked(&spec.whitened(&placeholder), &[]),
        })
        .transpose()?;
    // With a selection, the first pass also gathers the moments of the declared model it
    // is compared with, and those of the `[identify.compare]` models over the same atoms; a
    // comparison model with other atoms (other non-polynomial terms) gathers its own.
    let declared = (select.is_some())
        .then(|| Problem::from_spec(&Specification::from_scenario(s), &placeholder))
        .transpose()?;
    let comparisons: Vec<Comparison> = s
        .identify
        .compare
        .iter()
        .map(|(name, links)| Comparison::new(name, links, s, &placeholder, &structure, options.batches))
        .collect();
    // A profiled term's position: the model at every position gathers its moments.
    let profile_candidates = super::super::profile::Candidates::new(s, &spec, &placeholder, options.batches);
    // A declared model with other atoms (a non-power term the candidates lack) gathers
    // its own moments, as a comparison model does.
    let declared_own = declared.as_ref().filter(|d| d.atoms != structure.atoms).map(|d| {
        StationaryData::new(
            d,
            weak::moment_degree(d),
            sim.record_length,
            sim.trajectories,
            options.batches,
        )
    });
    let also: Vec<&Problem> = declared
        .iter()
        .filter(|d| d.atoms == structure.atoms)
        .chain(
            comparisons
                .iter()
                .filter(|c| c.own.is_none())
                .filter_map(|c| c.problem.as_ref().ok()),
        )
        .collect();
    fits_in_memory(&structure, &also, sim.trajectories, select.is_some())?;
    let data = match also.is_empty() {
        false => {
            StationaryData::for_weak_forms(&structure, &also, sim.record_length, sim.trajectories, options.batches)
        }
        true => StationaryData::new(
            &structure,
            weak::moment_degree(&structure),
            sim.record_length,
            sim.trajectories,
            options.batches,
        ),
    };
    // The naive white-noise row shows what ignoring the filters costs against the truth;
    // measured data have none to show it against, and nobody asked for it there.
    let naive_data = naive_structure
        .as_ref()
        .filter(|_| input.measured().is_none())
        .map(|p| {
            StationaryData::new(
                p,
                weak::moment_degree(p),
                sim.record_length,
                sim.trajectories,
                options.batches,
            )
        });
    let forces = ForceSpectra::new(s, &filtered);
    // The structure identified is known now unless a profile or a selection chooses it.
    let settled = select.is_none() && profile_candidates.is_none();
    let fisher = settled.then(|| super::second_pass::fisher(s, &structure)).flatten();
    let floor = super::super::sensors::noise_floor(input, &structure, data.batch_count());
    Ok(Identification {
        input,
        options,
        grader,
        methods,
        placeholder,
        select,
        spec,
        structure,
        symmetric,
        naive_structure,
        comparisons,
        declared_own,
        profile_candidates,
        sample_checks: super::super::sample_checks::all(input),
        data,
        naive_data,
        forces,
        floor,
        profiled: None,
        sensor_noise: None,
        taken_out: Vec::new(),
        deconvolution: None,
        selected: None,
        total: None,
        estimators: Vec::new(),
        dist: None,
        settled,
        fisher,
        force_scale: None,
        fitted: None,
        rows: Vec::new(),
        first: None,
        estimates: Vec::new(),
        reported: None,
        validation: None,
        prediction: None,
        failed_checks: Vec::new(),
    })
}

/// `spec`'s problem over `filters`, and the exact symmetry of its force model
/// ([`crate::ident::exact_symmetry`]) where the run goes on without it. A symmetry refuses
/// the whole run when every method needs the force model; when one reads the measured
/// force instead (`weak-measured-force`, `force-regression`: a rig in volts whose mass is
/// unknown, where the measured force fixes the scale the density cannot), only the others
/// are refused, each with the symmetry as its reason (the rows stage).
pub(crate) fn structure_of(
    spec: &Specification,
    filters: &[Filter],
    methods: &[crate::estimators::Method],
) -> Result<(Problem, Option<IdentError>), IdentError> {
    match Problem::from_spec(spec, filters) {
        Err(e @ IdentError::Symmetric { .. }) if methods.iter().any(|m| m.reads_measured_force()) => {
            Ok((Problem::from_spec_unchecked(spec, filters)?, Some(e)))
        }
        other => Ok((other?, None)),
    }
}

/// One model of `[identify.compare]` before the first pass: its problem over the
/// placeholder filters, and its own moments when its atoms differ from the identified
/// structure's (their moments are other variables' moments); otherwise it reads the
/// shared data.
pub(crate) struct Comparison {
    pub name: String,
    pub links: Vec<crate::scenario::IdentifyLink>,
    pub problem: Result<Problem, IdentError>,
    pub own: Option<StationaryData>,
}

impl Comparison {
    fn new(
        name: &str,
        links: &[crate::scenario::IdentifyLink],
        s: &Scenario,
        placeholder: &[Filter],
        structure: &Problem,
        batches: usize,
    ) -> Comparison {
        let problem = Problem::from_spec(&Specification::with_links(s, links), placeholder);
        let own = match &problem {
            // With a profile the shared moments are replaced by the chosen position's.
            Ok(p) if p.atoms != structure.atoms || s.identify.profile.is_some() => Some(StationaryData::new(
                p,
                weak::moment_degree(p),
                s.simulation.record_length,
                s.simulation.trajectories,
                batches,
            )),
            _ => None,
        };
        Comparison {
            name: name.to_string(),
            links: links.to_vec(),
            problem,
            own,
        }
    }
}

/// The first pass's largest tables, known before they are allocated: a selection over
/// many high powers can ask for more than the machine has. `Err` names the sizes and
/// what to ask instead.
fn fits_in_memory(
    structure: &Problem,
    also: &[&Problem],
    trajectories: usize,
    select: bool,
) -> Result<(), PipelineError> {
    let (moments, weighting) = StationaryData::weak_forms_bytes(structure, also, trajectories);
    let need = moments + weighting;
    let budget = super::super::memory_budget();
    if need <= budget {
        return Ok(());
    }
    Err(PipelineError::Memory(format!(
        "the weak form of {} ({} unknowns, moments to degree {}, {} equations) would take {:.1} GB (its \
         moments over their fine batches {:.1} GB, the weighting of its equations {:.1} GB), more than the \
         {:.1} GB an identification may take (half this machine's memory, or FPKBENCH_MEMORY_BUDGET): ask \
         for fewer or lower powers{}",
        if select { "the candidate model" } else { "the model" },
        structure.unknowns.len(),
        weak::moment_degree(structure),
        weak::equation_count(structure),
        need as f64 / 1e9,
        moments as f64 / 1e9,
        weighting as f64 / 1e9,
        budget as f64 / 1e9,
        if select {
            " (--select-powers, [identify.select])"
        } else {
            ""
        }
    )))
}

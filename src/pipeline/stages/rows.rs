//! Stage "rows and grading": one report row per requested method, each with its own
//! outcome (a refusal is that method's row) and graded against the truth where there is
//! one, the Cramér–Rao bound beside every standard error, then the ungated rows — the
//! naive white-noise baseline, the `[identify.compare]` models, and with a selection the
//! declared model and the baseline selection's.

use super::super::grading::{method_report, Grader};
use super::super::PipelineError;
use super::{Comparison, Identification};
use crate::estimators::{Context, Estimator, Method};
use crate::ident::data::{Observed, StationaryData};
use crate::ident::{self, Filter, IdentError, Problem, Specification, Unknown};
use crate::report::MethodReport;
use crate::scenario::ReportMethod;
use rayon::prelude::*;
use std::time::Instant;

/// The comparison row of a selection: the weak form with the terms `[identify.links]`
/// declares.
pub const DECLARED: &str = "declared terms";

/// The comparison row of the baseline selection (STLSQ on the same equations).
pub const THRESHOLDED: &str = "STLSQ selection";

pub(crate) fn run(id: &mut Identification) -> Result<(), PipelineError> {
    let fitted = id.fitted.as_ref().expect("the excitation fit runs before");
    let problem = &fitted.problem;
    // With an unknown corner the drift is bilinear, and the reports are about the physical
    // coefficients and corners.
    let bilinear = problem.unknowns.iter().any(|u| matches!(u, Unknown::Corner(_)));
    let reported = if bilinear { problem.physical() } else { problem.clone() };
    let context = Context {
        problem,
        data: &id.data,
        typical: &fitted.typical,
        bilinear,
        level_replicates: &fitted.level_replicates,
    };
    let (mut rows, estimates) = estimator_rows(
        &mut id.estimators,
        &context,
        (fitted.rejected.as_deref(), id.symmetric.as_ref()),
        &reported,
        &id.grader,
        id.data.observed(),
    )?;
    let sample_interval = id.input.info.scenario.simulation.sample_interval;
    if let Some(bound) = id
        .fisher
        .take()
        .and_then(|f| f.bound(id.data.samples() as f64 * sample_interval))
    {
        for row in &mut rows {
            for p in &mut row.parameters {
                if let Some(k) = problem.names.iter().position(|n| *n == p.name) {
                    p.cramer_rao_std = Some(bound[k]);
                }
            }
        }
    }
    let naive = id.naive_data.as_ref().filter(|_| !id.placeholder.is_empty());
    rows.extend(comparison_rows(
        &id.spec,
        fitted.rejected.as_deref(),
        (&fitted.filters, &fitted.levels),
        naive,
        &id.data,
        &id.comparisons,
        &id.grader,
    )?);
    if let Some(selected) = &id.selected {
        // The model as declared, on the same samples: what the selection is measured
        // against (for a simulation, the true structure unless [identify.links] says
        // otherwise); and the baseline selection's model.
        let s = &id.input.info.scenario;
        for (name, spec, names, data) in [
            (
                DECLARED,
                Specification::from_scenario(s),
                None,
                id.declared_own.as_ref().unwrap_or(&id.data),
            ),
            (
                THRESHOLDED,
                selected.baseline.clone(),
                Some(selected.selection.thresholded_names()),
                &id.data,
            ),
        ] {
            let t = Instant::now();
            let p = Problem::from_spec(&spec, &fitted.filters)?;
            let est = match &fitted.rejected {
                Some(why) => Err(IdentError::ForceModelRejected(why.clone())),
                _ => ident::identify_weak(&p, data),
            };
            let mut row = method_report(
                ReportMethod::Compare(name.into()),
                None,
                est,
                &id.grader,
                &p,
                data.observed(),
                t,
            );
            row.selected = names.map(|names| names.iter().map(|n| n.to_string()).collect());
            rows.push(row);
        }
    }
    id.rows = rows;
    id.first = estimates
        .iter()
        .find(|(_, _, baseline)| !baseline)
        .map(|(m, v, _)| (v.clone(), m.clone()));
    id.estimates = estimates.into_iter().map(|(m, v, _)| (m, v)).collect();
    id.reported = Some(reported);
    Ok(())
}

/// One row per requested method, and every estimate that succeeded, with whether its
/// method is a baseline (the first FPK one is what the validation re-simulates); rows are
/// about `reported` (the physical problem of a bilinear one). Where the data reject the force model (`rejected`), every
/// method but those that read the measured force itself is refused; so it is where the
/// force model has an exact symmetry (`symmetric`) those methods do not share.
#[allow(clippy::type_complexity)]
fn estimator_rows(
    estimators: &mut [(Method, Box<dyn Estimator>)],
    cx: &Context,
    (rejected, symmetric): (Option<&str>, Option<&IdentError>),
    reported: &Problem,
    grader: &Grader,
    observed: Observed,
) -> Result<(Vec<MethodReport>, Vec<(ReportMethod, Vec<f64>, bool)>), PipelineError> {
    let s = grader.scenario;
    let mut rows = Vec::new();
    let mut estimates = Vec::new();
    crate::interrupt::check()?;
    // The methods' estimates are independent: on as many cores as there are (each with its
    // own time, so a row's time is its method's alone).
    let outcomes: Vec<(Result<ident::Estimate, IdentError>, std::time::Duration)> = estimators
        .par_iter_mut()
        .map(|(m, estimator)| {
            let t = Instant::now();
            let est = match (rejected, symmetric) {
                (_, Some(e)) if !m.reads_measured_force() => Err(e.clone()),
                (Some(why), _) if !m.reads_measured_force() => Err(IdentError::ForceModelRejected(why.to_string())),
                _ => estimator.estimate(cx),
            };
            (est, t.elapsed())
        })
        .collect();
    crate::interrupt::check()?;
    for ((m, _), (est, took)) in estimators.iter().zip(outcomes) {
        let t = Instant::now().checked_sub(took).unwrap_or_else(Instant::now);
        let method = ReportMethod::Estimator(*m);
        if let Ok(est) = &est {
            estimates.push((method.clone(), est.values.clone(), m.is_baseline()));
        }
        // Baselines and known-biased comparisons are compared, never gated.
        let threshold = m.is_gated().then(|| s.accept.threshold(&method));
        rows.push(method_report(method, threshold, est, grader, reported, observed, t));
    }
    Ok((rows, estimates))
}

/// The ungated rows: the naive baseline (the white-noise identification applied to
/// filtered data, each filtered force taken as white of the same low-frequency density
/// `σ = A/B`; `naive` holds its data when there are filtered forces) and the alternative
/// models of `[identify.compare]` (e.g. the paper's linear case 1).
fn comparison_rows(
    spec: &Specification,
    rejected: Option<&str>,
    (filters, levels): (&[Filter], &[(usize, f64)]),
    naive: Option<&StationaryData>,
    data: &StationaryData,
    comparisons: &[Comparison],
    grader: &Grader,
) -> Result<Vec<MethodReport>, PipelineError> {
    let observed = data.observed();
    let mut rows = Vec::new();
    if let Some(d) = naive {
        let t = Instant::now();
        let p = Problem::from_spec(&spec.whitened(filters), &[])?;
        let est = ident::identify_weak(&p, d);
        rows.push(method_report(
            ReportMethod::WeakWhiteNaive,
            None,
            est,
            grader,
            &p,
            observed,
            t,
        ));
    }
    for c in comparisons {
        let t = Instant::now();
        let spec = super::excitation::with_levels(&Specification::with_links(grader.scenario, &c.links), levels);
        let (p, est) = match Problem::from_spec(&spec, filters) {
            Ok(p) if rejected.is_some() => {
                let why = rejected.unwrap_or_default().to_string();
                (p, Err(IdentError::ForceModelRejected(why)))
            }
            Ok(p) => {
                let est = ident::identify_weak(&p, c.own.as_ref().unwrap_or(data));
                (p, est)
            }
            // The row says why (a symmetry of the comparison model); its problem, built
            // without that check, only lays out the row.
            Err(e) => (Problem::from_spec_unchecked(&spec, filters)?, Err(e)),
        };
        let observed = c.own.as_ref().map_or(observed, |d| d.observed());
        rows.push(method_report(
            ReportMethod::Compare(c.name.clone()),
            None,
            est,
            grader,
            &p,
            observed,
            t,
        ));
    }
    Ok(rows)
}

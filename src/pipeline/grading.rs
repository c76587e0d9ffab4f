//! Grading an estimate against the truth: per-parameter and per-curve errors over the
//! observed ranges (`docs/methods.md`, accuracy) and dissipativity (3.4), each method's
//! report row. The report itself is put together in `assemble.rs`.

use crate::ident::data::Observed;
use crate::ident::{self, IdentError, Problem, Unknown};
use crate::io::log::LogInfo;
use crate::model::{Characteristic, Coefficient, Term, Truth};
use crate::report::{CurveReport, MethodOutcome, MethodReport, Parameter};
use crate::scenario::{End, ReportMethod, Scenario};
use crate::stats;
use std::collections::BTreeMap;
use std::time::Instant;

/// What estimates are graded against: the truth, from the log's own truth record (never
/// from the identifier's problem), and the scenario for the links' names and the known
/// characteristics.
pub(crate) struct Grader<'a> {
    pub scenario: &'a Scenario,
    pub truth: Truth,
}

impl<'a> Grader<'a> {
    /// The grader of a log: its scenario and its truth record.
    pub fn of_log(info: &'a LogInfo) -> Result<Grader<'a>, super::PipelineError> {
        Ok(Grader {
            scenario: &info.scenario,
            truth: Truth::from_pairs(&info.truth).map_err(super::PipelineError::Truth)?,
        })
    }
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn fill_accuracy(
    rep: &mut MethodReport,
    g: &Grader,
    problem: &Problem,
    coef_of: &[Option<Coefficient>],
    values: &[f64],
    std_error: &[f64],
    covariance: &[Vec<f64>],
    dof: usize,
    observed: Observed,
) {
    let range = |c: Coefficient| match c.kind {
        Characteristic::Stiffness => (observed.ranges[c.link][0], observed.ranges[c.link][1]),
        Characteristic::Damping => (observed.ranges[c.link][2], observed.ranges[c.link][3]),
    };
    // Per link and argument (u, w): its power means under the observed density.
    let means: Vec<[Vec<f64>; 2]> = observed
        .powers
        .iter()
        .map(|p| p.each_ref().map(|sums| sums.iter().map(|s| s / sums[0]).collect()))
        .collect();
    let on = |c: Coefficient| {
        let (lo, hi) = range(c);
        let arg = match c.kind {
            Characteristic::Stiffness => 0,
            Characteristic::Damping => 1,
        };
        stats::Observed {
            lo,
            hi,
            means: means
                .get(c.link)
                .map(|m| m[arg].as_slice())
                .filter(|m| m[0].is_finite()),
        }
    };
    let s = g.scenario;
    let true_curve = |l: usize, kind| g.truth.characteristic(&s.links[l].name, kind);
    let true_values = problem.true_values(&g.truth);
    // Measured data on a model file without values for the unknowns: nothing to grade.
    let graded = true_values.iter().all(|t| t.is_finite());
    // A characteristic whose model cannot represent its truth (powers for a friction, hinges
    // for a cubic) has coefficients that estimate no true ones: its curve grades it.
    let represents = |l: usize, kind| {
        let model: Vec<Term> = coef_of
            .iter()
            .flatten()
            .filter(|c| c.link == l && c.kind == kind)
            .map(|c| c.term)
            .collect();
        represents(&model, &true_curve(l, kind))
    };
    let mut worst: f64 = 0.0;
    for (k, name) in problem.names.iter().enumerate() {
        let t = true_values[k];
        let rel = match coef_of[k] {
            Some(c) if !represents(c.link, c.kind) => f64::NAN,
            Some(c) => stats::coefficient_error(values[k], t, c.term, &true_curve(c.link, c.kind), &on(c)),
            None => ((values[k] - t) / t).abs(),
        };
        worst = worst.max(rel);
        let ci95 = (std_error[k].is_finite() && dof > 0).then(|| {
            let half = stats::student_t_975(dof) * std_error[k];
            [values[k] - half, values[k] + half]
        });
        rep.parameters.push(Parameter {
            name: name.clone(),
            true_value: t,
            estimate: values[k],
            std_error: std_error[k],
            ci95,
            differs_from_zero: ci95.map(|[lo, hi]| lo > 0.0 || hi < 0.0),
            rel_error: rel,
            cramer_rao_std: None,
        });
    }
    for l in 0..s.links.len() {
        for kind in [Characteristic::Stiffness, Characteristic::Damping] {
            let (est, unknown) = stats::estimated_characteristic(s, coef_of, values, l, kind);
            if !unknown {
                continue;
            }
            let truth = true_curve(l, kind);
            let c = Coefficient {
                link: l,
                kind,
                term: Term::Power(1),
            };
            let (lo, hi) = range(c);
            let e = if graded {
                stats::rel_l2(&est, &truth, &on(c))
            } else {
                f64::NAN
            };
            let both = crate::scenario::Curve {
                terms: est.terms.iter().chain(&truth.terms).copied().collect(),
            };
            let norm = match on(c).under_density(&both) {
                true => crate::report::NORM_DENSITY,
                false => crate::report::NORM_RANGE,
            };
            worst = worst.max(e);
            let terms_covariance = terms_covariance(&est, coef_of, covariance, l, kind);
            rep.curves.push(CurveReport {
                link: s.links[l].name.clone(),
                kind: kind.name(),
                rel_l2_error: e,
                norm,
                range: [lo, hi],
                identified: est.terms.clone(),
                covariance: terms_covariance,
                dof,
            });
            let d = stats::dissipativity(&s.links[l].name, kind, &est, lo, hi);
            rep.dissipativity.push(match rep.method.ignores() {
                Some(cause) => d.blame(cause),
                None => d,
            });
        }
        reversed_end(s, l, coef_of, values, rep);
    }
    if graded {
        rep.worst_rel_error = worst;
        rep.passed = rep.threshold.map(|t| worst <= t);
    } else {
        rep.worst_rel_error = f64::NAN;
        rep.threshold = None;
        rep.passed = None;
        rep.gated = false;
    }
}

/// Link `l` between two masses whose identified stiffness and damping both fail the
/// dissipativity check with negative linear terms: its two failures name a sensor mounted
/// the other way ([`stats::Dissipativity::reversed_end`]) instead of the degree.
fn reversed_end(s: &Scenario, l: usize, coef_of: &[Option<Coefficient>], values: &[f64], rep: &mut MethodReport) {
    let [End::Mass(a), End::Mass(b)] = s.links[l].ends else {
        return;
    };
    let linear = |kind| {
        (coef_of.iter().zip(values))
            .find(|(c, _)| {
                **c == Some(Coefficient {
                    link: l,
                    kind,
                    term: Term::Power(1),
                })
            })
            .map(|(_, &v)| v)
    };
    let (Some(k), Some(c)) = (linear(Characteristic::Stiffness), linear(Characteristic::Damping)) else {
        return;
    };
    let name = &s.links[l].name;
    let failing = |d: &stats::Dissipativity| &d.link == name && !d.holds;
    if k >= 0.0 || c >= 0.0 || rep.dissipativity.iter().filter(|d| failing(d)).count() < 2 {
        return;
    }
    for d in rep.dissipativity.iter_mut().filter(|d| &d.link == name) {
        *d = d.clone().reversed_end(&s.masses[a].name, &s.masses[b].name, [k, c]);
    }
}

/// The covariance of the identified terms' coefficients of link `l`'s `kind`, in their
/// order in `est` (empty without a covariance).
fn terms_covariance(
    est: &crate::scenario::Curve,
    coef_of: &[Option<Coefficient>],
    covariance: &[Vec<f64>],
    l: usize,
    kind: Characteristic,
) -> Vec<Vec<f64>> {
    if covariance.is_empty() {
        return Vec::new();
    }
    let index: Vec<Option<usize>> = est
        .terms
        .iter()
        .map(|&(term, _)| {
            coef_of
                .iter()
                .position(|c| *c == Some(Coefficient { link: l, kind, term }))
        })
        .collect();
    index
        .iter()
        .map(|a| {
            index
                .iter()
                .map(|b| match (a, b) {
                    (Some(a), Some(b)) => covariance[*a][*b],
                    _ => 0.0,
                })
                .collect()
        })
        .collect()
}

/// Whether a characteristic identified with the terms `model` can represent the true one:
/// every term of the truth is among them, a position (gap, scale, knot) possibly elsewhere
/// (as a profile leaves it). Else the model's coefficients estimate no true coefficients
/// and only the curve's error grades it.
fn represents(model: &[Term], truth: &crate::scenario::Curve) -> bool {
    let same = |a: &Term, b: &Term| match (a, b) {
        (Term::Power(p), Term::Power(q)) | (Term::SignedPower(p), Term::SignedPower(q)) => p == q,
        _ => std::mem::discriminant(a) == std::mem::discriminant(b),
    };
    truth
        .terms
        .iter()
        .filter(|(_, v)| *v != 0.0)
        .all(|(t, _)| model.iter().any(|m| same(m, t)))
}

/// The coefficient behind each unknown (`None` for masses and intensities).
pub(crate) fn coefficients_of(problem: &Problem) -> Vec<Option<Coefficient>> {
    problem
        .unknowns
        .iter()
        .map(|u| {
            if let Unknown::Coefficient(c) = u {
                Some(*c)
            } else {
                None
            }
        })
        .collect()
}

/// One method's report: estimates, accuracy, dissipativity; `threshold` `None` for an
/// ungated baseline or comparison.
pub(crate) fn method_report(
    method: ReportMethod,
    threshold: Option<f64>,
    est: Result<ident::Estimate, IdentError>,
    g: &Grader,
    problem: &Problem,
    observed: Observed,
    started: Instant,
) -> MethodReport {
    let threshold_default = threshold.is_some() && g.scenario.accept.is_default(&method);
    let mut rep = MethodReport {
        method,
        outcome: MethodOutcome::Estimated,
        gated: threshold.is_some(),
        parameters: Vec::new(),
        curves: Vec::new(),
        worst_rel_error: f64::NAN,
        threshold,
        threshold_default,
        passed: threshold.map(|_| false),
        warnings: Vec::new(),
        diagnostics: None,
        weakly_determined: false,
        facts: BTreeMap::new(),
        dissipativity: Vec::new(),
        seconds: 0.0,
        selected: None,
    };
    match est {
        Err(IdentError::NotApplicable(why)) => {
            rep.outcome = MethodOutcome::NotApplicable(why);
            rep.passed = None;
        }
        Err(e) => {
            rep.outcome = MethodOutcome::of_error(&e);
        }
        Ok(e) => {
            fill_accuracy(
                &mut rep,
                g,
                problem,
                &coefficients_of(problem),
                &e.values,
                &e.std_error,
                &e.covariance,
                e.dof,
                observed,
            );
            rep.warnings = e.warnings.clone();
            rep.diagnostics = Some(e.diagnostics.clone());
            rep.weakly_determined = e.weakly_determined;
            rep.facts = e.facts.into_iter().collect();
            for (name, direct, from_product) in problem.recovered(&e.values) {
                rep.facts.insert(
                    format!("physical {name}"),
                    format!("{direct:.6} directly, {from_product:.6} from (B*{name})/B"),
                );
            }
        }
    }
    rep.seconds = started.elapsed().as_secs_f64();
    rep
}

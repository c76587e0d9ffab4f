//! One method's row of a report: its outcome with the reason, its estimates and curves, its
//! gate and diagnostics; serialised into `report.json`'s `methods` (docs/methods.md,
//! "Outcomes and exit codes").

use super::{CurveReport, Parameter};
use crate::ident::lsq::Diagnostics;
use crate::scenario::ReportMethod;
use crate::stats;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// What a method made of the data: each method's outcome is its own (docs/methods.md,
/// "Outcomes and exit codes").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Outcome {
    /// Estimates with standard errors (or the reason they have none).
    Estimated,
    /// The data cannot decide: the unknowns cannot be separated (rank, singular values) or
    /// there are too few samples. No estimates are given.
    Refused,
    /// The method does not apply to this problem (e.g. a density lattice in too many
    /// dimensions): not a failure.
    NotApplicable,
    /// The method failed on these data (e.g. a non-finite result).
    Failed,
}

impl Outcome {
    /// The outcome of an identification that ended with `e`.
    pub fn of_error(e: &crate::ident::IdentError) -> Outcome {
        use crate::ident::IdentError as E;
        match e {
            E::NotApplicable(_) => Outcome::NotApplicable,
            E::NotIdentifiable { .. }
            | E::Symmetric { .. }
            | E::Inseparable(_)
            | E::TooLittleData(_)
            | E::ForceModelRejected(_) => Outcome::Refused,
            _ => Outcome::Failed,
        }
    }

    /// The name reports and study rows use.
    pub fn name(self) -> &'static str {
        match self {
            Outcome::Estimated => "estimated",
            Outcome::Refused => "refused",
            Outcome::NotApplicable => "not-applicable",
            Outcome::Failed => "failed",
        }
    }
}

/// A method's outcome with its reason: estimates, or why there are none. One value, so a
/// row cannot say "estimated" and carry an error beside it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MethodOutcome {
    /// Estimates with standard errors (or the reason they have none).
    Estimated,
    /// The data cannot decide (rank, singular values, too few samples, a rejected force
    /// model): why.
    Refused(String),
    /// The method does not apply to this problem (e.g. a density lattice in too many
    /// dimensions): why. Not a failure, and not counted by the gates.
    NotApplicable(String),
    /// The method failed on these data (e.g. a non-finite result): why.
    Failed(String),
}

impl MethodOutcome {
    /// The outcome of an identification that ended with `e`.
    pub fn of_error(e: &crate::ident::IdentError) -> MethodOutcome {
        let why = e.to_string();
        match Outcome::of_error(e) {
            Outcome::Estimated | Outcome::Failed => MethodOutcome::Failed(why),
            Outcome::Refused => MethodOutcome::Refused(why),
            Outcome::NotApplicable => MethodOutcome::NotApplicable(why),
        }
    }

    /// Its kind, as study rows and exit codes count it.
    pub fn kind(&self) -> Outcome {
        match self {
            MethodOutcome::Estimated => Outcome::Estimated,
            MethodOutcome::Refused(_) => Outcome::Refused,
            MethodOutcome::NotApplicable(_) => Outcome::NotApplicable,
            MethodOutcome::Failed(_) => Outcome::Failed,
        }
    }

    /// Why a refused or failed method gave no estimate (`report.json`'s `error`).
    pub fn error(&self) -> Option<&str> {
        match self {
            MethodOutcome::Refused(why) | MethodOutcome::Failed(why) => Some(why),
            _ => None,
        }
    }

    /// Why the method does not apply (`report.json`'s `not_applicable`).
    pub fn not_applicable(&self) -> Option<&str> {
        match self {
            MethodOutcome::NotApplicable(why) => Some(why),
            _ => None,
        }
    }

    /// Whether the method gave estimates.
    pub fn is_estimated(&self) -> bool {
        *self == MethodOutcome::Estimated
    }
}

/// One method's row of a report: its outcome, estimates, curves, gate and diagnostics
/// (docs/methods.md, "Outcomes and exit codes").
#[derive(Debug, Clone)]
pub struct MethodReport {
    /// The estimator, baseline or comparison model this row is about.
    pub method: ReportMethod,
    /// Estimated, or why not: refused, not applicable or failed, with the reason.
    pub outcome: MethodOutcome,
    /// Whether this method has an acceptance gate (baselines and comparisons do not).
    pub gated: bool,
    /// Every unknown's estimate (empty when the method gave none).
    pub parameters: Vec<Parameter>,
    /// Every identified characteristic against the truth.
    pub curves: Vec<CurveReport>,
    /// The largest relative error over the parameters and curves (NaN without a truth or an
    /// estimate).
    pub worst_rel_error: f64,
    /// The regression gate on `worst_rel_error` (mean + 4 sd over seeds, set in the
    /// scenario's `[accept]`); `None` for baselines and comparisons.
    pub threshold: Option<f64>,
    /// Whether `threshold` is the 5 % default of a scenario without `[accept]`
    /// `worst_rel_error`, which no spread over seeds calibrated.
    pub threshold_default: bool,
    /// The gate's verdict: whether the worst error is within it; `Some(false)` for a gated
    /// method that was refused or failed; `None` when not gated or not applicable.
    pub passed: Option<bool>,
    /// Warnings about the estimate's reliability (e.g. too few usable cells per unknown).
    pub warnings: Vec<String>,
    /// The least squares' conditioning and the method's own diagnostics.
    pub diagnostics: Option<Diagnostics>,
    /// Whether the smallest singular value is so small against the largest that some
    /// combination of unknowns is poorly determined by the data.
    pub weakly_determined: bool,
    /// What the method did, as label and text (moments, test functions, grid, weighting).
    pub facts: BTreeMap<String, String>,
    /// Per characteristic: whether the estimate is dissipative over the observed range
    /// ((3.4), (3.16)–(3.17)).
    pub dissipativity: Vec<stats::Dissipativity>,
    /// The method's wall-clock time (s).
    pub seconds: f64,
    /// With structure selection: the terms selected, which this method identified
    /// (docs/selection.md).
    pub selected: Option<Vec<String>>,
}

/// `report.json`'s form of a [`MethodReport`]: the outcome as its kind with `not_applicable`
/// and `error` beside it, in the fields' order readers have (docs/methods.md).
#[derive(Serialize)]
struct MethodReportJson<'a> {
    method: &'a ReportMethod,
    outcome: Outcome,
    gated: bool,
    parameters: &'a [Parameter],
    curves: &'a [CurveReport],
    worst_rel_error: f64,
    threshold: Option<f64>,
    threshold_default: bool,
    passed: Option<bool>,
    not_applicable: Option<&'a str>,
    warnings: &'a [String],
    diagnostics: &'a Option<Diagnostics>,
    weakly_determined: bool,
    facts: &'a BTreeMap<String, String>,
    dissipativity: &'a [stats::Dissipativity],
    error: Option<&'a str>,
    seconds: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    selected: Option<&'a Vec<String>>,
}

impl Serialize for MethodReport {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        MethodReportJson {
            method: &self.method,
            outcome: self.outcome.kind(),
            gated: self.gated,
            parameters: &self.parameters,
            curves: &self.curves,
            worst_rel_error: self.worst_rel_error,
            threshold: self.threshold,
            threshold_default: self.threshold_default,
            passed: self.passed,
            not_applicable: self.outcome.not_applicable(),
            warnings: &self.warnings,
            diagnostics: &self.diagnostics,
            weakly_determined: self.weakly_determined,
            facts: &self.facts,
            dissipativity: &self.dissipativity,
            error: self.outcome.error(),
            seconds: self.seconds,
            selected: self.selected.as_ref(),
        }
        .serialize(s)
    }
}

//! What a row of a report is ([`ReportMethod`]), and its name in reports and `[accept]`.

use super::Method;

/// What a row of a report is: an estimator, a baseline, a comparison model, or a step or
/// bound of the section-4 procedure. Written in reports and `[accept] methods` by
/// [`ReportMethod::name`].
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum ReportMethod {
    /// One of the estimators of `[identify] methods`.
    Estimator(Method),
    /// The white-noise weak form applied to data with filtered forces, each taken as white
    /// of the same low-frequency density: what ignoring the filters costs (ungated).
    WeakWhiteNaive,
    /// The weak form with the `[identify.compare.NAME]` model (ungated).
    Compare(String),
    /// Section 4, step 0 (4.4)–(4.7): every unknown, the disturbance ignored.
    Step0,
    /// Section 4: an intermediate step of a sequence.
    Step,
    /// Section 4, the paper's sequence (spectral single-mass step (4.10)–(4.15)).
    Iterated,
    /// Section 4, the sequence with the measured-force single-mass step.
    IteratedForce,
    /// Section 4, one solve of the subtracted equation (4.8) for `k1`, `K2`, `C2`.
    DirectForce,
    /// Bound: the disturbance given as measured, in the paper's model of the forces.
    PzMeasured,
    /// Bound: the disturbance given as measured, in the measured-force weak form.
    PzMeasuredForce,
}

impl ReportMethod {
    /// The methods an `[accept] methods` key may name (the section-4 ones only with
    /// `[identify.disturbance]`).
    pub fn gated(disturbance: bool) -> Vec<ReportMethod> {
        let mut out: Vec<ReportMethod> = Method::gated().map(ReportMethod::Estimator).collect();
        if disturbance {
            out.extend([ReportMethod::IteratedForce, ReportMethod::DirectForce]);
        }
        out
    }

    /// What this row ignores by design, when it does: a non-dissipative estimate there is
    /// that model error's doing, not the polynomial degree's.
    pub fn ignores(&self) -> Option<&'static str> {
        match self {
            ReportMethod::WeakWhiteNaive => Some("the filtered forces' spectra (each force taken as white)"),
            ReportMethod::Step0 => Some("the unmeasured disturbance (the paper's step 0)"),
            ReportMethod::PzMeasured => Some("the filtered forces' spectra (the paper's white-noise model of them)"),
            _ => None,
        }
    }

    /// The name reports and scenarios use, e.g. `strong-marginals`, `weak [linear]`.
    pub fn name(&self) -> String {
        match self {
            ReportMethod::Estimator(m) => m.name().to_string(),
            ReportMethod::WeakWhiteNaive => "weak-white-naive".into(),
            ReportMethod::Compare(n) => format!("weak [{n}]"),
            ReportMethod::Step0 => "step-0".into(),
            ReportMethod::Step => "step".into(),
            ReportMethod::Iterated => "iterated".into(),
            ReportMethod::IteratedForce => "iterated-force".into(),
            ReportMethod::DirectForce => "direct-force".into(),
            ReportMethod::PzMeasured => "pz-measured".into(),
            ReportMethod::PzMeasuredForce => "pz-measured-force".into(),
        }
    }
}

impl std::fmt::Display for ReportMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // `pad`, so that widths and alignment in format strings apply.
        f.pad(&self.name())
    }
}

impl serde::Serialize for ReportMethod {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.name())
    }
}

impl PartialEq<&str> for ReportMethod {
    fn eq(&self, other: &&str) -> bool {
        self.name() == *other
    }
}

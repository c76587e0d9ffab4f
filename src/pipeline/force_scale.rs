//! The scale of the measured forces, checked against the known masses (docs/methods.md,
//! "Checks", **force scale**): on measured data whose every force is measured, the force
//! regression with every mass unknown (each fixed by its equation's residual times its
//! known force, `ident::baseline`) says what mass the forces and the accelerations imply.
//! A mass several times the declared one, or below zero, is a force column in other
//! units than the model's (kN for N), a force cell or an accelerometer mounted the other
//! way, or a wrong mass — and every estimate that reads the force, its spectrum or the
//! mass inherits it, while the estimates themselves stay consistent with each other.

use crate::estimators::Setup;
use crate::ident::accumulate::{Accumulator, Sample};
use crate::ident::baseline::Increments;
use crate::ident::{Problem, Specification, Unknown};
use crate::report::FailedCheck;

/// A declared mass fails when the implied one is further than this factor from it (either
/// way) and [`SCALE_SE`] standard errors: far above the implied mass's bias from
/// accelerations derived at coarse sampling (+3.3 % on the Silverbox twin at nine samples
/// a period, docs/methods.md), far below the factors a unit slip makes (10³ for kN, 9.81
/// for an accelerometer in g).
pub const SCALE_FACTOR: f64 = 1.5;

/// Standard errors the implied mass must also be from the declared one.
pub const SCALE_SE: f64 = 4.0;

/// The force regression with every mass unknown, fed the second pass's samples.
pub(crate) struct ForceScale {
    regression: Increments,
    problem: Problem,
}

impl ForceScale {
    /// The check of `setup`'s measured data under `spec`, where it applies: measured data
    /// holding every force, every mass known (an unknown mass is estimated, not checked).
    pub(crate) fn new(setup: &Setup, spec: &Specification, placeholder: &[crate::ident::Filter]) -> Option<ForceScale> {
        let present = setup.measured?;
        let layout = spec.model.columns();
        let forces = (0..spec.model.excitations.len()).all(|e| present[layout.force(e)]);
        if !spec.unknown_masses.is_empty() || !forces {
            return None;
        }
        let mut free = spec.whitened(placeholder);
        free.unknown_masses = (0..spec.model.masses()).collect();
        let problem = Problem::from_spec_unchecked(&free, &[]).ok()?;
        let regression = crate::estimators::force_regression(setup, &problem).ok()?;
        Some(ForceScale { regression, problem })
    }

    /// The failed check, if an implied mass contradicts its declared value; `identified`:
    /// the identification's problem and its column scales, whose coefficients this
    /// problem shares (else nothing is checked).
    pub(crate) fn verdict(&self, (identified, typical): (&Problem, &[f64])) -> Option<FailedCheck> {
        let p = &self.problem;
        let rc = p.coefficient_count();
        if identified.unknowns.get(..rc) != Some(&p.unknowns[..rc]) {
            return None;
        }
        let mut scales = typical[..rc].to_vec();
        scales.extend(p.start[scales.len()..].iter().map(|m| m.abs()));
        let est = self.regression.estimate(&scales).ok()?;
        let off: Vec<String> = (p.unknowns.iter().enumerate())
            .filter_map(|(k, u)| {
                let Unknown::Mass(i) = *u else { return None };
                let (declared, implied, se) = (p.model.mass[i], est.values[k], est.std_error[k]);
                let ratio = implied / declared;
                let far = !(1.0 / SCALE_FACTOR..=SCALE_FACTOR).contains(&ratio);
                let certain = !se.is_finite() || (implied - declared).abs() > SCALE_SE * se;
                (far && certain).then(|| {
                    format!(
                        "{} = {implied:.4e} ± {se:.1e} for the declared {declared} (a factor {ratio:.4})",
                        p.names[k]
                    )
                })
            })
            .collect();
        (!off.is_empty()).then(|| FailedCheck {
            check: "force scale",
            method: "force-regression".into(),
            message: format!(
                "the measured forces and accelerations imply other masses than the model's: {} — a force or \
                 acceleration column in other units than the model's (kN for N: [data.scale]), a force cell or \
                 an accelerometer mounted the other way (a negative factor), or a wrong mass; every estimate \
                 that reads the force or the mass inherits the factor",
                off.join("; ")
            ),
        })
    }
}

impl Accumulator for ForceScale {
    fn push(&mut self, s: &Sample) {
        self.regression.push(s.trajectory as usize, s.t, s.batch, s.row);
    }

    fn finish(&mut self) {
        self.regression.finish();
    }
}

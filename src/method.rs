//! Which identification methods there are: each method's identity (its name in scenarios,
//! the CLI, Python, studies and reports, its kind and the terms it takes), below every
//! other module so that a scenario can name a method without reaching up to the
//! estimators that build it (docs/architecture.md, "Layers").
//!
//! `registry!` is the one list of methods. This module makes [`Method`] from it; the
//! estimators' module (`estimators/mod.rs`) makes each method's constructor from the same
//! list, so that adding a method is one line here and one file among the estimators.

/// The registry: one line per method — its variant, name, kind, the terms it takes and
/// the module of `estimators` whose `build` makes its estimator. Handed to a macro that
/// makes something of each line (`registry!(callback)`).
use std::str::FromStr;

macro_rules! registry {
    ($then:ident) => {
        $then! {
            /// Weak form: stationarity of test-function expectations from raw moments (docs/theory.md §5).
            Weak = "weak", Fpk, Any, weak;
            /// Strong form: the paper's FPK residual (3.8) point by point, from kernel estimates of the
            /// density and its fluxes (or the paper's histogram, `StrongDensity::Histogram`).
            Strong = "strong", Fpk, Any, strong;
            /// Strong form with the joint density replaced by the product of its marginals (3.21).
            StrongMarginals = "strong-marginals", Fpk, Any, marginals;
            /// Weak form with the measured forces as inputs, so no model of their spectrum (docs/methods.md).
            /// It takes any band-limited force (a multisine, band-limited noise) and an unknown mass.
            WeakMeasuredForce = "weak-measured-force", Fpk, Polynomial, weak_measured_force;
            /// Baseline (not FPK): regression of velocity increments on the drift (Euler pseudo-likelihood).
            Increments = "increments", Baseline, Any, increments;
            /// Baseline (not FPK): binned conditional mean increments (Kramers–Moyal), then the drift.
            KramersMoyal = "kramers-moyal", Baseline, Polynomial, kramers_moyal;
            /// Baseline (not FPK): the local-linearisation (Shoji–Ozaki) quasi-likelihood of the sample
            /// pairs, exact in the interval for a linear system.
            LocalLinear = "local-linear", Baseline, Polynomial, local_linear;
            /// Oracle bound (not FPK): the equation error with the measured excitation forces.
            ForceRegression = "force-regression", Oracle, Any, force_regression;
        }
    };
}
pub(crate) use registry;

/// What a method is: an FPK estimator (the only kind a regression gate may hold), a
/// baseline on the same samples, or an oracle bound that uses information the FPK
/// methods never have.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Fpk,
    Baseline,
    Oracle,
}

/// Which characteristic terms an estimator takes: any [`crate::model::Term`] (through the
/// generalised moments of [`crate::ident::Atom`]s), or only terms with a polynomial form.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Terms {
    Any,
    Polynomial,
}

/// The identity part of the registry: [`Method`] with its name, kind, help and terms.
macro_rules! identities {
    ($( $(#[doc = $doc:literal])+ $variant:ident = $name:literal, $kind:ident, $terms:ident, $module:ident; )+) => {
        /// An identification method (`[identify] methods`, `--method`): one line of the
        /// registry in `method.rs`.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub enum Method {
            $( $(#[doc = $doc])+ $variant, )+
        }

        impl Method {
            /// Every method, in the registry's order.
            pub const REGISTERED: &'static [Method] = &[$(Method::$variant),+];

            /// The name scenarios, the CLI, Python and reports use.
            pub fn name(self) -> &'static str {
                match self { $(Method::$variant => $name,)+ }
            }

            /// An FPK estimator, a baseline or an oracle.
            pub fn kind(self) -> Kind {
                match self { $(Method::$variant => Kind::$kind,)+ }
            }

            /// One line on what it is (the first line of its registry entry's doc).
            pub fn help(self) -> &'static str {
                match self { $(Method::$variant => [$($doc),+][0].trim(),)+ }
            }

            /// Which terms it takes.
            pub fn terms(self) -> Terms {
                match self { $(Method::$variant => Terms::$terms,)+ }
            }
        }
    };
}

registry!(identities);

impl Method {
    /// The methods a regression gate may hold: the FPK estimators, but for the paper's
    /// product-of-marginals simplification (3.21), which is known to miss (by about 95 %
    /// on the shipped two-mass and bushing cases) and is reported to show what it costs,
    /// as a comparison: a gate on it would call a known failure "within".
    pub fn gated() -> impl Iterator<Item = Method> {
        Method::REGISTERED.iter().copied().filter(|m| m.is_gated())
    }

    /// Whether a regression gate holds it ([`Method::gated`]).
    pub fn is_gated(self) -> bool {
        self.kind() == Kind::Fpk && self != Method::StrongMarginals
    }

    /// Whether it is compared, never gated (a baseline or an oracle).
    pub fn is_baseline(self) -> bool {
        self.kind() != Kind::Fpk
    }

    /// Whether it reads the measured forces themselves, so needs no model of their
    /// spectrum (a force model the data reject refuses every other method).
    pub fn reads_measured_force(self) -> bool {
        matches!(self, Method::ForceRegression | Method::WeakMeasuredForce)
    }

    /// Whether its estimator reads the samples in the passes after the first: every one
    /// does but the weak form's, which reads the first pass's moments (an identification
    /// by the weak form alone keeps no samples for later passes).
    pub fn reads_samples(self) -> bool {
        self != Method::Weak
    }

    /// Every name, for messages: `weak, strong, …`.
    pub fn names() -> String {
        Method::REGISTERED
            .iter()
            .map(|m| m.name())
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Method, String> {
        Method::REGISTERED
            .iter()
            .copied()
            .find(|m| m.name() == s)
            .ok_or_else(|| format!("unknown method {s:?}: the methods are {}", Method::names()))
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(self.name())
    }
}

impl<'de> serde::Deserialize<'de> for Method {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Method, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(|_| {
            let names: Vec<String> = Method::REGISTERED.iter().map(|m| format!("`{}`", m.name())).collect();
            serde::de::Error::custom(format!("unknown method `{s}`, expected one of {}", names.join(", ")))
        })
    }
}

impl serde::Serialize for Method {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_method_round_trips_through_its_name() {
        for &m in Method::REGISTERED {
            assert_eq!(m.name().parse::<Method>(), Ok(m));
            assert_eq!(m.to_string(), m.name());
            assert!(!m.help().is_empty() && !m.help().contains('\n'), "{m}: {:?}", m.help());
        }
        let err = "Weak".parse::<Method>().unwrap_err();
        assert!(err.contains("weak, strong, strong-marginals"), "{err}");
        let names: std::collections::BTreeSet<_> = Method::REGISTERED.iter().map(|m| m.name()).collect();
        assert_eq!(names.len(), Method::REGISTERED.len(), "a name is registered twice");
    }

    #[test]
    fn only_fpk_estimators_are_gated() {
        let gated: Vec<_> = Method::gated().collect();
        assert_eq!(gated, [Method::Weak, Method::Strong, Method::WeakMeasuredForce]);
        assert!(Method::ForceRegression.is_baseline() && Method::Increments.is_baseline());
    }
}

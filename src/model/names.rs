//! Parameter names as reports, plots and the log's truth record write them: `m[m1]`,
//! `k3[ground-m1]`, `c1[m1-m2]`, `sigma[m1]`, `A[P]`, `B[P]`. Formatted and parsed here
//! only; everything else handles a [`ParameterName`].

use super::{Characteristic, Term};
use crate::scenario::Curve;
use std::collections::BTreeMap;
use std::fmt;
use std::str::FromStr;

/// A parameter of the system, named by the mass, link or excitation it belongs to.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ParameterName {
    /// `m[<mass>]`: a mass (or moment of inertia).
    Mass(String),
    /// `k<t>[<link>]` or `c<t>[<link>]`: the coefficient of term `t` in the link's stiffness
    /// `K(u)` or damping `C(w)`: `k3[ground-m1]` multiplies `u³` (3.3).
    Coefficient {
        kind: Characteristic,
        term: Term,
        link: String,
    },
    /// `sigma[<excitation>]`: the intensity of a white excitation.
    Intensity(String),
    /// `A[<excitation>]`: the noise gain of a filtered excitation (3.20).
    FilterGain(String),
    /// `B[<excitation>]`: the corner of a filtered excitation (3.20).
    Corner(String),
}

impl fmt::Display for ParameterName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParameterName::Mass(m) => write!(f, "m[{m}]"),
            ParameterName::Coefficient { kind, term, link } => write!(f, "{}{term}[{link}]", kind.symbol()),
            ParameterName::Intensity(e) => write!(f, "sigma[{e}]"),
            ParameterName::FilterGain(e) => write!(f, "A[{e}]"),
            ParameterName::Corner(e) => write!(f, "B[{e}]"),
        }
    }
}

impl FromStr for ParameterName {
    type Err = String;

    fn from_str(s: &str) -> Result<ParameterName, String> {
        let bad = || {
            format!("{s:?} is not a parameter name (m[mass], k<p>[link], c<q>[link], sigma[excitation], A[excitation] or B[excitation])")
        };
        let (head, rest) = s.split_once('[').ok_or_else(bad)?;
        let owner = rest
            .strip_suffix(']')
            .filter(|o| !o.is_empty() && !o.contains(['[', ']']))
            .ok_or_else(bad)?;
        let owner = owner.to_string();
        Ok(match head {
            "m" => ParameterName::Mass(owner),
            "sigma" => ParameterName::Intensity(owner),
            "A" => ParameterName::FilterGain(owner),
            "B" => ParameterName::Corner(owner),
            _ => {
                let kind = match head.chars().next() {
                    Some('k') => Characteristic::Stiffness,
                    Some('c') => Characteristic::Damping,
                    _ => return Err(bad()),
                };
                let term = head[1..].parse().map_err(|_| bad())?;
                ParameterName::Coefficient {
                    kind,
                    term,
                    link: owner,
                }
            }
        })
    }
}

/// True parameter values by name: what a log's `fpkbench.truth` record holds. The one
/// source the pipeline grades against; the identifier never sees it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Truth(BTreeMap<ParameterName, f64>);

impl Truth {
    /// From `(name, value)` pairs as a log or [`crate::Scenario::truth`] gives them.
    pub fn from_pairs(pairs: &[(String, f64)]) -> Result<Truth, String> {
        let mut t = BTreeMap::new();
        for (name, v) in pairs {
            t.insert(name.parse()?, *v);
        }
        Ok(Truth(t))
    }

    /// The true value of `name`, if the truth has it.
    pub fn get(&self, name: &ParameterName) -> Option<f64> {
        self.0.get(name).copied()
    }

    /// The true value of the parameter named `name` as written in a report: a coefficient
    /// the true system does not have is 0; a name that is no parameter (e.g. a product of
    /// unknowns) or a mass or excitation parameter the truth lacks has none.
    pub fn of(&self, name: &str) -> Option<f64> {
        let n: ParameterName = name.parse().ok()?;
        match (self.get(&n), &n) {
            (Some(v), _) => Some(v),
            (None, ParameterName::Coefficient { .. }) => Some(0.0),
            (None, _) => None,
        }
    }

    /// The true characteristic `K(u)` or `C(w)` of the link named `link`, term by term
    /// (empty when the link has none).
    pub fn characteristic(&self, link: &str, kind: Characteristic) -> Curve {
        let terms = self
            .0
            .iter()
            .filter_map(|(n, &v)| match n {
                ParameterName::Coefficient { kind: k, term, link: l } if *k == kind && l == link => Some((*term, v)),
                _ => None,
            })
            .collect();
        Curve { terms }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_of_name_parses_back_to_itself() {
        for s in [
            "m[m1]",
            "k3[ground-m1]",
            "c1[m1-m2]",
            "k12[a_b]",
            "sigma[m1]",
            "A[P]",
            "B[p_z]",
        ] {
            let n: ParameterName = s.parse().unwrap();
            assert_eq!(n.to_string(), s);
        }
        assert_eq!(
            "c2[ground-m2]".parse::<ParameterName>().unwrap(),
            ParameterName::Coefficient {
                kind: Characteristic::Damping,
                term: Term::Power(2),
                link: "ground-m2".into()
            }
        );
    }

    #[test]
    fn malformed_names_are_refused() {
        for s in [
            "", "m1", "k[m1]", "kx[m1]", "q1[m1]", "m[]", "m[m1", "m[a[b]]", "k-1[m1]",
        ] {
            assert!(s.parse::<ParameterName>().is_err(), "{s:?} was accepted");
        }
    }
}

//! Parameter names as reports, plots and the log's truth record write them: `m[m1]`,
//! `k3[ground-m1]`, `c1[m1-m2]`, `sigma[m1]`, `A[P]`, `B[P]`, and the names of a problem's
//! unknowns that are not parameters (`B[P]*k1[m1-m2]`, `drift[m1]:x_m1*v_m1`). Formatted
//! here only, and parsed only from a log's truth record; everything else, from the problem
//! to the report's rows, handles a [`ParameterName`] or an [`UnknownName`].

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

/// The name of one unknown of an identification problem, carried from the problem through
/// the estimate into the report's rows (written as text only when printed or serialized).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum UnknownName {
    /// A parameter of the system.
    Parameter(ParameterName),
    /// The product of an unknown corner and a coefficient, `B[P]*k1[m1-m2]`: what the data
    /// determine when both are unknown (docs/theory.md §6).
    Product(ParameterName, ParameterName),
    /// A coefficient of the drift's monomial form on `mass`: `drift[m1]:x_m1*v_m1`.
    Monomial { mass: String, monomial: String },
}

impl UnknownName {
    /// The system parameter this unknown is, if it is one.
    pub fn parameter(&self) -> Option<&ParameterName> {
        match self {
            UnknownName::Parameter(p) => Some(p),
            _ => None,
        }
    }
}

impl From<ParameterName> for UnknownName {
    fn from(p: ParameterName) -> UnknownName {
        UnknownName::Parameter(p)
    }
}

impl fmt::Display for UnknownName {
    /// The name as reports write it, padded to a width where one is asked for.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let text = match self {
            UnknownName::Parameter(p) => p.to_string(),
            UnknownName::Product(a, b) => format!("{a}*{b}"),
            UnknownName::Monomial { mass, monomial } => format!("drift[{mass}]:{monomial}"),
        };
        f.pad(&text)
    }
}

impl serde::Serialize for UnknownName {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl PartialEq<str> for UnknownName {
    /// Whether `other` is this name as written.
    fn eq(&self, other: &str) -> bool {
        /// What is left of `other` after the name's text so far (`None`: no match).
        struct Rest<'a>(Option<&'a str>);
        impl fmt::Write for Rest<'_> {
            fn write_str(&mut self, s: &str) -> fmt::Result {
                self.0 = self.0.and_then(|r| r.strip_prefix(s));
                Ok(())
            }
        }
        let mut rest = Rest(Some(other));
        fmt::write(&mut rest, format_args!("{self}")).is_ok() && rest.0 == Some("")
    }
}

impl PartialEq<&str> for UnknownName {
    fn eq(&self, other: &&str) -> bool {
        self == *other
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

    /// The true value of the unknown `name`: a product's is the product of its factors'; a
    /// monomial of the drift has none.
    pub fn of(&self, name: &UnknownName) -> Option<f64> {
        match name {
            UnknownName::Parameter(p) => self.parameter(p),
            UnknownName::Product(a, b) => Some(self.parameter(a)? * self.parameter(b)?),
            UnknownName::Monomial { .. } => None,
        }
    }

    /// The true value of the parameter `n`: NaN on a characteristic whose truth has a NaN
    /// (none is known); a coefficient the true system does not have is 0, unless its term has a position (a profiled gap) and the true characteristic has
    /// exactly one term of that kind at another position, whose coefficient it is; a mass
    /// or excitation parameter the truth lacks has none.
    fn parameter(&self, n: &ParameterName) -> Option<f64> {
        if let ParameterName::Coefficient { kind, link, .. } = n {
            // A characteristic without a truth (a hysteretic link's) has none for any term.
            let unknown = self.0.iter().any(|(m, v)| {
                v.is_nan() && matches!(m, ParameterName::Coefficient { kind: k, link: l, .. } if k == kind && l == link)
            });
            if unknown {
                return Some(f64::NAN);
            }
        }
        match (self.get(n), n) {
            (Some(v), _) => Some(v),
            (None, ParameterName::Coefficient { kind, term, link }) if term.position().is_some() => {
                let same_kind: Vec<f64> = self
                    .0
                    .iter()
                    .filter_map(|(m, &v)| match m {
                        ParameterName::Coefficient {
                            kind: k,
                            term: t,
                            link: l,
                        } if k == kind && l == link && std::mem::discriminant(t) == std::mem::discriminant(term) => {
                            Some(v)
                        }
                        _ => None,
                    })
                    .collect();
                Some(if same_kind.len() == 1 { same_kind[0] } else { 0.0 })
            }
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
    fn unknown_names_write_as_reports_do_and_truths_value_them() {
        let k1: ParameterName = "k1[m1-m2]".parse().unwrap();
        let b = ParameterName::Corner("P".into());
        let product = UnknownName::Product(b.clone(), k1.clone());
        let monomial = UnknownName::Monomial {
            mass: "m1".into(),
            monomial: "x_m1*v_m1".into(),
        };
        assert_eq!(product.to_string(), "B[P]*k1[m1-m2]");
        assert_eq!(monomial.to_string(), "drift[m1]:x_m1*v_m1");
        assert_eq!(format!("|{:<16}|", UnknownName::from(k1.clone())), "|k1[m1-m2]       |");
        assert!(product == "B[P]*k1[m1-m2]" && product != "B[P]*k1[m1-m2]x" && product != "B[P]");
        assert_eq!(serde_json::to_string(&product).unwrap(), "\"B[P]*k1[m1-m2]\"");
        let truth = Truth::from_pairs(&[("k1[m1-m2]".into(), 10.0), ("B[P]".into(), 2.0)]).unwrap();
        assert_eq!(truth.of(&product), Some(20.0));
        assert_eq!(
            truth.of(&"k3[m1-m2]".parse::<ParameterName>().unwrap().into()),
            Some(0.0)
        );
        assert_eq!(truth.of(&monomial), None);
        assert_eq!(truth.of(&ParameterName::Mass("m1".into()).into()), None);
    }

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

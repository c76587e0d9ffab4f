//! The terms a link's characteristic is a sum of: `K(u) = Σ k_t t(u)` and `C(w) = Σ c_t t(w)`,
//! each term `t` a function of the link's relative displacement `u` (stiffness) or velocity
//! `w` (damping) with its own coefficient (docs/theory.md §1). The paper's characteristics
//! (3.3) are power polynomials, so today every term is a [`Term::Power`]; the identification
//! stays linear in the coefficients whatever the term is.
//!
//! A term says what it is worth ([`Term::value`]) and how fast it changes ([`Term::slope`],
//! which the filtered-noise drift (3.24) needs), how it is written in names and scenario keys
//! (`Display`/`FromStr`: the `3` of `k3[ground-m1]`), its polynomial form where it has one
//! ([`Term::power`]: the fast simulation kernels and the raw-moment estimators use it), how
//! it grows ([`Term::degree`], which scales coefficients for the solvers and the grading) and
//! whether it is odd ([`Term::is_odd`], which the stationarity physics asks).

use std::fmt;
use std::str::FromStr;

/// One term of a characteristic.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Term {
    /// `z^p`, `p ≥ 1` (3.3).
    Power(u32),
}

impl Term {
    /// The highest power a scenario or model may use.
    pub const MAX_POWER: u32 = 15;

    /// `t(z)`.
    #[inline]
    pub fn value(self, z: f64) -> f64 {
        match self {
            Term::Power(p) => z.powi(p as i32),
        }
    }

    /// `t'(z)`.
    #[inline]
    pub fn slope(self, z: f64) -> f64 {
        match self {
            Term::Power(p) => p as f64 * z.powi(p as i32 - 1),
        }
    }

    /// The power `p` if the term is `z^p`: the polynomial form that the shaped simulation
    /// kernels, the moment equations and the raw-moment estimators are built on.
    pub fn power(self) -> Option<u32> {
        match self {
            Term::Power(p) => Some(p),
        }
    }

    /// How the term grows with the size of its argument: `|t(λz)| ≈ λ^degree |t(z)|`. A
    /// coefficient of this term has the unit of a force over `z^degree`, which is how the
    /// solvers scale it and the grading weighs it.
    pub fn degree(self) -> u32 {
        match self {
            Term::Power(p) => p,
        }
    }

    /// Whether `t(−z) = −t(z)`: an odd term pushes back symmetrically, which the
    /// stationarity conditions (3.4) ask of a link's leading terms.
    pub fn is_odd(self) -> bool {
        match self {
            Term::Power(p) => p % 2 == 1,
        }
    }

    /// The term in a formula of the variable `var`: `u`, `w³`, `u^7`.
    pub fn written(self, var: &str) -> String {
        match self {
            Term::Power(p) => {
                let sup = match p {
                    1 => String::new(),
                    2 => "²".into(),
                    3 => "³".into(),
                    5 => "⁵".into(),
                    p => format!("^{p}"),
                };
                format!("{var}{sup}")
            }
        }
    }

    /// What the term is called in messages: `power 3`.
    pub fn describe(self) -> String {
        match self {
            Term::Power(p) => format!("power {p}"),
        }
    }
}

impl fmt::Display for Term {
    /// The term as a name writes it after `k` or `c`: `3` in `k3[ground-m1]`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Term::Power(p) => write!(f, "{p}"),
        }
    }
}

/// In JSON (reports, study rows) a power is its number, as the name writes it.
impl serde::Serialize for Term {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match *self {
            Term::Power(p) => s.serialize_u32(p),
        }
    }
}

impl FromStr for Term {
    type Err = String;

    /// The inverse of `Display`: `3` is `z³`. Anything else is refused with what is allowed.
    fn from_str(s: &str) -> Result<Term, String> {
        if !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()) {
            if let Ok(p) = s.parse::<u32>() {
                if (1..=Term::MAX_POWER).contains(&p) {
                    return Ok(Term::Power(p));
                }
            }
        }
        Err(format!(
            "power {s:?} is not allowed: powers are whole numbers 1..={}",
            Term::MAX_POWER
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_term_reads_back_what_it_writes() {
        for p in 1..=Term::MAX_POWER {
            let t = Term::Power(p);
            assert_eq!(t.to_string().parse::<Term>(), Ok(t));
        }
        for bad in ["", "0", "16", "-1", "+3", "3.0", "x", "01x"] {
            assert!(bad.parse::<Term>().is_err(), "{bad:?} was accepted");
        }
    }

    #[test]
    fn a_power_is_worth_its_value_and_slope() {
        let z = -1.7_f64;
        for p in 1..=9 {
            let t = Term::Power(p);
            assert_eq!(t.value(z), z.powi(p as i32));
            // The slope against a central difference.
            let h = 1e-6;
            let fd = (t.value(z + h) - t.value(z - h)) / (2.0 * h);
            assert!((t.slope(z) - fd).abs() <= 1e-6 * fd.abs().max(1.0), "p = {p}");
            assert_eq!(t.is_odd(), t.value(-z) == -t.value(z));
            assert_eq!((t.power(), t.degree()), (Some(p), p));
        }
    }
}

//! The terms a link's characteristic is a sum of: `K(u) = Σ k_t t(u)` and `C(w) = Σ c_t t(w)`,
//! each term `t` a function of the link's relative displacement `u` (stiffness) or velocity
//! `w` (damping) with its own coefficient (docs/theory.md §1, docs/scenario.md "Terms"). The
//! paper's characteristics (3.3) are power polynomials ([`Term::Power`]); real mounts add
//! dry friction, fluid damping, clearances, saturation and shapes known only by a few knots,
//! each still linear in its coefficient, so the identification stays linear whatever the
//! term is.
//!
//! A term says what it is worth ([`Term::value`]) and how fast it changes ([`Term::slope`],
//! which the filtered-noise drift (3.24) needs, and which only a continuous term has:
//! [`Term::is_continuous`]), how it is written in names and scenario keys (`Display`/
//! `FromStr`: the `3` of `k3[ground-m1]`, the `sign` of `csign[ground-m1]`), its polynomial
//! form where it has one ([`Term::power`]: the fast simulation kernels and the raw-moment
//! estimators use it), the unit of its coefficient ([`Term::degree`]: force over `z^degree`,
//! which scales coefficients for the solvers and the grading), how it behaves far out
//! ([`Term::far`]: the stationarity physics) and whether it is odd ([`Term::is_odd`]).

use std::cmp::Ordering;
use std::fmt;
use std::hash::{Hash, Hasher};
use std::str::FromStr;

/// A term's given position (a gap, a saturation amplitude, a knot), in the unit of its
/// argument: a finite number compared, ordered and hashed by its value (`-0` is `0`), so
/// terms can key maps and be sorted.
#[derive(Debug, Clone, Copy)]
pub struct Level(f64);

impl Level {
    /// `x`, if finite.
    pub fn new(x: f64) -> Option<Level> {
        x.is_finite().then_some(Level(x + 0.0))
    }
    pub fn get(self) -> f64 {
        self.0
    }
}

impl PartialEq for Level {
    fn eq(&self, other: &Level) -> bool {
        self.0.to_bits() == other.0.to_bits()
    }
}
impl Eq for Level {}
impl Hash for Level {
    fn hash<H: Hasher>(&self, h: &mut H) {
        self.0.to_bits().hash(h);
    }
}
impl PartialOrd for Level {
    fn partial_cmp(&self, other: &Level) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Level {
    fn cmp(&self, other: &Level) -> Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// One term of a characteristic, a function `t(z)` of the link's `u` or `w`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Term {
    /// `z^p`, `p ≥ 1` (3.3). Written `p`.
    Power(u32),
    /// `|z|^(p−1)·z` for an even `p` (an odd `p` is the power itself): the signed power,
    /// `|w|·w` being quadratic (fluid, orifice) damping. Written `abs<p>`.
    SignedPower(u32),
    /// `sgn z`: Coulomb (dry) friction `F·sgn w` with the friction force `F` its coefficient.
    /// Written `sign`.
    Sign,
    /// `sgn z · max(|z| − g, 0)` for a given gap `g > 0`: a clearance (dead zone) spring,
    /// and with a large coefficient an end stop. Written `gap(<g>)`.
    DeadZone(Level),
    /// `z₀ · tanh(z / z₀)` for a given `z₀ > 0`: a saturating spring, of slope 1 at the
    /// origin and force `k z₀` far out. Written `tanh(<z0>)`.
    Tanh(Level),
    /// The hinge at a given knot `a ≠ 0`: `max(z − a, 0)` for `a > 0`, `min(z − a, 0)` for
    /// `a < 0`, zero at the origin either way. With `z` itself, hinges at given knots span
    /// the piecewise-linear characteristics through the origin with those knots: the
    /// non-parametric curve for when the shape is unknown. Written `hinge(<a>)`.
    Hinge(Level),
}

/// Which way a term grows far out along `sgn z = s`: `|t(z)| ≈ scale · |z|^growth`,
/// `t(z) ≈ coefficient · |z|^growth` there ([`Term::far`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Far {
    pub growth: u32,
    pub coefficient: f64,
}

impl Term {
    /// The highest power a scenario or model may use.
    pub const MAX_POWER: u32 = 15;

    /// `t(z)`.
    #[inline]
    pub fn value(self, z: f64) -> f64 {
        match self {
            Term::Power(p) => z.powi(p as i32),
            Term::SignedPower(p) => z.abs().powi(p as i32 - 1) * z,
            Term::Sign => sign(z),
            Term::DeadZone(g) => sign(z) * (z.abs() - g.0).max(0.0),
            Term::Tanh(z0) => z0.0 * (z / z0.0).tanh(),
            Term::Hinge(a) if a.0 > 0.0 => (z - a.0).max(0.0),
            Term::Hinge(a) => (z - a.0).min(0.0),
        }
    }

    /// `t'(z)`, where the term has one: a continuous term's slope is a function (piecewise
    /// at a kink, where the side towards the origin is taken); [`Term::Sign`] has none
    /// (its derivative is a Dirac mass at 0), and 0 is returned.
    #[inline]
    pub fn slope(self, z: f64) -> f64 {
        match self {
            Term::Power(p) => p as f64 * z.powi(p as i32 - 1),
            Term::SignedPower(p) => p as f64 * z.abs().powi(p as i32 - 1),
            Term::Sign => 0.0,
            Term::DeadZone(g) => f64::from(u8::from(z.abs() > g.0)),
            Term::Tanh(z0) => {
                let t = (z / z0.0).tanh();
                1.0 - t * t
            }
            Term::Hinge(a) if a.0 > 0.0 => f64::from(u8::from(z > a.0)),
            Term::Hinge(a) => f64::from(u8::from(z < a.0)),
        }
    }

    /// Whether `t` is continuous, so that its slope is a function and the force's time
    /// derivative (the filtered-noise layout (3.24)) exists: all but [`Term::Sign`].
    pub fn is_continuous(self) -> bool {
        self != Term::Sign
    }

    /// The given position of a term that has one: a gap, a saturation amplitude `z₀`, a
    /// knot. It is not linear in the data, so it is given, or profiled (docs/scenario.md).
    pub fn position(self) -> Option<f64> {
        match self {
            Term::DeadZone(x) | Term::Tanh(x) | Term::Hinge(x) => Some(x.0),
            _ => None,
        }
    }

    /// The same kind of term at the position `x`, if it has positions and `x` is one it may
    /// take (a gap or `z₀` positive, a knot on the same side of 0).
    pub fn at_position(self, x: f64) -> Option<Term> {
        let l = Level::new(x)?;
        match self {
            Term::DeadZone(_) if x > 0.0 => Some(Term::DeadZone(l)),
            Term::Tanh(_) if x > 0.0 => Some(Term::Tanh(l)),
            Term::Hinge(a) if x != 0.0 && (x > 0.0) == (a.0 > 0.0) => Some(Term::Hinge(l)),
            _ => None,
        }
    }

    /// The power `p` if the term is `z^p`: the polynomial form that the shaped simulation
    /// kernels, the moment equations and the raw-moment estimators are built on.
    pub fn power(self) -> Option<u32> {
        match self {
            Term::Power(p) => Some(p),
            _ => None,
        }
    }

    /// The unit of the term's coefficient: a force over `z^degree` (a friction force has
    /// degree 0; a gap's, a saturation's and a hinge's coefficient is a stiffness or damping
    /// rate, degree 1). The solvers scale a coefficient and the grading weighs it by it.
    pub fn degree(self) -> u32 {
        match self {
            Term::Power(p) | Term::SignedPower(p) => p,
            Term::Sign => 0,
            Term::DeadZone(_) | Term::Tanh(_) | Term::Hinge(_) => 1,
        }
    }

    /// How the term behaves far out on the side `s` (`±1`) of the origin: its growth and
    /// the factor of `|z|^growth` it tends to (0 where it vanishes: a hinge on its other
    /// side). The stationarity conditions (3.4) ask whether the leading behaviour on each
    /// side restores (stiffness) or dissipates (damping).
    pub fn far(self, s: f64) -> Far {
        let (growth, coefficient) = match self {
            Term::Power(p) => (p, s.powi(p as i32)),
            Term::SignedPower(p) => (p, s),
            Term::Sign => (0, s),
            Term::DeadZone(_) => (1, s),
            Term::Tanh(z0) => (0, s * z0.0),
            Term::Hinge(a) => (1, if (a.0 > 0.0) == (s > 0.0) { s } else { 0.0 }),
        };
        Far { growth, coefficient }
    }

    /// Whether `t(−z) = −t(z)`: an odd term pushes back symmetrically, which the
    /// stationarity conditions (3.4) ask of a link's leading terms.
    pub fn is_odd(self) -> bool {
        match self {
            Term::Power(p) => p % 2 == 1,
            Term::Hinge(_) => false,
            _ => true,
        }
    }

    /// The term in a formula of the variable `var`: `u`, `w³`, `u^7`, `|w|·w`, `sgn w`,
    /// `gap(u; 0.05)`, `0.2·tanh(u/0.2)`, `(w − 0.5)₊`.
    pub fn written(self, var: &str) -> String {
        let sup = |p: u32| match p {
            1 => String::new(),
            2 => "²".into(),
            3 => "³".into(),
            5 => "⁵".into(),
            p => format!("^{p}"),
        };
        match self {
            Term::Power(p) => format!("{var}{}", sup(p)),
            Term::SignedPower(p) => format!("|{var}|{}·{var}", sup(p - 1)),
            Term::Sign => format!("sgn {var}"),
            Term::DeadZone(g) => format!("gap({var}; {})", g.0),
            Term::Tanh(z0) => format!("{0}·tanh({var}/{0})", z0.0),
            Term::Hinge(a) if a.0 > 0.0 => format!("({var} − {})₊", a.0),
            Term::Hinge(a) => format!("({var} + {})₋", -a.0),
        }
    }

    /// What the term is called in messages: `power 3`, `Coulomb friction sign`.
    pub fn describe(self) -> String {
        match self {
            Term::Power(p) => format!("power {p}"),
            Term::SignedPower(p) => format!("signed power abs{p}"),
            Term::Sign => "Coulomb friction term sign".into(),
            Term::DeadZone(g) => format!("clearance term gap({})", g.0),
            Term::Tanh(z0) => format!("saturation term tanh({})", z0.0),
            Term::Hinge(a) => format!("hinge term hinge({})", a.0),
        }
    }
}

/// `sgn z` with `sgn 0 = 0`.
#[inline]
fn sign(z: f64) -> f64 {
    if z > 0.0 {
        1.0
    } else if z < 0.0 {
        -1.0
    } else {
        0.0
    }
}

impl fmt::Display for Term {
    /// The term as a name writes it after `k` or `c`: `3` in `k3[ground-m1]`, `gap(0.05)` in
    /// `kgap(0.05)[m1-m2]`. A position is written as Rust writes the shortest decimal that
    /// reads back to the same number, in exponent form far from 1 (`gap(1e20)`, not 21
    /// digits), which reads back the same too.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Term::Power(p) => write!(f, "{p}"),
            Term::SignedPower(p) => write!(f, "abs{p}"),
            Term::Sign => write!(f, "sign"),
            Term::DeadZone(g) => write!(f, "gap({})", Position(g.0)),
            Term::Tanh(z0) => write!(f, "tanh({})", Position(z0.0)),
            Term::Hinge(a) => write!(f, "hinge({})", Position(a.0)),
        }
    }
}

/// A term's position as its name writes it: the shortest decimal that reads back to the
/// same number, in exponent form beyond 1e6 or below 1e-4 in magnitude.
struct Position(f64);

impl fmt::Display for Position {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0;
        if x != 0.0 && !(1e-4..1e6).contains(&x.abs()) {
            write!(f, "{x:e}")
        } else {
            write!(f, "{x}")
        }
    }
}

/// In JSON (reports, study rows) a power is its number and any other term its name, as the
/// parameter names write them.
impl serde::Serialize for Term {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match *self {
            Term::Power(p) => s.serialize_u32(p),
            t => s.serialize_str(&t.to_string()),
        }
    }
}

/// What a term may be written as, for messages.
pub const TERM_SYNTAX: &str = "a power 1..=15, abs<p> for an even p (|z|^(p-1)·z), sign (Coulomb friction), \
                               gap(<g>) with g > 0 (a clearance spring), tanh(<z0>) with z0 > 0 (a saturating \
                               spring) or hinge(<a>) with a ≠ 0 (a piecewise-linear part)";

impl FromStr for Term {
    type Err = String;

    /// The inverse of `Display`. Anything else is refused with what is allowed.
    fn from_str(s: &str) -> Result<Term, String> {
        let bad = || match s.starts_with(|c: char| c.is_ascii_digit() || c == '-' || c == '+') {
            true => format!(
                "power {s:?} is not allowed: powers are whole numbers 1..={} (other terms: {TERM_SYNTAX})",
                Term::MAX_POWER
            ),
            false => format!("term {s:?} is not allowed: a term is {TERM_SYNTAX}"),
        };
        let power = |digits: &str| -> Option<u32> {
            if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
                return None;
            }
            digits.parse::<u32>().ok().filter(|p| (1..=Term::MAX_POWER).contains(p))
        };
        if let Some(p) = power(s) {
            return Ok(Term::Power(p));
        }
        if let Some(rest) = s.strip_prefix("abs") {
            return match power(rest) {
                Some(p) if p % 2 == 0 => Ok(Term::SignedPower(p)),
                Some(p) => Err(format!(
                    "term {s:?}: abs{p} is the power {p} itself (an odd power is already signed); write {p}"
                )),
                None => Err(bad()),
            };
        }
        if s == "sign" {
            return Ok(Term::Sign);
        }
        let Some((head, arg)) = s.strip_suffix(')').and_then(|x| x.split_once('(')) else {
            return Err(bad());
        };
        let x = arg
            .trim()
            .parse::<f64>()
            .ok()
            .and_then(Level::new)
            .ok_or_else(|| format!("term {s:?}: {arg:?} is not a finite number"))?;
        match head {
            "gap" | "tanh" if x.0 <= 0.0 => Err(format!(
                "term {s:?}: the {} must be positive",
                if head == "gap" {
                    "gap"
                } else {
                    "saturation amplitude z0"
                }
            )),
            "gap" => Ok(Term::DeadZone(x)),
            "tanh" => Ok(Term::Tanh(x)),
            "hinge" if x.0 == 0.0 => Err(format!(
                "term {s:?}: a hinge at 0 is the power 1 itself on one side; put knots away from 0 and list 1"
            )),
            "hinge" => Ok(Term::Hinge(x)),
            _ => Err(bad()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One term of every kind, each at a position that a test can cross.
    fn every_kind() -> Vec<Term> {
        let l = |x: f64| Level::new(x).unwrap();
        let mut out: Vec<Term> = (1..=Term::MAX_POWER).map(Term::Power).collect();
        out.extend([2, 4].map(Term::SignedPower));
        out.extend([
            Term::Sign,
            Term::DeadZone(l(0.3)),
            Term::Tanh(l(0.7)),
            Term::Hinge(l(0.5)),
            Term::Hinge(l(-0.4)),
        ]);
        out
    }

    #[test]
    fn a_term_reads_back_what_it_writes() {
        let l = |x: f64| Level::new(x).unwrap();
        let far = [
            Term::DeadZone(l(1e20)),
            Term::Hinge(l(-2.5e-7)),
            Term::Tanh(l(123456.7)),
        ];
        for t in every_kind().into_iter().chain(far) {
            assert_eq!(t.to_string().parse::<Term>(), Ok(t), "{t}");
        }
        // Far from 1 in exponent form, not 21 digits; near it as a decimal.
        assert_eq!(
            far.map(|t| t.to_string()),
            ["gap(1e20)", "hinge(-2.5e-7)", "tanh(123456.7)"]
        );
        for bad in [
            "",
            "0",
            "16",
            "-1",
            "+3",
            "3.0",
            "x",
            "01x",
            "abs3",
            "abs",
            "abs16",
            "signs",
            "gap(0)",
            "gap(-1)",
            "gap(x)",
            "gap(inf)",
            "tanh(0)",
            "hinge(0)",
            "hinge(-0)",
            "gap 0.1",
            "knee(1)",
            "gap(0.1",
        ] {
            assert!(bad.parse::<Term>().is_err(), "{bad:?} was accepted");
        }
        // The same number however written.
        assert_eq!("gap(0.050)".parse::<Term>(), "gap(5e-2)".parse::<Term>());
    }

    #[test]
    fn a_power_is_worth_its_value_and_slope() {
        let z = -1.7_f64;
        for p in 1..=9 {
            let t = Term::Power(p);
            assert_eq!(t.value(z), z.powi(p as i32));
            assert_eq!((t.power(), t.degree()), (Some(p), p));
        }
    }

    #[test]
    fn every_term_has_its_slope_oddness_and_far_behaviour() {
        let h = 1e-6;
        for t in every_kind() {
            // Away from every kink: the slope against a central difference.
            for z in [-2.3, -1.1, -0.61, -0.2, 0.13, 0.45, 0.9, 1.7, 2.6] {
                let fd = (t.value(z + h) - t.value(z - h)) / (2.0 * h);
                assert!(
                    (t.slope(z) - fd).abs() <= 1e-6 * fd.abs().max(1.0),
                    "{t} at {z}: {} vs {fd}",
                    t.slope(z)
                );
                if t.is_odd() {
                    assert_eq!(t.value(-z), -t.value(z), "{t} at {z}");
                }
            }
            // A term that is not odd is seen not to be somewhere.
            let odd_everywhere = [0.3, 0.7, 1.1, 2.6].iter().all(|&z| t.value(-z) == -t.value(z));
            assert_eq!(t.is_odd(), odd_everywhere, "{t}");
            assert_eq!(t.value(0.0), 0.0, "{t} at the origin");
            // Far out: t(z) / |z|^growth tends to the stated factor.
            for s in [1.0, -1.0] {
                let far = t.far(s);
                let z = s * 1e6;
                let ratio = t.value(z) / z.abs().powi(far.growth as i32);
                assert!(
                    (ratio - far.coefficient).abs() < 1e-5 * far.coefficient.abs().max(1.0),
                    "{t} on {s}"
                );
            }
        }
        // The kinks and jumps where they are meant to be.
        let l = |x: f64| Level::new(x).unwrap();
        assert_eq!(Term::Sign.value(-1e-300), -1.0);
        assert_eq!(Term::DeadZone(l(0.3)).value(0.3), 0.0);
        assert_eq!(Term::DeadZone(l(0.3)).value(-0.5), -0.5 + 0.3);
        assert_eq!(Term::Hinge(l(-0.4)).value(-1.0), -0.6);
        assert_eq!(Term::Hinge(l(-0.4)).value(1.0), 0.0);
        assert!(!Term::Sign.is_continuous() && Term::Tanh(l(1.0)).is_continuous());
    }
}

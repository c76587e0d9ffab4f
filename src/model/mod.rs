//! The mechanical model compiled from a [`Scenario`] into flat arrays.
//!
//! One `Model` serves the simulator (forces on every mass, stepped in lanes) and the
//! identifier (the drift and its derivative with respect to each link coefficient, the
//! "features" `g_ir(y)` of docs/theory.md §2). A characteristic is a sum of [`Term`]s. Its
//! polynomial part lives in one contiguous array, dense by power, so evaluation needs no
//! allocation and the fast simulation kernels can take it; terms without a polynomial form
//! are kept beside it, term by term. Depends only on `scenario`.

pub mod admissible;
mod columns;
mod hysteresis;
mod names;
mod term;

pub use columns::{Columns, Quantity};
pub use hysteresis::BoucWen;
pub use names::{ParameterName, Truth, UnknownName};
pub use term::{Far, Level, Term, TERM_SYNTAX};

use crate::scenario::{End, Process, Scenario};

/// Marks a link end at the ground.
pub const GROUND: usize = usize::MAX;

/// Which characteristic of a link a coefficient belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Characteristic {
    /// `K(u)`, `u` the relative displacement of the link's ends.
    Stiffness,
    /// `C(w)`, `w` the relative velocity of the link's ends.
    Damping,
}

impl Characteristic {
    pub fn symbol(self) -> char {
        match self {
            Characteristic::Stiffness => 'k',
            Characteristic::Damping => 'c',
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            Characteristic::Stiffness => "stiffness",
            Characteristic::Damping => "damping",
        }
    }
}

/// One coefficient of one link: of term `t` in its stiffness (`k_t`) or damping (`c_t`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Coefficient {
    pub link: usize,
    pub kind: Characteristic,
    pub term: Term,
}

/// A compiled excitation.
#[derive(Debug, Clone, PartialEq)]
pub struct CompiledExcitation {
    pub process: Process,
    pub targets: Vec<usize>,
    pub measured: bool,
}

/// The model in flat form.
#[derive(Debug, Clone)]
pub struct Model {
    pub mass_names: Vec<String>,
    pub link_names: Vec<String>,
    pub excitation_names: Vec<String>,
    pub mass: Vec<f64>,
    pub inv_mass: Vec<f64>,
    /// First end of each link (a mass index).
    pub link_a: Vec<usize>,
    /// Second end of each link (a mass index or [`GROUND`]).
    pub link_b: Vec<usize>,
    /// Stiffness coefficients of link `l`: `coefs[k_start[l] + p − 1]` is `k_p`, `p = 1..=k_len[l]`.
    pub k_start: Vec<usize>,
    pub k_len: Vec<usize>,
    pub c_start: Vec<usize>,
    pub c_len: Vec<usize>,
    pub coefs: Vec<f64>,
    /// The terms without a polynomial form, with their coefficients (none of today's
    /// kinds: every [`Term`] so far is a power). Evaluated term by term, by the generic
    /// stepper only.
    pub other_terms: Vec<(Coefficient, f64)>,
    /// Per hysteretic link: the link and its Bouc–Wen element, a force with a state of
    /// its own. Only the simulator's generic stepper carries that state; [`Model::link_force`]
    /// and the identifier leave it out (they know the link force as a function of `u`
    /// and `w` alone, which a hysteretic force is not).
    pub hysteresis: Vec<(usize, BoucWen)>,
    pub excitations: Vec<CompiledExcitation>,
}

/// Horner evaluation of `Σ_{p=1..len} coefs[p−1] z^p`.
#[inline(always)]
fn poly(coefs: &[f64], z: f64) -> f64 {
    let mut acc = 0.0;
    for &c in coefs.iter().rev() {
        acc = acc * z + c;
    }
    acc * z
}

impl Model {
    /// Compile a scenario's true system.
    pub fn new(s: &Scenario) -> Model {
        let mut m = Model {
            mass_names: s.masses.iter().map(|m| m.name.clone()).collect(),
            link_names: s.links.iter().map(|l| l.name.clone()).collect(),
            excitation_names: s.excitations.iter().map(|e| e.name.clone()).collect(),
            mass: s.masses.iter().map(|m| m.value).collect(),
            inv_mass: s.masses.iter().map(|m| 1.0 / m.value).collect(),
            link_a: Vec::new(),
            link_b: Vec::new(),
            k_start: Vec::new(),
            k_len: Vec::new(),
            c_start: Vec::new(),
            c_len: Vec::new(),
            coefs: Vec::new(),
            other_terms: Vec::new(),
            hysteresis: Vec::new(),
            excitations: s
                .excitations
                .iter()
                .map(|e| CompiledExcitation {
                    process: e.process.clone(),
                    targets: e.acts_on.clone(),
                    measured: e.measured,
                })
                .collect(),
        };
        for l in &s.links {
            let idx = |e: End| match e {
                End::Ground => GROUND,
                End::Mass(i) => i,
            };
            // The scenario puts a ground end second, so `a` is always a mass.
            m.link_a.push(idx(l.ends[0]));
            m.link_b.push(idx(l.ends[1]));
            let link = m.link_a.len() - 1;
            if let Some(bw) = l.hysteresis {
                m.hysteresis.push((link, bw));
            }
            for (kind, poly, start, len) in [
                (Characteristic::Stiffness, &l.stiffness, &mut m.k_start, &mut m.k_len),
                (Characteristic::Damping, &l.damping, &mut m.c_start, &mut m.c_len),
            ] {
                let n = poly.max_power() as usize;
                start.push(m.coefs.len());
                len.push(n);
                m.coefs.extend((1..=n as u32).map(|p| poly.coefficient(Term::Power(p))));
                for &(term, c) in poly.terms.iter().filter(|t| t.0.power().is_none()) {
                    m.other_terms.push((Coefficient { link, kind, term }, c));
                }
            }
        }
        m
    }

    pub fn masses(&self) -> usize {
        self.mass.len()
    }
    pub fn links(&self) -> usize {
        self.link_a.len()
    }

    /// Stiffness coefficients of link `l`, dense from power 1.
    pub fn stiffness(&self, l: usize) -> &[f64] {
        &self.coefs[self.k_start[l]..self.k_start[l] + self.k_len[l]]
    }
    /// Every term of link `l`'s characteristic `kind` with a non-zero coefficient: the
    /// polynomial part by ascending power, then the other terms.
    pub fn terms(&self, l: usize, kind: Characteristic) -> impl Iterator<Item = (Term, f64)> + '_ {
        let dense = match kind {
            Characteristic::Stiffness => self.stiffness(l),
            Characteristic::Damping => self.damping(l),
        };
        let powers = dense.iter().enumerate().map(|(p, &c)| (Term::Power(p as u32 + 1), c));
        let others = self
            .other_terms
            .iter()
            .filter(move |(c, _)| c.link == l && c.kind == kind)
            .map(|&(c, v)| (c.term, v));
        powers.chain(others).filter(|t| t.1 != 0.0)
    }

    /// Replace link `l`'s characteristic `kind` by `Σ c t(z)` over `terms` (`(t, c)`, sorted
    /// by term); the flat arrays are laid out again as [`Model::new`] lays them out.
    pub fn set_characteristic(&mut self, l: usize, kind: Characteristic, terms: &[(Term, f64)]) {
        self.other_terms.retain(|(c, _)| (c.link, c.kind) != (l, kind));
        for &(term, c) in terms.iter().filter(|t| t.0.power().is_none()) {
            self.other_terms.push((Coefficient { link: l, kind, term }, c));
        }
        let dense = |terms: &[(Term, f64)]| -> Vec<f64> {
            let n = terms.iter().filter_map(|t| t.0.power()).max().unwrap_or(0) as usize;
            let mut d = vec![0.0; n];
            for &(t, c) in terms {
                if let Some(p) = t.power() {
                    d[p as usize - 1] = c;
                }
            }
            d
        };
        let mut polys: Vec<[Vec<f64>; 2]> = (0..self.links())
            .map(|k| [self.stiffness(k).to_vec(), self.damping(k).to_vec()])
            .collect();
        polys[l][match kind {
            Characteristic::Stiffness => 0,
            Characteristic::Damping => 1,
        }] = dense(terms);
        self.coefs.clear();
        for (k, [stiffness, damping]) in polys.into_iter().enumerate() {
            self.k_start[k] = self.coefs.len();
            self.k_len[k] = stiffness.len();
            self.coefs.extend(stiffness);
            self.c_start[k] = self.coefs.len();
            self.c_len[k] = damping.len();
            self.coefs.extend(damping);
        }
    }

    /// The one-mass system of mass `i` on link `l` (whose second end is the ground),
    /// driven by `excitation` alone, named `name`.
    pub fn single_mass(&self, i: usize, l: usize, excitation: CompiledExcitation, name: &str) -> Model {
        assert_eq!(self.ends(l), (i, None), "link {l} joins mass {i} to the ground");
        let (k, c) = (self.stiffness(l).to_vec(), self.damping(l).to_vec());
        let other_terms = self
            .other_terms
            .iter()
            .filter(|(c, _)| c.link == l)
            .map(|&(c, v)| (Coefficient { link: 0, ..c }, v))
            .collect();
        Model {
            mass_names: vec![self.mass_names[i].clone()],
            link_names: vec![self.link_names[l].clone()],
            excitation_names: vec![name.to_string()],
            mass: vec![self.mass[i]],
            inv_mass: vec![self.inv_mass[i]],
            link_a: vec![0],
            link_b: vec![GROUND],
            k_start: vec![0],
            k_len: vec![k.len()],
            c_start: vec![k.len()],
            c_len: vec![c.len()],
            coefs: [k, c].concat(),
            other_terms,
            hysteresis: self
                .hysteresis
                .iter()
                .filter(|h| h.0 == l)
                .map(|&(_, bw)| (0, bw))
                .collect(),
            excitations: vec![excitation],
        }
    }

    /// Set every coefficient of link `l`'s characteristic `kind` to zero (it is unknown).
    pub fn clear(&mut self, l: usize, kind: Characteristic) {
        let (start, len) = match kind {
            Characteristic::Stiffness => (self.k_start[l], self.k_len[l]),
            Characteristic::Damping => (self.c_start[l], self.c_len[l]),
        };
        self.coefs[start..start + len].iter_mut().for_each(|c| *c = 0.0);
        self.other_terms.retain(|(c, _)| (c.link, c.kind) != (l, kind));
    }
    /// Damping coefficients of link `l`, dense from power 1.
    pub fn damping(&self, l: usize) -> &[f64] {
        &self.coefs[self.c_start[l]..self.c_start[l] + self.c_len[l]]
    }

    /// `+1` if mass `i` is the first end of link `l`, `−1` if the second, 0 otherwise.
    pub fn sign(&self, l: usize, i: usize) -> f64 {
        if self.link_a[l] == i {
            1.0
        } else if self.link_b[l] == i {
            -1.0
        } else {
            0.0
        }
    }

    /// The link geometry, stated once: link `l`'s relative motion is `q_a − q_b` of the
    /// mass quantity `q(i)` (`x`, `v`, `a`, or the state variable that holds it) at its ends,
    /// with `q_b = 0` for the ground. Every relative displacement and velocity in the code
    /// is this (or [`Model::geometry`], its terms).
    #[inline]
    pub fn relative_with(&self, l: usize, q: impl Fn(usize) -> f64) -> f64 {
        let (a, b) = self.ends(l);
        q(a) - b.map_or(0.0, q)
    }

    /// The terms `(mass, sign)` of link `l`'s relative motion ([`Model::relative_with`]):
    /// `(a, +1)`, then `(b, −1)` unless `b` is the ground.
    pub fn geometry(&self, l: usize) -> impl Iterator<Item = (usize, f64)> {
        let (a, b) = self.ends(l);
        std::iter::once((a, 1.0)).chain(b.map(|b| (b, -1.0)))
    }

    /// Relative displacement `u = x_a − x_b` of link `l` (from positions `x`, or velocities).
    #[inline]
    pub fn relative(&self, l: usize, x: &[f64]) -> f64 {
        self.relative_with(l, |i| x[i])
    }

    /// Relative displacement and velocity `(u, w)` of link `l` in a logged sample `row`.
    #[inline]
    pub fn link_motion(&self, l: usize, row: &[f64]) -> (f64, f64) {
        let c = self.columns();
        (
            self.relative_with(l, |i| row[c.x(i)]),
            self.relative_with(l, |i| row[c.v(i)]),
        )
    }

    /// The link force `F = K(u) + C(w)`.
    #[inline]
    pub fn link_force(&self, l: usize, u: f64, w: f64) -> f64 {
        let f = poly(self.stiffness(l), u) + poly(self.damping(l), w);
        if self.other_terms.is_empty() {
            return f;
        }
        let others: f64 = self
            .other_terms
            .iter()
            .filter(|(c, _)| c.link == l)
            .map(|&(c, v)| match c.kind {
                Characteristic::Stiffness => v * c.term.value(u),
                Characteristic::Damping => v * c.term.value(w),
            })
            .sum();
        f + others
    }

    /// Net force on every mass from the links alone: `−Σ_ℓ s_iℓ F_ℓ` (no excitation).
    pub fn link_forces(&self, x: &[f64], v: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|f| *f = 0.0);
        for l in 0..self.links() {
            let f = self.link_force(l, self.relative(l, x), self.relative(l, v));
            out[self.link_a[l]] -= f;
            if self.link_b[l] != GROUND {
                out[self.link_b[l]] += f;
            }
        }
    }

    /// Whether a white-noise excitation acts on mass `i` (then its acceleration has no
    /// value at an instant and is logged as `Δv ÷ interval`).
    pub fn white_on(&self, i: usize) -> bool {
        self.excitations
            .iter()
            .any(|e| matches!(e.process, Process::White { .. }) && e.targets.contains(&i))
    }

    /// The name of a coefficient, e.g. `k3[ground-m1]`.
    pub fn coefficient_name(&self, c: Coefficient) -> ParameterName {
        ParameterName::Coefficient {
            kind: c.kind,
            term: c.term,
            link: self.link_names[c.link].clone(),
        }
    }

    /// Where each value of a logged sample sits.
    pub fn columns(&self) -> Columns {
        Columns::new(self.masses(), self.excitations.len())
    }

    /// The log's column names, in order.
    pub fn column_names(&self) -> Vec<String> {
        self.columns().names(&self.mass_names, &self.excitation_names)
    }

    /// The masses at the ends of link `l`: the first end, and the second (`None` for the
    /// ground, which is always the second end).
    pub fn ends(&self, l: usize) -> (usize, Option<usize>) {
        let b = self.link_b[l];
        (self.link_a[l], (b != GROUND).then_some(b))
    }

    /// Whether every link is linear (powers ≤ 1, no other term): then the stationary
    /// response is Gaussian.
    pub fn is_linear(&self) -> bool {
        self.k_len.iter().chain(&self.c_len).all(|&n| n <= 1)
            && self.other_terms.is_empty()
            && self.hysteresis.is_empty()
    }

    /// This model with its polynomial part moved among the other terms: the same system,
    /// evaluated term by term as a term without a polynomial form is. Tests of that path.
    #[cfg(test)]
    pub(crate) fn with_powers_as_other_terms(&self) -> Model {
        let mut m = self.clone();
        for l in 0..m.links() {
            for kind in [Characteristic::Stiffness, Characteristic::Damping] {
                for (term, v) in self.terms(l, kind).collect::<Vec<_>>() {
                    m.other_terms.push((Coefficient { link: l, kind, term }, v));
                }
            }
        }
        m.coefs.iter_mut().for_each(|c| *c = 0.0);
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::Curve;

    #[test]
    fn a_set_characteristic_is_laid_out_as_a_model_of_the_edited_scenario() {
        let mut s = crate::zoo::linear_2dof("dt = 1e-3\nrecord_length = 10.0\nsample_interval = 0.1");
        let mut model = Model::new(&s);
        // A longer polynomial in the middle link shifts every later link's coefficients.
        let terms = Curve::powers(&[(1, 3.0), (2, -0.5), (5, 0.25)]).terms;
        model.set_characteristic(1, Characteristic::Stiffness, &terms);
        s.links[1].stiffness = Curve { terms };
        let edited = Model::new(&s);
        assert_eq!(
            (&model.coefs, &model.k_start, &model.k_len, &model.c_start, &model.c_len),
            (
                &edited.coefs,
                &edited.k_start,
                &edited.k_len,
                &edited.c_start,
                &edited.c_len
            )
        );
        model.clear(1, Characteristic::Stiffness);
        assert!(model.stiffness(1).iter().all(|&c| c == 0.0));
        assert_eq!(model.damping(1), edited.damping(1));
    }
}

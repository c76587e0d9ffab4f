//! The drift's force terms, built from the model's characteristic terms: each term as its
//! polynomial in the state, or as an [`Atom`] where it has no polynomial form.

use super::*;

/// A characteristic term without a polynomial form (`t(z)`, or its slope `t'(z)` in the
/// filtered layout's force derivative) as a variable of the moment equations: appended to
/// the state after the masses' variables and the measured inputs, its value computed from
/// each sample's link motion ([`Atom::value`]), so the weak form's expectations become
/// generalised moments `E[t(z) y^β]` (docs/theory.md §5). Never an argument of a test
/// function, like a measured input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Atom {
    pub link: usize,
    pub kind: Characteristic,
    pub term: Term,
    /// `t'(z)` rather than `t(z)`.
    pub slope: bool,
}

impl Atom {
    /// The atom at a log row: the term (or its slope) at the link's relative displacement
    /// (stiffness) or velocity (damping).
    #[inline]
    pub fn value(&self, model: &Model, row: &[f64]) -> f64 {
        let (u, w) = model.link_motion(self.link, row);
        let z = match self.kind {
            Characteristic::Stiffness => u,
            Characteristic::Damping => w,
        };
        if self.slope {
            self.term.slope(z)
        } else {
            self.term.value(z)
        }
    }
}

/// The force terms of the drift as polynomials of the state: white `−s c t(z)`;
/// augmented `−s c (B t(z) + t'(z) ż)`, the time derivative of the force through
/// `K'(u) u̇` and `C'(w) ẇ` ((3.22)–(3.28), docs/theory.md §3). A term enters through its
/// polynomial form, or as an [`Atom`] ([`ForceTerms::value`], [`ForceTerms::slope`]).
pub(super) struct ForceTerms<'a> {
    pub(super) model: &'a Model,
    pub(super) state: &'a StateChoice,
    /// The [`Atom`]s met so far, in the order of their variables.
    pub(super) atoms: RefCell<Vec<Atom>>,
    /// Links whose powers enter as atoms too (tests of the atom path).
    pub(super) atom_links: &'a [usize],
}

impl ForceTerms<'_> {
    /// Relative motion of link `l`'s ends in the state variables `base(i)`.
    fn relative(&self, l: usize, base: &dyn Fn(usize) -> usize) -> Poly {
        let terms: Vec<(usize, f64)> = self.model.geometry(l).map(|(i, sign)| (base(i), sign)).collect();
        Poly::linear(&terms)
    }

    /// `z` and `ż` of a characteristic of link `l`: `(u, w)` for the stiffness, `(w, ẇ)`
    /// for the damping.
    fn argument(&self, l: usize, kind: Characteristic) -> (Poly, Poly) {
        let st = self.state;
        match kind {
            Characteristic::Stiffness => (self.relative(l, &|i| st.x(i)), self.relative(l, &|i| st.v(i))),
            Characteristic::Damping => (self.relative(l, &|i| st.v(i)), self.relative(l, &|i| st.a(i))),
        }
    }

    /// Force term of one characteristic term `c t(z)` of link `l` on mass `i`, per unit of
    /// `c` and before `1/m_i`.
    fn term(&self, l: usize, kind: Characteristic, t: Term, i: usize) -> Poly {
        let s = self.model.sign(l, i);
        if s == 0.0 {
            return Poly::zero();
        }
        let (z, zdot) = self.argument(l, kind);
        let mut out = Poly::zero();
        match self.state.layout {
            Layout::White => out.add(&self.value(l, kind, t, &z), -s),
            Layout::Augmented => {
                // With an unknown corner the B·t(z) part belongs to the product unknown.
                if self.state.corner_unknown[i].is_none() {
                    out.add(&self.value(l, kind, t, &z), -s * self.state.corner[i]);
                }
                let (slope, factor) = self.slope(l, kind, t, &z);
                out.add(&slope.mul(&zdot), -s * factor);
            }
        }
        out
    }

    /// The `B` part alone, `−s t(z)` (per unit of `B·c`).
    fn b_part(&self, l: usize, kind: Characteristic, t: Term, i: usize) -> Poly {
        let (z, _) = self.argument(l, kind);
        let mut out = Poly::zero();
        out.add(&self.value(l, kind, t, &z), -self.model.sign(l, i));
        out
    }

    /// `t(z)` of link `l`'s characteristic `kind` as a polynomial: its polynomial form,
    /// or its [`Atom`]'s variable.
    fn value(&self, l: usize, kind: Characteristic, t: Term, z: &Poly) -> Poly {
        match t.power() {
            Some(p) if !self.atom_links.contains(&l) => z.pow(p),
            _ => self.atom(Atom {
                link: l,
                kind,
                term: t,
                slope: false,
            }),
        }
    }

    /// `t'(z)` as `(polynomial, factor)`, `t'(z) = factor · polynomial` (the factor kept
    /// apart so a power's slope is `p · z^(p−1)` as written in (3.24)).
    fn slope(&self, l: usize, kind: Characteristic, t: Term, z: &Poly) -> (Poly, f64) {
        match t.power() {
            Some(p) if !self.atom_links.contains(&l) => (z.pow(p - 1), p as f64),
            _ => {
                let atom = Atom {
                    link: l,
                    kind,
                    term: t,
                    slope: true,
                };
                (self.atom(atom), 1.0)
            }
        }
    }

    /// The variable of `atom`, numbered after the state (a problem is built with no
    /// inputs; they are added later and only to problems without atoms).
    fn atom(&self, atom: Atom) -> Poly {
        let mut atoms = self.atoms.borrow_mut();
        let k = atoms.iter().position(|a| *a == atom).unwrap_or_else(|| {
            atoms.push(atom);
            atoms.len() - 1
        });
        y(self.state.width * self.model.masses() + k)
    }

    /// Every non-zero known coefficient as `(link, kind, term, value)`, link by link,
    /// stiffness before damping, by term.
    fn known_coefficients(&self) -> impl Iterator<Item = (usize, Characteristic, Term, f64)> + '_ {
        let m = self.model;
        (0..m.links()).flat_map(move |l| {
            [Characteristic::Stiffness, Characteristic::Damping]
                .into_iter()
                .flat_map(move |kind| m.terms(l, kind).map(move |(t, c)| (l, kind, t, c)))
        })
    }

    /// The known part of every mass's force term, and the highest power in it.
    pub(super) fn known_force(&self) -> (Vec<Poly>, u32) {
        let mut known_force = vec![Poly::zero(); self.model.masses()];
        let mut pmax = 1;
        for (l, kind, t, c) in self.known_coefficients() {
            pmax = pmax.max(t.degree());
            for (i, kf) in known_force.iter_mut().enumerate() {
                kf.add(&self.term(l, kind, t, i), c);
            }
        }
        (known_force, pmax)
    }

    /// Per unknown: its force term per unit on every mass (coefficients and corners), its
    /// name and its Gauss–Newton start; and the highest power in the drift.
    #[allow(clippy::type_complexity)]
    pub(super) fn unknown_terms(
        &self,
        unknowns: &[Unknown],
        mut pmax: u32,
    ) -> Result<(Vec<Vec<Poly>>, Vec<UnknownName>, Vec<f64>, u32), IdentError> {
        let (model, st) = (self.model, self.state);
        let n = model.masses();
        let mut unit_force = Vec::new();
        let mut names = Vec::new();
        let mut start = Vec::new();
        for u in unknowns {
            match *u {
                Unknown::Coefficient(c) => {
                    pmax = pmax.max(c.term.degree());
                    unit_force.push((0..n).map(|i| self.term(c.link, c.kind, c.term, i)).collect());
                    names.push(model.coefficient_name(c).into());
                    start.push(0.0);
                }
                Unknown::CornerProduct(c, e) => {
                    unit_force.push(
                        (0..n)
                            .map(|i| match st.corner_unknown[i] == Some(e) {
                                true => self.b_part(c.link, c.kind, c.term, i),
                                false => Poly::zero(),
                            })
                            .collect(),
                    );
                    names.push(UnknownName::Product(
                        ParameterName::Corner(model.excitation_names[e].clone()),
                        model.coefficient_name(c),
                    ));
                    start.push(0.0);
                }
                Unknown::Corner(e) => {
                    // Per unit of B: −(m_i a_i + Σ s F_known) on every mass it drives.
                    unit_force.push((0..n).map(|i| self.corner_force(e, i)).collect());
                    names.push(ParameterName::Corner(model.excitation_names[e].clone()).into());
                    start.push(0.0);
                }
                Unknown::Monomial(..) => unreachable!("monomial unknowns come from monomial_form"),
                Unknown::InputGain(_) => unreachable!("input gains are added to a built problem"),
                Unknown::Mass(i) => {
                    if st.layout == Layout::Augmented {
                        return Err(IdentError::Unsupported(
                            "unknown masses with filtered excitation are not supported".into(),
                        ));
                    }
                    names.push(ParameterName::Mass(model.mass_names[i].clone()).into());
                    start.push(model.mass[i]);
                }
                Unknown::Intensity(e) => {
                    let Process::White { sigma } = model.excitations[e].process else {
                        return Err(IdentError::Unsupported(format!(
                            "excitation {} is filtered: its A and B come from the spectral fit (or are known), not from the density",
                            model.excitation_names[e]
                        )));
                    };
                    names.push(ParameterName::Intensity(model.excitation_names[e].clone()).into());
                    start.push(sigma);
                }
            }
        }
        Ok((unit_force, names, start, pmax))
    }

    /// The force on mass `i` per unit of the unknown corner of excitation `e`:
    /// `−(m_i a_i + Σ s F_known)` where `e` drives `i`.
    fn corner_force(&self, e: usize, i: usize) -> Poly {
        let m = self.model;
        let mut f = Poly::zero();
        if self.state.corner_unknown[i] == Some(e) {
            f.add(&Poly::monomial(var(self.state.a(i)), 1.0), -m.mass[i]);
            for (l, kind, t, c) in self.known_coefficients() {
                f.add(&self.b_part(l, kind, t, i), c);
            }
        }
        f
    }
}

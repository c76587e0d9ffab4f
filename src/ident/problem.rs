//! The identification problem: which coefficients, masses, intensities and corners are
//! unknown, the drift split into a known part and a part linear in the unknowns, the
//! residual of the stationarity identity and its least-squares solution. Built from a
//! [`Specification`] in named stages: the state ([`StateChoice`]), the unknowns, the force
//! terms of the drift ([`ForceTerms`], (3.22)–(3.28), in `problem/forces.rs`) and the noise
//! sources. It holds no truth.

use super::poly::{var, Poly, MAX_VARS};
use super::{lsq, moments, poly, IdentError, Specification};
use crate::model::{Characteristic, Coefficient, Model, ParameterName, Quantity, Term, Truth, UnknownName};
use crate::scenario::{Process, Scenario};
use nalgebra::{DMatrix, DVector};
use std::cell::RefCell;

#[cfg(test)]
mod augmented_drift;
mod forces;
mod start;
#[cfg(test)]
mod tests;

pub use forces::Atom;
use forces::ForceTerms;

/// One unknown of the identification.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unknown {
    Coefficient(Coefficient),
    /// Mass `i`.
    Mass(usize),
    /// Intensity `σ` of (white) excitation `e`.
    Intensity(usize),
    /// Corner `B` of filtered excitation `e` (declared unknown: the drift is bilinear).
    Corner(usize),
    /// The product `B_e · θ` of an unknown corner and a coefficient (bilinear drift).
    CornerProduct(Coefficient, usize),
    /// The coefficient of one monomial in the unknown part of mass `i`'s drift (the
    /// linear stage of a bilinear identification).
    Monomial(usize, poly::Exponents),
    /// The gain of measured input `j` (state variable `dim() − inputs + j`): its force per
    /// unit gain is the unknown's `unit_force`, set by whoever adds the input (e.g. the
    /// `2 k1 (x1 − x2)` of [`super::disturbance::direct_problem`]). Never built from a scenario.
    InputGain(usize),
}

/// Which state the stationary density is taken of.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Layout {
    /// White-noise forces: `y = (x_1, v_1, …, x_n, v_n)`; forces and noise act on `v`.
    White,
    /// Filtered (Ornstein–Uhlenbeck) forces: `(x, v)` is not Markov, `(x_i, v_i, a_i)` is
    /// (docs/theory.md §3, (3.22)–(3.28)); forces and noise act on `a`.
    Augmented,
}

/// A filtered excitation as the identifier sees it: `dP = −B P dt + A dW`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Filter {
    pub excitation: usize,
    pub a: f64,
    pub b: f64,
}

/// The identification problem.
#[derive(Debug, Clone)]
pub struct Problem {
    pub model: Model,
    pub layout: Layout,
    pub unknowns: Vec<Unknown>,
    pub names: Vec<UnknownName>,
    /// Value each unknown starts Gauss–Newton from: the log's nominal mass or intensity;
    /// 0 for coefficients (they enter linearly, so their start does not matter).
    pub start: Vec<f64>,
    /// Masses.
    pub n: usize,
    /// Highest polynomial degree in the drift (known and unknown parts).
    pub pmax: u32,
    /// Known drift terms not scaled by `1/m`: `(state variable, drift polynomial)`
    /// (`ẋ = v`; with the augmented state also `v̇ = a` and the `−B a` part of `ȧ`).
    pub free_drift: Vec<(usize, Poly)>,
    /// Per mass: the state variable its forces and noise act on (`v_i` or `a_i`).
    pub noise_var: Vec<usize>,
    /// Per mass: the known part of the force term (scaled by `1/m_i` in the drift of
    /// `noise_var[i]`), a polynomial in `y`.
    pub known_force: Vec<Poly>,
    /// Per unknown coefficient (in order of `unknowns`' coefficients): per mass, the force
    /// term per unit of the coefficient (white: `−s_iℓ z^p`).
    pub unit_force: Vec<Vec<Poly>>,
    /// Noise sources: targets, nominal intensity (`σ` or `A`), and the index of its
    /// unknown (if any). The noise covariance on `noise_var` is `Σ σ² μ_i μ_j`.
    pub white: Vec<(Vec<usize>, f64, Option<usize>)>,
    /// The filters used (augmented layout).
    pub filters: Vec<Filter>,
    /// Log column of each state variable.
    pub columns: Vec<usize>,
    pub state_names: Vec<String>,
    /// Measured inputs appended to the state after the masses' variables: forces known at
    /// every sample that enter `known_force` but have no dynamics of their own, so test
    /// functions never depend on them (see [`super::disturbance`]'s measured-force step). 0 for a
    /// problem built from a scenario.
    pub inputs: usize,
    /// Terms without a polynomial form, each a variable of its own after the inputs: see
    /// [`Atom`]; and the slope of every unknown hinge, which only the weak form's local test
    /// functions read (white layout). Empty when every term is a power.
    pub atoms: Vec<Atom>,
}

impl Problem {
    /// Build the problem from a scenario's `[identify]` section and known system. With
    /// filtered excitations the filters are taken at their given values; use
    /// [`Problem::with_filters`] to give fitted ones.
    pub fn new(s: &Scenario) -> Result<Problem, IdentError> {
        let spec = Specification::from_scenario(s);
        Problem::from_spec(&spec, &spec.given_filters())
    }

    /// Build the problem from a scenario with the given filter parameters for the measured
    /// filtered excitations (fitted from the force spectrum, or known).
    pub fn with_filters(s: &Scenario, filters: &[Filter]) -> Result<Problem, IdentError> {
        Problem::from_spec(&Specification::from_scenario(s), filters)
    }

    /// Build the problem of a specification, with the given filter parameters for its
    /// measured filtered excitations.
    pub fn from_spec(spec: &Specification, filters: &[Filter]) -> Result<Problem, IdentError> {
        let problem = Problem::from_spec_unchecked(spec, filters)?;
        // A symmetry of the model is refused from its structure, before any data.
        if let Some(sym) = super::exact_symmetry(&problem) {
            return Err(IdentError::Symmetric {
                directions: sym
                    .directions
                    .iter()
                    .map(|d| {
                        d.iter()
                            .zip(&problem.names)
                            .filter(|(x, _)| **x != 0.0)
                            .map(|(x, n)| (n.clone(), *x))
                            .collect()
                    })
                    .collect(),
                why: sym.why.to_string(),
            });
        }
        Ok(problem)
    }

    /// [`Problem::from_spec`] without refusing an exact symmetry: for checking the
    /// symmetries themselves against exact moments.
    #[doc(hidden)]
    pub fn from_spec_unchecked(spec: &Specification, filters: &[Filter]) -> Result<Problem, IdentError> {
        Problem::build(spec, filters, &[])
    }

    /// [`Problem::from_spec`] with every term of the links `links` entered as an [`Atom`],
    /// powers too: the path of a term without a polynomial form, for testing it against
    /// the polynomial one.
    #[cfg(test)]
    pub(crate) fn with_terms_as_atoms(
        spec: &Specification,
        filters: &[Filter],
        links: &[usize],
    ) -> Result<Problem, IdentError> {
        Problem::build(spec, filters, links)
    }

    fn build(spec: &Specification, filters: &[Filter], atom_links: &[usize]) -> Result<Problem, IdentError> {
        let known = &spec.model;
        let n = known.masses();
        let state = StateChoice::new(known, filters, &spec.unknown_corners)?;
        let unknowns = unknowns(spec, &state.corner_unknown)?;
        let terms = ForceTerms {
            model: known,
            state: &state,
            atoms: RefCell::new(Vec::new()),
            atom_links,
        };
        let (known_force, known_pmax) = terms.known_force();
        let (unit_force, names, start, pmax) = terms.unknown_terms(&unknowns, known_pmax)?;
        let mut atoms = terms.atoms.into_inner();
        // The slope of every unknown hinge: the weak form's local test functions read it
        // (`weak::local_tests`; white layout only).
        if state.layout == Layout::White {
            for u in &unknowns {
                if let Unknown::Coefficient(
                    c @ Coefficient {
                        term: Term::Hinge(_), ..
                    },
                ) = *u
                {
                    let slope = Atom {
                        link: c.link,
                        kind: c.kind,
                        term: c.term,
                        slope: true,
                    };
                    if !atoms.contains(&slope) {
                        atoms.push(slope);
                    }
                }
            }
        }
        if let Some(a) = atoms.iter().find(|a| a.slope && !a.term.is_continuous()) {
            return Err(IdentError::Unsupported(format!(
                "with filtered excitation the drift holds the force's time derivative (3.24), and the {} of link {:?} \
                 jumps at 0, so it has none: identify it under white excitation, or model the friction by a \
                 continuous term (tanh with a small z0)",
                a.term.describe(),
                known.link_names[a.link]
            )));
        }
        let dim = state.width * n + atoms.len();
        if dim > MAX_VARS {
            return Err(IdentError::Unsupported(format!(
                "the moment equations take at most {MAX_VARS} variables, and this problem has {dim} ({n} masses × {} \
                 state variables{}): identify a smaller part of the system",
                state.width,
                match atoms.len() {
                    0 => String::new(),
                    k => format!(" and {k} terms without a polynomial form"),
                }
            )));
        }
        let white = noise_sources(known, filters, &unknowns)?;
        let layout = state.layout;
        let mut free_drift = Vec::new();
        for i in 0..n {
            free_drift.push((state.x(i), Poly::monomial(var(state.v(i)), 1.0)));
            if layout == Layout::Augmented {
                free_drift.push((state.v(i), Poly::monomial(var(state.a(i)), 1.0)));
                if state.corner_unknown[i].is_none() {
                    free_drift.push((state.a(i), Poly::monomial(var(state.a(i)), -state.corner[i])));
                }
            }
        }
        let noise_var = (0..n)
            .map(|i| {
                if layout == Layout::Augmented {
                    state.a(i)
                } else {
                    state.v(i)
                }
            })
            .collect();
        // Per mass, in the state's order: x, v (and a when augmented).
        let quantities: &[Quantity] = match layout {
            Layout::White => &[Quantity::Displacement, Quantity::Velocity],
            Layout::Augmented => &[Quantity::Displacement, Quantity::Velocity, Quantity::Acceleration],
        };
        let log = known.columns();
        let columns = (0..n)
            .flat_map(|i| quantities.iter().map(move |&q| log.of_mass(q, i)))
            .collect();
        let state_names = (0..n)
            .flat_map(|i| {
                let name = &known.mass_names[i];
                quantities.iter().map(move |&q| q.column_name(name))
            })
            .collect();
        let problem = Problem {
            model: known.clone(),
            layout,
            unknowns,
            names,
            start,
            n,
            pmax,
            free_drift,
            noise_var,
            known_force,
            unit_force,
            white,
            filters: filters.to_vec(),
            columns,
            state_names,
            inputs: 0,
            atoms,
        };
        let degree = super::weak::moment_degree(&problem);
        if degree > poly::MAX_EXPONENT {
            return Err(IdentError::Unsupported(format!(
                "the weak form of this model reads moments of degree {degree}, and at most {} can be held: give \
                 the characteristics fewer or lower terms",
                poly::MAX_EXPONENT
            )));
        }
        Ok(problem)
    }

    /// The true value of every unknown, looked up by its name in `truth` (for grading; the
    /// identifier itself never sees a truth); NaN where the truth has none (e.g. a monomial).
    pub fn true_values(&self, truth: &Truth) -> Vec<f64> {
        self.names.iter().map(|n| truth.of(n).unwrap_or(f64::NAN)).collect()
    }

    /// Index of `x_i` in the state.
    pub fn x(&self, i: usize) -> usize {
        self.width() * i
    }
    /// Index of `v_i` in the state.
    pub fn v(&self, i: usize) -> usize {
        self.width() * i + 1
    }
    fn width(&self) -> usize {
        match self.layout {
            Layout::White => 2,
            Layout::Augmented => 3,
        }
    }

    /// Drift of mass `i`'s noise variable (`v̇_i` white, `ȧ_i` augmented) at state `y` with
    /// the unknown coefficients `theta` (masses and intensities at their nominal values).
    #[cfg(test)]
    fn noise_drift(&self, i: usize, y: &[f64], theta: &[f64]) -> f64 {
        let j = self.noise_var[i];
        let free: f64 = self
            .free_drift
            .iter()
            .filter(|(v, _)| *v == j)
            .map(|(_, p)| p.eval(y))
            .sum();
        let mut f = self.known_force[i].eval(y);
        for (r, unit) in self.unit_force.iter().enumerate() {
            f += theta[r] * unit[i].eval(y);
        }
        free + f / self.model.mass[i]
    }

    /// With unknown corners: each coefficient estimated directly and recovered from its
    /// product with the corner, `(name, direct, (B·θ)/B̂)`.
    pub fn recovered(&self, values: &[f64]) -> Vec<(String, f64, f64)> {
        let mut out = Vec::new();
        for (k, u) in self.unknowns.iter().enumerate() {
            if let Unknown::CornerProduct(c, e) = *u {
                let direct = self
                    .unknowns
                    .iter()
                    .position(|x| *x == Unknown::Coefficient(c))
                    .map_or(f64::NAN, |j| values[j]);
                let b = self
                    .unknowns
                    .iter()
                    .position(|x| *x == Unknown::Corner(e))
                    .map_or(f64::NAN, |j| values[j]);
                out.push((self.model.coefficient_name(c).to_string(), direct, values[k] / b));
            }
        }
        out
    }

    /// Number of variables of the moment equations: the state, the measured inputs and the
    /// [`Atom`]s.
    pub fn dim(&self) -> usize {
        self.width() * self.n + self.inputs + self.atoms.len()
    }

    /// Number of the variables a density over the state is over: the masses' state and
    /// the measured inputs, not the atoms (which are functions of the state).
    pub fn density_dim(&self) -> usize {
        self.columns.len()
    }

    /// The atoms' values at a point `y` of the state: its first [`Problem::density_dim`]
    /// values in, the atoms' written after them. `row` is scratch of the log's width.
    pub fn fill_atoms(&self, y: &mut [f64], row: &mut [f64]) {
        let d = self.density_dim();
        for (j, &c) in self.columns.iter().enumerate() {
            row[c] = y[j];
        }
        for (k, a) in self.atoms.iter().enumerate() {
            y[d + k] = a.value(&self.model, row);
        }
    }

    /// Number of the masses' own state variables (those test functions depend on).
    pub fn dynamic_dim(&self) -> usize {
        self.width() * self.n
    }

    /// Number of unknowns that enter the drift linearly — coefficients, products, corners,
    /// monomial coefficients (they come first in `unknowns`).
    pub fn coefficient_count(&self) -> usize {
        self.unknowns
            .iter()
            .filter(|u| {
                matches!(
                    u,
                    Unknown::Coefficient(_)
                        | Unknown::CornerProduct(..)
                        | Unknown::Corner(_)
                        | Unknown::Monomial(..)
                        | Unknown::InputGain(_)
                )
            })
            .count()
    }

    /// `μ_i = 1/m_i` and the velocity noise covariance `Q` for parameter values `p`.
    pub(crate) fn mu_q(&self, p: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        let mut mu: Vec<f64> = self.model.mass.iter().map(|m| 1.0 / m).collect();
        for (k, u) in self.unknowns.iter().enumerate() {
            if let Unknown::Mass(i) = u {
                mu[*i] = 1.0 / p[k];
            }
        }
        let mut q = vec![0.0; n * n];
        for (targets, sigma, idx) in &self.white {
            let s = idx.map_or(*sigma, |k| p[k]);
            for &i in targets {
                for &j in targets {
                    q[i * n + j] += s * s * mu[i] * mu[j];
                }
            }
        }
        (mu, q)
    }

    /// Residual `r(p)` and Jacobian `∂r/∂p` of the pieces at parameters `p`.
    pub fn residual(&self, pc: &Pieces, p: &[f64]) -> (DVector<f64>, DMatrix<f64>) {
        let (n, rc, nu) = (self.n, self.coefficient_count(), self.unknowns.len());
        let (mu, q) = self.mu_q(p);
        let mut r = DVector::zeros(pc.rows);
        let mut jac = DMatrix::zeros(pc.rows, nu);
        // The unknown masses: (unknown, mass), in the unknowns' order.
        let masses: Vec<(usize, usize)> = (self.unknowns.iter().enumerate())
            .filter_map(|(u_, unk)| match *unk {
                Unknown::Mass(m) => Some((u_, m)),
                _ => None,
            })
            .collect();
        for k in 0..pc.rows {
            let mut rk = pc.t0[k];
            // Force part per mass: F_ik = a_ki + Σ θ b_kir.
            for i in 0..n {
                let mut f = pc.a[k * n + i];
                for r_ in 0..rc {
                    let b = pc.b[(k * n + i) * rc + r_];
                    f += p[r_] * b;
                    jac[(k, r_)] += mu[i] * b;
                }
                rk += mu[i] * f;
                for &(u_, _) in masses.iter().filter(|&&(_, m)| m == i) {
                    // d(μ_i F)/dm_i = −μ_i² F
                    jac[(k, u_)] += -mu[i] * mu[i] * f;
                }
            }
            for i in 0..n {
                for j in 0..n {
                    rk += 0.5 * q[i * n + j] * pc.c[(k * n + i) * n + j];
                }
            }
            // Noise part derivatives.
            for (targets, sigma, idx) in &self.white {
                let s = idx.map_or(*sigma, |kk| p[kk]);
                for &i in targets {
                    for &j in targets {
                        let c = 0.5 * pc.c[(k * n + i) * n + j];
                        if let Some(kk) = idx {
                            jac[(k, *kk)] += c * 2.0 * s * mu[i] * mu[j];
                        }
                        for &(u_, m) in &masses {
                            // d(s² μ_i μ_j)/dm = −s² μ_i μ_j (1/m)([i=m] + [j=m])
                            let cnt = (i == m) as u8 as f64 + (j == m) as u8 as f64;
                            if cnt > 0.0 {
                                jac[(k, u_)] += -c * s * s * mu[i] * mu[j] * cnt * mu[m];
                            }
                        }
                    }
                }
            }
            r[k] = rk;
        }
        (r, jac)
    }

    /// Solve the pieces for all unknowns: Gauss–Newton from `start` (one exact step when
    /// only coefficients are unknown). `typical` gives each unknown's data-based magnitude,
    /// used for column scaling; the diagnostics at the solution use the estimates
    /// themselves, so the weakest direction is in relative changes of the unknowns.
    /// `weight`, if given, multiplies the equations (a whitening transform, see
    /// [`super::weak::weighting`]); the diagnostics are always those of the unweighted equations,
    /// so the identifiability thresholds mean the same whatever the weighting.
    pub fn solve(&self, pc: &Pieces, typical: &[f64], weight: Option<&DMatrix<f64>>) -> (Vec<f64>, lsq::Diagnostics) {
        let (p, diag) = self.solve_with(pc, typical, weight, true);
        (p, diag.expect("asked for"))
    }

    /// The values of [`Problem::solve`] without its diagnostics (the same numbers, one SVD
    /// fewer): what a jackknife replicate needs.
    pub fn solve_values(&self, pc: &Pieces, typical: &[f64], weight: Option<&DMatrix<f64>>) -> Vec<f64> {
        self.solve_with(pc, typical, weight, false).0
    }

    fn solve_with(
        &self,
        pc: &Pieces,
        typical: &[f64],
        weight: Option<&DMatrix<f64>>,
        diagnostics: bool,
    ) -> (Vec<f64>, Option<lsq::Diagnostics>) {
        let weighted = |(r, j): (DVector<f64>, DMatrix<f64>)| match weight {
            Some(t) => (t * r, t * j),
            None => (r, j),
        };
        // 1. The coefficients by linear least squares, masses and intensities at their
        //    nominal values (unknown masses scaled first by [`Problem::mass_scale`]): the
        //    linearisation point of the diagnostics.
        let rc = self.coefficient_count();
        let mut p = self.start.clone();
        let coefficients = |p: &[f64]| {
            let (r, j) = weighted(self.residual(pc, p));
            let (dx, _) = if rc == j.ncols() {
                lsq::solve(&j, &(-&r), typical)
            } else {
                lsq::solve(&j.columns(0, rc).into_owned(), &(-&r), &typical[..rc])
            };
            let left = (&r + j.columns(0, rc) * dx.rows(0, rc)).norm();
            (dx, left)
        };
        let masses: Vec<usize> = (0..self.unknowns.len())
            .filter(|&k| matches!(self.unknowns[k], Unknown::Mass(_)))
            .collect();
        if !masses.is_empty() {
            // What no fit goes below: rounding, on the scale of the equations unsolved.
            let floor = 1e-9 * weighted(self.residual(pc, &p)).0.norm();
            // A common factor first, then each mass's own (masses off by different factors,
            // or of either sign: swapped or reversed channels), twice round.
            let mut groups = vec![masses.clone()];
            if masses.len() > 1 {
                for _ in 0..2 {
                    groups.extend(masses.iter().map(|&k| vec![k]));
                }
            }
            for group in groups {
                let factor = Problem::mass_scale(|f| {
                    let q = Problem::scaled_at(&p, &group, f);
                    coefficients(&q).1.max(floor)
                });
                p = Problem::scaled_at(&p, &group, factor);
            }
        }
        let (dx, _) = coefficients(&p);
        for k in 0..rc {
            p[k] += dx[k];
        }
        // 2. Diagnostics of the full Jacobian there, directions relative to the values.
        let diag = diagnostics.then(|| {
            let (_, j) = self.residual(pc, &p);
            let scale: Vec<f64> = p
                .iter()
                .zip(typical)
                .map(|(&v, &t)| if v.abs() > 1e-6 * t.abs() { v } else { t })
                .collect();
            lsq::solve(&j, &DVector::zeros(pc.rows), &scale).1
        });
        // 3. Gauss–Newton for all unknowns (nothing to do when only coefficients are unknown).
        if rc < self.unknowns.len() {
            for _ in 0..100 {
                let (r, j) = weighted(self.residual(pc, &p));
                let (dx, _) = lsq::solve(&j, &(-r), typical);
                let mut change: f64 = 0.0;
                for (k, v) in p.iter_mut().enumerate() {
                    *v += dx[k];
                    change = change.max((dx[k] / typical[k]).abs());
                }
                if change < 1e-13 {
                    break;
                }
            }
        }
        (p, diag)
    }

    /// Per unknown, the scale its uncertainty is judged against (never its own value, which
    /// may be 0): for a coefficient of `z^p`, its whole characteristic's typical force —
    /// `Σ_q |k_q| a^q` over the characteristic's known and estimated coefficients at the
    /// data's typical amplitude `a = E[z²]^(1/2)` — in units of this coefficient (÷ `a^p`);
    /// for other unknowns (masses, intensities, corners, gains) `|value|`.
    /// `typical` is [`Problem::typical`] (`a^(-p)` for a coefficient).
    pub fn judging_scales(&self, values: &[f64], typical: &[f64]) -> Vec<f64> {
        self.unknowns
            .iter()
            .enumerate()
            .map(|(k, u)| match *u {
                Unknown::Coefficient(c) if typical[k] > 0.0 && typical[k].is_finite() => {
                    let a = typical[k].powf(-1.0 / c.term.degree() as f64);
                    let mut force: f64 = self
                        .model
                        .terms(c.link, c.kind)
                        .map(|(t, k)| k.abs() * a.powi(t.degree() as i32))
                        .sum();
                    for (j, v) in self.unknowns.iter().enumerate() {
                        if let Unknown::Coefficient(d) = *v {
                            if (d.link, d.kind) == (c.link, c.kind) {
                                force += values[j].abs() * a.powi(d.term.degree() as i32);
                            }
                        }
                    }
                    force * typical[k]
                }
                _ => values[k].abs(),
            })
            .collect()
    }

    /// Data-based typical magnitude of each unknown: for a coefficient of `z^p`,
    /// `1/E[z²]^(p/2)` (a unit force at a typical amplitude); the nominal value for masses
    /// and intensities.
    pub fn typical(&self, mom: &moments::RawMoments) -> Vec<f64> {
        let coef_scale = |c: Coefficient| -> f64 {
            let base = |i: usize| match c.kind {
                Characteristic::Stiffness => self.x(i),
                Characteristic::Damping => self.v(i),
            };
            let mut ends = self.model.geometry(c.link);
            let (a, sign) = ends.next().expect("a link has a first end");
            let mut z = Poly::monomial(var(base(a)), sign);
            for (b, sign) in ends {
                z.add_term(var(base(b)), sign);
            }
            let ez2 = z.mul(&z).expectation(|e| mom.moment(e));
            if ez2 > 0.0 {
                ez2.powf(-(c.term.degree() as f64) / 2.0)
            } else {
                1.0
            }
        };
        let corner = |e: usize| self.filters.iter().find(|f| f.excitation == e).map_or(1.0, |f| f.b);
        self.unknowns
            .iter()
            .zip(&self.start)
            .map(|(u, &s)| match *u {
                Unknown::Coefficient(c) => coef_scale(c),
                Unknown::CornerProduct(c, e) => coef_scale(c) * corner(e),
                Unknown::Corner(e) => corner(e),
                Unknown::InputGain(j) => {
                    let u = self.dynamic_dim() + j;
                    let e = y(u).mul(&y(u)).expectation(|e| mom.moment(e));
                    if e > 0.0 {
                        1.0 / e.sqrt()
                    } else {
                        1.0
                    }
                }
                _ => s.abs(),
            })
            .collect()
    }
}

/// The residual's pieces for `rows` equations (test functions or grid cells):
/// `t0[k]`, `a[k][i]`, `b[k][i][r]`, `c[k][i][j]` (see the module docs).
#[derive(Debug, Clone)]
pub struct Pieces {
    pub rows: usize,
    pub t0: Vec<f64>,
    pub a: Vec<f64>,
    pub b: Vec<f64>,
    pub c: Vec<f64>,
}

impl Pieces {
    /// Refuse equations that hold non-finite numbers: sample values too large for the
    /// moments (or histogram) the method forms, or a non-finite value in the data.
    pub fn check_finite(&self, method: &str) -> Result<(), IdentError> {
        let all = [&self.t0, &self.a, &self.b, &self.c];
        if all.iter().all(|v| v.iter().all(|x| x.is_finite())) {
            return Ok(());
        }
        Err(IdentError::NonFinite(format!(
            "the {method} equations hold non-finite numbers: the data hold a non-finite value, \
             or values so large that their powers overflow (express the data in units that make \
             them of order 1)"
        )))
    }
    pub fn new(rows: usize, n: usize, r: usize) -> Pieces {
        Pieces {
            rows,
            t0: vec![0.0; rows],
            a: vec![0.0; rows * n],
            b: vec![0.0; rows * n * r],
            c: vec![0.0; rows * n * n],
        }
    }
}

/// Convenience: the monomial `y_j`.
pub fn y(j: usize) -> Poly {
    Poly::monomial(var(j), 1.0)
}

/// The state the density is taken of, and per mass the corner `B` of the filtered force
/// driving it (augmented state) and whether that corner is unknown.
struct StateChoice {
    layout: Layout,
    /// State variables per mass: 2 (`x, v`) or 3 (`x, v, a`).
    width: usize,
    corner: Vec<f64>,
    corner_unknown: Vec<Option<usize>>,
}

impl StateChoice {
    /// White forces give `(x, v)`; filtered forces the augmented `(x, v, a)` of
    /// (3.22)–(3.28), which needs exactly one filtered force on every mass.
    fn new(model: &Model, filters: &[Filter], unknown_corners: &[usize]) -> Result<StateChoice, IdentError> {
        let n = model.masses();
        let exc = &model.excitations;
        let measured: Vec<usize> = (0..exc.len()).filter(|&e| exc[e].measured).collect();
        let filtered = measured
            .iter()
            .any(|&e| matches!(exc[e].process, Process::Filtered { .. }));
        let white_any = measured
            .iter()
            .any(|&e| matches!(exc[e].process, Process::White { .. }));
        if filtered && white_any {
            return Err(IdentError::Unsupported(
                "white and filtered excitations together: with white noise on one mass a neighbour's acceleration is not a proper state (docs/theory.md §3); the force-augmented state this needs is not implemented".into(),
            ));
        }
        let mut corner = vec![f64::NAN; n];
        let mut corner_unknown: Vec<Option<usize>> = vec![None; n];
        if filtered {
            for &e in &measured {
                let f = filters.iter().find(|f| f.excitation == e).ok_or_else(|| {
                    IdentError::Unsupported(format!(
                        "no filter parameters for excitation {}",
                        model.excitation_names[e]
                    ))
                })?;
                for &i in &exc[e].targets {
                    if !corner[i].is_nan() {
                        return Err(IdentError::Unsupported(format!(
                            "mass {} is driven by two filtered excitations: its force is then not one Ornstein–Uhlenbeck process and (x, v, a) is not Markov",
                            model.mass_names[i]
                        )));
                    }
                    corner[i] = f.b;
                    if unknown_corners.contains(&e) {
                        corner_unknown[i] = Some(e);
                    }
                }
            }
            if let Some(i) = corner.iter().position(|c| c.is_nan()) {
                return Err(IdentError::Unsupported(format!(
                    "mass {} has no filtered excitation: its acceleration is then a function of (x, v) and the augmented state is degenerate",
                    model.mass_names[i]
                )));
            }
        }
        Ok(StateChoice {
            layout: if filtered { Layout::Augmented } else { Layout::White },
            width: if filtered { 3 } else { 2 },
            corner,
            corner_unknown,
        })
    }
    fn x(&self, i: usize) -> usize {
        self.width * i
    }
    fn v(&self, i: usize) -> usize {
        self.width * i + 1
    }
    fn a(&self, i: usize) -> usize {
        self.width * i + 2
    }
}

/// The unknowns in their order: the coefficients link by link; with unknown corners, the
/// products `B·θ` of the coefficients acting on the masses they drive, then the corners
/// (all linear); then masses and intensities.
fn unknowns(spec: &Specification, corner_unknown: &[Option<usize>]) -> Result<Vec<Unknown>, IdentError> {
    let mut unknowns = Vec::new();
    for il in &spec.links {
        for (kind, terms) in [
            (Characteristic::Stiffness, &il.stiffness),
            (Characteristic::Damping, &il.damping),
        ] {
            for &term in terms.iter().flatten() {
                unknowns.push(Unknown::Coefficient(Coefficient {
                    link: il.link,
                    kind,
                    term,
                }));
            }
        }
    }
    let coefs: Vec<Coefficient> = unknowns
        .iter()
        .filter_map(|u| match u {
            Unknown::Coefficient(c) => Some(*c),
            _ => None,
        })
        .collect();
    for &e in &spec.unknown_corners {
        for c in &coefs {
            let (a, b) = spec.model.ends(c.link);
            if [Some(a), b].into_iter().flatten().any(|m| corner_unknown[m] == Some(e)) {
                unknowns.push(Unknown::CornerProduct(*c, e));
            }
        }
        unknowns.push(Unknown::Corner(e));
    }
    unknowns.extend(spec.unknown_masses.iter().map(|&i| Unknown::Mass(i)));
    unknowns.extend(spec.unknown_intensities.iter().map(|&e| Unknown::Intensity(e)));
    if unknowns.is_empty() {
        return Err(IdentError::NothingToIdentify);
    }
    Ok(unknowns)
}

/// The measured noise sources: targets, nominal intensity (`σ`, or `A` of a filter) and the
/// index of its unknown, if any.
#[allow(clippy::type_complexity)]
fn noise_sources(
    model: &Model,
    filters: &[Filter],
    unknowns: &[Unknown],
) -> Result<Vec<(Vec<usize>, f64, Option<usize>)>, IdentError> {
    let mut white = Vec::new();
    for (e, exc) in model.excitations.iter().enumerate() {
        if !exc.measured {
            continue;
        }
        let intensity = match exc.process {
            Process::White { sigma } => sigma,
            Process::Filtered { .. } => filters.iter().find(|f| f.excitation == e).expect("checked").a,
            // Read as its equivalent white noise, whose level the stage "excitation fit"
            // sets from the measured spectrum: 1 until then.
            Process::Lab(_) => 1.0,
        };
        let idx = unknowns.iter().position(|u| *u == Unknown::Intensity(e));
        white.push((exc.targets.clone(), intensity, idx));
    }
    for (e, exc) in model.excitations.iter().enumerate() {
        if !exc.measured && unknowns.contains(&Unknown::Intensity(e)) {
            return Err(IdentError::Unsupported(format!(
                "excitation {} is unmeasured: its intensity cannot be an unknown here",
                model.excitation_names[e]
            )));
        }
    }
    Ok(white)
}

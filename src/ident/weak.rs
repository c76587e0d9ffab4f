//! Weak form (docs/theory.md §5): for every test function `ψ`, stationarity gives `E[𝒜ψ(Y)] = 0`
//! with `𝒜ψ = Σ v_i ∂ψ/∂x_i + Σ a_i(y) ∂ψ/∂v_i + ½ Σ Q_ij ∂²ψ/∂v_i∂v_j`, linear in the
//! unknown coefficients and needing only sample means — here raw moments accumulated in
//! one pass ([`RawMoments`]), so no density, no differentiated data, constant memory.
//!
//! Test functions: every monomial of the state (never of measured inputs, see
//! [`super::Problem::inputs`]) of degree 1..=`p_max + 1` (degree ≤ 3
//! cannot separate `k1` from `k3` when cubic terms are present). Each is written in the
//! standardised variables `y_j / s_j` — a fixed, data-derived weighting by natural scale;
//! equations are never normalised by their own norm (rows that vanish by symmetry would
//! otherwise get full weight).
//!
//! Local test functions ([`local_tests`]): a characteristic with unknown hinges
//! (piecewise-linear terms) is seen by polynomial test functions only through their
//! smooth averages, so knots a few tenths apart leave the equations nearly rank-deficient.
//! Each unknown hinge `(z − b)₊` adds test functions built on the hinge itself, nonzero
//! only beyond its knot: for a damping `ψ = G(w)` with `G' = (w − b)₊ (w/s)^k`, for a
//! stiffness `ψ = (w/s) (u − b)₊ (u/s)^k`, `k <` [`LOCAL_POWERS`]. Their expectations are
//! generalised moments of the hinge, its slope `1{z > b}` (an [`super::Atom`] of its own)
//! and the state, accumulated with the raw moments.
//!
//! Weighting: the equations' sampling noise differs by orders of magnitude and is
//! correlated, so the estimate solves them weighted by the inverse of their covariance,
//! estimated from the spread of the equations over fine time batches at a first
//! (unweighted) estimate — the efficient generalised method of moments ([`weighting`]).
//! On `silentblock` this cut the worst error at 1e3 s from ≈7 % to ≈1 % (median over
//! seeds).

use super::moments::RawMoments;
use super::poly::{degree, exponent, monomials, var, Poly};
use super::{Pieces, Problem};

/// The test functions' monomials.
pub fn test_functions(problem: &Problem) -> Vec<super::poly::Exponents> {
    let all = monomials(problem.dynamic_dim(), test_degree(problem));
    match problem.layout {
        super::Layout::White => all,
        // At most linear in the accelerations: higher powers of a heavy-tailed acceleration
        // only add noise.
        super::Layout::Augmented => all
            .into_iter()
            .filter(|&e| {
                let a_degree = (0..problem.n).map(|i| exponent(e, problem.noise_var[i])).sum::<u32>();
                a_degree <= A_DEGREE + bilinear(problem) as u32
            })
            .collect(),
    }
}

/// Highest total power of the accelerations in the augmented layout's test functions.
pub const A_DEGREE: u32 = 1;

/// Degree of moments the weak form needs for `problem`.
pub fn moment_degree(problem: &Problem) -> u32 {
    // Drift of degree p_max times ∂ψ of degree test − 1; a local test function's factor
    // (a hinge times a power below LOCAL_POWERS) times the drift, and its square (its scale).
    let local = match local_tests(problem).is_empty() {
        true => 0,
        false => (problem.pmax + LOCAL_POWERS).max(2 * LOCAL_POWERS) + 1,
    };
    (test_degree(problem) + problem.pmax - 1).max(local)
}

/// Number of the weak form's equations: the polynomial test functions, then the local ones.
pub fn equation_count(problem: &Problem) -> usize {
    test_functions(problem).len() + local_tests(problem).len()
}

/// Powers `k` of a characteristic's argument a local test function's factor is multiplied
/// by (`k = 0 … LOCAL_POWERS − 1`): two equations per hinge (three gave the same accuracy
/// on `friction_sdof`).
pub const LOCAL_POWERS: u32 = 2;

/// A local test function of an unknown hinge (see the module's docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalTest {
    pub link: usize,
    pub kind: crate::model::Characteristic,
    /// Variables of the hinge `(z − b)₊` and of its slope `1{z > b}` (both atoms).
    pub hinge: usize,
    pub step: usize,
    /// The power `k` of the argument.
    pub power: u32,
}

/// The local test functions of `problem`: [`LOCAL_POWERS`] per unknown hinge whose slope
/// the problem carries as an atom (white layout).
pub fn local_tests(problem: &Problem) -> Vec<LocalTest> {
    let first = problem.dim() - problem.atoms.len();
    let find = |c: &crate::model::Coefficient, slope: bool| {
        problem
            .atoms
            .iter()
            .position(|a| a.link == c.link && a.kind == c.kind && a.term == c.term && a.slope == slope)
            .map(|k| first + k)
    };
    let mut out = Vec::new();
    for u in &problem.unknowns {
        if let super::Unknown::Coefficient(c) = u {
            if let (crate::model::Term::Hinge(_), Some(hinge), Some(step)) = (c.term, find(c, false), find(c, true)) {
                out.extend((0..LOCAL_POWERS).map(|power| LocalTest {
                    link: c.link,
                    kind: c.kind,
                    hinge,
                    step,
                    power,
                }));
            }
        }
    }
    out
}

/// Test-function degree for `problem`: one above the drift's highest power; and where a
/// characteristic has terms without a polynomial form (atoms, each of degree 1 in the
/// moment equations), enough for its unknown terms to meet as many informative test
/// functions along their argument: an odd term is seen only by the test functions odd in it
/// (under a symmetric density the others give `0 = 0`), so two degrees per odd term and one
/// per other term. Power polynomials keep the first bound, and hinges (white layout) are
/// left to their local test functions (docs/theory.md §5).
pub fn test_degree(problem: &Problem) -> u32 {
    // Per characteristic: (odd unknown terms, other unknown terms, has an atom).
    let mut per: std::collections::BTreeMap<(usize, bool), (u32, u32, bool)> = Default::default();
    for u in &problem.unknowns {
        if let super::Unknown::Coefficient(c) = u {
            // Hinges are seen by their local test functions instead.
            if matches!(c.term, crate::model::Term::Hinge(_)) && problem.layout == super::Layout::White {
                continue;
            }
            let e = per
                .entry((c.link, c.kind == crate::model::Characteristic::Damping))
                .or_default();
            match c.term.is_odd() {
                true => e.0 += 1,
                false => e.1 += 1,
            }
            e.2 |= c.term.power().is_none();
        }
    }
    let atoms = per.values().filter(|e| e.2).map(|e| 2 * e.0 + e.1).max().unwrap_or(0);
    (problem.pmax + 1).max(atoms) + bilinear(problem) as u32
}

/// Whether a corner is unknown: the bilinear drift has more monomial unknowns and needs
/// richer test functions (one degree more, quadratic in the accelerations).
fn bilinear(problem: &Problem) -> bool {
    problem
        .unknowns
        .iter()
        .any(|u| matches!(u, super::Unknown::Corner(_) | super::Unknown::Monomial(..)))
}

/// The raw moments the weak form of `problem` reads (a fraction of all monomials of
/// degree ≤ `2 p_max`: accumulate only these).
pub fn required_moments(problem: &Problem) -> Vec<super::poly::Exponents> {
    let seen = std::cell::RefCell::new(std::collections::BTreeSet::new());
    assemble(problem, &|e| {
        seen.borrow_mut().insert(e);
        1.0
    });
    seen.into_inner().into_iter().filter(|&e| e != 0).collect()
}

/// Moments accumulator for `problem`'s weak form.
pub fn accumulator(problem: &Problem) -> RawMoments {
    RawMoments::with_monomials(problem.dim(), moment_degree(problem), &required_moments(problem))
}

/// Assemble the weak-form pieces from raw moments of the state.
pub fn pieces(problem: &Problem, mom: &RawMoments) -> Pieces {
    assemble(problem, &|e| mom.moment(e))
}

fn assemble(problem: &Problem, moment: &dyn Fn(super::poly::Exponents) -> f64) -> Pieces {
    let scale = scales(problem, moment);
    let local = local_scales(problem, moment);
    let mut pc = Pieces::new(equation_count(problem), problem.n, problem.coefficient_count());
    generate(problem, &scale, &local, &mut |slot, p| {
        *slot.of(&mut pc) += p.expectation(moment)
    });
    pc
}

/// Each state variable's root mean square: the test functions' natural scales.
fn scales(problem: &Problem, moment: &dyn Fn(super::poly::Exponents) -> f64) -> Vec<f64> {
    (0..problem.dim())
        .map(|j| moment(2 * super::poly::var(j)).sqrt().max(1e-300))
        .collect()
}

/// Relative displacement and velocity `(u, w)` of link `l` as polynomials of the state.
fn link_motion(problem: &Problem, l: usize) -> (Poly, Poly) {
    let geometry: Vec<(usize, f64)> = problem.model.geometry(l).collect();
    let u: Vec<(usize, f64)> = geometry.iter().map(|&(i, sign)| (problem.x(i), sign)).collect();
    let w: Vec<(usize, f64)> = geometry.iter().map(|&(i, sign)| (problem.v(i), sign)).collect();
    (Poly::linear(&u), Poly::linear(&w))
}

/// `p · f`.
fn scaled(p: &Poly, f: f64) -> Poly {
    let mut out = Poly::zero();
    out.add(p, f);
    out
}

/// Per local test function: the natural scales of its characteristic's argument `z` and of
/// its link's velocity `w`, and the weight that gives its factor `g(z)` unit mean square.
#[derive(Debug, Clone, Copy)]
struct LocalScale {
    z: f64,
    w: f64,
    weight: f64,
}

fn local_scales(problem: &Problem, moment: &dyn Fn(super::poly::Exponents) -> f64) -> Vec<LocalScale> {
    let rms = |p: &Poly| p.mul(p).expectation(moment).sqrt().max(1e-300);
    local_tests(problem)
        .iter()
        .map(|t| {
            let (u, w) = link_motion(problem, t.link);
            let (s_z, s_w) = (rms(local_argument(t, &u, &w)), rms(&w));
            let (g, _) = local_factor(t, &u, &w, s_z);
            LocalScale {
                z: s_z,
                w: s_w,
                weight: 1.0 / rms(&g),
            }
        })
        .collect()
}

/// The argument `z` of a local test function's characteristic: `u` or `w`.
fn local_argument<'a>(t: &LocalTest, u: &'a Poly, w: &'a Poly) -> &'a Poly {
    match t.kind {
        crate::model::Characteristic::Stiffness => u,
        crate::model::Characteristic::Damping => w,
    }
}

/// A local test function's factor `g(z) = (z − b)₊ (z/s)^k` and its derivative
/// `g'(z) = 1{z > b} (z/s)^k + (k/s) (z − b)₊ (z/s)^(k−1)`.
fn local_factor(t: &LocalTest, u: &Poly, w: &Poly, s: f64) -> (Poly, Poly) {
    let z = local_argument(t, u, w);
    let zk = |k: u32| scaled(&z.pow(k), s.powi(-(k as i32)));
    let hinge = Poly::monomial(var(t.hinge), 1.0);
    let g = hinge.mul(&zk(t.power));
    let mut slope = Poly::monomial(var(t.step), 1.0).mul(&zk(t.power));
    if t.power > 0 {
        slope.add(&hinge.mul(&zk(t.power - 1)), t.power as f64 / s);
    }
    (g, slope)
}

/// Where a polynomial's expectation goes in [`Pieces`].
#[derive(Debug, Clone, Copy)]
enum Slot {
    T0(usize),
    A(usize),
    B(usize),
    C(usize),
}

impl Slot {
    fn of(self, pc: &mut Pieces) -> &mut f64 {
        match self {
            Slot::T0(k) => &mut pc.t0[k],
            Slot::A(k) => &mut pc.a[k],
            Slot::B(k) => &mut pc.b[k],
            Slot::C(k) => &mut pc.c[k],
        }
    }
}

/// Every polynomial of the weak form, with the slot of [`Pieces`] its expectation fills.
fn generate(problem: &Problem, scale: &[f64], local: &[LocalScale], put: &mut dyn FnMut(Slot, &Poly)) {
    let n = problem.n;
    let d = problem.dim();
    let rc = problem.coefficient_count();
    let tests = test_functions(problem);
    for (k, &alpha) in tests.iter().enumerate() {
        // ψ = Π (y_j / s_j)^α_j
        let w: f64 = (0..d).map(|j| scale[j].powi(-(exponent(alpha, j) as i32))).product();
        let psi = Poly::monomial(alpha, w);
        let mut t0 = Poly::zero();
        for (j, drift) in &problem.free_drift {
            t0.add(&drift.mul(&psi.derivative(*j)), 1.0);
        }
        put(Slot::T0(k), &t0);
        for i in 0..n {
            let dpsi = psi.derivative(problem.noise_var[i]);
            if dpsi.terms.is_empty() {
                continue;
            }
            put(Slot::A(k * n + i), &problem.known_force[i].mul(&dpsi));
            for r in 0..rc {
                put(Slot::B((k * n + i) * rc + r), &problem.unit_force[r][i].mul(&dpsi));
            }
            for j in 0..n {
                put(Slot::C((k * n + i) * n + j), &dpsi.derivative(problem.noise_var[j]));
            }
        }
        debug_assert!(degree(alpha) <= test_degree(problem));
    }
    // The local test functions (module docs), after the polynomial ones.
    for (k, (t, sc)) in local_tests(problem).iter().zip(local).enumerate() {
        let row = tests.len() + k;
        let (u, w) = link_motion(problem, t.link);
        let (g, slope) = local_factor(t, &u, &w, sc.z);
        // Per mass: ∂ψ/∂v_i (a damping's ψ = G(w) has no x; a stiffness's ψ = (w/s_w) g(u)
        // is linear in v).
        let (dpsi, second) = match t.kind {
            crate::model::Characteristic::Damping => (scaled(&g, sc.weight), Some(scaled(&slope, sc.weight))),
            crate::model::Characteristic::Stiffness => {
                // Σ v_i ∂ψ/∂x_i = w² g'(u) / s_w.
                put(Slot::T0(row), &scaled(&w.mul(&w).mul(&slope), sc.weight / sc.w));
                (scaled(&g, sc.weight / sc.w), None)
            }
        };
        for i in 0..n {
            let si = problem.model.sign(t.link, i);
            if si == 0.0 {
                continue;
            }
            let dpsi_i = scaled(&dpsi, si);
            put(Slot::A(row * n + i), &problem.known_force[i].mul(&dpsi_i));
            for r in 0..rc {
                put(Slot::B((row * n + i) * rc + r), &problem.unit_force[r][i].mul(&dpsi_i));
            }
            if let Some(second) = &second {
                for j in 0..n {
                    let sj = problem.model.sign(t.link, j);
                    if sj != 0.0 {
                        put(Slot::C((row * n + i) * n + j), &scaled(second, si * sj));
                    }
                }
            }
        }
    }
}

/// The weak form's pieces as a linear map of the raw moments, with the test functions
/// scaled once by the whole record's moments: applied to any batch of the same
/// accumulator, it gives that batch's equations in the same units — cheap enough for a
/// thousand batches.
#[derive(Debug, Clone)]
pub struct PiecesMap {
    rows: usize,
    n: usize,
    rc: usize,
    /// `(slot, moment index, coefficient)`.
    entries: Vec<(Slot, usize, f64)>,
}

impl PiecesMap {
    /// The map for `problem` over the monomials of `total`, scaled by `total`'s moments.
    pub fn new(problem: &Problem, total: &RawMoments) -> PiecesMap {
        let scale = scales(problem, &|e| total.moment(e));
        let local = local_scales(problem, &|e| total.moment(e));
        let mut entries = Vec::new();
        generate(problem, &scale, &local, &mut |slot, p| {
            for (&e, &c) in &p.terms {
                let idx = total
                    .index_of(e)
                    .unwrap_or_else(|| panic!("moment of degree {} not accumulated", degree(e)));
                entries.push((slot, idx, c));
            }
        });
        PiecesMap {
            rows: equation_count(problem),
            n: problem.n,
            rc: problem.coefficient_count(),
            entries,
        }
    }

    /// The pieces of one accumulator (the whole record or a batch; same monomials as the
    /// map was built on).
    pub fn apply(&self, mom: &RawMoments) -> Pieces {
        let mut pc = Pieces::new(self.rows, self.n, self.rc);
        let inv = 1.0 / mom.count.max(1) as f64;
        for &(slot, idx, c) in &self.entries {
            *slot.of(&mut pc) += c * mom.sums[idx] * inv;
        }
        pc
    }
}

/// The residual of the weak form's equations at fixed parameters as a linear map of the
/// raw moments (one sparse row per equation): the residual of each of thousands of fine
/// batches without forming its pieces.
#[derive(Debug, Clone)]
pub struct ResidualMap {
    rows: usize,
    /// `(equation, moment index, coefficient)`, one entry per pair.
    entries: Vec<(u32, u32, f64)>,
}

impl PiecesMap {
    /// The residual map at parameters `p` of `problem` (the residual of
    /// [`Problem::residual`], as a map of the moments).
    pub fn residual_map(&self, problem: &Problem, p: &[f64]) -> ResidualMap {
        let (n, rc) = (self.n, self.rc);
        let (mu, q) = problem.mu_q(p);
        let mut merged: std::collections::BTreeMap<(u32, u32), f64> = std::collections::BTreeMap::new();
        for &(slot, idx, c) in &self.entries {
            let (k, factor) = match slot {
                Slot::T0(k) => (k, 1.0),
                Slot::A(ki) => (ki / n, mu[ki % n]),
                Slot::B(kir) => {
                    let (ki, r) = (kir / rc, kir % rc);
                    (ki / n, mu[ki % n] * p[r])
                }
                Slot::C(kij) => {
                    let (ki, j) = (kij / n, kij % n);
                    (ki / n, 0.5 * q[(ki % n) * n + j])
                }
            };
            if factor != 0.0 {
                *merged.entry((k as u32, idx as u32)).or_insert(0.0) += c * factor;
            }
        }
        ResidualMap {
            rows: self.rows,
            entries: merged.into_iter().map(|((k, i), c)| (k, i, c)).collect(),
        }
    }
}

impl ResidualMap {
    /// The residual of one accumulator's equations, into `out` (one per equation).
    pub fn apply_into(&self, mom: &RawMoments, out: &mut [f64]) {
        debug_assert_eq!(out.len(), self.rows);
        out.fill(0.0);
        let inv = 1.0 / mom.count.max(1) as f64;
        for &(k, idx, c) in &self.entries {
            out[k as usize] += c * mom.sums[idx as usize] * inv;
        }
    }

    pub fn rows(&self) -> usize {
        self.rows
    }
}

/// Batches needed per equation before the weak form weights its equations by their
/// covariance (fewer: plain least squares at the natural scales).
pub const BATCHES_PER_EQUATION: usize = 4;

/// The equation weighting of the efficient (generalised-method-of-moments) weak form:
/// the test functions' equations are correlated and differ in noise by orders of
/// magnitude, so plain least squares lets noisy equations dominate. Column `b` of
/// `residuals` is batch `b`'s residual vector at a first (unweighted) estimate and `counts[b]` its
/// sample count; their spread estimates the covariance `S` of the equations, shrunk
/// towards its diagonal by `rows / batches` (a noisy full covariance otherwise
/// over-fits), and the returned `T = S^(-1/2)` whitens them (rows of zero variance are
/// dropped). `None` when there are too few batches for the equations.
pub fn weighting(residuals: nalgebra::DMatrix<f64>, counts: &[u64]) -> Option<nalgebra::DMatrix<f64>> {
    let (rows, nb) = residuals.shape();
    if nb < BATCHES_PER_EQUATION * rows || nb < 2 || rows == 0 {
        return None;
    }
    let total: f64 = counts.iter().map(|&c| c as f64).sum();
    let mut mean = nalgebra::DVector::zeros(rows);
    for (r, &c) in residuals.column_iter().zip(counts) {
        mean.axpy(c as f64 / total, &r, 1.0);
    }
    // Covariance of a sample's contribution: Σ n_b (r_b − r̄)(r_b − r̄)ᵀ / Σ n_b, as one
    // matrix product of the weighted deviations (formed in place).
    let mut dev = residuals;
    for (mut r, &c) in dev.column_iter_mut().zip(counts) {
        r -= &mean;
        r *= (c as f64 / total).sqrt();
    }
    // In blocks of batches, so no transposed copy of the whole matrix is made.
    let mut s = nalgebra::DMatrix::zeros(rows, rows);
    for start in (0..nb).step_by(256) {
        let block = dev.columns(start, 256.min(nb - start));
        s.gemm(1.0, &block, &block.transpose(), 1.0);
    }
    drop(dev);
    let lambda = rows as f64 / nb as f64;
    for i in 0..rows {
        for j in 0..rows {
            if i != j {
                s[(i, j)] *= 1.0 - lambda;
            }
        }
    }
    whitening(s)
}

/// A whitening `T` of the covariance `s` (`TᵀT = S⁻¹`, so `‖T r‖² = rᵀS⁻¹r`): the inverse
/// of the Cholesky factor of `s` equilibrated to unit diagonal, or, where `s` has rows of
/// no variance or is singular to 1e-12 of its scale, `Λ^(-1/2)Vᵀ` of its eigen-decomposition
/// with those directions dropped. Any `T` with the same `TᵀT` gives the same estimates and
/// criteria; the Cholesky root costs a few seconds where the eigen-decomposition of three
/// thousand equations took minutes.
pub(crate) fn whitening(s: nalgebra::DMatrix<f64>) -> Option<nalgebra::DMatrix<f64>> {
    cholesky_whitening(&s).or_else(|| eigen_whitening(s))
}

/// `T = L⁻¹D^(-1/2)` with `D^(-1/2) S D^(-1/2) = LLᵀ`; `None` where a diagonal is not
/// positive or a pivot falls under 1e-12 (then the eigen root drops what is singular).
fn cholesky_whitening(s: &nalgebra::DMatrix<f64>) -> Option<nalgebra::DMatrix<f64>> {
    let n = s.nrows();
    let d: Vec<f64> = (0..n).map(|i| s[(i, i)]).collect();
    if d.iter().any(|&x| !(x.is_finite() && x > 0.0)) {
        return None;
    }
    let inv_sqrt: Vec<f64> = d.iter().map(|x| 1.0 / x.sqrt()).collect();
    let c = nalgebra::DMatrix::from_fn(n, n, |i, j| s[(i, j)] * inv_sqrt[i] * inv_sqrt[j]);
    let l = c.cholesky()?.unpack();
    let pivot = |i: usize| l[(i, i)] * l[(i, i)];
    if (0..n).any(|i| !pivot(i).is_finite() || pivot(i) <= 1e-12) {
        return None;
    }
    let mut t = lower_triangular_inverse(&l);
    for (mut col, &w) in t.column_iter_mut().zip(&inv_sqrt) {
        col *= w;
    }
    Some(t)
}

/// The inverse of the lower-triangular `l` (itself lower-triangular), column by column in
/// parallel: column `j` solves `L x = e_j` by forward substitution from row `j`, the
/// updates running down `L`'s contiguous columns.
fn lower_triangular_inverse(l: &nalgebra::DMatrix<f64>) -> nalgebra::DMatrix<f64> {
    use rayon::prelude::*;
    let n = l.nrows();
    let ls = l.as_slice();
    let mut x = vec![0.0; n * n];
    x.par_chunks_mut(n.max(1)).enumerate().for_each(|(j, col)| {
        col[j] = 1.0;
        for k in j..n {
            let xk = col[k] / ls[k * n + k];
            col[k] = xk;
            if xk != 0.0 {
                let lk = &ls[k * n + k + 1..(k + 1) * n];
                for (xi, &lik) in col[k + 1..].iter_mut().zip(lk) {
                    *xi -= xk * lik;
                }
            }
        }
    });
    nalgebra::DMatrix::from_vec(n, n, x)
}

/// `T = Λ^(-1/2)Vᵀ` of `s = VΛVᵀ`, eigenvalues under 1e-12 of the largest dropped (their
/// rows zero).
fn eigen_whitening(s: nalgebra::DMatrix<f64>) -> Option<nalgebra::DMatrix<f64>> {
    let rows = s.nrows();
    let eig = super::lsq::symmetric_eigen(s)?;
    let emax = eig.eigenvalues.max();
    if emax.is_nan() || emax <= 0.0 {
        return None;
    }
    let mut t = nalgebra::DMatrix::zeros(rows, rows);
    for k in 0..rows {
        let e = eig.eigenvalues[k];
        if e > 1e-12 * emax {
            t.set_row(k, &(eig.eigenvectors.column(k).transpose() / e.sqrt()));
        }
    }
    Some(t)
}

#[cfg(test)]
mod whitening_tests {
    use super::*;
    use nalgebra::DMatrix;

    /// `TᵀT` against `S⁻¹`, relative to the largest entry.
    fn misfit(t: &DMatrix<f64>, s: &DMatrix<f64>) -> f64 {
        let want = s.clone().try_inverse().expect("regular");
        let got = t.transpose() * t;
        (&got - &want).abs().max() / want.abs().max()
    }

    #[test]
    fn the_cholesky_root_whitens_as_the_eigen_root_does() {
        // A covariance of scales 1e-2 … 1e2 with strong correlations, 40 equations.
        let n = 40;
        let a = DMatrix::from_fn(n, n, |i, j| {
            ((i * 7 + j * 13) % 11) as f64 - 5.0 + if i == j { 9.0 } else { 0.0 }
        });
        let scale: Vec<f64> = (0..n)
            .map(|i| 10f64.powf(-2.0 + 4.0 * i as f64 / (n - 1) as f64))
            .collect();
        let aat = &a * a.transpose();
        let s = DMatrix::from_fn(n, n, |i, j| aat[(i, j)] * scale[i] * scale[j]);
        let chol = cholesky_whitening(&s).expect("positive definite");
        let eig = eigen_whitening(s.clone()).expect("positive definite");
        assert!(misfit(&chol, &s) < 1e-9, "Cholesky root: {:e}", misfit(&chol, &s));
        // The eigen root loses digits to the covariance's condition (~1e10 here).
        assert!(misfit(&eig, &s) < 1e-7, "eigen root: {:e}", misfit(&eig, &s));
        // Lower-triangular inverse exact: L·L⁻¹ = I.
        let l = DMatrix::from_fn(n, n, |i, j| {
            if i >= j {
                a[(i, j)] + if i == j { 20.0 } else { 0.0 }
            } else {
                0.0
            }
        });
        let err = (&l * lower_triangular_inverse(&l) - DMatrix::identity(n, n))
            .abs()
            .max();
        assert!(err < 1e-12, "L·L⁻¹ − I: {err:e}");
        // Scales 1e-4 … 1e4: the eigen root drops the directions under 1e-12 of the largest
        // variance, the equilibrated Cholesky root still whitens every one.
        let wide = DMatrix::from_fn(n, n, |i, j| s[(i, j)] * scale[i] * scale[j]);
        let t = cholesky_whitening(&wide).expect("positive definite");
        let white = &t * &wide * t.transpose() - DMatrix::identity(n, n);
        assert!(white.abs().max() < 1e-9, "T S Tᵀ − I: {:e}", white.abs().max());
    }

    #[test]
    fn a_row_of_no_variance_falls_back_to_the_eigen_root_and_is_dropped() {
        let mut s = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.0, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0]);
        assert!(cholesky_whitening(&s).is_none());
        let t = whitening(s.clone()).expect("the eigen root");
        let white = &t * &s * t.transpose();
        let ones: f64 = (0..3).map(|i| white[(i, i)]).sum();
        assert!((ones - 2.0).abs() < 1e-12, "two directions whitened: trace {ones}");
        // Singular to rounding (two equal rows): the eigen root too.
        s = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        assert!(cholesky_whitening(&s).is_none());
        assert!(whitening(s).is_some());
    }
}

//! Weak form (DESIGN §5): for every test function `ψ`, stationarity gives `E[𝒜ψ(Y)] = 0`
//! with `𝒜ψ = Σ v_i ∂ψ/∂x_i + Σ a_i(y) ∂ψ/∂v_i + ½ Σ Q_ij ∂²ψ/∂v_i∂v_j`, linear in the
//! unknown coefficients and needing only sample means — here raw moments accumulated in
//! one pass ([`RawMoments`]), so no density, no differentiated data, constant memory.
//!
//! Test functions: every monomial of the state of degree 1..=`p_max + 1` (degree ≤ 3
//! cannot separate `k1` from `k3` when cubic terms are present). Each is written in the
//! standardised variables `y_j / s_j` — a fixed, data-derived weighting by natural scale;
//! equations are never normalised by their own norm (rows that vanish by symmetry would
//! otherwise get full weight).

use super::moments::RawMoments;
use super::poly::{degree, exponent, monomials, Poly};
use super::{Pieces, Problem};

/// The test functions' monomials.
pub fn test_functions(problem: &Problem) -> Vec<super::poly::Exponents> {
    let all = monomials(problem.dim(), test_degree(problem));
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
    // Drift of degree p_max times ∂ψ of degree test − 1.
    test_degree(problem) + problem.pmax - 1
}

/// Test-function degree for `problem`.
pub fn test_degree(problem: &Problem) -> u32 {
    problem.pmax + 1 + bilinear(problem) as u32
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
    let d = problem.dim();
    let all = RawMoments::exact(d, moment_degree(problem), |_| 1.0);
    let seen = std::cell::RefCell::new(std::collections::BTreeSet::new());
    assemble(problem, &|e| {
        seen.borrow_mut().insert(e);
        all.moment(e)
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
    let n = problem.n;
    let d = problem.dim();
    let rc = problem.coefficient_count();
    let tests = test_functions(problem);
    let scale: Vec<f64> = (0..d)
        .map(|j| moment(2 * super::poly::var(j)).sqrt().max(1e-300))
        .collect();
    let mut pc = Pieces::new(tests.len(), n, rc);
    let ex = |p: &Poly| p.expectation(moment);
    for (k, &alpha) in tests.iter().enumerate() {
        // ψ = Π (y_j / s_j)^α_j
        let w: f64 = (0..d).map(|j| scale[j].powi(-(exponent(alpha, j) as i32))).product();
        let psi = Poly::monomial(alpha, w);
        let mut t0 = Poly::zero();
        for (j, drift) in &problem.free_drift {
            t0.add(&drift.mul(&psi.derivative(*j)), 1.0);
        }
        pc.t0[k] = ex(&t0);
        for i in 0..n {
            let dpsi = psi.derivative(problem.noise_var[i]);
            if dpsi.terms.is_empty() {
                continue;
            }
            pc.a[k * n + i] = ex(&problem.known_force[i].mul(&dpsi));
            for r in 0..rc {
                pc.b[(k * n + i) * rc + r] = ex(&problem.unit_force[r][i].mul(&dpsi));
            }
            for j in 0..n {
                pc.c[(k * n + i) * n + j] = ex(&dpsi.derivative(problem.noise_var[j]));
            }
        }
        debug_assert!(degree(alpha) <= test_degree(problem));
    }
    pc
}

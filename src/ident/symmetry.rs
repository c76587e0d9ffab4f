//! Exact symmetries of the stationary density, recognised from the model's structure
//! (docs/theory.md §6): directions in the unknowns along which the density — and so every
//! equation of every method, whatever the data and the record length — is unchanged. They
//! are found by linear algebra on the model, never from the noise of the data, so a model
//! that has one is refused the same way on every seed.
//!
//! Two families are derived:
//! - **force scale** (every model): multiplying every mass, every spring and damper
//!   coefficient and every excitation's force (`σ`, or a filter's gain `A`) by one factor
//!   leaves the equations of motion divided by the masses unchanged;
//! - **fluctuation–dissipation** (white noise, linear damping, noise covariance `D`
//!   proportional to the damping matrix `C`, `D = 2T·C` for every value of the unknowns):
//!   the density is `exp(−H/T)` with `H = ½ vᵀMv + U(x)`, so it fixes `M/T` and `U/T`
//!   only. Any change of the dampers and intensities that keeps `D = 2T'·C` with `M` and
//!   `U` scaled by `T'/T` leaves it unchanged: damping against intensity, and with an
//!   unknown mass, the mass and springs against the damping.

use super::{Layout, Problem, Unknown};
use crate::model::{Characteristic, Term};
use nalgebra::DMatrix;

/// An exact symmetry: what it is and its null directions over the unknowns in relative
/// units (`d ln value`), each scaled to a largest entry of 1.
#[derive(Debug, Clone)]
pub struct Symmetry {
    pub why: &'static str,
    pub directions: Vec<Vec<f64>>,
}

const FORCE_SCALE: &str = "multiplying every mass, every spring and damper coefficient and every \
    excitation's force by one factor leaves the motion unchanged, and none of them is known";
const FLUCTUATION_DISSIPATION: &str = "the model satisfies the fluctuation–dissipation relation \
    (white noise, linear damping, noise covariance proportional to the damping matrix), so its \
    stationary density is exp(−H/T) with H = ½ vᵀMv + U(x): it fixes M/T and U/T only, and \
    damping trades against intensity (and, with an unknown mass, the mass and springs against \
    the damping)";

/// Deterministic values in [0.5, 2] standing for the unknowns: a structural property must
/// hold for every value, so it is tested at generic ones.
fn draw(seed: u64, k: usize) -> f64 {
    let mut z = seed.wrapping_add((k as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    0.5 * 4f64.powf((z >> 11) as f64 / (1u64 << 53) as f64)
}

/// The exact symmetry of `problem`'s unknowns, if its structure has one.
pub fn exact_symmetry(problem: &Problem) -> Option<Symmetry> {
    if problem.inputs > 0 {
        return None;
    }
    if !problem.atoms.is_empty() {
        // Terms without a polynomial form: only the force scale is decided structurally.
        return force_scale(problem);
    }
    match gibbs_temperatures(problem) {
        Some(_) => fluctuation_dissipation(problem),
        None => force_scale(problem),
    }
}

/// Force scale alone: a symmetry exactly when no force-scale quantity is known.
fn force_scale(problem: &Problem) -> Option<Symmetry> {
    let m = &problem.model;
    let unknown_mass = |i| problem.unknowns.contains(&Unknown::Mass(i));
    let known_mass = (0..problem.n).any(|i| !unknown_mass(i));
    let known_coefficient = m
        .coefs
        .iter()
        .chain(m.other_terms.iter().map(|t| &t.1))
        .any(|&c| c != 0.0);
    let known_force = problem.white.iter().any(|(_, s, idx)| idx.is_none() && *s != 0.0);
    if known_mass || known_coefficient || known_force {
        return None;
    }
    let direction = problem
        .unknowns
        .iter()
        .map(|u| match u {
            Unknown::Corner(_) => 0.0,
            _ => 1.0,
        })
        .collect();
    Some(Symmetry {
        why: FORCE_SCALE,
        directions: vec![direction],
    })
}

/// Whether the model is white and linearly damped with `D = 2T·C` at two generic draws of
/// the unknowns; the temperatures if so.
fn gibbs_temperatures(problem: &Problem) -> Option<[f64; 2]> {
    if problem.layout != Layout::White {
        return None;
    }
    let m = &problem.model;
    let nonlinear_known = (0..m.links()).any(|l| m.terms(l, Characteristic::Damping).any(|(t, _)| t != Term::Power(1)));
    let nonlinear_unknown = problem
        .unknowns
        .iter()
        .any(|u| matches!(u, Unknown::Coefficient(c) if c.kind == Characteristic::Damping && c.term != Term::Power(1)));
    if nonlinear_known || nonlinear_unknown {
        return None;
    }
    let mut t = [0.0; 2];
    for (d, seed) in [0x5EED_0001u64, 0x5EED_0002].into_iter().enumerate() {
        let values: Vec<f64> = (0..problem.unknowns.len()).map(|k| draw(seed, k)).collect();
        let (dm, cm) = (noise_matrix(problem, &values), damping_matrix(problem, &values));
        let cc = cm.dot(&cm);
        if cc == 0.0 {
            return None;
        }
        let temperature = dm.dot(&cm) / (2.0 * cc);
        if temperature <= 0.0 || (&dm - &cm * (2.0 * temperature)).norm() > 1e-9 * dm.norm() {
            return None;
        }
        t[d] = temperature;
    }
    Some(t)
}

/// The force covariance `D = Σ_e σ_e² b_e b_eᵀ` (`b_e`: 1 on the masses `e` drives), with
/// unknown intensities at `values`.
fn noise_matrix(problem: &Problem, values: &[f64]) -> DMatrix<f64> {
    let mut d = DMatrix::zeros(problem.n, problem.n);
    for (targets, sigma, idx) in &problem.white {
        let s = idx.map_or(*sigma, |k| values[k]);
        for &i in targets {
            for &j in targets {
                d[(i, j)] += s * s;
            }
        }
    }
    d
}

/// Link `l`'s damper geometry `g gᵀ` added to `c` with weight `w` (`g = e_a − e_b`).
fn add_damper(c: &mut DMatrix<f64>, problem: &Problem, l: usize, w: f64) {
    let (a, b) = problem.model.ends(l);
    c[(a, a)] += w;
    if let Some(b) = b {
        c[(b, b)] += w;
        c[(a, b)] -= w;
        c[(b, a)] -= w;
    }
}

/// The linear damping matrix `C = Σ_l c1_l g_l g_lᵀ`, with unknown `c1` at `values`.
fn damping_matrix(problem: &Problem, values: &[f64]) -> DMatrix<f64> {
    let m = &problem.model;
    let mut c = DMatrix::zeros(problem.n, problem.n);
    for l in 0..m.links() {
        if let Some(&c1) = m.damping(l).first() {
            add_damper(&mut c, problem, l, c1);
        }
    }
    for (k, u) in problem.unknowns.iter().enumerate() {
        if let Unknown::Coefficient(co) = u {
            if co.kind == Characteristic::Damping {
                add_damper(&mut c, problem, co.link, values[k]);
            }
        }
    }
    c
}

/// The fluctuation–dissipation family's tangent space at a generic draw, in relative
/// units: variables `(τ, δ_1 … δ_nu)` with `τ = d ln T` and `δ_k = d ln value_k`.
/// Masses and stiffness coefficients follow `T` (`δ = τ`, a known one pins `τ = 0`); the
/// dampers and intensities keep `D = 2T·C`: `Σ 2σ²δ_σ b bᵀ − 2T Σ c δ_c g gᵀ − 2Tτ C = 0`.
fn fluctuation_dissipation(problem: &Problem) -> Option<Symmetry> {
    let nu = problem.unknowns.len();
    let values: Vec<f64> = (0..nu).map(|k| draw(0x5EED_0001, k)).collect();
    let temperature = gibbs_temperatures(problem)?[0];
    let n = problem.n;
    let m = &problem.model;
    let mut rows: Vec<Vec<f64>> = Vec::new();
    let pin_tau = |rows: &mut Vec<Vec<f64>>| {
        let mut r = vec![0.0; nu + 1];
        r[0] = 1.0;
        rows.push(r);
    };
    let known_mass = (0..n).any(|i| !problem.unknowns.contains(&Unknown::Mass(i)));
    let known_stiffness = (0..m.links()).any(|l| m.terms(l, Characteristic::Stiffness).next().is_some());
    if known_mass || known_stiffness {
        pin_tau(&mut rows);
    }
    for (k, u) in problem.unknowns.iter().enumerate() {
        let follows_t = match u {
            Unknown::Mass(_) => true,
            Unknown::Coefficient(c) => c.kind == Characteristic::Stiffness,
            _ => false,
        };
        if follows_t {
            let mut r = vec![0.0; nu + 1];
            r[0] = -1.0;
            r[k + 1] = 1.0;
            rows.push(r);
        }
    }
    // The matrix equation, entry by entry (i ≤ j).
    let c_now = damping_matrix(problem, &values);
    for i in 0..n {
        for j in i..n {
            let mut r = vec![0.0; nu + 1];
            r[0] = -2.0 * temperature * c_now[(i, j)];
            for (k, u) in problem.unknowns.iter().enumerate() {
                match u {
                    Unknown::Intensity(e) => {
                        let targets = &problem.model.excitations[*e].targets;
                        if targets.contains(&i) && targets.contains(&j) {
                            r[k + 1] += 2.0 * values[k] * values[k];
                        }
                    }
                    Unknown::Coefficient(co) if co.kind == Characteristic::Damping => {
                        let mut g = DMatrix::zeros(n, n);
                        add_damper(&mut g, problem, co.link, 1.0);
                        r[k + 1] -= 2.0 * temperature * values[k] * g[(i, j)];
                    }
                    _ => {}
                }
            }
            let norm = r.iter().map(|x| x * x).sum::<f64>().sqrt();
            if norm > 0.0 {
                rows.push(r.iter().map(|x| x / norm).collect());
            }
        }
    }
    let a = DMatrix::from_fn(rows.len(), nu + 1, |r, c| rows[r][c]);
    let directions = canonical(null_space(&a).into_iter().map(|v| v[1..].to_vec()).collect());
    (!directions.is_empty()).then_some(Symmetry {
        why: FLUCTUATION_DISSIPATION,
        directions,
    })
}

/// A basis of the span of `vectors` that does not depend on how the SVD rotated it: the
/// reduced row echelon form (so the first unknowns each move in one direction only), each
/// row scaled to a largest entry of +1.
fn canonical(mut rows: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
    let cols = rows.first().map_or(0, Vec::len);
    let mut rank = 0;
    for c in 0..cols {
        let Some(p) = (rank..rows.len()).max_by(|&a, &b| rows[a][c].abs().total_cmp(&rows[b][c].abs())) else {
            break;
        };
        if rows[p][c].abs() < 1e-9 {
            continue;
        }
        rows.swap(rank, p);
        let pivot = rows[rank][c];
        rows[rank].iter_mut().for_each(|x| *x /= pivot);
        for r in 0..rows.len() {
            if r != rank {
                let f = rows[r][c];
                let pr = rows[rank].clone();
                rows[r].iter_mut().zip(&pr).for_each(|(x, p)| *x -= f * p);
            }
        }
        rank += 1;
    }
    rows.truncate(rank);
    rows.into_iter()
        .map(|d| {
            let big = d
                .iter()
                .fold(0.0f64, |acc, x| if x.abs() > acc.abs() { *x } else { acc });
            d.iter().map(|x| clean(x / big)).collect()
        })
        .collect()
}

/// Round-off below 1e-12 shown as 0.
fn clean(x: f64) -> f64 {
    if x.abs() < 1e-12 {
        0.0
    } else {
        x
    }
}

/// Orthonormal basis of the null space of `a` (columns of relative tolerance 1e-9).
fn null_space(a: &DMatrix<f64>) -> Vec<Vec<f64>> {
    let cols = a.ncols();
    // Pad with zero rows so the SVD yields a full set of right singular vectors.
    let padded = if a.nrows() < cols {
        let mut p = DMatrix::zeros(cols, cols);
        p.view_mut((0, 0), (a.nrows(), cols)).copy_from(a);
        p
    } else {
        a.clone()
    };
    // A structural matrix of small integers-like entries: an SVD that fails to converge
    // finds no null space (no symmetry is claimed on it).
    let Some(svd) = super::lsq::svd(padded, false, true) else {
        return Vec::new();
    };
    let vt = svd.v_t.expect("requested");
    let largest = svd.singular_values.iter().cloned().fold(0.0f64, f64::max).max(1.0);
    svd.singular_values
        .iter()
        .enumerate()
        .filter(|(_, &s)| s <= 1e-9 * largest)
        .map(|(k, _)| vt.row(k).iter().cloned().collect())
        .collect()
}

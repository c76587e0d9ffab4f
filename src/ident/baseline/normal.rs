//! The normal equations the increment and force regressions accumulate, per batch
//! ([`Normal`]), and the lane sums they are built from ([`dot`]).

use super::super::{Pieces, Problem, Unknown};
use multiversion::multiversion;

/// The normal equations of a weighted linear least-squares fit of the velocity equations,
/// kept per mass over the unknowns acting on it ([`Normal::pieces`]: as [`Pieces`] with
/// one row per unknown, row `R` being `Σ w μ_i b_iR · residual_i`).
///
/// An unknown mass `m_i` (the force regression only) has a row of its own: the residual of
/// mass `i`'s equation times its known force `G_i` (the measured force and the known
/// terms, [`Increments::push`]), `Σ w μ_i G_i · residual_i` — the estimating equation of an
/// instrument, linear in `μ_i = 1/m_i` as every row of [`Pieces`] is, and zero in
/// expectation at the true values whatever the equation error, since `G_i` depends on the
/// state and the measured force only. The coefficients' rows are the least squares'
/// normal equations as before, so with every mass known nothing changes.
#[derive(Clone)]
pub(super) struct Normal {
    /// Unknowns (rows), coefficients (the unknowns with a unit force) and masses.
    r: usize,
    rc: usize,
    n: usize,
    /// Per mass: the coefficients whose unit force on it is not identically zero (an
    /// unknown acts on the one or two masses its link joins), ascending.
    acting: Vec<Vec<usize>>,
    /// Per mass, `1 / m_i` (the model's value: an unknown mass's start).
    mu: Vec<f64>,
    /// Per unknown: `−Σ f target`.
    t0: Vec<f64>,
    /// Per mass and acting unknown: `Σ f known`.
    a: Vec<Vec<f64>>,
    /// Per mass: the upper triangle of `Σ f unit` over its acting unknowns, row by row.
    b: Vec<Vec<f64>>,
    /// Per mass: the row of its mass if it is unknown, with `Σ f G` (`f = w μ_i G_i`) and
    /// `Σ f unit` over its acting unknowns.
    mass: Vec<Option<MassRow>>,
    /// Scratch: one mass's unit forces of its acting unknowns.
    unit: Vec<f64>,
}

/// An unknown mass's row in [`Normal`].
#[derive(Clone)]
struct MassRow {
    row: usize,
    a: f64,
    b: Vec<f64>,
}

impl Normal {
    pub(super) fn new(problem: &Problem) -> Normal {
        let (n, r, rc) = (problem.n, problem.unknowns.len(), problem.unit_force.len());
        let acting: Vec<Vec<usize>> = (0..n)
            .map(|i| {
                (0..rc)
                    .filter(|&row| !problem.unit_force[row][i].terms.is_empty())
                    .collect()
            })
            .collect();
        let mass = (0..n)
            .map(|i| {
                let row = problem.unknowns.iter().position(|u| *u == Unknown::Mass(i))?;
                Some(MassRow {
                    row,
                    a: 0.0,
                    b: vec![0.0; acting[i].len()],
                })
            })
            .collect();
        Normal {
            r,
            rc,
            n,
            mu: problem.model.mass.iter().map(|m| 1.0 / m).collect(),
            t0: vec![0.0; r],
            a: acting.iter().map(|u| vec![0.0; u.len()]).collect(),
            b: acting.iter().map(|u| vec![0.0; u.len() * (u.len() + 1) / 2]).collect(),
            mass,
            unit: vec![0.0; rc],
            acting,
        }
    }

    /// One equation per mass: `target_i ≈ μ_i (known_i + Σ_r θ_r unit_ir)`, weight `w`.
    /// Only the unknowns acting on mass `i` enter its terms (the others' unit forces are
    /// identically zero there).
    pub(super) fn add(&mut self, w: f64, target: &[f64], known: &[f64], unit: &[f64]) {
        let n = self.n;
        for (i, acting) in self.acting.iter().enumerate() {
            let m = acting.len();
            let u = &mut self.unit[..m];
            for (u, &row) in u.iter_mut().zip(acting) {
                *u = unit[row * n + i];
            }
            let (a, b, wmu) = (&mut self.a[i], &mut self.b[i], w * self.mu[i]);
            let mut at = 0;
            for k in 0..m {
                let f = wmu * u[k];
                if f != 0.0 {
                    self.t0[acting[k]] -= f * target[i];
                    a[k] += f * known[i];
                    // Symmetric in (row, col): the upper triangle, the rest in `pieces`.
                    for (b, &v) in b[at..at + m - k].iter_mut().zip(&u[k..]) {
                        *b += f * v;
                    }
                }
                at += m - k;
            }
            if let Some(mr) = &mut self.mass[i] {
                let f = wmu * known[i];
                self.t0[mr.row] -= f * target[i];
                mr.a += f * known[i];
                for (b, &v) in mr.b.iter_mut().zip(u.iter()) {
                    *b += f * v;
                }
            }
        }
    }

    /// A block of pairs of one batch, each with weight 1: `parts[k * lanes + l]` is part
    /// `k` of pair `l` (the known force per mass, then the unit force per unknown and
    /// mass, [`DriftParts`]' order) and `target[i * stride + l]` pair `l`'s target on mass
    /// `i`. Each entry gains `μ_i Σ_l (…)`, the sum over the block along the lanes
    /// ([`dot`]); the same equations as [`Normal::add`] pair by pair, up to the order of
    /// the additions.
    pub(super) fn add_block(&mut self, lanes: usize, parts: &[f64], target: &[f64], stride: usize) {
        add_block(self, lanes, parts, target, stride);
    }

    /// The equations as [`Pieces`] (both triangles).
    pub(super) fn pieces(&self) -> Pieces {
        let (n, r, rc) = (self.n, self.r, self.rc);
        let mut p = Pieces::new(r, n, rc);
        p.t0.copy_from_slice(&self.t0);
        for (i, acting) in self.acting.iter().enumerate() {
            let mut at = 0;
            for (k, &row) in acting.iter().enumerate() {
                p.a[row * n + i] = self.a[i][k];
                for &col in &acting[k..] {
                    let v = self.b[i][at];
                    p.b[(row * n + i) * rc + col] = v;
                    p.b[(col * n + i) * rc + row] = v;
                    at += 1;
                }
            }
            if let Some(mr) = &self.mass[i] {
                p.a[mr.row * n + i] = mr.a;
                for (&col, &v) in acting.iter().zip(&mr.b) {
                    p.b[(mr.row * n + i) * rc + col] = v;
                }
            }
        }
        p
    }

    pub(super) fn merge(&mut self, other: &Normal, sign: f64) {
        let pairs = self
            .a
            .iter_mut()
            .chain(self.b.iter_mut())
            .zip(other.a.iter().chain(&other.b));
        for (x, y) in std::iter::once((&mut self.t0, &other.t0)).chain(pairs) {
            for (x, y) in x.iter_mut().zip(y) {
                *x += sign * y;
            }
        }
        for (x, y) in self.mass.iter_mut().zip(&other.mass) {
            if let (Some(x), Some(y)) = (x, y) {
                x.a += sign * y.a;
                for (x, y) in x.b.iter_mut().zip(&y.b) {
                    *x += sign * y;
                }
            }
        }
    }
}

/// [`Normal::add_block`], compiled for the vector units at hand.
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
))]
fn add_block(normal: &mut Normal, lanes: usize, parts: &[f64], target: &[f64], stride: usize) {
    let n = normal.n;
    let lane = |k: usize| &parts[k * lanes..(k + 1) * lanes];
    for (i, acting) in normal.acting.iter().enumerate() {
        let (a, b, mu) = (&mut normal.a[i], &mut normal.b[i], normal.mu[i]);
        let (known, tgt) = (lane(i), &target[i * stride..i * stride + lanes]);
        let mut at = 0;
        for (k, &row) in acting.iter().enumerate() {
            let u = lane(n + row * n + i);
            normal.t0[row] -= mu * dot(u, tgt);
            a[k] += mu * dot(u, known);
            for &col in &acting[k..] {
                b[at] += mu * dot(u, lane(n + col * n + i));
                at += 1;
            }
        }
        if let Some(mr) = &mut normal.mass[i] {
            normal.t0[mr.row] -= mu * dot(known, tgt);
            mr.a += mu * dot(known, known);
            for (b, &col) in mr.b.iter_mut().zip(acting) {
                *b += mu * dot(known, lane(n + col * n + i));
            }
        }
    }
}

/// `Σ_l a_l b_l` over eight running sums (vectorised; the same value on every CPU, as
/// nothing is contracted into a fused multiply–add), then the sums added in a fixed order.
#[inline(always)]
pub(in crate::ident) fn dot(a: &[f64], b: &[f64]) -> f64 {
    const K: usize = 8;
    let mut acc = [0.0; K];
    let (ca, cb) = (a.chunks_exact(K), b.chunks_exact(K));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for j in 0..K {
            acc[j] += x[j] * y[j];
        }
    }
    for (j, (x, y)) in ra.iter().zip(rb).enumerate() {
        acc[j] += x * y;
    }
    ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]))
}

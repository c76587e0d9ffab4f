//! Least squares with diagnostics: columns scaled to unit norm, solved by SVD (never by
//! inverting the normal matrix), with rank, condition number, singular values and the
//! weakest direction reported in every result.

use nalgebra::{DMatrix, DVector, Dyn, SymmetricEigen, SVD};

/// Singular-value ratio below which columns count as linearly dependent (numerical rank).
pub const RANK_TOL: f64 = 1e-9;

/// Most iterations an SVD or a symmetric eigen-decomposition may take. A matrix of
/// subnormal entries (data scaled by 1e-170, an ADC range of 1e-300) kept nalgebra's sweeps
/// from ever converging; a well-scaled one of a few hundred columns takes a few thousand.
pub const MAX_ITERATIONS: usize = 100_000;

/// The SVD of `m`, or `None` where an entry is not finite or the iteration does not
/// converge within [`MAX_ITERATIONS`]: every SVD of the identification goes through here,
/// so none can hang (docs/reliability.md).
pub fn svd(m: DMatrix<f64>, u: bool, v: bool) -> Option<SVD<f64, Dyn, Dyn>> {
    if !m.iter().all(|x| x.is_finite()) {
        return None;
    }
    SVD::try_new(m, u, v, f64::EPSILON, MAX_ITERATIONS)
}

/// The eigen-decomposition of the symmetric `m`, bounded as [`svd`] is.
pub fn symmetric_eigen(m: DMatrix<f64>) -> Option<SymmetricEigen<f64, Dyn>> {
    if !m.iter().all(|x| x.is_finite()) {
        return None;
    }
    SymmetricEigen::try_new(m, f64::EPSILON, MAX_ITERATIONS)
}

/// Diagnostics of one least-squares solve.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Diagnostics {
    /// Numerical rank of the column-scaled matrix.
    pub rank: usize,
    /// Number of unknowns.
    pub cols: usize,
    /// Equations used.
    pub rows: usize,
    /// Smallest over largest singular value of the column-scaled matrix.
    pub sv_ratio: f64,
    pub condition: f64,
    /// Singular values, largest first.
    pub singular_values: Vec<f64>,
    /// Right singular vector of the smallest singular value, in the unknowns' own relative
    /// units (each entry multiplied by the unknown's scale), normalised to max |entry| = 1.
    pub weakest_direction: Vec<f64>,
}

/// Solve `min ‖A x − b‖` with columns scaled by `scale` (typical magnitudes of the
/// unknowns; the weakest direction is reported relative to them). Returns `x` and the
/// diagnostics; `x` is the minimum-norm solution in scaled units when rank-deficient.
pub fn solve(a: &DMatrix<f64>, b: &DVector<f64>, scale: &[f64]) -> (DVector<f64>, Diagnostics) {
    let (rows, cols) = a.shape();
    // Nothing determined: reported as rank 0. Callers check their equations first and say
    // why (`Pieces::check_finite`).
    let undetermined = || {
        (
            DVector::from_element(cols, f64::NAN),
            Diagnostics {
                rank: 0,
                cols,
                rows,
                sv_ratio: 0.0,
                condition: f64::INFINITY,
                singular_values: vec![f64::NAN; cols.min(rows)],
                weakest_direction: vec![f64::NAN; cols],
            },
        )
    };
    if !(a.iter().chain(b.iter()).all(|x| x.is_finite())) {
        return undetermined();
    }
    // Unknown-magnitude scaling first (so directions are relative), then unit columns.
    let mut s = a.clone();
    let mut colscale = vec![1.0; cols];
    for j in 0..cols {
        let sc = if scale[j].is_finite() && scale[j] != 0.0 {
            scale[j].abs()
        } else {
            1.0
        };
        let mut col = s.column_mut(j);
        col *= sc;
        let norm = col.norm();
        let n = if norm > 0.0 { norm } else { 1.0 };
        col /= n;
        colscale[j] = sc / n;
    }
    // A tall system (far more equations than unknowns: grid cells, lattice nodes) is
    // reduced first by Householder QR, `A = Q R`: `R` (cols × cols) has the singular
    // values and right singular vectors of `A`, and `min ‖R x − Qᵀb‖` has the same
    // solution, so the SVD works on `R` and never forms `A`'s left singular vectors.
    let (s, b) = if rows > cols {
        let qr = s.qr();
        let mut qtb = b.clone();
        qr.q_tr_mul(&mut qtb);
        (qr.r(), qtb.rows(0, cols).into_owned())
    } else {
        (s, b.clone())
    };
    let Some(svd) = svd(s, true, true) else {
        return undetermined();
    };
    let sv: Vec<f64> = svd.singular_values.iter().copied().collect();
    let mut order: Vec<usize> = (0..sv.len()).collect();
    order.sort_by(|&i, &j| sv[j].partial_cmp(&sv[i]).unwrap_or(std::cmp::Ordering::Equal));
    let smax = sv.iter().copied().fold(0.0, f64::max);
    let smin = if rows >= cols {
        sv.iter().copied().fold(f64::INFINITY, f64::min)
    } else {
        0.0
    };
    let rank = sv.iter().filter(|&&x| x > RANK_TOL * smax).count();
    let x_scaled = svd.solve(&b, RANK_TOL * smax).unwrap_or_else(|_| DVector::zeros(cols));
    let x = DVector::from_iterator(cols, (0..cols).map(|j| x_scaled[j] * colscale[j]));
    let v_t = svd.v_t.as_ref().expect("computed");
    let weakest = *order.last().unwrap_or(&0);
    let mut dir: Vec<f64> = (0..cols)
        .map(|j| {
            let sc = if scale[j].is_finite() && scale[j] != 0.0 {
                scale[j].abs()
            } else {
                1.0
            };
            // Back from unit-norm columns to units of the unknown's scale.
            v_t[(weakest, j)] * colscale[j] / sc
        })
        .collect();
    let m = dir.iter().fold(0.0f64, |a, &v| a.max(v.abs()));
    if m > 0.0 {
        // Sign: the largest entry positive.
        let big = dir
            .iter()
            .copied()
            .fold(0.0f64, |a, v| if v.abs() > a.abs() { v } else { a });
        let sign = if big < 0.0 { -1.0 } else { 1.0 };
        dir.iter_mut().for_each(|v| *v *= sign / m);
    }
    let sv_ratio = if smax > 0.0 { smin / smax } else { 0.0 };
    let diag = Diagnostics {
        rank,
        cols,
        rows,
        sv_ratio,
        condition: if sv_ratio > 0.0 { 1.0 / sv_ratio } else { f64::INFINITY },
        singular_values: order.iter().map(|&i| sv[i]).collect(),
        weakest_direction: dir,
    };
    (x, diag)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Equations of subnormal magnitude (the moments of data scaled by 1e-170, or clipped
    /// by an ADC range of 1e-300) once kept the SVD's sweeps from converging, and a run
    /// hung; now the decomposition either converges or is reported as not converged.
    #[test]
    fn subnormal_equations_end_in_bounded_time() {
        let a = DMatrix::from_fn(12, 4, |i, j| 1e-310 * (((i * 7 + j * 3) % 11) as f64 - 5.0));
        let b = DVector::from_fn(12, |i, _| 1e-310 * (i as f64 - 6.0));
        let (x, d) = solve(&a, &b, &[1.0; 4]);
        assert!(x.len() == 4 && d.rank <= 4);
        let _ = svd(a.clone(), true, true);
        let _ = symmetric_eigen(a.transpose() * &a);
        // Non-finite entries are refused before any sweep.
        let mut bad = a;
        bad[(0, 0)] = f64::NAN;
        assert!(svd(bad, true, true).is_none());
    }
}

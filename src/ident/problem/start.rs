//! Where the solve starts for unknown masses: a rig in volts has a "mass" that is a gain's
//! inverse, orders of magnitude from any value a user can give (docs/data.md, "A rig in
//! volts"), so the masses' starting values are scaled first ([`Problem::solve`]).

use super::Problem;

impl Problem {
    /// `p` with the unknowns `at` multiplied by `factor`.
    pub(super) fn scaled_at(p: &[f64], at: &[usize], factor: f64) -> Vec<f64> {
        let mut q = p.to_vec();
        for &k in at {
            q[k] *= factor;
        }
        q
    }

    /// The common factor on the unknown masses' starting values that leaves the least
    /// residual after the coefficients' linear solve (`left(factor)`): a rig in volts has
    /// a "mass" that is a gain's inverse, orders of magnitude from any value a user can
    /// guess, and Gauss–Newton in `1/m` does not come back from such a start. Over ±12
    /// decades in half decades, either sign (a force cell mounted the other way implies a
    /// negative mass, which the force-scale check names), then golden-section search in the
    /// decade around the least,
    /// to a thousandth of a decade. The residual grows without bound as the masses go to 0
    /// (the known forces over them are then unbalanced) and tends to a constant as they
    /// grow, so its least is inside the scan whenever the data determine the masses. The
    /// start stays unless the least (after the search) is under half its residual (on a
    /// rig in volts it is 0 to rounding, the start's the whole): where the data do not
    /// determine the masses (a symmetry, a rank deficiency) the residual is flat along the
    /// scan, and the diagnostics are taken at the start as they are without masses.
    pub(super) fn mass_scale(mut left: impl FnMut(f64) -> f64) -> f64 {
        let mut cost = |sign: f64, e: f64| {
            let c = left(sign * 10f64.powf(e));
            if c.is_finite() {
                c
            } else {
                f64::INFINITY
            }
        };
        let grid: Vec<(f64, f64)> = [1.0, -1.0]
            .into_iter()
            .flat_map(|sign| (-24..=24).map(move |k| (sign, 0.5 * k as f64)))
            .collect();
        let costs: Vec<f64> = grid.iter().map(|&(sign, e)| cost(sign, e)).collect();
        let start = 24; // the factor +1
        let best = (0..grid.len()).fold(start, |b, k| if costs[k] < costs[b] { k } else { b });
        if !costs[best].is_finite() {
            return 1.0;
        }
        let (sign, centre) = grid[best];
        let (mut lo, mut hi) = (centre - 0.5, centre + 0.5);
        let g = 0.5 * (5f64.sqrt() - 1.0);
        let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
        let (mut c1, mut c2) = (cost(sign, x1), cost(sign, x2));
        while hi - lo > 1e-3 {
            if c1 <= c2 {
                (hi, x2, c2) = (x2, x1, c1);
                x1 = hi - g * (hi - lo);
                c1 = cost(sign, x1);
            } else {
                (lo, x1, c1) = (x1, x2, c2);
                x2 = lo + g * (hi - lo);
                c2 = cost(sign, x2);
            }
        }
        let e = 0.5 * (lo + hi);
        if cost(sign, e) < 0.5 * costs[start] {
            sign * 10f64.powf(e)
        } else {
            1.0
        }
    }
}

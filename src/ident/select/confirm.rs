//! The jackknife's word on a selected model (docs/selection.md, "The confirmation").
//!
//! The criterion weighs a term by how much `J` rises without it, divided by one
//! dispersion for every direction. On many candidates that is not enough: the efficient
//! weighting is estimated from the spread over fine batches, and along some directions of
//! the equations it understates their noise several times (a false candidate link's `k1`
//! on a 3-mass chain: `ΔJ/dispersion` ≈ 20, while its delete-one jackknife t-statistic over
//! the record's independent batches is 1.7). The confirmation judges each selected term,
//! and each link's selected terms together, by the Wald statistic of the jackknife
//! covariance — the spread of the model's estimates over the batches, which needs no model
//! of the equations' noise — against the same penalty per term: a term stays when
//! `t² ≥ ln N`, a link's terms stay when their joint Wald statistic is at least their count
//! times `ln N`. The weakest removal is made, the model refitted, until every term and link
//! earns its penalty; removals that would leave a characteristic with an even or negative
//! leading term, or no stationary density, are not made.

use super::{Admissibility, Equations};
use nalgebra::{DMatrix, DVector};

/// One removal the confirmation made.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Removal {
    /// The candidates removed (one term, or a link's selected terms).
    pub terms: Vec<usize>,
    /// Their Wald statistic under the jackknife covariance (`t²` for one term).
    pub wald: f64,
    /// The penalty they had to earn: their count times `ln N`.
    pub penalty: f64,
}

/// The estimates of `set` on the whole record and their delete-one jackknife covariance
/// over `replicates`; `None` when a fit fails.
fn jackknife(whole: &Equations, replicates: &[Equations], set: &[usize]) -> Option<(Vec<f64>, DMatrix<f64>)> {
    let (theta, _) = whole.fit(set)?;
    let k = set.len();
    let reps: Vec<DVector<f64>> = replicates
        .iter()
        .map(|eq| {
            eq.fit(set)
                .map(|(t, _)| DVector::from_iterator(k, set.iter().map(|&i| t[i])))
        })
        .collect::<Option<_>>()?;
    let b = reps.len();
    if b < 2 {
        return None;
    }
    let mean = reps.iter().fold(DVector::zeros(k), |acc, r| acc + r) / b as f64;
    let mut cov = DMatrix::zeros(k, k);
    for r in &reps {
        let d = r - &mean;
        cov += &d * d.transpose();
    }
    cov *= (b - 1) as f64 / b as f64;
    Some((set.iter().map(|&i| theta[i]).collect(), cov))
}

/// The Wald statistic `θ_Rᵀ V_RR⁻¹ θ_R` of the positions `r` of `theta` under `cov`;
/// infinite where the replicates do not move them (nothing to doubt).
fn wald(theta: &[f64], cov: &DMatrix<f64>, r: &[usize]) -> f64 {
    let v = DMatrix::from_fn(r.len(), r.len(), |a, b| cov[(r[a], r[b])]);
    let t = DVector::from_iterator(r.len(), r.iter().map(|&a| theta[a]));
    match v.cholesky() {
        Some(ch) => t.dot(&ch.solve(&t)),
        None => f64::INFINITY,
    }
}

/// The removals open to `set` (positions into `set`, the Wald statistic, the count of
/// terms): every term alone, and every link with two or more selected terms as a whole.
fn options(set: &[usize], theta: &[f64], cov: &DMatrix<f64>, link_of: &[usize]) -> Vec<(Vec<usize>, f64)> {
    let mut out: Vec<(Vec<usize>, f64)> = (0..set.len()).map(|a| (vec![a], wald(theta, cov, &[a]))).collect();
    let mut links: Vec<usize> = set.iter().map(|&i| link_of[i]).collect();
    links.sort_unstable();
    links.dedup();
    for l in links {
        let r: Vec<usize> = (0..set.len()).filter(|&a| link_of[set[a]] == l).collect();
        if r.len() > 1 {
            let w = wald(theta, cov, &r);
            out.push((r, w));
        }
    }
    out
}

/// Confirm the selection `set` (fitted by `fit`, the jackknife spread from `replicates`):
/// the model with every term and every link earning its penalty `penalty` per term, and
/// the removals made, in order.
pub(super) fn confirm(
    fit: &Equations,
    replicates: &[Equations],
    admissibility: &Admissibility,
    mut set: Vec<usize>,
    penalty: f64,
) -> (Vec<usize>, Vec<Removal>) {
    let link_of: Vec<usize> = admissibility.coefficients.iter().map(|c| c.link).collect();
    let mut removed = Vec::new();
    while let Some((theta, cov)) = jackknife(fit, replicates, &set) {
        // The weakest first: the smallest statistic per penalty it had to earn.
        let mut open: Vec<(Vec<usize>, f64)> = options(&set, &theta, &cov, &link_of)
            .into_iter()
            .filter(|(r, w)| *w < r.len() as f64 * penalty)
            .collect();
        open.sort_by(|a, b| (a.1 / a.0.len() as f64).total_cmp(&(b.1 / b.0.len() as f64)));
        let next = open.into_iter().find_map(|(r, w)| {
            let drop: Vec<usize> = r.iter().map(|&a| set[a]).collect();
            let rest: Vec<usize> = set.iter().copied().filter(|i| !drop.contains(i)).collect();
            if admissibility.even_leading(&rest) != 0 {
                return None;
            }
            let (t, _) = fit.fit(&rest)?;
            admissibility.admits(&rest, &t).then(|| {
                let removal = Removal {
                    penalty: drop.len() as f64 * penalty,
                    terms: drop,
                    wald: w,
                };
                (rest, removal)
            })
        });
        let Some((rest, removal)) = next else { break };
        set = rest;
        removed.push(removal);
    }
    (set, removed)
}

#[cfg(test)]
mod tests {
    use super::super::tests::{exact, one_link};
    use super::*;

    /// Replicates whose estimates scatter around `theta` by `jitter` (alternating signs,
    /// per coefficient): the spread the jackknife reads, whatever the whole record's `J`
    /// says.
    fn replicates(theta: &[f64], jitter: &[f64]) -> Vec<Equations> {
        (0..32)
            .map(|b| {
                let sign = if b % 2 == 0 { 1.0 } else { -1.0 };
                let t: Vec<f64> = theta.iter().zip(jitter).map(|(t, j)| t + sign * j).collect();
                exact(&t, 40)
            })
            .collect()
    }

    #[test]
    fn the_jackknife_removes_a_term_the_criterion_keeps_on_understated_noise() {
        // The whole record's equations hold c3 = 0.01 exactly: by `J` it is as certain as
        // the true terms. The replicates move it by ±0.004 (jackknife SE 0.022, t = 0.45):
        // the confirmation removes it and keeps k1, k3, c1 (moved by 1e-4 of their size).
        let adm = one_link();
        let theta = [10.0, 0.0, 20.0, 0.5, 0.0, 0.01];
        let whole = exact(&theta, 40);
        let s = super::super::Search::new(&whole, &adm, 40).unwrap();
        let (best, _) = s.choose(6).unwrap();
        assert_eq!(best.set, vec![0, 2, 3, 5], "the criterion keeps c3");
        let reps = replicates(&theta, &[1e-3, 0.0, 2e-3, 5e-5, 0.0, 0.004]);
        let (set, removed) = confirm(&whole, &reps, &adm, best.set, s.penalty);
        assert_eq!(set, vec![0, 2, 3]);
        assert_eq!(removed.len(), 1);
        assert_eq!(removed[0].terms, vec![5]);
        let t2 = 0.01f64.powi(2) / (31.0 * 0.004f64.powi(2));
        assert!(
            (removed[0].wald - t2).abs() < 1e-6 * t2,
            "{} against {t2}",
            removed[0].wald
        );
        // The same c3 of 0.1, moved by ±0.001 (t² ≈ 320 > ln N ≈ 13.8): confirmed.
        let theta = [10.0, 0.0, 20.0, 0.5, 0.0, 0.1];
        let whole = exact(&theta, 40);
        let reps = replicates(&theta, &[1e-3, 0.0, 2e-3, 5e-5, 0.0, 0.001]);
        let (set, removed) = confirm(&whole, &reps, &adm, vec![0, 2, 3, 5], s.penalty);
        assert_eq!((set, removed), (vec![0, 2, 3, 5], vec![]));
    }
}

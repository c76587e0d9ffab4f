//! The candidate model's whitened weak-form equations as normal equations, for the whole
//! record, for each batch, and for any choice of batches (the jackknife's replicates, the
//! bootstrap's resamples) as the count-weighted mean of the batches' whitened equations:
//! the equations are linear in the batches' mean moments, so no choice of batches needs a
//! pass over the samples or a weighting of its own (docs/selection.md).

use super::super::{Pieces, Problem};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// The whitened candidate equations as normal equations: for `θ`, `J(θ) = c + 2 hᵀθ + θᵀGθ`
/// with `G = N·AᵀA`, `h = N·Aᵀb`, `c = N·bᵀb`, `A = T·∂r/∂θ`, `b = T·r(0)`.
pub(super) struct Equations {
    pub(super) g: DMatrix<f64>,
    pub(super) h: DVector<f64>,
    pub(super) c: f64,
    /// The samples they are from.
    pub(super) n: f64,
}

/// One batch's whitened equations `A = T·∂r/∂θ`, `b = T·r(0)` per sample, and its
/// sample count: linear in the batch's mean moments, so the equations of any weighted
/// choice of batches are their count-weighted mean ([`Equations::resampled`]).
pub(super) struct Whitened {
    a: DMatrix<f64>,
    b: DVector<f64>,
    n: f64,
}

impl Whitened {
    /// The count-weighted mean of `times[i]` copies of batch `i`.
    fn sum(batches: &[Whitened], times: &[u32]) -> Whitened {
        let n: f64 = batches.iter().zip(times).map(|(b, &t)| t as f64 * b.n).sum();
        let mut sum = Whitened {
            a: DMatrix::zeros(batches[0].a.nrows(), batches[0].a.ncols()),
            b: DVector::zeros(batches[0].b.len()),
            n,
        };
        for (bw, &t) in batches.iter().zip(times).filter(|(b, &t)| t > 0 && b.n > 0.0) {
            let w = t as f64 * bw.n / n;
            for (x, y) in sum.a.iter_mut().zip(bw.a.iter()) {
                *x += w * y;
            }
            sum.b.axpy(w, &bw.b, 1.0);
        }
        sum
    }

    pub(super) fn new(problem: &Problem, pc: &Pieces, weight: &DMatrix<f64>, n: f64) -> Whitened {
        let (r0, jac) = problem.residual(pc, &vec![0.0; problem.unknowns.len()]);
        Whitened {
            a: weight * jac,
            b: weight * r0,
            n,
        }
    }
}

impl Equations {
    pub(super) fn new(problem: &Problem, pc: &Pieces, weight: &DMatrix<f64>, n: f64) -> Equations {
        Equations::of(&Whitened::new(problem, pc, weight, n))
    }

    pub(super) fn of(w: &Whitened) -> Equations {
        Equations {
            g: w.a.tr_mul(&w.a) * w.n,
            h: w.a.tr_mul(&w.b) * w.n,
            c: w.b.norm_squared() * w.n,
            n: w.n,
        }
    }

    /// The equations of the record made of `times[i]` copies of batch `i`.
    pub(super) fn resampled(batches: &[Whitened], times: &[u32]) -> Equations {
        Equations::of(&Whitened::sum(batches, times))
    }

    /// The jackknife's replicates as sums of the batches: the whole record without each
    /// non-empty batch in turn (the sum less the batch, so each costs one batch's size).
    pub(super) fn leave_one_out(batches: &[Whitened]) -> Vec<Equations> {
        let times: Vec<u32> = batches.iter().map(|b| u32::from(b.n > 0.0)).collect();
        if times.iter().sum::<u32>() < 2 {
            return Vec::new();
        }
        let whole = Whitened::sum(batches, &times);
        (batches.par_iter())
            .filter(|b| b.n > 0.0)
            .map(|out| {
                let n = whole.n - out.n;
                let (wa, wo) = (whole.n / n, out.n / n);
                Equations::of(&Whitened {
                    a: DMatrix::from_fn(whole.a.nrows(), whole.a.ncols(), |r, c| {
                        wa * whole.a[(r, c)] - wo * out.a[(r, c)]
                    }),
                    b: DVector::from_fn(whole.b.len(), |r, _| wa * whole.b[r] - wo * out.b[r]),
                    n,
                })
            })
            .collect()
    }

    /// `J` at the coefficients `theta`.
    pub(super) fn value(&self, theta: &[f64]) -> f64 {
        let t = DVector::from_column_slice(theta);
        self.c + 2.0 * self.h.dot(&t) + t.dot(&(&self.g * &t))
    }

    /// The least-squares fit of the model of the terms `set`: the coefficients (zero
    /// outside `set`) and `J`. `None` when the model's columns are dependent.
    pub(super) fn fit(&self, set: &[usize]) -> Option<(Vec<f64>, f64)> {
        let k = set.len();
        let mut theta = vec![0.0; self.h.len()];
        if k == 0 {
            return Some((theta, self.c));
        }
        // Columns equilibrated to unit diagonal before the factorisation.
        let d: Vec<f64> = set.iter().map(|&i| 1.0 / self.g[(i, i)].sqrt()).collect();
        if d.iter().any(|x| !x.is_finite()) {
            return None;
        }
        let m = DMatrix::from_fn(k, k, |r, c| d[r] * self.g[(set[r], set[c])] * d[c]);
        let rhs = DVector::from_fn(k, |r, _| -d[r] * self.h[set[r]]);
        let y = m.cholesky()?.solve(&rhs);
        for (r, &i) in set.iter().enumerate() {
            theta[i] = d[r] * y[r];
        }
        let mut j = self.c;
        for &i in set {
            j += 2.0 * self.h[i] * theta[i];
            for &l in set {
                j += theta[i] * self.g[(i, l)] * theta[l];
            }
        }
        Some((theta, j.max(0.0)))
    }
}

#[cfg(test)]
mod tests {
    use super::super::super::{data::StationaryData, weak};
    use super::*;

    /// The equations of sums of batches built from the batches' whitened equations (the
    /// jackknife's replicates, the bootstrap's resamples) are those built from the summed
    /// moments; the bootstrap draws the same resamples every time.
    #[test]
    fn equations_of_resampled_batches_are_those_of_their_summed_moments() {
        use crate::ident::spec::Specification;
        use crate::scenario::Scenario;
        let path = format!("{}/scenarios/duffing2dof.toml", env!("CARGO_MANIFEST_DIR"));
        let mut s = Scenario::parse(&std::fs::read_to_string(&path).unwrap(), &path, "t").unwrap();
        (s.simulation.record_length, s.simulation.trajectories) = (250.0, 32);
        let mut samples = crate::sim::Collect::default();
        crate::sim::simulate(&crate::model::Model::new(&s), &s.simulation, &mut samples, &|_| {}).unwrap();
        let problem = Problem::from_spec(&Specification::from_scenario(&s), &[]).unwrap();
        let mut data = StationaryData::new(&problem, weak::moment_degree(&problem), 250.0, 32, 8);
        for b in &samples.batches {
            b.for_each_sample(|j, t, row| data.push(j, t, row));
        }
        data.finish();
        let w = super::super::Weighted::new(&problem, &data, "test", |_, _| String::new()).expect("weighted");
        let whitened: Vec<Whitened> = (data.batches().iter())
            .map(|b| Whitened::new(&problem, &w.map.apply(b), &w.weight, b.count as f64))
            .collect();
        let close = |a: &Equations, b: &Equations, what: &str| {
            let scale = b.g.abs().max();
            assert!((&a.g - &b.g).abs().max() <= 1e-9 * scale, "{what}: G");
            assert!((&a.h - &b.h).abs().max() <= 1e-9 * b.h.abs().max(), "{what}: h");
            assert!((a.c - b.c).abs() <= 1e-9 * b.c && a.n == b.n, "{what}: c, n");
        };
        let direct = |m: &crate::ident::moments::RawMoments| {
            Equations::new(&problem, &w.map.apply(m), &w.weight, m.count as f64)
        };
        let ones = vec![1; whitened.len()];
        close(
            &Equations::resampled(&whitened, &ones),
            &direct(&data.total()),
            "the whole record",
        );
        let loo = Equations::leave_one_out(&whitened);
        let want: Vec<Equations> = data.leave_one_out().iter().map(direct).collect();
        assert_eq!(loo.len(), want.len());
        for (b, (a, d)) in loo.iter().zip(&want).enumerate() {
            close(a, d, &format!("replicate {b}"));
        }
        let draws = data.bootstrap(3);
        assert_eq!(draws, data.bootstrap(3), "the same stream");
        let batches = data.batches();
        for times in &draws {
            assert_eq!(
                times.iter().sum::<u32>() as usize,
                batches.iter().filter(|b| b.count > 0).count()
            );
            let mut merged = batches[0].clone();
            merged.count = 0;
            merged.sums.iter_mut().for_each(|x| *x = 0.0);
            for (b, &t) in batches.iter().zip(times) {
                for _ in 0..t {
                    merged.merge(b);
                }
            }
            close(&Equations::resampled(&whitened, times), &direct(&merged), "a resample");
        }
    }
}

//! The Cramér–Rao bound of continuous observation, estimated from the samples: how small
//! a standard error any unbiased estimator of the drift's coefficients could reach had it
//! seen the whole path, not samples of it (docs/methods.md, "How close to optimal").
//!
//! For white-noise forcing the drift is `F(y) = F₀(y) + G(y) θ` with `G` non-zero on the
//! masses' velocity rows only (`μ_i` times each unknown's unit force on mass `i`), and the
//! noise covariance per unit time on those rows is `S_ij = Σ σ² μ_i μ_j` over the forces
//! acting on both. Girsanov's likelihood gives the Fisher information per unit time
//! `I = E[Gᵀ S⁻¹ G]` under the stationary density, so a path of total length `T` bounds
//! the covariance of any unbiased estimate by `(T I)⁻¹`. The expectation is the samples'
//! mean; `T` is the number of samples times the sample interval.
//!
//! Known answer: the linear oscillator `m ẍ + c ẋ + k x = σ ξ` has `I = diag(1/(2kc),
//! 1/(2cm))`, so `var(k̂) ≥ 2kc/T` and `var(ĉ) ≥ 2cm/T` (`tests/baselines.rs`).

use super::baseline::{applicable, dot, DriftParts};
use super::Problem;
use multiversion::multiversion;
use nalgebra::DMatrix;

/// Samples gathered before their parts are evaluated together.
const BLOCK: usize = 64;

/// The samples' mean of `Gᵀ S⁻¹ G`, accumulated over blocks of samples: the drift's parts
/// of a block evaluated along its lanes at once, and each product of two unknowns' unit
/// forces summed over the lanes (what the compiler vectorises; per sample the work was
/// bound by its indexing).
pub struct FisherInformation {
    problem: Problem,
    parts: DriftParts,
    /// The non-zero products of `Gᵀ S⁻¹ G`: unknowns `a ≤ b`, the parts of their unit
    /// forces on masses `i` and `j` (both acted on), and `μ_i S⁻¹_ij μ_j`.
    products: Vec<(usize, usize, usize, usize, f64)>,
    /// `Σ Gᵀ S⁻¹ G` (`r × r`, upper triangle) and the samples summed.
    sum: Vec<f64>,
    count: u64,
    /// The block's states, variable-major (`block[j * BLOCK + l]`), `lanes` of them.
    block: Vec<f64>,
    lanes: usize,
    /// Scratch: the block packed to `lanes` per variable, the parts' values, one state
    /// and one log row (for the atoms' values).
    packed: Vec<f64>,
    values: Vec<f64>,
    point: Vec<f64>,
    row: Vec<f64>,
}

impl FisherInformation {
    /// For `problem`, or why the bound does not apply: white forcing and unknown
    /// coefficients only (as the increment baselines need), and noise on every mass (a
    /// mass without noise would be observed exactly: an infinite information).
    pub fn new(problem: &Problem) -> Result<FisherInformation, String> {
        applicable(problem, false).map_err(|e| e.to_string())?;
        let n = problem.n;
        let mu: Vec<f64> = problem.model.mass.iter().map(|m| 1.0 / m).collect();
        let mut s = DMatrix::<f64>::zeros(n, n);
        for (targets, sigma, _) in &problem.white {
            for &i in targets {
                for &j in targets {
                    s[(i, j)] += sigma * sigma * mu[i] * mu[j];
                }
            }
        }
        let s_inv = s
            .cholesky()
            .ok_or("a mass has no random force of its own: its motion is not noisy, and the bound of continuous observation is not finite")?
            .inverse();
        let r = problem.unknowns.len();
        // Part `n + q n + i` is unknown q's unit force on mass i (`DriftParts`' order).
        let acts = |q: usize, i: usize| !problem.unit_force[q][i].terms.is_empty();
        let mut products = Vec::new();
        for a in 0..r {
            for b in a..r {
                for i in (0..n).filter(|&i| acts(a, i)) {
                    for j in (0..n).filter(|&j| acts(b, j) && s_inv[(i, j)] != 0.0) {
                        products.push((a, b, n + a * n + i, n + b * n + j, mu[i] * s_inv[(i, j)] * mu[j]));
                    }
                }
            }
        }
        let parts = DriftParts::of(problem);
        let d = problem.dim();
        Ok(FisherInformation {
            values: vec![0.0; parts.parts.len() * BLOCK],
            parts,
            products,
            sum: vec![0.0; r * r],
            count: 0,
            block: vec![0.0; d * BLOCK],
            lanes: 0,
            packed: vec![0.0; d * BLOCK],
            point: vec![0.0; d],
            row: vec![0.0; problem.columns.iter().max().map_or(0, |&c| c + 1)],
            problem: problem.clone(),
        })
    }

    /// One sample (a log row).
    pub fn push(&mut self, row: &[f64]) {
        let p = &self.problem;
        for (j, &c) in p.columns.iter().enumerate() {
            self.point[j] = row[c];
        }
        if !p.atoms.is_empty() {
            p.fill_atoms(&mut self.point, &mut self.row);
        }
        let l = self.lanes;
        for (j, &y) in self.point.iter().enumerate() {
            self.block[j * BLOCK + l] = y;
        }
        self.lanes += 1;
        if self.lanes == BLOCK {
            self.flush();
        }
    }

    /// The gathered block into the sum.
    fn flush(&mut self) {
        let lanes = self.lanes;
        if lanes == 0 {
            return;
        }
        let d = self.point.len();
        // A full block is already `lanes` values per variable; a partial one is packed.
        let states = match lanes == BLOCK {
            true => &self.block[..],
            false => {
                for j in 0..d {
                    self.packed[j * lanes..(j + 1) * lanes].copy_from_slice(&self.block[j * BLOCK..j * BLOCK + lanes]);
                }
                &self.packed[..d * lanes]
            }
        };
        let values = &mut self.values[..self.parts.parts.len() * lanes];
        self.parts.parts.eval_block(states, lanes, values);
        let r = self.problem.unknowns.len();
        add_products(&mut self.sum, r, &self.products, values, lanes);
        self.count += lanes as u64;
        self.lanes = 0;
    }

    /// The bound's standard deviation of every unknown, for a path of `total_time`
    /// seconds, after the pass's `finish`; `None` when the information is singular (an
    /// unknown the path does not determine) or no sample was seen.
    pub fn bound(&self, total_time: f64) -> Option<Vec<f64>> {
        assert_eq!(self.lanes, 0, "FisherInformation::finish before bound");
        let r = self.problem.unknowns.len();
        if self.count == 0 || total_time <= 0.0 {
            return None;
        }
        let mut info = DMatrix::<f64>::zeros(r, r);
        for a in 0..r {
            for b in a..r {
                let v = self.sum[a * r + b] / self.count as f64 * total_time;
                info[(a, b)] = v;
                info[(b, a)] = v;
            }
        }
        let cov = info.cholesky()?.inverse();
        let sd: Vec<f64> = (0..r).map(|k| cov[(k, k)].sqrt()).collect();
        sd.iter().all(|v| v.is_finite()).then_some(sd)
    }
}

/// `sum[a·r + b] += w · Σ_l part_pa[l] · part_pb[l]` for every product, the parts' values
/// `lanes` apiece in `values`; compiled for the widest vector unit the CPU has (`dot`
/// contracts nothing into a fused multiply–add: the same bits on every CPU).
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
))]
fn add_products(
    sum: &mut [f64],
    r: usize,
    products: &[(usize, usize, usize, usize, f64)],
    values: &[f64],
    lanes: usize,
) {
    let lane = |k: usize| &values[k * lanes..(k + 1) * lanes];
    for &(a, b, pa, pb, w) in products {
        sum[a * r + b] += w * dot(lane(pa), lane(pb));
    }
}

impl super::accumulate::Accumulator for FisherInformation {
    fn push(&mut self, s: &super::accumulate::Sample) {
        FisherInformation::push(self, s.row)
    }

    fn finish(&mut self) {
        self.flush();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ident::Specification;
    use crate::sim::{simulate, Collect};
    use crate::Scenario;

    /// A link's powers entered as atoms (the way of a term without a polynomial form, whose
    /// values the information must fill in from each sample) give the bound of the same
    /// powers as polynomials.
    #[test]
    fn terms_entered_as_atoms_give_the_bound_of_their_polynomials() {
        let path = format!("{}/scenarios/sdof_duffing.toml", env!("CARGO_MANIFEST_DIR"));
        let mut s = Scenario::parse(&std::fs::read_to_string(&path).unwrap(), &path, "t").unwrap();
        s.simulation.record_length = 200.0;
        let mut samples = Collect::default();
        simulate(&crate::Model::new(&s), &s.simulation, &mut samples, &|_| {}).unwrap();
        let spec = Specification::from_scenario(&s);
        let bound = |p: &Problem| {
            let mut fi = FisherInformation::new(p).unwrap();
            for b in &samples.batches {
                b.for_each_sample(|_, _, row| fi.push(row));
            }
            crate::ident::accumulate::Accumulator::finish(&mut fi);
            fi.bound(1e4).unwrap()
        };
        let polynomial = bound(&Problem::from_spec(&spec, &[]).unwrap());
        let atoms = bound(&Problem::with_terms_as_atoms(&spec, &[], &[0]).unwrap());
        for (a, b) in polynomial.iter().zip(&atoms) {
            assert!((a / b - 1.0).abs() < 1e-9, "{polynomial:?} against {atoms:?}");
        }
    }
}

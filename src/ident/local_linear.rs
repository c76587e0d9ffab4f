//! Baseline, not FPK: the local-linearisation (Shoji–Ozaki) quasi-likelihood — the
//! discretisation-consistent competitor of the increment baselines (docs/methods.md,
//! "Baselines").
//!
//! Between consecutive samples `h` apart the drift `F(y; θ)` is linearised about the start
//! state `y₀` — `F(y₀ + z) ≈ F + J z`, with the Itô term of its curvature along the noise,
//! `M = ½ Σ_ab S_ab ∂_a∂_b F` (`S`: the noise covariance), growing linearly in time — and
//! the increment's conditional mean is that linear system's exact solution:
//!
//! `E[y(h) | y₀] ≈ y₀ + z(h)`,  `ż = J z + F + M t`,  `z(0) = 0`,
//!
//! read off one matrix exponential of the augmented matrix `[[J, M, F], [0, 0, 1], [0, 0, 0]]·h`
//! (exact for a linear system at any `h`; for a nonlinear one the error is the drift's
//! variation beyond its linearisation over one interval, not the interval itself as in the
//! Euler pseudo-likelihood). The estimate minimises `Σ (y₁ − E[y₁|y₀])ᵀ W (y₁ − E[y₁|y₀])`
//! over every pair of consecutive samples, displacements and velocities alike, with `W` the
//! inverse of the linearised model's conditional covariance at the data's mean state (Van
//! Loan's integral): a quasi-likelihood, consistent for any fixed weight. Gauss–Newton from
//! the Euler estimate, steps halved while the objective does not fall, `W` refreshed once at
//! the first solution. `J`, `M` and the mean's derivatives in `θ` by finite differences
//! (the drift is polynomial and linear in `θ`).
//!
//! The samples' pairs are held in memory (`2 × dim` numbers per pair), and every pass over
//! them costs `(unknowns + 1)` matrix exponentials per pair: a baseline for the sparse
//! showcase and studies, not for the default runs. Standard errors: the delete-one jackknife
//! over the same batches as the weak form, one Gauss–Newton step from the full solution.

use super::baseline::{DriftParts, Pairs};
use super::estimate::{estimate, solve_replicates};
use super::{Estimate, IdentError, Pieces, Problem};
use nalgebra::DMatrix;
use rayon::prelude::*;

/// The local-linearisation estimator: sample pairs gathered per batch, estimated at the end.
pub struct LocalLinear {
    problem: Problem,
    parts: DriftParts,
    pairs: Pairs,
    /// Per batch: consecutive sample pairs, `2 d` numbers each (start, then end), in the
    /// problem's state order.
    batches: Vec<Vec<f64>>,
    y: Vec<f64>,
}

/// One batch's normal equations of the linearised fit, and its objective.
#[derive(Clone)]
struct Normal {
    /// `Dᵀ W D` (`r × r`) and `Dᵀ W (e + D θ)` (`r`).
    n: Vec<f64>,
    rhs: Vec<f64>,
    ssr: f64,
    pairs: usize,
}

impl Normal {
    fn zero(r: usize) -> Normal {
        Normal {
            n: vec![0.0; r * r],
            rhs: vec![0.0; r],
            ssr: 0.0,
            pairs: 0,
        }
    }
    fn add(&mut self, o: &Normal, sign: f64) {
        for (a, b) in self.n.iter_mut().zip(&o.n).chain(self.rhs.iter_mut().zip(&o.rhs)) {
            *a += sign * b;
        }
        self.ssr += sign * o.ssr;
    }
}

/// Per-thread scratch of one pass.
struct Work {
    parts: DriftParts,
    known: Vec<f64>,
    unit: Vec<f64>,
    point: Vec<f64>,
    /// Per evaluation point, per part `q` (0: the known drift, `1 + r`: unknown `r`'s unit
    /// drift), the drift vector: `g[(p * (r + 1) + q) * d + k]`.
    g: Vec<f64>,
    /// The augmented matrix for `θ` and its change per unit of each unknown.
    z: Vec<f64>,
    dz: Vec<f64>,
    /// The augmented matrix with one unknown moved by its finite-difference step.
    shifted: Vec<f64>,
    /// Matrix exponential scratch.
    a: Vec<f64>,
    e: Vec<f64>,
    t: Vec<f64>,
    mean: Vec<f64>,
    dmean: Vec<f64>,
    resid: Vec<f64>,
    /// `W e` and `W D` (column per unknown).
    we: Vec<f64>,
    wd: Vec<f64>,
}

/// The fixed layout of one pass: evaluation points around the start state and the noise.
struct Layout {
    d: usize,
    r: usize,
    h: f64,
    /// Finite-difference step per state variable.
    delta: Vec<f64>,
    /// Per mass, `1/m`.
    mu: Vec<f64>,
    /// Noise covariance `S` (`d × d`) and its non-zero off-diagonal pairs `a < b`.
    s: Vec<f64>,
    cross: Vec<(usize, usize)>,
}

impl Layout {
    /// Points: the start, `± δ_j e_j` per variable, then `(±, ±)` per cross pair.
    fn points(&self) -> usize {
        1 + 2 * self.d + 4 * self.cross.len()
    }
    /// Point `p`'s displacement from the start state: up to two `(variable, step)`.
    fn offset(&self, p: usize) -> ([(usize, f64); 2], usize) {
        let d = self.d;
        if p == 0 {
            ([(0, 0.0); 2], 0)
        } else if p <= 2 * d {
            let j = (p - 1) / 2;
            let sign = if (p - 1).is_multiple_of(2) { 1.0 } else { -1.0 };
            ([(j, sign * self.delta[j]), (0, 0.0)], 1)
        } else {
            let c = (p - 1 - 2 * d) / 4;
            let (a, b) = self.cross[c];
            let which = (p - 1 - 2 * d) % 4;
            let sa = if which < 2 { 1.0 } else { -1.0 };
            let sb = if which.is_multiple_of(2) { 1.0 } else { -1.0 };
            ([(a, sa * self.delta[a]), (b, sb * self.delta[b])], 2)
        }
    }
}

impl LocalLinear {
    /// For `problem` (white-noise forcing, coefficients unknown: [`super::baseline::applicable`]),
    /// samples every `h` seconds, `batches` jackknife batches.
    pub fn new(problem: &Problem, h: f64, batches: usize) -> LocalLinear {
        LocalLinear {
            problem: problem.clone(),
            parts: DriftParts::of(problem),
            pairs: Pairs::new(h),
            batches: vec![Vec::new(); batches.max(1)],
            y: vec![0.0; problem.dim()],
        }
    }

    /// One sample (a log row) of `trajectory` at `t`, in batch `batch`.
    pub fn push(&mut self, trajectory: usize, t: f64, batch: usize, row: &[f64]) {
        for (j, &c) in self.problem.columns.iter().enumerate() {
            self.y[j] = row[c];
        }
        let b = batch.min(self.batches.len() - 1);
        let (store, y) = (&mut self.batches[b], &self.y);
        self.pairs.step(trajectory, t, y, |y0| {
            store.extend_from_slice(y0);
            store.extend_from_slice(y);
        });
    }

    fn layout(&self) -> Result<Layout, IdentError> {
        let p = &self.problem;
        let (d, n) = (p.dim(), p.n);
        let count: usize = self.batches.iter().map(|b| b.len()).sum::<usize>() / (2 * d);
        if count < 2 * (p.unknowns.len() + 1) {
            return Err(IdentError::TooLittleData(format!(
                "local-linear needs pairs of consecutive samples {} s apart; the data hold {count}",
                self.pairs.h
            )));
        }
        // Spread of each variable over the pairs' starts: the finite-difference steps.
        let mut sum = vec![0.0; d];
        let mut sq = vec![0.0; d];
        for b in &self.batches {
            for pair in b.chunks_exact(2 * d) {
                for j in 0..d {
                    sum[j] += pair[j];
                    sq[j] += pair[j] * pair[j];
                }
            }
        }
        let delta: Vec<f64> = (0..d)
            .map(|j| {
                let m = sum[j] / count as f64;
                let sd = (sq[j] / count as f64 - m * m).max(0.0).sqrt();
                1e-4 * if sd > 0.0 { sd } else { 1.0 }
            })
            .collect();
        let mu: Vec<f64> = p.model.mass.iter().map(|m| 1.0 / m).collect();
        let mut s = vec![0.0; d * d];
        for (targets, sigma, _) in &p.white {
            for &i in targets {
                for &j in targets {
                    s[p.noise_var[i] * d + p.noise_var[j]] += sigma * sigma * mu[i] * mu[j];
                }
            }
        }
        let cross = (0..d)
            .flat_map(|a| (a + 1..d).map(move |b| (a, b)))
            .filter(|&(a, b)| s[a * d + b] != 0.0)
            .collect();
        debug_assert_eq!(mu.len(), n);
        Ok(Layout {
            d,
            r: p.unknowns.len(),
            h: self.pairs.h,
            delta,
            mu,
            s,
            cross,
        })
    }

    fn work(&self, l: &Layout) -> Work {
        let (d, r, n) = (l.d, l.r, self.problem.n);
        let dd = (d + 2) * (d + 2);
        Work {
            parts: self.parts.clone(),
            known: vec![0.0; n],
            unit: vec![0.0; r * n],
            point: vec![0.0; d],
            g: vec![0.0; l.points() * (r + 1) * d],
            z: vec![0.0; dd],
            dz: vec![0.0; r * dd],
            shifted: vec![0.0; dd],
            a: vec![0.0; dd],
            e: vec![0.0; dd],
            t: vec![0.0; dd],
            mean: vec![0.0; d],
            dmean: vec![0.0; r * d],
            resid: vec![0.0; d],
            we: vec![0.0; d],
            wd: vec![0.0; r * d],
        }
    }

    /// The drift's parts at every evaluation point around `y0`, into `w.g`.
    fn evaluate(&self, l: &Layout, w: &mut Work, y0: &[f64]) {
        let p = &self.problem;
        let (d, r, n) = (l.d, l.r, p.n);
        for pt in 0..l.points() {
            w.point.copy_from_slice(y0);
            let (steps, count) = l.offset(pt);
            for &(j, dj) in &steps[..count] {
                w.point[j] += dj;
            }
            w.parts.at(&w.point, &mut w.known, &mut w.unit);
            let g = &mut w.g[pt * (r + 1) * d..(pt + 1) * (r + 1) * d];
            g.fill(0.0);
            for (var, poly) in &p.free_drift {
                g[*var] += poly.eval(&w.point);
            }
            for i in 0..n {
                let v = p.noise_var[i];
                g[v] += l.mu[i] * w.known[i];
                for q in 0..r {
                    g[(q + 1) * d + v] += l.mu[i] * w.unit[q * n + i];
                }
            }
        }
    }

    /// The augmented matrix `[[J, M, F], [0, 0, 1], [0, 0, 0]]·h` of part `q` (linear in
    /// the parts: the matrix for `θ` is part 0 plus `Σ θ_q` part `q + 1`), added with
    /// weight `c` into `out`.
    fn augmented(&self, l: &Layout, g: &[f64], q: usize, c: f64, out: &mut [f64]) {
        let (d, r, h) = (l.d, l.r, l.h);
        let dim = d + 2;
        let part = |pt: usize, k: usize| g[(pt * (r + 1) + q) * d + k];
        for k in 0..d {
            // F
            out[k * dim + d + 1] += c * h * part(0, k);
            // J, column j: central difference.
            for j in 0..d {
                let dj = (part(1 + 2 * j, k) - part(2 + 2 * j, k)) / (2.0 * l.delta[j]);
                out[k * dim + j] += c * h * dj;
            }
            // M = ½ Σ S_ab ∂a∂b F.
            let mut m = 0.0;
            for a in 0..d {
                let saa = l.s[a * d + a];
                if saa != 0.0 {
                    let second =
                        (part(1 + 2 * a, k) - 2.0 * part(0, k) + part(2 + 2 * a, k)) / (l.delta[a] * l.delta[a]);
                    m += 0.5 * saa * second;
                }
            }
            for (ci, &(a, b)) in l.cross.iter().enumerate() {
                let base = 1 + 2 * d + 4 * ci;
                let mixed = (part(base, k) - part(base + 1, k) - part(base + 2, k) + part(base + 3, k))
                    / (4.0 * l.delta[a] * l.delta[b]);
                m += l.s[a * d + b] * mixed;
            }
            out[k * dim + d] += c * h * m;
        }
        if q == 0 {
            out[d * dim + d + 1] += c * h;
        }
    }

    /// One pass over batch `b` at `theta`: its normal equations and objective.
    fn pass(&self, l: &Layout, w: &mut Work, b: usize, theta: &[f64], weight: &[f64], eps: &[f64]) -> Normal {
        let (d, r) = (l.d, l.r);
        let dim = d + 2;
        let dd = dim * dim;
        let mut out = Normal::zero(r);
        for pair in self.batches[b].chunks_exact(2 * d) {
            let (y0, y1) = pair.split_at(d);
            self.evaluate(l, w, y0);
            let g = std::mem::take(&mut w.g);
            w.z.fill(0.0);
            self.augmented(l, &g, 0, 1.0, &mut w.z);
            w.dz.fill(0.0);
            for q in 0..r {
                self.augmented(l, &g, q + 1, theta[q], &mut w.z);
                self.augmented(l, &g, q + 1, 1.0, &mut w.dz[q * dd..(q + 1) * dd]);
            }
            w.g = g;
            expm_last_column(&w.z, dim, &mut w.a, &mut w.e, &mut w.t, &mut w.mean);
            for q in 0..r {
                for (a, (z, dz)) in w.shifted.iter_mut().zip(w.z.iter().zip(&w.dz[q * dd..(q + 1) * dd])) {
                    *a = z + eps[q] * dz;
                }
                expm_last_column(&w.shifted, dim, &mut w.a, &mut w.e, &mut w.t, &mut w.resid);
                for k in 0..d {
                    w.dmean[q * d + k] = (w.resid[k] - w.mean[k]) / eps[q];
                }
            }
            // e = y1 − y0 − z; the linearised target e + D θ.
            for k in 0..d {
                w.resid[k] = y1[k] - y0[k] - w.mean[k];
            }
            mat_vec(weight, &w.resid, &mut w.we);
            out.ssr += w.resid.iter().zip(&w.we).map(|(a, b)| a * b).sum::<f64>();
            for q in 0..r {
                mat_vec(weight, &w.dmean[q * d..(q + 1) * d], &mut w.wd[q * d..(q + 1) * d]);
            }
            for q in 0..r {
                let dq = &w.dmean[q * d..(q + 1) * d];
                let mut rhs = dq.iter().zip(&w.we).map(|(a, b)| a * b).sum::<f64>();
                for c in 0..r {
                    let n_qc = dq
                        .iter()
                        .zip(&w.wd[c * d..(c + 1) * d])
                        .map(|(a, b)| a * b)
                        .sum::<f64>();
                    out.n[q * r + c] += n_qc;
                    rhs += n_qc * theta[c];
                }
                out.rhs[q] += rhs;
            }
            out.pairs += 1;
        }
        out
    }

    /// Every batch's normal equations at `theta`, in batch order (the same numbers for any
    /// thread count).
    fn all(&self, l: &Layout, theta: &[f64], weight: &[f64], eps: &[f64]) -> Vec<Normal> {
        (0..self.batches.len())
            .into_par_iter()
            .map_init(|| self.work(l), |w, b| self.pass(l, w, b, theta, weight, eps))
            .collect()
    }

    /// The Euler estimate that Gauss–Newton starts from: the velocity increments regressed
    /// on the drift at the start state, each mass's equation weighted by `m_i²/σ_i²`.
    fn euler(&self, l: &Layout) -> Vec<f64> {
        let p = &self.problem;
        let (d, r) = (l.d, l.r);
        let mut w = self.work(l);
        let mut nrm = vec![0.0; r * r];
        let mut rhs = vec![0.0; r];
        for batch in &self.batches {
            for pair in batch.chunks_exact(2 * d) {
                let (y0, y1) = pair.split_at(d);
                w.parts.at(y0, &mut w.known, &mut w.unit);
                for i in 0..p.n {
                    let v = p.noise_var[i];
                    let s = l.s[v * d + v];
                    if s <= 0.0 {
                        continue;
                    }
                    let target = (y1[v] - y0[v]) / l.h - l.mu[i] * w.known[i];
                    for a in 0..r {
                        let ua = l.mu[i] * w.unit[a * p.n + i];
                        rhs[a] += ua * target / s;
                        for b in 0..r {
                            nrm[a * r + b] += ua * l.mu[i] * w.unit[b * p.n + i] / s;
                        }
                    }
                }
            }
        }
        let m = DMatrix::from_row_slice(r, r, &nrm);
        super::lsq::svd(m, true, true)
            .and_then(|s| s.solve(&nalgebra::DVector::from_column_slice(&rhs), 1e-14).ok())
            .map(|x| x.iter().copied().collect())
            .unwrap_or_else(|| vec![0.0; r])
    }

    /// The weight `W`: the inverse of the linearised model's conditional covariance over
    /// one interval at the data's mean state (Van Loan: `Q = Φ ∫ e^{-Js} S e^{-Jᵀs} ds`).
    fn weight(&self, l: &Layout, theta: &[f64]) -> Vec<f64> {
        let d = l.d;
        let mut w = self.work(l);
        let mean = self.mean_state(d);
        self.evaluate(l, &mut w, &mean);
        let dim = d + 2;
        let mut aug = vec![0.0; dim * dim];
        let g = w.g.clone();
        self.augmented(l, &g, 0, 1.0, &mut aug);
        for q in 0..l.r {
            self.augmented(l, &g, q + 1, theta[q], &mut aug);
        }
        // J h from the augmented matrix; the Van Loan block [[−J, S], [0, Jᵀ]]·h.
        let n2 = 2 * d;
        let mut c = vec![0.0; n2 * n2];
        for i in 0..d {
            for j in 0..d {
                let jh = aug[i * dim + j];
                c[i * n2 + j] = -jh;
                c[(d + i) * n2 + d + j] = aug[j * dim + i];
                c[i * n2 + d + j] = l.s[i * d + j] * l.h;
            }
        }
        let e = expm(&DMatrix::from_row_slice(n2, n2, &c));
        let phi = e.view((d, d), (d, d)).transpose();
        let g12 = e.view((0, d), (d, d)).into_owned();
        let q = &phi * g12;
        let q = (&q + q.transpose()) * 0.5;
        let inv = q
            .clone()
            .cholesky()
            .map(|c| c.inverse())
            .unwrap_or_else(|| q.pseudo_inverse(1e-300).unwrap_or_else(|_| DMatrix::identity(d, d)));
        inv.transpose().as_slice().to_vec()
    }

    fn mean_state(&self, d: usize) -> Vec<f64> {
        let mut sum = vec![0.0; d];
        let mut count = 0usize;
        for b in &self.batches {
            for pair in b.chunks_exact(2 * d) {
                for j in 0..d {
                    sum[j] += pair[j];
                }
                count += 1;
            }
        }
        sum.iter().map(|s| s / count.max(1) as f64).collect()
    }

    /// The estimate, with its jackknife replicates and `facts`, from the batches' normal
    /// equations.
    fn solve(
        &self,
        l: &Layout,
        normals: &[Normal],
        typical: &[f64],
        facts: Vec<(String, String)>,
    ) -> Result<Estimate, IdentError> {
        let r = l.r;
        let total = sum(normals, r);
        let to_pieces = |n: &Normal| -> Pieces {
            // Rows: the unknowns; row k's residual Σ_c N_kc θ_c − rhs_k, written as mass 0's
            // force part (the problem multiplies it by μ₀).
            let nm = self.problem.n;
            let mut p = Pieces::new(r, nm, r);
            let m0 = 1.0 / l.mu[0];
            for k in 0..r {
                p.t0[k] = -n.rhs[k];
                for c in 0..r {
                    p.b[(k * nm) * r + c] = n.n[k * r + c] * m0;
                }
            }
            p
        };
        let pieces = to_pieces(&total);
        let replicates: Vec<Pieces> = if normals.len() >= 2 {
            normals
                .iter()
                .map(|b| {
                    let mut rest = total.clone();
                    rest.add(b, -1.0);
                    to_pieces(&rest)
                })
                .collect()
        } else {
            Vec::new()
        };
        let per_replicate = solve_replicates(&self.problem, "local-linear", replicates, typical, None)?;
        estimate(
            &self.problem,
            "local-linear",
            &pieces,
            &per_replicate,
            typical,
            facts,
            None,
        )
    }

    /// The estimate, with jackknife standard errors and the usual diagnostics.
    pub fn estimate(&self, typical: &[f64]) -> Result<Estimate, IdentError> {
        let l = self.layout()?;
        let r = l.r;
        let mut theta = self.euler(&l);
        let start = theta.clone();
        let eps_of = |theta: &[f64]| -> Vec<f64> {
            let big = theta.iter().chain(&start).fold(0.0f64, |m, v| m.max(v.abs()));
            (0..r)
                .map(|q| 1e-6 * (theta[q].abs().max(start[q].abs()) + 1e-9 * big).max(1e-12))
                .collect()
        };
        let mut passes = 0;
        let mut halvings = 0;
        let mut converged = false;
        let mut normals = Vec::new();
        for stage in 0..2 {
            let weight = self.weight(&l, &theta);
            normals = self.all(&l, &theta, &weight, &eps_of(&theta));
            passes += 1;
            if stage == 0 {
                // Unknowns the linearised equations at the start cannot separate are not
                // separated by the iterations either: refused after one pass, not hundreds.
                if let Err(e @ IdentError::NotIdentifiable { .. }) = self.solve(&l, &normals, typical, Vec::new()) {
                    return Err(e);
                }
            }
            for _ in 0..30 {
                let total = sum(&normals, r);
                let proposal = solve_normal(&total, r);
                let Some(mut next) = proposal else { break };
                let mut accepted = None;
                for _ in 0..12 {
                    let trial = self.all(&l, &next, &weight, &eps_of(&next));
                    passes += 1;
                    let ssr: f64 = trial.iter().map(|n| n.ssr).sum();
                    if ssr.is_finite() && ssr <= total.ssr * (1.0 + 1e-12) {
                        accepted = Some((next.clone(), trial));
                        break;
                    }
                    halvings += 1;
                    for q in 0..r {
                        next[q] = 0.5 * (next[q] + theta[q]);
                    }
                }
                let Some((next, trial)) = accepted else { break };
                let change = (0..r)
                    .map(|q| (next[q] - theta[q]).abs() / (next[q].abs() + 1e-9 * typical_scale(&next)))
                    .fold(0.0f64, f64::max);
                theta = next;
                normals = trial;
                if change < 1e-7 {
                    converged = stage == 1;
                    break;
                }
            }
        }
        let pairs: usize = normals.iter().map(|n| n.pairs).sum();
        let mut facts = vec![
            ("sample pairs".to_string(), pairs.to_string()),
            ("sample interval".to_string(), format!("{} s", l.h)),
            ("passes over the pairs".to_string(), passes.to_string()),
            ("step halvings".to_string(), halvings.to_string()),
        ];
        facts.push((
            "Gauss–Newton".to_string(),
            if converged {
                "converged".into()
            } else {
                "stopped before converging".into()
            },
        ));
        let mut est = self.solve(&l, &normals, typical, facts)?;
        if !converged {
            est.warnings
                .push("local-linear: Gauss–Newton stopped before its steps fell below 1e-7 of the estimates".into());
        }
        Ok(est)
    }
}

fn typical_scale(theta: &[f64]) -> f64 {
    theta.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

fn sum(normals: &[Normal], r: usize) -> Normal {
    let mut t = Normal::zero(r);
    for n in normals {
        t.add(n, 1.0);
        t.pairs += n.pairs;
    }
    t
}

fn solve_normal(n: &Normal, r: usize) -> Option<Vec<f64>> {
    let m = DMatrix::from_row_slice(r, r, &n.n);
    let x = super::lsq::svd(m, true, true)?
        .solve(&nalgebra::DVector::from_column_slice(&n.rhs), 1e-14)
        .ok()?;
    x.iter().all(|v| v.is_finite()).then(|| x.iter().copied().collect())
}

/// `out = W v` for a row-major `d × d` matrix `W`, `d = v.len()`.
fn mat_vec(w: &[f64], v: &[f64], out: &mut [f64]) {
    let d = v.len();
    for (i, o) in out.iter_mut().enumerate() {
        *o = (0..d).map(|j| w[i * d + j] * v[j]).sum();
    }
}

/// `C = A B` for row-major `n × n` matrices.
#[inline(always)]
fn mat_mul(a: &[f64], b: &[f64], c: &mut [f64], n: usize) {
    let (a, b, c) = (&a[..n * n], &b[..n * n], &mut c[..n * n]);
    for (ci, ai) in c.chunks_exact_mut(n).zip(a.chunks_exact(n)) {
        ci.fill(0.0);
        for (&aik, bk) in ai.iter().zip(b.chunks_exact(n)) {
            if aik != 0.0 {
                for (x, y) in ci.iter_mut().zip(bk) {
                    *x += aik * y;
                }
            }
        }
    }
}

/// `exp(z)` of a row-major `n × n` matrix into `e` (`a` and `t`: `n × n` scratch):
/// scaling and squaring with a degree-12 Taylor polynomial (after scaling the norm is at
/// most ½; truncation below 10⁻¹³). The sizes the local linearisation meets (a state of
/// two to six variables and the augmented matrix's two more rows) get loops of known
/// length, which the compiler unrolls; the arithmetic is the same for every size.
fn expm_into(z: &[f64], n: usize, a: &mut [f64], e: &mut [f64], t: &mut [f64]) {
    match n {
        4 => expm_sized(z, 4, a, e, t),
        5 => expm_sized(z, 5, a, e, t),
        6 => expm_sized(z, 6, a, e, t),
        7 => expm_sized(z, 7, a, e, t),
        8 => expm_sized(z, 8, a, e, t),
        _ => expm_sized(z, n, a, e, t),
    }
}

#[inline(always)]
fn expm_sized(z: &[f64], n: usize, a: &mut [f64], e: &mut [f64], t: &mut [f64]) {
    let (z, a, e, t) = (&z[..n * n], &mut a[..n * n], &mut e[..n * n], &mut t[..n * n]);
    let norm = z
        .chunks_exact(n)
        .map(|row| row.iter().map(|x| x.abs()).sum::<f64>())
        .fold(0.0f64, f64::max);
    let s = if norm > 0.5 {
        (norm / 0.5).log2().ceil() as i32
    } else {
        0
    };
    let scale = 0.5f64.powi(s);
    for (x, y) in a.iter_mut().zip(z) {
        *x = y * scale;
    }
    // Horner: E = I + A/1 (I + A/2 (… (I + A/12))).
    e.fill(0.0);
    for i in 0..n {
        e[i * n + i] = 1.0;
    }
    for k in (1..=12).rev() {
        mat_mul(a, e, t, n);
        let k = k as f64;
        for (i, (row, x)) in e.chunks_exact_mut(n).zip(t.chunks_exact(n)).enumerate() {
            for (j, (y, x)) in row.iter_mut().zip(x).enumerate() {
                *y = x / k + if i == j { 1.0 } else { 0.0 };
            }
        }
    }
    for _ in 0..s {
        mat_mul(e, e, t, n);
        e.copy_from_slice(t);
    }
}

/// The last column of `exp(z)` into `col` (its first `col.len()` rows).
fn expm_last_column(z: &[f64], n: usize, a: &mut [f64], e: &mut [f64], t: &mut [f64], col: &mut [f64]) {
    expm_into(z, n, a, e, &mut t[..n * n]);
    for (k, c) in col.iter_mut().enumerate() {
        *c = e[k * n + n - 1];
    }
}

/// `exp(m)` of a small dense matrix (the Van Loan block).
fn expm(m: &DMatrix<f64>) -> DMatrix<f64> {
    let n = m.nrows();
    let z: Vec<f64> = m.transpose().as_slice().to_vec(); // row-major
    let (mut a, mut e, mut t) = (vec![0.0; n * n], vec![0.0; n * n], vec![0.0; n * n]);
    expm_into(&z, n, &mut a, &mut e, &mut t);
    DMatrix::from_row_slice(n, n, &e)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_matrix_exponential_matches_a_rotation_and_a_shear() {
        // exp([[0, w], [−w, 0]] t) is a rotation by w t.
        let (w, t) = (3.0, 2.5);
        let m = DMatrix::from_row_slice(2, 2, &[0.0, w * t, -w * t, 0.0]);
        let e = expm(&m);
        assert!((e[(0, 0)] - (w * t).cos()).abs() < 1e-12);
        assert!((e[(0, 1)] - (w * t).sin()).abs() < 1e-12);
        // The augmented form: ż = −k z + f, z(0) = 0 → z(h) = f (1 − e^{−kh}) / k.
        let (k, f, h) = (4.0, 2.0, 0.7);
        let z = [-k * h, f * h, 0.0, 0.0];
        let (mut a, mut e, mut tt, mut col) = (vec![0.0; 4], vec![0.0; 4], vec![0.0; 8], vec![0.0; 1]);
        expm_last_column(&z, 2, &mut a, &mut e, &mut tt, &mut col);
        assert!((col[0] - f * (1.0 - (-k * h).exp()) / k).abs() < 1e-12);
    }

    /// Every size, those with loops of known length (4–8) and the others: `exp(cI + tN)`
    /// with `N` the shift (ones above the diagonal) is `e^c t^(j−i)/(j−i)!` above and on
    /// the diagonal, 0 below; the norm (|c| + t = 2.2) needs three squarings.
    #[test]
    fn the_matrix_exponential_of_a_shifted_jordan_block_at_every_size() {
        let (c, t) = (-0.7, 1.5);
        for n in 2..=10 {
            let mut m = DMatrix::zeros(n, n);
            for i in 0..n {
                m[(i, i)] = c;
                if i + 1 < n {
                    m[(i, i + 1)] = t;
                }
            }
            let e = expm(&m);
            for i in 0..n {
                for j in 0..n {
                    let exact = if j < i {
                        0.0
                    } else {
                        let p = (j - i) as i32;
                        c.exp() * t.powi(p) / (1..=p).map(f64::from).product::<f64>()
                    };
                    assert!(
                        (e[(i, j)] - exact).abs() < 1e-13,
                        "n {n}: ({i}, {j}) {} vs {exact}",
                        e[(i, j)]
                    );
                }
            }
        }
    }
}

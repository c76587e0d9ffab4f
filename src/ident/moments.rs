//! Raw moments `E[Y^β]` of the state up to a given degree, accumulated in one streaming
//! pass in constant memory — all the weak form needs.
//!
//! Samples arrive in blocks; each block is split into fixed-size chunks summed in parallel
//! and merged in chunk order, so the result does not depend on the number of threads. Each
//! monomial is its parent monomial times one variable, evaluated for `CHUNK_LANES`
//! samples at a time so the inner loop vectorises.

use super::poly::{exponent, monomials, var, Exponents};
use multiversion::multiversion;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::Arc;

/// Samples per parallel chunk (fixed, so sums do not depend on the thread count).
const CHUNK: usize = 4096;
/// Partial sums kept per monomial (reduced once per chunk).
const CHUNK_LANES: usize = 8;
/// Samples evaluated side by side in the monomial recursion.
const BLOCK: usize = 512;

/// Accumulated raw moments.
#[derive(Debug, Clone)]
pub struct RawMoments {
    pub vars: usize,
    pub max_degree: u32,
    /// Which monomials, in which order: shared by every accumulator cloned from this one
    /// (a weak form's thousands of fine batches hold only their sums).
    shape: Arc<Shape>,
    pub sums: Vec<f64>,
    pub count: u64,
    /// Per variable: smallest and largest value seen.
    pub min: Vec<f64>,
    pub max: Vec<f64>,
}

/// The monomials an accumulator sums and the recursion that evaluates them.
#[derive(Debug)]
struct Shape {
    /// Monomials in evaluation order (degree 1 first); index 0 is the constant 1.
    monomials: Vec<Exponents>,
    /// For monomial `k ≥ 1`: the monomial it is `parent × y_var` of.
    parent: Vec<usize>,
    var: Vec<usize>,
    /// Per monomial: its row among the kept values if it is some other monomial's parent
    /// (its values must be kept), else `usize::MAX` (a leaf: only summed).
    kept: Vec<usize>,
    /// Monomials whose values are kept.
    parents: usize,
    index: HashMap<Exponents, usize>,
}

impl RawMoments {
    /// The monomials accumulated, in evaluation order (index 0 is the constant 1).
    pub fn monomials(&self) -> &[Exponents] {
        &self.shape.monomials
    }

    pub fn new(vars: usize, max_degree: u32) -> RawMoments {
        Self::with_monomials(vars, max_degree, &monomials(vars, max_degree))
    }

    /// Accumulate only `wanted` (and the lower monomials their evaluation passes through).
    pub fn with_monomials(vars: usize, max_degree: u32, wanted: &[Exponents]) -> RawMoments {
        // Close under "drop one power of the last variable present" (the recursion's parent),
        // for every variable present, so any wanted monomial can be reached.
        let mut set: std::collections::BTreeSet<Exponents> = wanted.iter().copied().collect();
        // Second moments of every variable are always kept (means and standard deviations).
        for j in 0..vars {
            set.insert(var(j));
            set.insert(2 * var(j));
        }
        // And under "drop two powers of any variable": the sensor-noise correction
        // ([`RawMoments::deconvolve`]) writes each moment through those.
        let mut frontier: Vec<Exponents> = set.iter().copied().collect();
        while let Some(e) = frontier.pop() {
            if let Some(j) = (0..vars).rev().find(|&j| exponent(e, j) > 0) {
                let p = e - var(j);
                if p != 0 && set.insert(p) {
                    frontier.push(p);
                }
            }
            for j in 0..vars {
                if exponent(e, j) >= 2 {
                    let p = e - 2 * var(j);
                    if p != 0 && set.insert(p) {
                        frontier.push(p);
                    }
                }
            }
        }
        let mut mons: Vec<Exponents> = vec![0];
        let mut rest: Vec<Exponents> = set.into_iter().filter(|&e| e != 0).collect();
        rest.sort_by_key(|&e| (super::poly::degree(e), e));
        mons.extend(rest);
        let index: HashMap<Exponents, usize> = mons.iter().enumerate().map(|(i, &e)| (e, i)).collect();
        let mut parent = vec![0; mons.len()];
        let mut vr = vec![0; mons.len()];
        for (k, &e) in mons.iter().enumerate().skip(1) {
            let j = (0..vars).rev().find(|&j| exponent(e, j) > 0).unwrap();
            parent[k] = index[&(e - var(j))];
            vr[k] = j;
        }
        let mut is_parent = vec![false; mons.len()];
        is_parent[0] = true;
        for &p in &parent[1..] {
            is_parent[p] = true;
        }
        let mut parents = 0;
        let kept = is_parent
            .iter()
            .map(|&p| {
                if p {
                    parents += 1;
                    parents - 1
                } else {
                    usize::MAX
                }
            })
            .collect();
        RawMoments {
            vars,
            max_degree,
            sums: vec![0.0; mons.len()],
            shape: Arc::new(Shape {
                kept,
                parents,
                monomials: mons,
                parent,
                var: vr,
                index,
            }),
            count: 0,
            min: vec![f64::INFINITY; vars],
            max: vec![f64::NEG_INFINITY; vars],
        }
    }

    /// Moments given exactly by `moment(β)` (reference tests with known densities).
    pub fn exact(vars: usize, max_degree: u32, moment: impl Fn(Exponents) -> f64) -> RawMoments {
        RawMoments::exact_of(RawMoments::new(vars, max_degree), moment)
    }

    /// Only the monomials `wanted` (and those [`RawMoments::with_monomials`] adds) given
    /// exactly by `moment(β)`: many variables, where every monomial would be too many.
    pub fn exact_monomials(
        vars: usize,
        max_degree: u32,
        wanted: &[Exponents],
        moment: impl Fn(Exponents) -> f64,
    ) -> RawMoments {
        RawMoments::exact_of(RawMoments::with_monomials(vars, max_degree, wanted), moment)
    }

    fn exact_of(mut m: RawMoments, moment: impl Fn(Exponents) -> f64) -> RawMoments {
        m.sums = m
            .monomials()
            .iter()
            .map(|&e| if e == 0 { 1.0 } else { moment(e) })
            .collect();
        m.count = 1;
        m
    }

    /// `E[Y^β]`; panics if `β` is beyond the accumulated degree.
    pub fn moment(&self, e: Exponents) -> f64 {
        let k = *self
            .shape
            .index
            .get(&e)
            .unwrap_or_else(|| panic!("moment of degree {} not accumulated", super::poly::degree(e)));
        self.sums[k] / self.count as f64
    }

    pub fn has(&self, e: Exponents) -> bool {
        self.shape.index.contains_key(&e)
    }

    pub fn mean(&self, j: usize) -> f64 {
        self.moment(var(j))
    }

    pub fn std(&self, j: usize) -> f64 {
        (self.moment(2 * var(j)) - self.mean(j).powi(2)).max(0.0).sqrt()
    }

    /// Add a block of samples: `rows` is row-major with `self.vars` values per sample.
    pub fn add_block(&mut self, rows: &[f64]) {
        let d = self.vars;
        let n = rows.len() / d;
        let parts: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> = rows
            .par_chunks(CHUNK * d)
            .map_init(Vec::new, |scratch, c| chunk_sums(self, c, scratch))
            .collect();
        for (k, (s, lo, hi)) in parts.iter().enumerate() {
            let samples = (n - k * CHUNK).min(CHUNK);
            self.absorb(s, lo, hi, samples as u64);
        }
    }

    /// Add samples to several accumulators of the same monomials at once: sample `s`
    /// (`rows[s·vars..]`) goes to `batches[ids[s]]`. Runs of equal ids are summed in
    /// parallel pieces of at most one chunk and merged in order, so the sums do not depend
    /// on the number of threads.
    pub fn add_batched(batches: &mut [RawMoments], rows: &[f64], ids: &[u32]) {
        let Some(first) = batches.first() else { return };
        let d = first.vars;
        debug_assert_eq!(rows.len(), ids.len() * d);
        let mut pieces = Vec::new();
        let mut start = 0;
        while start < ids.len() {
            let id = ids[start];
            let mut end = start + 1;
            while end < ids.len() && ids[end] == id && end - start < CHUNK {
                end += 1;
            }
            pieces.push((id as usize, start, end));
            start = end;
        }
        let sums: Vec<_> = pieces
            .par_iter()
            .map_init(Vec::new, |scratch, &(_, a, b)| {
                chunk_sums(first, &rows[a * d..b * d], scratch)
            })
            .collect();
        for (&(id, a, b), (s, lo, hi)) in pieces.iter().zip(sums) {
            batches[id].absorb(&s, &lo, &hi, (b - a) as u64);
        }
    }

    /// Add another accumulator of the same monomials (e.g. a batch into a total).
    pub fn merge(&mut self, other: &RawMoments) {
        self.absorb(&other.sums, &other.min, &other.max, other.count);
    }

    /// Add partial sums and extremes of `samples` samples.
    fn absorb(&mut self, sums: &[f64], lo: &[f64], hi: &[f64], samples: u64) {
        for (a, s) in self.sums.iter_mut().zip(sums) {
            *a += s;
        }
        for j in 0..self.vars {
            self.min[j] = self.min[j].min(lo[j]);
            self.max[j] = self.max[j].max(hi[j]);
        }
        self.count += samples;
    }

    /// Remove additive sensor noise: the samples are `y = x + e` with `e` Gaussian, white,
    /// independent of `x` and between variables, of variance `noise[j]` on variable `j`
    /// (0: exact). Each sum of `y^β` becomes the unbiased sum of `x^β`, every power
    /// `y_j^b` replaced by the Hermite polynomial `He_b(y_j; σ_j²) = Σ_k (−1)^k b! /
    /// (k! (b−2k)! 2^k) σ_j^{2k} y_j^{b−2k}` (`E[He_b(x + e)] = x^b`: `y² − σ²`,
    /// `y³ − 3σ²y`, `y⁴ − 6σ²y² + 3σ⁴`, …; docs/measurement.md). Linear in the sums, so
    /// batches corrected one by one add up to the corrected total.
    pub fn deconvolve(&mut self, noise: &[f64]) {
        if noise.iter().all(|&s| s == 0.0) || self.count == 0 {
            return;
        }
        let n = self.count as f64;
        let old = self.sums.clone();
        for (k, &e) in self.shape.monomials.iter().enumerate().skip(1) {
            // Expand the product of one Hermite polynomial per variable.
            let mut terms: Vec<(Exponents, f64)> = vec![(e, 1.0)];
            for (j, &s2) in noise.iter().enumerate().take(self.vars) {
                let b = exponent(e, j);
                if s2 == 0.0 || b < 2 {
                    continue;
                }
                let mut next = Vec::with_capacity(terms.len() * (b as usize / 2 + 1));
                for &(t, c) in &terms {
                    let mut ck = 1.0;
                    for kk in 0..=b / 2 {
                        next.push((t - 2 * kk as Exponents * var(j), c * ck));
                        // Ratio of consecutive coefficients of He_b.
                        let m = b - 2 * kk;
                        ck *= -s2 * (m * (m - 1)) as f64 / (2.0 * (kk + 1) as f64);
                    }
                }
                terms = next;
            }
            self.sums[k] = terms
                .iter()
                .map(|&(t, c)| c * if t == 0 { n } else { old[self.shape.index[&t]] })
                .sum();
        }
    }

    /// Index of monomial `e` in [`RawMoments::sums`], if accumulated.
    pub fn index_of(&self, e: Exponents) -> Option<usize> {
        self.shape.index.get(&e).copied()
    }
}

/// Sums of every monomial of `moments` over `rows`, with the per-variable extremes.
/// Dispatched at run time to the widest vector unit the CPU has (the lanes are
/// explicit, so the sums are the same on every machine).
#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
    "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
))]
fn chunk_sums(moments: &RawMoments, rows: &[f64], scratch: &mut Vec<f64>) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let d = moments.vars;
    let shape = &*moments.shape;
    let m = shape.monomials.len();
    let mut lo = vec![f64::INFINITY; d];
    let mut hi = vec![f64::NEG_INFINITY; d];
    // vals[kept[k]·sb + s]: monomial k of the block's samples (parents only); acc[k][l]: per-lane partial sums,
    // reduced once per chunk (the order is fixed, so results do not depend on threads).
    // A block is at most BLOCK samples, and no wider than the piece (a fine batch's run
    // may be a few dozen samples).
    let n = rows.len() / d;
    let sb = n.clamp(1, BLOCK).next_multiple_of(CHUNK_LANES);
    // The monomials' and the variables' rows, every value written before it is read: in
    // `scratch`, kept by the caller from one call to the next (zeroing them anew for every
    // fine batch's run cost more than the run's sums).
    let need = (shape.parents + d) * sb;
    if scratch.len() < need {
        scratch.resize(need, 0.0);
    }
    let (vals, y) = scratch[..need].split_at_mut(shape.parents * sb);
    let mut acc = vec![[0.0f64; CHUNK_LANES]; m];
    let mut start = 0;
    while start < n {
        let len = (n - start).min(sb);
        for j in 0..d {
            let yj = &mut y[j * sb..(j + 1) * sb];
            for (s, v) in yj.iter_mut().enumerate() {
                *v = if s < len { rows[(start + s) * d + j] } else { 0.0 };
            }
            // Per-lane extremes over whole 8-sample chunks (vectorises), then the tail.
            let full = len / CHUNK_LANES * CHUNK_LANES;
            let (mut lo8, mut hi8) = ([lo[j]; CHUNK_LANES], [hi[j]; CHUNK_LANES]);
            for c in yj[..full].chunks_exact(CHUNK_LANES) {
                for l in 0..CHUNK_LANES {
                    lo8[l] = if c[l] < lo8[l] { c[l] } else { lo8[l] };
                    hi8[l] = if c[l] > hi8[l] { c[l] } else { hi8[l] };
                }
            }
            for &v in &yj[full..len] {
                lo8[0] = lo8[0].min(v);
                hi8[0] = hi8[0].max(v);
            }
            lo[j] = lo8.iter().fold(lo[j], |a, &b| a.min(b));
            hi[j] = hi8.iter().fold(hi[j], |a, &b| a.max(b));
        }
        for (s, v) in vals[..sb].iter_mut().enumerate() {
            *v = if s < len { 1.0 } else { 0.0 };
        }
        for k in 1..m {
            let (p, j) = (shape.kept[shape.parent[k]], shape.var[k]);
            let yj = &y[j * sb..(j + 1) * sb];
            let mut a = acc[k];
            let slot = shape.kept[k];
            if slot != usize::MAX {
                // Parents are kept in evaluation order, so a parent's row precedes its child's.
                let (head, tail) = vals.split_at_mut(slot * sb);
                let (pv, out) = (&head[p * sb..(p + 1) * sb], &mut tail[..sb]);
                // Two plain loops (product, then lane sums) vectorise; a fused loop with
                // the store did not.
                for ((o, &p), &y) in out.iter_mut().zip(pv.iter()).zip(yj.iter()) {
                    *o = p * y;
                }
                for c in out.chunks_exact(CHUNK_LANES) {
                    for l in 0..CHUNK_LANES {
                        a[l] += c[l];
                    }
                }
            } else {
                // A leaf: accumulate the product directly.
                let pv = &vals[p * sb..(p + 1) * sb];
                for (pc, yc) in pv.chunks_exact(CHUNK_LANES).zip(yj.chunks_exact(CHUNK_LANES)) {
                    for l in 0..CHUNK_LANES {
                        a[l] += pc[l] * yc[l];
                    }
                }
            }
            acc[k] = a;
        }
        for c in vals[..sb].chunks_exact(CHUNK_LANES) {
            for l in 0..CHUNK_LANES {
                acc[0][l] += c[l];
            }
        }
        start += len;
    }
    let sums = acc.iter().map(|a| a.iter().sum()).collect();
    (sums, lo, hi)
}

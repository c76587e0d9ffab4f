//! Strong form — the paper's procedure (3.8)–(3.15): estimate the joint density of the
//! state on a grid over a box around the data (3.12), form the stationary FPK residual
//! in every usable cell with central differences of the estimated density, and solve the
//! least-squares problem (3.13)–(3.15) for the unknowns.
//!
//! In cell `c` the residual (3.8) is
//! `−Σ v_i ∂f/∂x_i − Σ ∂(a_i f)/∂v_i + ½ Σ Q_ij ∂²f/∂v_i∂v_j`, split into the pieces of
//! [`super::Pieces`]. A cell is usable when it and every cell of its difference stencil
//! hold at least `min_count` samples. With `marginals` the joint density is replaced by
//! the product of the one-dimensional marginals, as the paper's experiment did (3.21).
//!
//! The histogram is filled in one streaming pass; memory is the grid, not the samples.

use super::moments::RawMoments;
use super::{poly::Poly, prefetch, Pieces, Problem};

/// Grid settings; [`GridOptions::auto`] gives the defaults.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct GridOptions {
    /// Bins per dimension.
    pub bins: usize,
    /// Half-width of the box in standard deviations around the mean.
    pub span_std: f64,
    /// Smallest count a stencil cell may hold.
    pub min_count: u32,
}

/// Cells beyond which the grid is refused (memory and time).
pub const MAX_CELLS: usize = 50_000_000;

/// Samples per cell, on average over the box, below which the automatic grid gets coarser.
pub const SAMPLES_PER_CELL: f64 = 20.0;

/// The coarsest automatic grid: a central difference needs interior cells.
pub const MIN_AUTO_BINS: usize = 6;

/// Whether the strong form applies to `samples` samples of a `dim`-dimensional state: the
/// coarsest automatic grid ([`MIN_AUTO_BINS`] per dimension) must hold
/// [`SAMPLES_PER_CELL`] per cell on average. The reason when not.
pub fn applicable(dim: usize, samples: u64) -> Result<(), String> {
    let needed = SAMPLES_PER_CELL * (MIN_AUTO_BINS as f64).powi(dim as i32);
    if (samples as f64) < needed {
        return Err(format!(
            "a density grid over a {dim}-dimensional state needs at least {needed:.0} samples ({SAMPLES_PER_CELL} per \
             cell of the coarsest grid, {MIN_AUTO_BINS}^{dim} cells); the record has {samples}. The weak form has no \
             grid and applies"
        ));
    }
    Ok(())
}

impl GridOptions {
    /// Defaults from our reference measurements: bins of 0.3–0.45 std, a ±4.5 std box in
    /// 2-D and ±3 std beyond (docs/theory.md §2), made coarser when `samples` would fill
    /// fewer than [`SAMPLES_PER_CELL`] per cell on average: then `⌊(N/20)^(1/d)⌋` bins, at
    /// least [`MIN_AUTO_BINS`] (docs/methods.md, the strong form's grid).
    pub fn auto(dim: usize, samples: u64) -> GridOptions {
        let mut o = if dim <= 2 {
            GridOptions {
                bins: 26,
                span_std: 4.5,
                min_count: 5,
            }
        } else if dim <= 3 {
            GridOptions {
                bins: 20,
                span_std: 3.5,
                min_count: 5,
            }
        } else {
            GridOptions {
                bins: 20,
                span_std: 3.0,
                min_count: 5,
            }
        };
        let affordable = (samples as f64 / SAMPLES_PER_CELL)
            .powf(1.0 / dim.max(1) as f64)
            .floor();
        if affordable < o.bins as f64 {
            o.bins = (affordable as usize).max(MIN_AUTO_BINS);
        }
        o
    }
}

/// Per-batch counts (B × cells) beyond which a grid keeps none, and its strong forms
/// have no standard errors: 32 MB of `u32`.
pub const MAX_BATCH_ENTRIES: usize = 1 << 23;

/// Each batch's share of a grid, for the jackknife (the same batches as the weak form's).
#[derive(Debug, Clone)]
struct BatchCounts {
    counts: Vec<Vec<u32>>,
    marginals: Vec<Vec<Vec<u64>>>,
    inside: Vec<u64>,
    total: Vec<u64>,
}

/// A histogram of the state over a box.
#[derive(Debug, Clone)]
pub struct DensityGrid {
    pub dim: usize,
    pub options: GridOptions,
    pub lo: Vec<f64>,
    pub h: Vec<f64>,
    /// Samples per cell (or, from an exact density, density × cell volume with `total` 1).
    pub counts: Vec<f64>,
    /// Per dimension: counts of the one-dimensional marginal (all samples inside that
    /// dimension's range).
    pub marginals: Vec<Vec<u64>>,
    pub inside: u64,
    pub total: u64,
    columns: Vec<usize>,
    stride: Vec<usize>,
    /// Whether the joint histogram is counted ([`DensityGrid::marginals_only`]: not).
    joint: bool,
    batches: Option<BatchCounts>,
    /// Cells of the samples binned by [`DensityGrid::push_in`] but not yet counted, with
    /// their batches, oldest first (see there).
    pending: std::collections::VecDeque<(usize, usize)>,
}

/// Samples a grid holds back before counting them (see [`DensityGrid::push_in`]).
const IN_FLIGHT: usize = 16;

impl DensityGrid {
    /// A grid over mean ± span·std of each state variable (from `mom`).
    pub fn new(problem: &Problem, mom: &RawMoments, options: GridOptions) -> Result<DensityGrid, super::IdentError> {
        let d = problem.density_dim();
        let cells = (options.bins as f64).powi(d as i32);
        if cells > MAX_CELLS as f64 {
            return Err(super::IdentError::NotApplicable(format!(
                "a {}-dimensional grid of {} bins has {cells:.1e} cells (limit {MAX_CELLS:.0e}): the strong form does not scale past 4–5 dimensions; use the weak form",
                d, options.bins
            )));
        }
        let mut lo = Vec::new();
        let mut h = Vec::new();
        for j in 0..d {
            let (m, s) = (mom.mean(j), mom.std(j).max(1e-300));
            lo.push(m - options.span_std * s);
            h.push(2.0 * options.span_std * s / options.bins as f64);
        }
        let mut stride = vec![1; d];
        for j in 1..d {
            stride[j] = stride[j - 1] * options.bins;
        }
        Ok(DensityGrid {
            dim: d,
            options,
            lo,
            h,
            counts: vec![0.0; cells as usize],
            marginals: vec![vec![0; options.bins]; d],
            inside: 0,
            total: 0,
            columns: problem.columns.clone(),
            stride,
            joint: true,
            batches: None,
            pending: Default::default(),
        })
    }

    /// Count the marginals only, not the joint histogram (all that the product of the
    /// marginals, (3.21), needs: a sample then touches `d` small tables instead of a cell
    /// of a table far larger than the caches). Before [`DensityGrid::with_batches`]; its
    /// [`DensityGrid::pieces_with`] takes `marginals` only.
    pub fn marginals_only(mut self) -> DensityGrid {
        self.joint = false;
        self
    }

    /// Keep each of `batches` batches' counts too (for standard errors), when that fits in
    /// [`MAX_BATCH_ENTRIES`] (a marginals-only grid's always do); then fill with
    /// [`DensityGrid::push_in`].
    pub fn with_batches(mut self, batches: usize) -> DensityGrid {
        if batches >= 2 && (!self.joint || self.counts.len().saturating_mul(batches) <= MAX_BATCH_ENTRIES) {
            self.batches = Some(BatchCounts {
                counts: (0..batches)
                    .filter(|_| self.joint)
                    .map(|_| {
                        let c = vec![0; self.counts.len()];
                        super::huge_pages(&c);
                        c
                    })
                    .collect(),
                marginals: vec![self.marginals.clone(); batches],
                inside: vec![0; batches],
                total: vec![0; batches],
            });
        }
        self
    }

    /// Add one sample of batch `batch` (also to that batch's counts, if kept);
    /// [`DensityGrid::finish`] after the last.
    ///
    /// A grid and its batches' counts are far larger than the caches, and consecutive
    /// samples land far apart: counting each at once waits on memory twice per sample.
    /// Its cells are asked for instead, and counted 16 samples later (counts
    /// are integers: the order does not change them).
    #[inline]
    pub fn push_in(&mut self, batch: usize, row: &[f64]) {
        if !self.joint {
            self.add(Some(batch), row, false);
            return;
        }
        if let Some(cell) = self.add(Some(batch), row, false) {
            prefetch(&self.counts[cell]);
            if let Some(bc) = &self.batches {
                prefetch(&bc.counts[batch][cell]);
            }
            if self.pending.len() == IN_FLIGHT {
                self.count_oldest();
            }
            self.pending.push_back((cell, batch));
        }
    }

    /// Count the samples still held back; call after the last [`DensityGrid::push_in`].
    pub fn finish(&mut self) {
        while !self.pending.is_empty() {
            self.count_oldest();
        }
    }

    fn count_oldest(&mut self) {
        if let Some((cell, batch)) = self.pending.pop_front() {
            self.counts[cell] += 1.0;
            if let Some(bc) = self.batches.as_mut() {
                bc.counts[batch][cell] += 1;
            }
        }
    }

    /// The jackknife's replicates: per non-empty batch, the grid of all samples but that
    /// batch's (none without per-batch counts). One at a time: see
    /// [`DensityGrid::replicate_batches`] and [`DensityGrid::without_batch`] to make them in
    /// parallel.
    pub fn leave_one_out(&self) -> impl Iterator<Item = DensityGrid> + '_ {
        self.replicate_batches().into_iter().map(|b| self.without_batch(b))
    }

    /// The batches the jackknife leaves out in turn: every non-empty one (none without
    /// per-batch counts).
    pub fn replicate_batches(&self) -> Vec<usize> {
        assert!(self.pending.is_empty(), "DensityGrid::finish after the last push_in");
        self.batches.as_ref().map_or(Vec::new(), |bc| {
            (0..bc.total.len()).filter(|&b| bc.total[b] > 0).collect()
        })
    }

    /// The grid of all samples but batch `b`'s (one of [`DensityGrid::replicate_batches`]).
    pub fn without_batch(&self, b: usize) -> DensityGrid {
        let bc = self.batches.as_ref().expect("a grid with per-batch counts");
        let mut g = self.clone_without_batches();
        g.counts = if self.joint {
            self.counts
                .iter()
                .zip(&bc.counts[b])
                .map(|(c, k)| c - *k as f64)
                .collect()
        } else {
            vec![0.0; self.counts.len()]
        };
        g.marginals = self
            .marginals
            .iter()
            .zip(&bc.marginals[b])
            .map(|(m, k)| m.iter().zip(k).map(|(a, b)| a - b).collect())
            .collect();
        g.inside = self.inside - bc.inside[b];
        g.total = self.total - bc.total[b];
        g
    }

    /// A copy of the geometry and totals, without counts and per-batch counts.
    fn clone_without_batches(&self) -> DensityGrid {
        DensityGrid {
            dim: self.dim,
            options: self.options,
            lo: self.lo.clone(),
            h: self.h.clone(),
            counts: Vec::new(),
            marginals: Vec::new(),
            inside: self.inside,
            total: self.total,
            columns: self.columns.clone(),
            stride: self.stride.clone(),
            joint: self.joint,
            batches: None,
            pending: Default::default(),
        }
    }

    /// Add one sample (`row`: the log's columns).
    #[inline]
    pub fn push(&mut self, row: &[f64]) {
        self.add(None, row, self.joint);
    }

    /// Bin one sample into the grid, its marginals and, with `batch`, that batch's counts;
    /// the sample's cell if it is inside the grid. The cell is counted only if `count`
    /// (else the caller counts it; the totals and marginals are counted here either way).
    #[inline]
    fn add(&mut self, batch: Option<usize>, row: &[f64], count: bool) -> Option<usize> {
        let mut bc = batch.and_then(|b| self.batches.as_mut().map(|bc| (b, bc)));
        self.total += 1;
        if let Some((b, bc)) = bc.as_mut() {
            bc.total[*b] += 1;
        }
        let mut idx = 0;
        let mut inside = true;
        for j in 0..self.dim {
            match crate::stats::bin((row[self.columns[j]] - self.lo[j]) / self.h[j], self.options.bins) {
                Some(k) => {
                    self.marginals[j][k] += 1;
                    if let Some((b, bc)) = bc.as_mut() {
                        bc.marginals[*b][j][k] += 1;
                    }
                    idx += k * self.stride[j];
                }
                None => inside = false,
            }
        }
        if !inside {
            return None;
        }
        self.inside += 1;
        if count {
            self.counts[idx] += 1.0;
        }
        if let Some((b, bc)) = bc {
            if count {
                bc.counts[b][idx] += 1;
            }
            bc.inside[b] += 1;
        }
        Some(idx)
    }

    /// A grid holding an exact density `f` at the cell centres over `lo + [0, bins·h]`
    /// (reference tests). Marginals are not available from it.
    pub fn from_density(
        problem: &Problem,
        lo: Vec<f64>,
        h: Vec<f64>,
        bins: usize,
        f: impl Fn(&[f64]) -> f64,
    ) -> DensityGrid {
        assert!(problem.atoms.is_empty(), "an exact density over the state has no atoms");
        let d = problem.density_dim();
        let mut stride = vec![1; d];
        for j in 1..d {
            stride[j] = stride[j - 1] * bins;
        }
        let vol: f64 = h.iter().product();
        let cells = bins.pow(d as u32);
        let mut g = DensityGrid {
            dim: d,
            options: GridOptions {
                bins,
                span_std: f64::NAN,
                min_count: 0,
            },
            lo,
            h,
            counts: vec![0.0; cells],
            marginals: vec![vec![0; bins]; d],
            inside: 1,
            total: 1,
            columns: problem.columns.clone(),
            stride,
            joint: true,
            batches: None,
            pending: Default::default(),
        };
        let mut idx = vec![0; d];
        for flat in 0..cells {
            let mut rest = flat;
            for j in 0..d {
                idx[j] = rest % bins;
                rest /= bins;
            }
            g.counts[flat] = f(&g.center(&idx)) * vol;
        }
        g
    }

    fn center(&self, idx: &[usize]) -> Vec<f64> {
        (0..self.dim)
            .map(|j| self.lo[j] + (idx[j] as f64 + 0.5) * self.h[j])
            .collect()
    }

    /// Occupied cells of the density the strong form uses: the joint histogram's, or (with
    /// `marginals`) those of the product of the marginals, the cells each of whose bins holds
    /// samples (a grid made by [`DensityGrid::marginals_only`] has no joint counts).
    pub fn occupied(&self, marginals: bool) -> usize {
        if marginals {
            self.marginals
                .iter()
                .map(|m| m.iter().filter(|&&c| c > 0).count())
                .product()
        } else {
            assert!(self.joint, "a marginals-only grid has no joint histogram");
            self.counts.iter().filter(|&&c| c > 0.0).count()
        }
    }

    /// The residual's pieces over the usable cells, from the joint histogram or (with
    /// `marginals`) from the product of the marginal histograms.
    pub fn pieces(&self, problem: &Problem, marginals: bool) -> (Pieces, usize) {
        let (pc, usable, _) = self.pieces_with(problem, marginals, None);
        (pc, usable)
    }

    /// [`DensityGrid::pieces`], reusing the stencil values `known` of a grid with the same
    /// bins where it has them; also the values it evaluated (none when `known` is given).
    pub fn pieces_with(
        &self,
        problem: &Problem,
        marginals: bool,
        known: Option<&Stencils>,
    ) -> (Pieces, usize, Stencils) {
        assert!(self.pending.is_empty(), "DensityGrid::finish after the last push_in");
        assert!(marginals || self.joint, "the joint histogram of a marginals-only grid");
        let n = problem.n;
        let rc = problem.coefficient_count();
        let vol: f64 = self.h.iter().product();
        let total = self.total as f64;
        let product;
        let eq: &[f64] = if marginals {
            product = self.marginal_product();
            &product
        } else {
            &self.counts
        };
        let count = |flat: usize| eq[flat];
        let cross = problem.white.iter().any(|(t, _, _)| t.len() > 1);
        let rows = self.usable_cells(problem, eq, cross);
        let f = |flat: usize| count(flat) / (total * vol);
        let mut pc = Pieces::new(rows.len(), n, rc);
        // The drift's parts at each row's stencil: from the full grid's values when given
        // (a replicate's usable cells are among the full grid's: its counts are smaller).
        let width = 2 * problem.free_drift.len() + 2 * n * (1 + rc);
        let mut evaluated = Stencils {
            rows: Vec::new(),
            width,
            values: Vec::new(),
        };
        let mut buf = vec![0.0; width];
        // Points of the problem's variables: the state, then the atoms' values there.
        let v = problem.dim();
        let (mut y, mut yu, mut yd) = (vec![0.0; v], vec![0.0; v], vec![0.0; v]);
        let mut row = vec![0.0; problem.model.columns().len()];
        // The known stencils' rows and `rows` both ascend: one cursor walks the former.
        let mut cursor = 0;
        for (k, &flat) in rows.iter().enumerate() {
            let vals: &[f64] = match known.and_then(|c| c.from(&mut cursor, flat)) {
                Some(v) => v,
                None => {
                    self.stencil_values(problem, flat, &mut buf, [&mut y, &mut yu, &mut yd], &mut row);
                    if known.is_none() {
                        evaluated.rows.push(flat);
                        evaluated.values.extend_from_slice(&buf);
                    }
                    &buf
                }
            };
            let mut vals = vals.chunks_exact(2);
            // −Σ_j ∂(drift_j f)/∂y_j for the known, unscaled drift terms.
            let mut t0 = 0.0;
            for (j, _) in &problem.free_drift {
                let j = *j;
                let g = vals.next().expect("stencil values");
                t0 -= (g[0] * f(flat + self.stride[j]) - g[1] * f(flat - self.stride[j])) / (2.0 * self.h[j]);
            }
            pc.t0[k] = t0;
            for i in 0..n {
                let j = problem.noise_var[i];
                let (up, dn) = (flat + self.stride[j], flat - self.stride[j]);
                let (fu, fd) = (f(up), f(dn));
                let h2 = 2.0 * self.h[j];
                let g = vals.next().expect("stencil values");
                pc.a[k * n + i] = -(g[0] * fu - g[1] * fd) / h2;
                for r in 0..rc {
                    let g = vals.next().expect("stencil values");
                    pc.b[(k * n + i) * rc + r] = -(g[0] * fu - g[1] * fd) / h2;
                }
                for m in 0..n {
                    let jm = problem.noise_var[m];
                    pc.c[(k * n + i) * n + m] = if m == i {
                        (fu - 2.0 * f(flat) + fd) / (self.h[j] * self.h[j])
                    } else if cross {
                        let (si, sm) = (self.stride[j], self.stride[jm]);
                        (f(flat + si + sm) - f(flat + si - sm) - f(flat - si + sm) + f(flat - si - sm))
                            / (4.0 * self.h[j] * self.h[jm])
                    } else {
                        0.0
                    };
                }
            }
        }
        (pc, rows.len(), evaluated)
    }

    /// The equivalent count of every cell of the product of the marginals, computed once
    /// (the stencils read each cell many times).
    fn marginal_product(&self) -> Vec<f64> {
        let total = self.total as f64;
        let scaled: Vec<Vec<f64>> = self
            .marginals
            .iter()
            .map(|m| m.iter().map(|&c| c as f64 / total).collect())
            .collect();
        // Cell by cell in flat order, the bin per dimension kept as an odometer.
        let mut bin = vec![0; self.dim];
        (0..self.counts.len())
            .map(|_| {
                let mut c = total;
                for (m, &i) in scaled.iter().zip(&bin) {
                    c *= m[i];
                }
                next_cell(&mut bin, self.options.bins);
                c
            })
            .collect()
    }

    /// The cells where the residual is formed, ascending: off the grid's edge, with at least
    /// `min_count` equivalent samples (`eq`) in the cell and in every cell its stencil reads
    /// (the diagonal neighbours too when the noise is correlated, `cross`).
    fn usable_cells(&self, problem: &Problem, eq: &[f64], cross: bool) -> Vec<usize> {
        let (d, n, nb) = (self.dim, problem.n, self.options.bins);
        let count = |flat: usize| eq[flat];
        let min = self.options.min_count as f64;
        let mut rows: Vec<usize> = Vec::new();
        let mut bin = vec![0; d];
        'cells: for flat in 0..self.counts.len() {
            // The bins of `flat` per dimension, the odometer moved on to the next cell's.
            let edge = bin.iter().any(|&i| i == 0 || i == nb - 1);
            next_cell(&mut bin, nb);
            if count(flat) < min || edge {
                continue;
            }
            for j in 0..d {
                if count(flat + self.stride[j]) < min || count(flat - self.stride[j]) < min {
                    continue 'cells;
                }
            }
            if cross {
                for i in 0..n {
                    for k in 0..n {
                        if i != k {
                            let (si, sk) = (self.stride[problem.noise_var[i]], self.stride[problem.noise_var[k]]);
                            for c in [flat + si + sk, flat + si - sk, flat - si + sk, flat - si - sk] {
                                if count(c) < min {
                                    continue 'cells;
                                }
                            }
                        }
                    }
                }
            }
            rows.push(flat);
        }
        rows
    }

    /// The drift's parts one cell up and one down along each dimension they act in, at the
    /// cell `flat`'s centre, into `buf`: the free drift, then per noise variable the known
    /// force and each coefficient's unit force. `scratch` holds three points of the
    /// problem's variables, `row` one of the log's width (for the atoms' values).
    fn stencil_values(
        &self,
        problem: &Problem,
        flat: usize,
        buf: &mut [f64],
        scratch: [&mut Vec<f64>; 3],
        row: &mut [f64],
    ) {
        let [y, yu, yd] = scratch;
        let nb = self.options.bins;
        let mut rest = flat;
        for j in 0..self.dim {
            y[j] = self.lo[j] + ((rest % nb) as f64 + 0.5) * self.h[j];
            rest /= nb;
        }
        let mut at = 0;
        let mut shifted = |j: usize, g: &Poly| {
            yu.copy_from_slice(y);
            yu[j] += self.h[j];
            yd.copy_from_slice(y);
            yd[j] -= self.h[j];
            if !problem.atoms.is_empty() {
                problem.fill_atoms(yu, row);
                problem.fill_atoms(yd, row);
            }
            buf[at] = g.eval(yu);
            buf[at + 1] = g.eval(yd);
            at += 2;
        };
        for (j, drift) in &problem.free_drift {
            shifted(*j, drift);
        }
        for i in 0..problem.n {
            let j = problem.noise_var[i];
            shifted(j, &problem.known_force[i]);
            for r in 0..problem.coefficient_count() {
                shifted(j, &problem.unit_force[r][i]);
            }
        }
    }
}

/// The next cell's bins in flat order (dimension 0 fastest), `nb` bins per dimension.
#[inline]
fn next_cell(bin: &mut [usize], nb: usize) {
    for i in bin {
        *i += 1;
        if *i < nb {
            return;
        }
        *i = 0;
    }
}

/// The drift's parts (free drift, known and unit forces) evaluated at the stencil of each
/// usable cell of a grid, kept so that the jackknife's replicates, whose usable cells are
/// among the full grid's, do not evaluate them again.
pub struct Stencils {
    /// Usable cells, ascending.
    rows: Vec<usize>,
    width: usize,
    values: Vec<f64>,
}

impl Stencils {
    /// The values of cell `flat`, looked for from row `cursor` on, which is moved past the
    /// cells before `flat` (cells asked for in ascending order).
    fn from(&self, cursor: &mut usize, flat: usize) -> Option<&[f64]> {
        while self.rows.get(*cursor).is_some_and(|&r| r < flat) {
            *cursor += 1;
        }
        let k = *cursor;
        (self.rows.get(k) == Some(&flat)).then(|| &self.values[k * self.width..(k + 1) * self.width])
    }
}

//! Streaming statistics of stationary samples for identification: raw moments per fine
//! batch (their sum is the whole record's; their spread weights the weak form), and each
//! link's observed ranges of relative displacement and velocity (3.16)–(3.17). Fed one
//! sample at a time from any source (a log reader, the simulator), in constant memory.

use super::moments::RawMoments;
use super::Problem;
use crate::model::Model;

/// The weak form's moments when `degree` is what it needs, else every moment to `degree`.
fn accumulator(problem: &Problem, degree: u32) -> RawMoments {
    if degree == super::weak::moment_degree(problem) {
        super::weak::accumulator(problem)
    } else {
        RawMoments::new(problem.dim(), degree)
    }
}

/// Samples buffered before a parallel moment update.
const BLOCK: usize = 1 << 16;

/// Fine batches: the spread of the weak form's equations over them gives the equations'
/// covariance, from which the weak form weights them (see [`super::weak`]). A fine batch
/// holds the samples of one of [`TRAJECTORY_GROUPS`] groups of trajectories (trajectory
/// mod groups) — or of a sub-group of it, when the equations need more batches than
/// [`MIN_FINE_BATCHES`] — over one of at least [`TIME_WINDOWS`] consecutive time windows:
/// groups are independent, and windows are long enough to be nearly so even for short
/// records. A covariance of `r` equations needs [`super::weak::BATCHES_PER_EQUATION`]` · r`
/// batches: sub-groups first (independent trajectories), then shorter windows.
pub const TRAJECTORY_GROUPS: usize = 8;
pub const TIME_WINDOWS: usize = 128;
/// Fine batches of a model with few equations: 8 groups × 128 windows.
pub const MIN_FINE_BATCHES: usize = TRAJECTORY_GROUPS * TIME_WINDOWS;

/// How the fine batches divide the samples: `TRAJECTORY_GROUPS` groups, each split into
/// `subgroups` by trajectory, over `windows` time windows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FineLayout {
    pub subgroups: usize,
    pub windows: usize,
}

impl FineLayout {
    /// The layout giving at least `wanted` fine batches for a record of `trajectories`:
    /// each trajectory group split by trajectory as far as it has trajectories, the windows
    /// a multiple of 4 (so the coarse batches stay quarters of each group's record).
    pub fn for_batches(wanted: usize, trajectories: usize) -> FineLayout {
        let per_group = wanted.max(MIN_FINE_BATCHES).div_ceil(TRAJECTORY_GROUPS);
        let subgroups = trajectories
            .div_ceil(TRAJECTORY_GROUPS)
            .clamp(1, per_group.div_ceil(TIME_WINDOWS));
        let windows = per_group.div_ceil(subgroups).next_multiple_of(4).max(TIME_WINDOWS);
        FineLayout { subgroups, windows }
    }

    /// Number of fine batches.
    pub fn count(&self) -> usize {
        TRAJECTORY_GROUPS * self.subgroups * self.windows
    }
}

/// Powers of a link's relative displacement and velocity summed over the samples: enough
/// for the mean square of a characteristic of degree up to 6 under their observed density.
pub const OBSERVED_POWERS: usize = 13;

/// `x.ceil() as usize` without the library call (the baseline x86-64 target has no
/// rounding instruction, and every sample's batch asks for it): the same value for every
/// `x`, NaN and negatives giving 0, beyond `usize::MAX` saturating.
#[inline]
fn ceil_index(x: f64) -> usize {
    let i = x as usize;
    if (i as f64) < x {
        i.saturating_add(1)
    } else {
        i
    }
}

/// The links' relative motion as observed: per link `[u_min, u_max, w_min, w_max]`, and the
/// sums of `u^k` and `w^k` (`k = 0 …` [`OBSERVED_POWERS`]` − 1`), from which the mean square
/// of a polynomial characteristic under the observed density is exact.
#[derive(Debug, Clone, Copy)]
pub struct Observed<'a> {
    pub ranges: &'a [[f64; 4]],
    pub powers: &'a [[[f64; OBSERVED_POWERS]; 2]],
}

/// Which fine and coarse batch a sample falls into: [`StationaryData`]'s layout, without
/// its moments.
#[derive(Debug, Clone, Copy)]
pub struct Batching {
    layout: FineLayout,
    record_length: f64,
    per_coarse: usize,
}

impl Batching {
    /// The fine batch of a sample of `trajectory` at time `t`.
    #[inline]
    fn fine_batch(&self, trajectory: u32, t: f64) -> usize {
        let FineLayout { subgroups, windows } = self.layout;
        let w = ceil_index(t / self.record_length * windows as f64).clamp(1, windows) - 1;
        let j = trajectory as usize;
        let (g, s) = (j % TRAJECTORY_GROUPS, (j / TRAJECTORY_GROUPS) % subgroups);
        (g * windows + w) * subgroups + s
    }

    /// The coarse batch of a sample of `trajectory` at time `t`.
    #[inline]
    pub fn batch_of(&self, trajectory: u32, t: f64) -> usize {
        self.fine_batch(trajectory, t) / self.per_coarse
    }
}

/// The seed of [`StationaryData::bootstrap`]'s draws.
const BOOTSTRAP_STREAM: u64 = 0x5e1e_c7ed_b007_57a9;

/// Moments and ranges of the state, per time batch.
#[derive(Debug, Clone)]
pub struct StationaryData {
    /// Fine batch `(g · windows + w) · subgroups + s` holds the samples of trajectories
    /// `j ≡ g` (mod [`TRAJECTORY_GROUPS`]) with `(j / TRAJECTORY_GROUPS) mod subgroups = s`
    /// and `t` in `[w, w+1) · record_length / windows` (see [`FineLayout`]). Their sum is the
    /// whole record's moments.
    pub fine: Vec<RawMoments>,
    pub layout: FineLayout,
    /// Coarse batches for the jackknife's standard errors (groups of consecutive fine
    /// batches: with 8, exactly the trajectory groups; with 32, their quarters).
    coarse: usize,
    record_length: f64,
    columns: Vec<usize>,
    /// The problem's [`super::Atom`]s, valued at each sample after its columns.
    atoms: Vec<super::Atom>,
    buffer: Vec<f64>,
    ids: Vec<u32>,
    /// Scratch: the buffer sorted by batch.
    sorted: Vec<f64>,
    sorted_ids: Vec<u32>,
    /// Per link: `[u_min, u_max, w_min, w_max]`.
    pub link_ranges: Vec<[f64; 4]>,
    /// Per link: the sums of `u^k` and of `w^k`, `k = 0 …` [`OBSERVED_POWERS`]` − 1` (norms
    /// under the observed density, [`Observed`]).
    pub link_powers: Vec<[[f64; OBSERVED_POWERS]; 2]>,
    /// The model, for its links' relative motion ([`Model::link_motion`]).
    model: Model,
    /// Per coarse batch: what the jackknife's replicate without it corrects for sensor
    /// noise beyond what every batch was corrected for ([`StationaryData::deconvolve`]).
    noise_replicates: Vec<Option<Vec<f64>>>,
}

/// What a sensor-noise correction takes out of moments ([`StationaryData::deconvolve`]):
/// per log column the variance (the noise, less what a filter's loss puts back), and per
/// coarse batch what its jackknife replicate takes out instead.
#[derive(Debug, Clone, PartialEq)]
pub struct Deconvolution {
    pub by_column: Vec<f64>,
    pub replicates: Vec<Option<Vec<f64>>>,
}

impl StationaryData {
    /// `degree`: highest moment degree; `record_length`: time span of `t` per trajectory;
    /// `trajectories`: how many the record has; `batches`: coarse time batches for
    /// standard errors. With the weak form's degree, the fine batches are enough for its
    /// equations' covariance ([`FineLayout::for_batches`]).
    pub fn new(
        problem: &Problem,
        degree: u32,
        record_length: f64,
        trajectories: usize,
        batches: usize,
    ) -> StationaryData {
        let (first, layout) = Self::plan(problem, degree, trajectories);
        StationaryData::from_accumulator(problem, first, layout, record_length, batches)
    }

    /// What [`StationaryData::new`] allocates: the moments of one fine batch and the layout.
    fn plan(problem: &Problem, degree: u32, trajectories: usize) -> (RawMoments, FineLayout) {
        let wanted = if degree == super::weak::moment_degree(problem) {
            super::weak::BATCHES_PER_EQUATION * super::weak::equation_count(problem)
        } else {
            MIN_FINE_BATCHES
        };
        (
            accumulator(problem, degree),
            FineLayout::for_batches(wanted, trajectories),
        )
    }

    /// The moments the weak forms of `problem` and of every one of `also` read (problems
    /// over the same state, e.g. a structure selection's candidate and declared models),
    /// with the fine batches `problem`'s equations need.
    pub fn for_weak_forms(
        problem: &Problem,
        also: &[&Problem],
        record_length: f64,
        trajectories: usize,
        batches: usize,
    ) -> StationaryData {
        let (first, layout) = Self::plan_weak_forms(problem, also, trajectories);
        StationaryData::from_accumulator(problem, first, layout, record_length, batches)
    }

    /// The bytes the weak forms' moments of `problem` and `also` take over their fine
    /// batches (what [`StationaryData::for_weak_forms`], or [`StationaryData::new`] at the
    /// weak form's degree without `also`, allocates), and the bytes the efficient weighting
    /// of `problem`'s equations takes (each fine batch's residuals, the covariance, its
    /// equilibrated copy, its Cholesky factor and the whitening), known before anything is
    /// allocated: a structure selection over many high powers can ask for more than the
    /// machine has.
    pub fn weak_forms_bytes(problem: &Problem, also: &[&Problem], trajectories: usize) -> (u64, u64) {
        let (first, layout) = match also.is_empty() {
            true => Self::plan(problem, super::weak::moment_degree(problem), trajectories),
            false => Self::plan_weak_forms(problem, also, trajectories),
        };
        let rows = super::weak::equation_count(problem);
        let f = std::mem::size_of::<f64>();
        (
            (first.sums.len() * layout.count() * f) as u64,
            ((rows * layout.count() + 4 * rows * rows) * f) as u64,
        )
    }

    /// What [`StationaryData::for_weak_forms`] allocates: the moments of one fine batch and
    /// the layout.
    fn plan_weak_forms(problem: &Problem, also: &[&Problem], trajectories: usize) -> (RawMoments, FineLayout) {
        let mut wanted = super::weak::required_moments(problem);
        let mut degree = super::weak::moment_degree(problem);
        for p in also {
            debug_assert_eq!(p.dim(), problem.dim());
            wanted.extend(super::weak::required_moments(p));
            degree = degree.max(super::weak::moment_degree(p));
        }
        wanted.sort_unstable();
        wanted.dedup();
        let layout = FineLayout::for_batches(
            super::weak::BATCHES_PER_EQUATION * super::weak::equation_count(problem),
            trajectories,
        );
        (RawMoments::with_monomials(problem.dim(), degree, &wanted), layout)
    }

    /// Every raw moment up to `degree` (for several problems over the same state).
    pub fn with_all_moments(problem: &Problem, degree: u32, record_length: f64, batches: usize) -> StationaryData {
        let d = problem.dim();
        let layout = FineLayout::for_batches(MIN_FINE_BATCHES, 1);
        StationaryData::from_accumulator(problem, RawMoments::new(d, degree), layout, record_length, batches)
    }

    fn from_accumulator(
        problem: &Problem,
        first: RawMoments,
        layout: FineLayout,
        record_length: f64,
        batches: usize,
    ) -> StationaryData {
        let d = problem.dim();
        StationaryData {
            fine: vec![first; layout.count()],
            layout,
            coarse: batches.clamp(1, layout.count()),
            record_length,
            columns: problem.columns.clone(),
            atoms: problem.atoms.clone(),
            buffer: Vec::with_capacity(BLOCK * d),
            ids: Vec::with_capacity(BLOCK),
            sorted: Vec::new(),
            sorted_ids: Vec::new(),
            link_ranges: vec![
                [f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
                problem.model.links()
            ],
            link_powers: vec![[[0.0; OBSERVED_POWERS]; 2]; problem.model.links()],
            model: problem.model.clone(),
            noise_replicates: Vec::new(),
        }
    }

    /// The links' relative motion as the samples show it.
    pub fn observed(&self) -> Observed<'_> {
        Observed {
            ranges: &self.link_ranges,
            powers: &self.link_powers,
        }
    }

    /// The fine batch of a sample of `trajectory` at time `t`.
    fn fine_batch(&self, trajectory: u32, t: f64) -> usize {
        self.batching().fine_batch(trajectory, t)
    }

    /// Fine batches per coarse batch.
    fn per_coarse(&self) -> usize {
        self.layout.count().div_ceil(self.coarse)
    }

    /// The coarse batch (see [`StationaryData::batches`]) of a sample of `trajectory` at
    /// time `t`: other estimators' jackknives use the same batches.
    pub fn batch_of(&self, trajectory: u32, t: f64) -> usize {
        self.batching().batch_of(trajectory, t)
    }

    /// How samples fall into batches, apart from the moments (what a pass hands every
    /// accumulator as [`super::accumulate::Sample::batch`]).
    pub fn batching(&self) -> Batching {
        Batching {
            layout: self.layout,
            record_length: self.record_length,
            per_coarse: self.per_coarse(),
        }
    }

    /// Number of coarse batches.
    pub fn batch_count(&self) -> usize {
        self.layout.count().div_ceil(self.per_coarse())
    }

    /// Add one sample (`row`: the log's columns) of `trajectory` taken at time `t` after
    /// burn-in.
    pub fn push(&mut self, trajectory: u32, t: f64, row: &[f64]) {
        self.push_values(trajectory, t, row);
        for l in 0..self.link_ranges.len() {
            let (u, w) = self.model.link_motion(l, row);
            let [u_lo, u_hi, w_lo, w_hi] = &mut self.link_ranges[l];
            let [u_sums, w_sums] = &mut self.link_powers[l];
            observe(u_lo, u_hi, u_sums, std::iter::once(u));
            observe(w_lo, w_hi, w_sums, std::iter::once(w));
        }
    }

    /// A run of samples, as [`StationaryData::push`] of each in turn: the moments' values
    /// sample by sample, then the links' ranges and power sums one link and argument at a
    /// time over the run, their sums held in registers (the same additions in the same
    /// order).
    pub fn push_run(&mut self, samples: &super::accumulate::Samples) {
        for k in 0..samples.len() {
            let s = samples.get(k);
            self.push_values(s.trajectory, s.t, s.row);
        }
        let model = &self.model;
        let rows = || (0..samples.len()).map(|k| samples.get(k).row);
        for (l, (range, [u_sums, w_sums])) in self.link_ranges.iter_mut().zip(&mut self.link_powers).enumerate() {
            let [u_lo, u_hi, w_lo, w_hi] = range;
            observe(u_lo, u_hi, u_sums, rows().map(|r| model.link_motion(l, r).0));
            observe(w_lo, w_hi, w_sums, rows().map(|r| model.link_motion(l, r).1));
        }
    }

    /// The sample's values for the moments (its columns, then its atoms) and its fine
    /// batch, the buffer flushed when full.
    fn push_values(&mut self, trajectory: u32, t: f64, row: &[f64]) {
        let b = self.fine_batch(trajectory, t);
        for &c in &self.columns {
            self.buffer.push(row[c]);
        }
        for a in &self.atoms {
            self.buffer.push(a.value(&self.model, row));
        }
        self.ids.push(b as u32);
        if self.ids.len() >= BLOCK {
            self.finish();
        }
    }

    /// Flush buffered samples.
    pub fn finish(&mut self) {
        if self.ids.is_empty() {
            return;
        }
        // Samples arrive in (time, trajectory) order, so consecutive ones belong to different
        // trajectory groups: a stable counting sort by batch makes each batch's samples one
        // run, summed in whole chunks (the order within a batch is kept: deterministic).
        let d = self.columns.len() + self.atoms.len();
        let fine = self.fine.len();
        let mut start = vec![0usize; fine + 1];
        for &b in &self.ids {
            start[b as usize + 1] += 1;
        }
        for b in 0..fine {
            start[b + 1] += start[b];
        }
        self.sorted.resize(self.buffer.len(), 0.0);
        self.sorted_ids.resize(self.ids.len(), 0);
        for (s, &b) in self.ids.iter().enumerate() {
            let at = start[b as usize];
            start[b as usize] += 1;
            super::accumulate::copy_row(&mut self.sorted[at * d..(at + 1) * d], &self.buffer[s * d..(s + 1) * d]);
            self.sorted_ids[at] = b;
        }
        RawMoments::add_batched(&mut self.fine, &self.sorted, &self.sorted_ids);
        self.buffer.clear();
        self.ids.clear();
    }

    /// Moments of the whole record (the sum of the batches).
    pub fn total(&self) -> RawMoments {
        sum_of(&self.fine)
    }

    /// The coarse batches (consecutive groups of fine ones: with 32, each trajectory
    /// group's four quarters of the record).
    pub fn batches(&self) -> Vec<RawMoments> {
        self.fine.chunks(self.per_coarse()).map(sum_of).collect()
    }

    /// The jackknife's replicates: per non-empty coarse batch, the moments of the whole
    /// record without it (summed from the others, never subtracted).
    pub fn leave_one_out(&self) -> Vec<RawMoments> {
        let batches: Vec<(usize, RawMoments)> = self
            .batches()
            .into_iter()
            .enumerate()
            .filter(|(_, b)| b.count > 0)
            .collect();
        if batches.len() < 2 {
            return Vec::new();
        }
        batches
            .iter()
            .map(|(out, _)| {
                let rest: Vec<RawMoments> = batches
                    .iter()
                    .filter(|(b, _)| b != out)
                    .map(|(_, m)| m.clone())
                    .collect();
                let mut r = sum_of(&rest);
                if let Some(Some(d)) = self.noise_replicates.get(*out) {
                    r.deconvolve(d);
                }
                r
            })
            .collect()
    }

    /// Per jackknife replicate (in [`StationaryData::leave_one_out`]'s order), the
    /// non-empty fine batches it is made of: what its own equation weighting is estimated
    /// from (`crate::ident::estimate::identify_weak`).
    pub fn leave_one_out_fine(&self) -> Vec<Vec<&RawMoments>> {
        let per = self.per_coarse();
        // The coarse batches `leave_one_out` keeps: those holding samples.
        let kept: Vec<usize> = (self.fine.chunks(per).enumerate())
            .filter(|(_, c)| c.iter().any(|f| f.count > 0))
            .map(|(b, _)| b)
            .collect();
        if kept.len() < 2 {
            return Vec::new();
        }
        kept.iter()
            .map(|&out| {
                self.fine
                    .iter()
                    .enumerate()
                    .filter(|&(i, f)| f.count > 0 && i / per != out)
                    .map(|(_, f)| f)
                    .collect()
            })
            .collect()
    }

    /// Whether a jackknife replicate carries its own sensor-noise correction
    /// ([`StationaryData::leave_one_out`]); without, each is the plain sum of the batches
    /// but one.
    pub fn has_noise_replicates(&self) -> bool {
        self.noise_replicates.iter().any(Option::is_some)
    }

    /// `count` bootstrap resamples of the record: per resample, how many times each coarse
    /// batch ([`StationaryData::batches`]) is drawn — as many draws as the record has
    /// non-empty batches, with replacement, from a fixed stream (the same record gives the
    /// same resamples on any thread count). Unlike the jackknife's replicates, which share
    /// all batches but one, two resamples share about 40 % of theirs: a choice that hangs
    /// on the luck of this record varies between them (docs/selection.md).
    pub fn bootstrap(&self, count: usize) -> Vec<Vec<u32>> {
        use rand::{RngExt, SeedableRng};
        // The non-empty coarse batches, from their fine batches' counts (no moments summed).
        let full: Vec<usize> = (self.fine.chunks(self.per_coarse()).enumerate())
            .filter(|(_, c)| c.iter().any(|b| b.count > 0))
            .map(|(i, _)| i)
            .collect();
        if full.len() < 2 {
            return Vec::new();
        }
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(BOOTSTRAP_STREAM);
        (0..count)
            .map(|_| {
                let mut times = vec![0u32; self.batch_count()];
                for _ in 0..full.len() {
                    times[full[rng.random_range(0..full.len())]] += 1;
                }
                times
            })
            .collect()
    }

    /// Take additive sensor noise out of every batch's moments and the links' power sums:
    /// `by_column[c]` is the noise variance of log column `c`
    /// ([`RawMoments::deconvolve`]); `replicates[b]`, the same from every coarse batch but
    /// `b`, for the jackknife's replicate without `b` (so the standard errors carry the
    /// noise estimate's uncertainty). Columns of the problem's atoms (functions of the
    /// columns) are left as they are: the caller says so.
    pub fn deconvolve(&mut self, by_column: &[f64], replicates: &[Option<Vec<f64>>]) {
        let by_state = |v: &[f64]| -> Vec<f64> {
            let mut out = vec![0.0; self.columns.len() + self.atoms.len()];
            for (s, &c) in self.columns.iter().enumerate() {
                out[s] = v[c];
            }
            out
        };
        let total = by_state(by_column);
        // Deconvolutions compose by adding variances: a replicate corrected with the
        // whole record's noise is brought to its own by the difference.
        self.noise_replicates = replicates
            .iter()
            .map(|r| {
                r.as_ref().map(|r| {
                    by_state(r)
                        .iter()
                        .zip(&total)
                        .map(|(a, b)| if *b != 0.0 { a - b } else { 0.0 })
                        .collect()
                })
            })
            .collect();
        use rayon::prelude::*;
        self.fine.par_iter_mut().for_each(|m| m.deconvolve(&total));
        let c = self.model.columns();
        for (l, powers) in self.link_powers.iter_mut().enumerate() {
            let (mut su, mut sw) = (0.0, 0.0);
            for i in 0..self.model.masses() {
                let s = self.model.sign(l, i);
                su += s * s * by_column[c.x(i)];
                sw += s * s * by_column[c.v(i)];
            }
            super::noise::deconvolve_powers(&mut powers[0], su);
            super::noise::deconvolve_powers(&mut powers[1], sw);
        }
    }

    /// [`StationaryData::deconvolve`] by `d`: its replicates where these moments have as
    /// many coarse batches (the same trajectory groups and time windows), else the whole
    /// record's correction alone.
    pub fn deconvolve_by(&mut self, d: &Deconvolution) {
        let same = d.replicates.len() == self.batch_count();
        self.deconvolve(&d.by_column, if same { &d.replicates } else { &[] });
    }

    pub fn samples(&self) -> u64 {
        self.fine.iter().map(|b| b.count).sum()
    }
}

/// The moments of several accumulators of the same monomials together.
fn sum_of(group: &[RawMoments]) -> RawMoments {
    let mut t = group[0].clone();
    for b in &group[1..] {
        t.merge(b);
    }
    t
}

/// A link argument's observed range `[lo, hi]` and power sums `Σ z^k` over `zs`, in order:
/// the sums read once, added to in registers, and written back. Each value's powers are
/// the running products `1, z, z·z, …` and each sum takes the values in turn, as one
/// value at a time would; [`OBSERVE_LANES`] values' products are formed side by side.
#[inline]
fn observe(lo: &mut f64, hi: &mut f64, sums: &mut [f64; OBSERVED_POWERS], zs: impl Iterator<Item = f64>) {
    let (mut l, mut h, mut s) = (*lo, *hi, *sums);
    let mut z = [0.0; OBSERVE_LANES];
    let mut m = 0;
    for x in zs {
        z[m] = x;
        m += 1;
        if m == OBSERVE_LANES {
            observe_lanes(&mut l, &mut h, &mut s, &z);
            m = 0;
        }
    }
    for &x in &z[..m] {
        observe_lanes(&mut l, &mut h, &mut s, &[x]);
    }
    (*lo, *hi, *sums) = (l, h, s);
}

/// Values whose powers [`observe`] forms side by side.
const OBSERVE_LANES: usize = 8;

/// [`observe`] of the values `z`, in order: every value's powers formed first, side by
/// side, then added to each sum value by value. The range takes a value below its low
/// end or above its high end (a NaN never; as `f64::min` and `max` but for which zero of
/// `±0` a tie keeps).
#[inline(always)]
fn observe_lanes<const N: usize>(lo: &mut f64, hi: &mut f64, sums: &mut [f64; OBSERVED_POWERS], z: &[f64; N]) {
    for &x in z {
        if x < *lo {
            *lo = x;
        }
        if x > *hi {
            *hi = x;
        }
    }
    let mut p = [[1.0; N]; OBSERVED_POWERS];
    for k in 1..OBSERVED_POWERS {
        for i in 0..N {
            p[k][i] = p[k - 1][i] * z[i];
        }
    }
    for (s, pk) in sums.iter_mut().zip(&p) {
        for &x in pk {
            *s += x;
        }
    }
}

impl super::accumulate::Accumulator for StationaryData {
    fn push(&mut self, s: &super::accumulate::Sample) {
        StationaryData::push(self, s.trajectory, s.t, s.row)
    }
    fn push_all(&mut self, samples: &super::accumulate::Samples) {
        self.push_run(samples)
    }
    fn finish(&mut self) {
        StationaryData::finish(self)
    }
}

#[cfg(test)]
mod tests {
    use super::{ceil_index, observe, OBSERVED_POWERS};

    /// The link's range and power sums over a run, its values' powers formed eight side by
    /// side, are those of one value at a time (the code before), bit for bit, for runs of
    /// every length around the lanes' width.
    #[test]
    fn a_runs_power_sums_are_those_of_one_value_at_a_time() {
        let mut state = 0x9e3779b97f4a7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 7.0
        };
        for n in [0, 1, 7, 8, 9, 16, 23, 100] {
            let mut zs: Vec<f64> = (0..n).map(|_| next()).collect();
            if n == 23 {
                // A value that is not a number leaves the range alone and poisons the sums.
                zs[11] = f64::NAN;
            }
            let start = [0.25; OBSERVED_POWERS];
            let (mut lo, mut hi, mut sums) = (f64::INFINITY, f64::NEG_INFINITY, start);
            observe(&mut lo, &mut hi, &mut sums, zs.iter().copied());
            let (mut lo1, mut hi1, mut sums1) = (f64::INFINITY, f64::NEG_INFINITY, start);
            for &z in &zs {
                lo1 = lo1.min(z);
                hi1 = hi1.max(z);
                let mut zk = 1.0;
                for s in sums1.iter_mut() {
                    *s += zk;
                    zk *= z;
                }
            }
            assert_eq!(
                (lo.to_bits(), hi.to_bits()),
                (lo1.to_bits(), hi1.to_bits()),
                "{n} values"
            );
            assert_eq!(sums.map(f64::to_bits), sums1.map(f64::to_bits), "{n} values");
        }
    }

    #[test]
    fn ceil_index_is_the_library_ceiling_cast_for_every_kind_of_value() {
        let mut xs = vec![
            0.0,
            -0.0,
            -0.5,
            -1.0,
            -7.25,
            0.5,
            1.0,
            1.0 + f64::EPSILON,
            1.0 - f64::EPSILON / 2.0,
            127.999_999_999,
            128.0,
            4503599627370495.5,
            9007199254740993.0,
            1e300,
            f64::MIN_POSITIVE,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        // A sample's window position `t / T · windows` over a record, as the batching forms it.
        let (record, windows) = (5000.0, 128usize);
        xs.extend((0..=50_000).map(|k| k as f64 * 0.1 / record * windows as f64));
        for x in xs {
            assert_eq!(ceil_index(x), x.ceil() as usize, "x = {x:e}");
        }
    }
}

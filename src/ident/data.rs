//! Streaming statistics of stationary samples for identification: raw moments per fine
//! batch (their sum is the whole record's; their spread weights the weak form), and each
//! link's observed ranges of relative displacement and velocity (3.16)–(3.17). Fed one
//! sample at a time from any source (a log reader, the simulator), in constant memory.

use super::moments::RawMoments;
use super::Problem;

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
/// is one of [`TRAJECTORY_GROUPS`] groups of trajectories (trajectory mod groups) over one
/// of [`TIME_WINDOWS`] consecutive time windows: groups are independent, and windows are
/// long enough to be nearly so even for short records.
pub const FINE_BATCHES: usize = TRAJECTORY_GROUPS * TIME_WINDOWS;
pub const TRAJECTORY_GROUPS: usize = 8;
pub const TIME_WINDOWS: usize = 128;

/// Moments and ranges of the state, per time batch.
#[derive(Debug, Clone)]
pub struct StationaryData {
    /// Fine batch `g · TIME_WINDOWS + w` holds the samples of trajectories `≡ g` (mod
    /// [`TRAJECTORY_GROUPS`]) with `t` in `[w, w+1) · record_length / TIME_WINDOWS`. Their
    /// sum is the whole record's moments.
    pub fine: Vec<RawMoments>,
    /// Coarse batches for the jackknife's standard errors (groups of consecutive fine
    /// batches: with 8, exactly the trajectory groups; with 32, their quarters).
    coarse: usize,
    record_length: f64,
    columns: Vec<usize>,
    buffer: Vec<f64>,
    ids: Vec<u32>,
    /// Scratch: the buffer sorted by batch.
    sorted: Vec<f64>,
    sorted_ids: Vec<u32>,
    /// Per link: `[u_min, u_max, w_min, w_max]`.
    pub link_ranges: Vec<[f64; 4]>,
    /// Per link: the log columns of `x` and `v` of its first end and of its second (none
    /// for the ground).
    link_columns: Vec<(XvColumns, Option<XvColumns>)>,
}

/// The log columns of `x` and `v` of one mass.
type XvColumns = (usize, usize);

impl StationaryData {
    /// `degree`: highest moment degree; `record_length`: time span of `t` per trajectory;
    /// `batches`: coarse time batches for standard errors.
    pub fn new(problem: &Problem, degree: u32, record_length: f64, batches: usize) -> StationaryData {
        StationaryData::from_accumulator(problem, || accumulator(problem, degree), record_length, batches)
    }

    /// Every raw moment up to `degree` (for several problems over the same state).
    pub fn with_all_moments(problem: &Problem, degree: u32, record_length: f64, batches: usize) -> StationaryData {
        let d = problem.dim();
        StationaryData::from_accumulator(problem, || RawMoments::new(d, degree), record_length, batches)
    }

    fn from_accumulator(
        problem: &Problem,
        make: impl Fn() -> RawMoments,
        record_length: f64,
        batches: usize,
    ) -> StationaryData {
        let d = problem.dim();
        let first = make();
        StationaryData {
            fine: vec![first; FINE_BATCHES],
            coarse: batches.clamp(1, FINE_BATCHES),
            record_length,
            columns: problem.columns.clone(),
            buffer: Vec::with_capacity(BLOCK * d),
            ids: Vec::with_capacity(BLOCK),
            sorted: Vec::new(),
            sorted_ids: Vec::new(),
            link_ranges: vec![
                [f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
                problem.model.links()
            ],
            link_columns: (0..problem.model.links())
                .map(|l| {
                    let (a, b) = problem.model.ends(l);
                    let cols = problem.model.columns();
                    ((cols.x(a), cols.v(a)), b.map(|b| (cols.x(b), cols.v(b))))
                })
                .collect(),
        }
    }

    /// The fine batch of a sample of `trajectory` at time `t`.
    fn fine_batch(&self, trajectory: u32, t: f64) -> usize {
        let nw = TIME_WINDOWS;
        let w = ((t / self.record_length * nw as f64).ceil() as usize).clamp(1, nw) - 1;
        (trajectory as usize % TRAJECTORY_GROUPS) * nw + w
    }

    /// The coarse batch (see [`StationaryData::batches`]) of a sample of `trajectory` at
    /// time `t`: other estimators' jackknives use the same batches.
    pub fn batch_of(&self, trajectory: u32, t: f64) -> usize {
        self.fine_batch(trajectory, t) / FINE_BATCHES.div_ceil(self.coarse)
    }

    /// Number of coarse batches.
    pub fn batch_count(&self) -> usize {
        FINE_BATCHES.div_ceil(FINE_BATCHES.div_ceil(self.coarse))
    }

    /// Add one sample (`row`: the log's columns) of `trajectory` taken at time `t` after
    /// burn-in.
    pub fn push(&mut self, trajectory: u32, t: f64, row: &[f64]) {
        let b = self.fine_batch(trajectory, t);
        for &c in &self.columns {
            self.buffer.push(row[c]);
        }
        self.ids.push(b as u32);
        for (l, &((xa, va), b)) in self.link_columns.iter().enumerate() {
            let u = row[xa] - b.map_or(0.0, |(xb, _)| row[xb]);
            let w = row[va] - b.map_or(0.0, |(_, vb)| row[vb]);
            let r = &mut self.link_ranges[l];
            r[0] = r[0].min(u);
            r[1] = r[1].max(u);
            r[2] = r[2].min(w);
            r[3] = r[3].max(w);
        }
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
        let d = self.columns.len();
        let mut start = vec![0usize; FINE_BATCHES + 1];
        for &b in &self.ids {
            start[b as usize + 1] += 1;
        }
        for b in 0..FINE_BATCHES {
            start[b + 1] += start[b];
        }
        self.sorted.resize(self.buffer.len(), 0.0);
        self.sorted_ids.resize(self.ids.len(), 0);
        for (s, &b) in self.ids.iter().enumerate() {
            let at = start[b as usize];
            start[b as usize] += 1;
            self.sorted[at * d..(at + 1) * d].copy_from_slice(&self.buffer[s * d..(s + 1) * d]);
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
        let per = FINE_BATCHES.div_ceil(self.coarse);
        self.fine.chunks(per).map(sum_of).collect()
    }

    /// The jackknife's replicates: per non-empty coarse batch, the moments of the whole
    /// record without it (summed from the others, never subtracted).
    pub fn leave_one_out(&self) -> Vec<RawMoments> {
        let batches: Vec<RawMoments> = self.batches().into_iter().filter(|b| b.count > 0).collect();
        if batches.len() < 2 {
            return Vec::new();
        }
        (0..batches.len())
            .map(|out| {
                let rest: Vec<RawMoments> = batches
                    .iter()
                    .enumerate()
                    .filter(|&(b, _)| b != out)
                    .map(|(_, m)| m.clone())
                    .collect();
                sum_of(&rest)
            })
            .collect()
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

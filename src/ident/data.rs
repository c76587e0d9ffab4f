//! Streaming statistics of stationary samples for identification: raw moments per time
//! batch (their sum is the whole record's), and each link's observed ranges of relative
//! displacement and velocity (3.16)–(3.17). Fed one sample at a time from any source (a
//! log reader, the simulator), in constant memory.

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

/// Moments and ranges of the state, per time batch.
#[derive(Debug, Clone)]
pub struct StationaryData {
    /// Batch `b` holds samples with `t` in `[b, b+1) · record_length / batches` (all
    /// trajectories): consecutive windows far longer than a correlation time, so batch
    /// estimates are nearly independent.
    pub batches: Vec<RawMoments>,
    record_length: f64,
    columns: Vec<usize>,
    buffers: Vec<Vec<f64>>,
    /// Per link: `[u_min, u_max, w_min, w_max]`.
    pub link_ranges: Vec<[f64; 4]>,
    link_ends: Vec<(usize, Option<usize>)>,
}

impl StationaryData {
    /// `degree`: highest moment degree; `record_length`: time span of `t` per trajectory.
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
        StationaryData {
            batches: (0..batches.max(1)).map(|_| make()).collect(),
            record_length,
            columns: problem.columns.clone(),
            buffers: vec![Vec::with_capacity(BLOCK * d); batches.max(1)],
            link_ranges: vec![
                [f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
                problem.link_ends.len()
            ],
            link_ends: problem.link_ends.clone(),
        }
    }

    /// Add one sample (`row`: the log's columns) taken at time `t` after burn-in.
    pub fn push(&mut self, t: f64, row: &[f64]) {
        let nb = self.batches.len();
        let b = ((t / self.record_length * nb as f64).ceil() as usize).clamp(1, nb) - 1;
        let d = self.columns.len();
        let buf = &mut self.buffers[b];
        for &c in &self.columns {
            buf.push(row[c]);
        }
        for (l, &(a, bb)) in self.link_ends.iter().enumerate() {
            // Log columns: x_i = 3i, v_i = 3i + 1.
            let u = row[3 * a] - bb.map_or(0.0, |b| row[3 * b]);
            let w = row[3 * a + 1] - bb.map_or(0.0, |b| row[3 * b + 1]);
            let r = &mut self.link_ranges[l];
            r[0] = r[0].min(u);
            r[1] = r[1].max(u);
            r[2] = r[2].min(w);
            r[3] = r[3].max(w);
        }
        if buf.len() >= BLOCK * d {
            self.batches[b].add_block(buf);
            buf.clear();
        }
    }

    /// Flush buffered samples.
    pub fn finish(&mut self) {
        for (b, buf) in self.buffers.iter_mut().enumerate() {
            if !buf.is_empty() {
                self.batches[b].add_block(buf);
                buf.clear();
            }
        }
    }

    /// Moments of the whole record (the sum of the batches).
    pub fn total(&self) -> RawMoments {
        let mut t = self.batches[0].clone();
        for b in &self.batches[1..] {
            for (a, s) in t.sums.iter_mut().zip(&b.sums) {
                *a += s;
            }
            t.count += b.count;
            for j in 0..t.vars {
                t.min[j] = t.min[j].min(b.min[j]);
                t.max[j] = t.max[j].max(b.max[j]);
            }
        }
        t
    }

    pub fn samples(&self) -> u64 {
        self.batches.iter().map(|b| b.count).sum()
    }
}

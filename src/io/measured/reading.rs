//! One pass over measured data ([`super::Measured::for_each_sample`]): each source's rows
//! read a block ahead and handed on record by record, every record through its own ring of
//! rows (the lagged differences, or the integration's drift windows).
//!
//! A logger's interleaved records (a simulated rig's log holds every trajectory at each
//! instant) would otherwise step a different record's ring and chains at every row, each
//! a cache miss of its own; grouped by record within a block, each record's state stays
//! in cache for the block's rows of it. Each record's samples still come in time order,
//! and every source (a log, a CSV file, a table in memory) is grouped the same way, so the
//! same rows give the same samples in the same order whatever holds them.

use super::{differentiate, integrate, sources, DataError, Measured, Plan, Step};
use crate::io::table::{err, Labels, Source};

/// Rows read ahead before they are handed on record by record: 16,384 rows of a rig's
/// 64 interleaved records give each record 256 rows in a row.
const ROWS_AHEAD: usize = 16_384;

/// Rows of one record integrated at a time ([`SourcePass::integrated_rows`]).
const CHUNK: usize = 64;

/// The reading's settings shared by every source of a pass.
struct Shape<'a> {
    data: &'a Measured,
    /// Rows kept per record: back to the oldest one a lagged difference, or the
    /// integration's displacement, reads (and the integration's chunk).
    ring: usize,
    /// The largest lag of a derived column.
    lag: usize,
    stencils: Vec<Vec<f64>>,
}

/// One source's reading state, per slot (a record of the source): its rows so far, its
/// current piece and the rows before it, its ring of rows and its integration chains.
struct SourcePass<'a> {
    shape: &'a Shape<'a>,
    plan: &'a Plan,
    chains: Vec<Vec<integrate::Chain>>,
    seen: Vec<usize>,
    piece: Vec<(usize, usize)>,
    rings: Vec<f64>,
    handed: u64,
}

/// Rows read ahead: their values (the plan's wanted columns), their row numbers and slots.
struct Ahead {
    width: usize,
    values: Vec<f64>,
    rows: Vec<(usize, usize)>,
    counts: Vec<usize>,
    order: Vec<usize>,
}

impl Ahead {
    fn new(width: usize, slots: usize) -> Ahead {
        Ahead {
            width,
            values: Vec::with_capacity(ROWS_AHEAD * width),
            rows: Vec::with_capacity(ROWS_AHEAD),
            counts: vec![0; slots + 1],
            order: vec![0; ROWS_AHEAD],
        }
    }

    fn push(&mut self, r: usize, slot: usize, v: &[f64]) {
        self.values.extend_from_slice(v);
        self.rows.push((r, slot));
    }

    fn full(&self) -> bool {
        self.rows.len() == ROWS_AHEAD
    }

    /// Hand the rows on record by record (each record's in their order; a counting sort
    /// by slot), then forget them. `Some(r)`: row `r` is past its record's end (the file
    /// changed since the scan).
    fn flush(&mut self, pass: &mut SourcePass, f: &mut dyn FnMut(u32, f64, &[f64])) -> Option<usize> {
        let n = self.rows.len();
        self.counts.fill(0);
        for &(_, slot) in &self.rows {
            self.counts[slot + 1] += 1;
        }
        for s in 1..self.counts.len() {
            self.counts[s] += self.counts[s - 1];
        }
        for (i, &(_, slot)) in self.rows.iter().enumerate() {
            self.order[self.counts[slot]] = i;
            self.counts[slot] += 1;
        }
        // Now `counts[slot]` is where the slot's rows end in `order`.
        let (mut changed, mut start) = (None, 0);
        for slot in 0..self.counts.len() - 1 {
            let run = &self.order[start..self.counts[slot]];
            start = self.counts[slot];
            if run.is_empty() {
                continue;
            }
            if let Some(q) = pass.rows(slot, run, (&self.values, self.width), f) {
                changed = Some(self.rows[run[q]].0);
                break;
            }
        }
        debug_assert!(changed.is_some() || start == n);
        self.values.clear();
        self.rows.clear();
        changed
    }
}

impl<'a> SourcePass<'a> {
    fn new(shape: &'a Shape<'a>, plan: &'a Plan) -> SourcePass<'a> {
        let (data, slots) = (shape.data, plan.pieces.len());
        let chains = match &data.integrate {
            Some(i) => {
                let chain = integrate::Chain::new(data.sample_interval, i.half, i.samples);
                vec![vec![chain; i.masses.len()]; slots]
            }
            None => Vec::new(),
        };
        SourcePass {
            shape,
            plan,
            chains,
            seen: vec![0; slots],
            piece: vec![(0, 0); slots],
            rings: vec![f64::NAN; slots * shape.ring * data.width],
            handed: 0,
        }
    }

    /// Where slot `slot`'s next row goes: its place in its piece, the piece's length and
    /// its trajectory (the next piece's once one is complete); `None` past the last piece.
    fn place(&mut self, slot: usize) -> Option<(usize, usize, u32)> {
        let (first, lens) = &self.plan.pieces[slot];
        let (p, before) = &mut self.piece[slot];
        if self.seen[slot] - *before == lens[*p] {
            *before += lens[*p];
            *p += 1;
            if *p == lens.len() {
                return None;
            }
        }
        Some((self.seen[slot] - *before, lens[*p], first + *p as u32))
    }

    /// Whether every slot got the rows the scan found.
    fn complete(&self) -> bool {
        (0..self.seen.len()).all(|s| self.seen[s] == self.plan.pieces[s].1.iter().sum::<usize>())
    }

    /// Take slot `slot`'s next rows, `run` (indices into `values`, `width` each), handing
    /// on every sample they complete; `Some(q)`: `run[q]` is past the slot's last piece.
    fn rows(
        &mut self,
        slot: usize,
        run: &[usize],
        (values, width): (&[f64], usize),
        f: &mut dyn FnMut(u32, f64, &[f64]),
    ) -> Option<usize> {
        if self.shape.data.integrate.is_some() {
            return self.integrated_rows(slot, run, (values, width), f);
        }
        run.iter()
            .position(|&i| !self.row(slot, &values[i * width..(i + 1) * width], f))
    }

    /// [`SourcePass::rows`] where velocities and displacements are integrated from
    /// accelerations: up to [`CHUNK`] rows at a time, each chain stepped over all of them
    /// before the next (its running sums the only dependence from row to row, so the rows'
    /// steps overlap in the CPU), then their samples handed on. The ring holds the chunk
    /// beside the drift windows' margin; the samples and their order are those of stepping
    /// row by row.
    fn integrated_rows(
        &mut self,
        slot: usize,
        run: &[usize],
        (values, width): (&[f64], usize),
        f: &mut dyn FnMut(u32, f64, &[f64]),
    ) -> Option<usize> {
        let Shape { data, ring, .. } = *self.shape;
        let i = data.integrate.as_ref().expect("integrated");
        let (w, h, m) = (data.width, data.sample_interval, i.margin());
        let mut k = 0;
        while k < run.len() {
            let Some((pos0, len, trajectory)) = self.place(slot) else {
                return Some(k);
            };
            let take = (run.len() - k).min(len - pos0).min(CHUNK);
            let rows = &mut self.rings[slot * ring * w..(slot + 1) * ring * w];
            // Ring places advance by one and wrap: no division per row (the ring is the
            // margin plus a chunk, not a power of two).
            let next = |at: usize| if at + 1 == ring { 0 } else { at + 1 };
            let mut at = pos0 % ring;
            for &r in &run[k..k + take] {
                self.plan
                    .fill(&mut rows[at * w..(at + 1) * w], &values[r * width..(r + 1) * width]);
                at = next(at);
            }
            for (chain, &(x, v, a)) in self.chains[slot].iter_mut().zip(&i.masses) {
                if pos0 == 0 {
                    chain.reset();
                }
                // The places of row `pos`, of its velocity's row `pos − m/2` and of its
                // displacement's `pos − m` (wrapped; not written until `pos` reaches them).
                let mut at = pos0 % ring;
                let mut at_v = (pos0 + ring - (m / 2) % ring) % ring;
                let mut at_x = (pos0 + ring - m % ring) % ring;
                for _ in 0..take {
                    let (vv, xx) = chain.push(rows[at * w + a]);
                    if let Some(vv) = vv {
                        rows[at_v * w + v] = vv;
                    }
                    if let Some(xx) = xx {
                        rows[at_x * w + x] = xx;
                    }
                    (at, at_v, at_x) = (next(at), next(at_v), next(at_x));
                }
            }
            // Row `pos − m`, its velocity and displacement ready, once it is `m` rows from
            // the record's start; its time counted from the first such.
            let first = pos0.max(2 * m);
            let mut at = (first + ring - m % ring) % ring;
            for s in (first..pos0 + take).map(|pos| pos - m) {
                f(trajectory, (s - m + 1) as f64 * h, &rows[at * w..(at + 1) * w]);
                at = next(at);
                self.handed += 1;
            }
            self.seen[slot] += take;
            k += take;
        }
        None
    }

    /// Take the next row `v` of slot `slot` (its motion derived by differences, or
    /// measured), handing on every sample it completes; false if the slot's pieces are
    /// already complete.
    fn row(&mut self, slot: usize, v: &[f64], f: &mut dyn FnMut(u32, f64, &[f64])) -> bool {
        let Shape { data, ring, lag, .. } = *self.shape;
        let (w, h) = (data.width, data.sample_interval);
        let Some((pos, len, trajectory)) = self.place(slot) else {
            return false;
        };
        self.seen[slot] += 1;
        let rows = &mut self.rings[slot * ring * w..(slot + 1) * ring * w];
        let at = pos % ring;
        self.plan.fill(&mut rows[at * w..(at + 1) * w], v);
        let handed = &mut self.handed;
        let mut emit = |s: usize, rows: &[f64]| {
            f(
                trajectory,
                (s + 1) as f64 * h,
                &rows[(s % ring) * w..(s % ring + 1) * w],
            );
            *handed += 1;
        };
        if data.derive.is_empty() {
            emit(pos, rows);
            return true;
        }
        for (s, stencil) in data.derive.iter().zip(&self.shape.stencils) {
            if pos >= s.lag {
                super::difference(rows, ring, w, h, *s, stencil, pos - s.lag, len);
            }
        }
        if pos + 1 < len {
            if pos >= lag {
                emit(pos - lag, rows);
            }
            return true;
        }
        // The record's (or piece's) last row: the lagged differences one-sided.
        for (s, stencil) in data.derive.iter().zip(&self.shape.stencils) {
            for q in (pos + 1).saturating_sub(s.lag)..=pos {
                super::difference(rows, ring, w, h, *s, stencil, q, len);
            }
        }
        for q in pos.saturating_sub(lag)..=pos {
            emit(q, rows);
        }
        true
    }
}

impl Plan {
    /// A row of the layout from a table row `v` (the wanted columns): each mapped value
    /// offset and scaled, NaN where the data hold nothing.
    fn fill(&self, row: &mut [f64], v: &[f64]) {
        row.fill(f64::NAN);
        for (&(k, scale, offset), x) in self.mapped.iter().zip(v) {
            row[k] = (x - offset) * scale;
        }
    }
}

/// [`Measured::for_each_sample`]'s pass; `ahead`: each file decoded on a thread of its own
/// ([`Source::for_each_row_ahead`]).
pub(super) fn for_each_sample(
    data: &Measured,
    f: &mut dyn FnMut(u32, f64, &[f64]),
    ahead: bool,
) -> Result<u64, DataError> {
    let lag = data.derive.iter().map(|s: &Step| s.lag).max().unwrap_or(0);
    let ring = match &data.integrate {
        Some(i) => i.margin() + CHUNK,
        None => data.derive.iter().map(|s| s.lag + s.half).max().unwrap_or(0).max(lag) + 1,
    };
    let stencils = data
        .derive
        .iter()
        .map(|s| differentiate::stencil(s.half, s.exact, s.second.is_some()))
        .collect();
    let shape = Shape {
        data,
        ring,
        lag,
        stencils,
    };
    let mut handed = 0u64;
    for (source, plan) in &data.plans {
        let (stopped, changed, pass) = read_source(&shape, (source, ahead), plan, f)?;
        handed += pass.handed;
        if stopped {
            return Ok(handed);
        }
        if let Some(r) = changed.or((!pass.complete()).then_some(usize::MAX)) {
            let at = if r == usize::MAX {
                "rows are missing".to_string()
            } else {
                format!("row {} is new", r + 1)
            };
            return Err(err(
                source.path(),
                format!("the file changed while it was read ({at} since its first reading): read it again"),
            ));
        }
    }
    Ok(handed)
}

/// One source's rows through its pass: whether a stop was requested, the first row found
/// new (the file changed since the scan), and the pass.
fn read_source<'a>(
    shape: &'a Shape<'a>,
    (source, decoded_ahead): (&Source, bool),
    plan: &'a Plan,
    f: &mut dyn FnMut(u32, f64, &[f64]),
) -> Result<(bool, Option<usize>, SourcePass<'a>), DataError> {
    let mut pass = SourcePass::new(shape, plan);
    let mut ahead = Ahead::new(plan.wanted.len(), plan.pieces.len());
    let (mut changed, mut stopped) = (None, false);
    let dense = sources::dense_slots(&plan.slots);
    let mut read = |r: usize, v: &[f64]| {
        if r.is_multiple_of(crate::interrupt::LOOK_EVERY) && crate::interrupt::requested() {
            stopped = true;
            return Ok(false);
        }
        let slot = plan
            .record_at
            .map_or(Some(0), |k| sources::slot_of(dense.as_deref(), &plan.slots, v[k]));
        let Some(slot) = slot else {
            changed = Some(r);
            return Ok(false);
        };
        ahead.push(r, slot, v);
        if ahead.full() {
            changed = ahead.flush(&mut pass, f);
        }
        Ok(changed.is_none())
    };
    let mut labels = Labels::default();
    match decoded_ahead {
        true => source.for_each_row_ahead(&plan.wanted, &mut labels, &mut read)?,
        false => source.for_each_row(&plan.wanted, &mut labels, &mut read)?,
    }
    if !stopped && changed.is_none() {
        changed = ahead.flush(&mut pass, f);
    }
    Ok((stopped, changed, pass))
}

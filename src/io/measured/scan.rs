//! The scan of a measured table: one pass over its rows that checks every value (finite,
//! not constant, no outlier), finds its records (in the order of their ids), their lengths
//! and where their time step changes, and from those the pieces between gaps — keeping
//! nothing row-sized.

use super::{key, GAP, OUTLIER};
use crate::io::table::{err, DataError, Labels, Source};
use crate::scenario::{DataMapping, MAGNITUDE};
use std::collections::HashMap;

/// Places per record where the time step may change (gaps, and where a split record's
/// pieces start) before the time column counts as unevenly sampled.
const STEP_CHANGES: usize = 1 << 20;

/// Values of a column kept for its quartiles (every k-th row, k doubling as the table
/// grows): exact below this many rows, within a fraction of a percent above.
const QUARTILE_SAMPLE: usize = 1 << 19;

/// Record ids below this, whole, find their slot by a table instead of the map (here and
/// in the later passes, `super::sources::dense_slots`).
pub(super) const DENSE_IDS: usize = 1 << 16;

/// A mapped column's checks over the scan: constant, extremes, a sample for its quartiles.
#[derive(Debug, Clone)]
pub(super) struct ColumnScan {
    pub(super) first: f64,
    pub(super) varies: bool,
    /// (value, row) of its smallest and largest values.
    pub(super) low: (f64, usize),
    pub(super) high: (f64, usize),
    pub(super) sample: Vec<f64>,
    pub(super) stride: usize,
}

impl ColumnScan {
    fn new() -> ColumnScan {
        ColumnScan {
            first: f64::NAN,
            varies: false,
            low: (f64::INFINITY, 0),
            high: (f64::NEG_INFINITY, 0),
            sample: Vec::new(),
            stride: 1,
        }
    }

    fn push(&mut self, r: usize, x: f64) {
        if r == 0 {
            self.first = x;
        } else if x != self.first {
            self.varies = true;
        }
        if x < self.low.0 {
            self.low = (x, r);
        }
        if x > self.high.0 {
            self.high = (x, r);
        }
        // The stride is a power of two: a mask, not a division per value.
        if r & (self.stride - 1) == 0 {
            self.sample.push(x);
            if self.sample.len() == QUARTILE_SAMPLE {
                let mut k = 0;
                self.sample.retain(|_| {
                    k += 1;
                    k % 2 == 1
                });
                self.stride *= 2;
            }
        }
    }

    /// The first quartile, the median and the third quartile.
    fn quartiles(&self) -> [f64; 3] {
        let mut sorted = self.sample.clone();
        let n = sorted.len();
        [0.25, 0.5, 0.75].map(|q| {
            *sorted
                .select_nth_unstable_by(((n - 1) as f64 * q) as usize, f64::total_cmp)
                .1
        })
    }
}

/// A run of equal time steps in a record: from its sample `at` (the row `row`, at `time`,
/// the step from `prev`), `count` steps of `step`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Run {
    pub(super) at: usize,
    pub(super) row: usize,
    pub(super) time: f64,
    pub(super) step: f64,
    pub(super) count: usize,
}

/// A record over the scan.
#[derive(Debug, Clone)]
pub(super) struct RecordScan {
    /// Its id: a number, or a text id's number in the labels.
    pub(super) id: f64,
    pub(super) rows: usize,
    /// Per mapped column, the sum of its values and the side of their running mean the
    /// last one lies on.
    pub(super) sums: Vec<f64>,
    pub(super) side: Vec<f64>,
    pub(super) first_time: f64,
    pub(super) last_time: f64,
    pub(super) runs: Vec<Run>,
    /// Its first values of the column the searches for periodic records compare (as many
    /// as the scan was asked to keep).
    pub(super) head: Vec<f64>,
}

/// What a scan of one source found.
pub(super) struct Scanned {
    pub(super) columns: Vec<ColumnScan>,
    /// In the order their rows first appear.
    pub(super) records: Vec<RecordScan>,
    pub(super) slots: HashMap<u64, usize>,
    /// The first steps of the table's first record, for the sample interval.
    pub(super) first_steps: Vec<f64>,
    /// Per mapped column: how often it crosses its record's running mean (for its motion's
    /// period in samples, which needs no units).
    pub(super) crossings: Vec<usize>,
    pub(super) labels: Vec<String>,
}

/// Why a scan stopped at a row, told once the record ids' text is known.
pub(super) enum Stop {
    Interrupted,
    NotFinite { row: usize, at: usize, value: f64 },
    Backwards { row: usize, slot: usize, t: f64, prev: f64 },
    Uneven { row: usize, slot: usize },
}

impl Scanned {
    /// Record id `id`'s slot, a new record (of `m` mapped columns) for a new id. Small
    /// whole ids (a logger's trajectories, a table's record numbers) are found by the table
    /// `dense`, others by the map: a logger's interleaved records change slot at every row.
    fn slot_of(&mut self, id: f64, dense: &mut Vec<usize>, m: usize) -> usize {
        let small = (id >= 0.0 && id < DENSE_IDS as f64 && id.fract() == 0.0).then_some(id as usize);
        if let Some(&slot) = small.and_then(|i| dense.get(i)).filter(|&&slot| slot != usize::MAX) {
            return slot;
        }
        let records = &mut self.records;
        let slot = *self.slots.entry(key(id)).or_insert_with(|| {
            records.push(RecordScan {
                id,
                rows: 0,
                sums: vec![0.0; m],
                side: vec![0.0; m],
                first_time: f64::NAN,
                last_time: f64::NAN,
                runs: Vec::new(),
                head: Vec::new(),
            });
            records.len() - 1
        });
        if let Some(i) = small {
            if dense.len() <= i {
                dense.resize(i + 1, usize::MAX);
            }
            dense[i] = slot;
        }
        slot
    }

    /// How a record is named in a message (`record 3, ` or `record "S0", `; nothing when
    /// the table is one record).
    fn in_record(&self, slot: usize, d: &DataMapping) -> String {
        self.id(slot, d).map_or(String::new(), |id| format!("record {id}, "))
    }

    fn id(&self, slot: usize, d: &DataMapping) -> Option<String> {
        d.record.as_ref()?;
        let id = self.records[slot].id;
        Some(match self.labels.get(id as usize) {
            Some(l) if !self.labels.is_empty() => format!("{l:?}"),
            _ => format!("{id}"),
        })
    }

    /// The slots in the order of their ids (text ids by their text).
    pub(super) fn order(&self) -> Vec<usize> {
        let mut order: Vec<usize> = (0..self.records.len()).collect();
        if self.labels.is_empty() {
            order.sort_by(|&a, &b| self.records[a].id.total_cmp(&self.records[b].id));
        } else {
            order.sort_by(|&a, &b| {
                self.labels[self.records[a].id as usize].cmp(&self.labels[self.records[b].id as usize])
            });
        }
        order
    }
}

/// The table columns a source is read by: the mapped ones, the time, the record.
pub(super) struct Columns {
    pub(super) wanted: Vec<usize>,
    /// Per mapped column: its layout column, scale and name.
    pub(super) mapped: Vec<(usize, f64, String)>,
    pub(super) time_at: Option<usize>,
    pub(super) record_at: Option<usize>,
}

impl Columns {
    pub(super) fn of(source: &Source, d: &DataMapping, names: &[String]) -> Result<Columns, DataError> {
        let mut wanted = Vec::new();
        let mut mapped = Vec::new();
        for (q, c) in &d.columns {
            let k = names.iter().position(|n| n == q).expect("checked by the model file");
            wanted.push(source.column(c, &format!("mapped to {q} in [data.columns]"))?);
            mapped.push((k, d.scale.get(c).copied().unwrap_or(1.0), c.clone()));
        }
        let mut at = |c: &Option<String>, role: &str| -> Result<Option<usize>, DataError> {
            c.as_ref()
                .map(|c| {
                    wanted.push(source.column(c, role)?);
                    Ok(wanted.len() - 1)
                })
                .transpose()
        };
        let time_at = at(&d.time, "the time column, [data] time")?;
        let record_at = at(&d.record, "the record column, [data] record")?;
        Ok(Columns {
            wanted,
            mapped,
            time_at,
            record_at,
        })
    }

    fn name<'a>(&'a self, j: usize, d: &'a DataMapping) -> &'a str {
        match j {
            j if j < self.mapped.len() => &self.mapped[j].2,
            j if Some(j) == self.time_at => d.time.as_deref().unwrap_or(""),
            _ => d.record.as_deref().unwrap_or(""),
        }
    }
}

/// Read `source` once: every value checked, its records and their time steps; with
/// `head = (j, n)`, each record's first `n` values of mapped column `j` kept.
pub(super) fn scan(
    source: &Source,
    c: &Columns,
    d: &DataMapping,
    head: Option<(usize, usize)>,
) -> Result<Scanned, DataError> {
    let m = c.mapped.len();
    let mut s = Scanned {
        columns: vec![ColumnScan::new(); m],
        records: Vec::new(),
        slots: HashMap::new(),
        first_steps: Vec::new(),
        crossings: vec![0; m],
        labels: Vec::new(),
    };
    let mut changes = 0usize;
    let mut stop = None;
    let mut labels = Labels::default();
    let mut dense: Vec<usize> = Vec::new();
    source.for_each_row_ahead(&c.wanted, &mut labels, &mut |r, v| {
        if r % crate::interrupt::LOOK_EVERY == 0 && crate::interrupt::requested() {
            stop = Some(Stop::Interrupted);
            return Ok(false);
        }
        if let Some(at) = v.iter().position(|x| !x.is_finite()) {
            stop = Some(Stop::NotFinite {
                row: r,
                at,
                value: v[at],
            });
            return Ok(false);
        }
        for (col, &x) in s.columns.iter_mut().zip(v) {
            col.push(r, x);
        }
        let id = c.record_at.map_or(0.0, |k| v[k]);
        let slot = s.slot_of(id, &mut dense, m);
        let rec = &mut s.records[slot];
        if let Some((j, _)) = head.filter(|&(_, n)| rec.head.len() < n) {
            rec.head.push(v[j]);
        }
        for (j, x) in v[..m].iter().enumerate() {
            rec.sums[j] += x;
            let side = (x - rec.sums[j] / (rec.rows + 1) as f64).signum();
            if side * rec.side[j] < 0.0 {
                s.crossings[j] += 1;
            }
            rec.side[j] = side;
        }
        if let Some(k) = c.time_at {
            let t = v[k];
            if rec.rows == 0 {
                rec.first_time = t;
            } else {
                let step = t - rec.last_time;
                if step <= 0.0 {
                    stop = Some(Stop::Backwards {
                        row: r,
                        slot,
                        t,
                        prev: rec.last_time,
                    });
                    return Ok(false);
                }
                if slot == 0 && s.first_steps.len() < 1000 {
                    s.first_steps.push(step);
                }
                match rec.runs.last_mut() {
                    Some(run) if (step - run.step).abs() <= 1e-6 * run.step => run.count += 1,
                    _ => {
                        changes += 1;
                        if changes > STEP_CHANGES {
                            stop = Some(Stop::Uneven { row: r, slot });
                            return Ok(false);
                        }
                        rec.runs.push(Run {
                            at: rec.rows,
                            row: r,
                            time: t,
                            step,
                            count: 1,
                        });
                    }
                }
            }
            rec.last_time = t;
        }
        rec.rows += 1;
        Ok(true)
    })?;
    s.labels = labels.names;
    let path = source.path();
    match stop {
        None => Ok(s),
        Some(Stop::Interrupted) => Err(err(path, "stopped: an interrupt was requested")),
        Some(Stop::NotFinite { row, at, value }) => {
            let name = c.name(at, d);
            Err(err(
                path,
                format!("row {}, column {name:?}: {value} (every value must be finite)", row + 1),
            )
            .in_column(name)
            .at_row(row + 1))
        }
        Some(Stop::Backwards { row, slot, t, prev }) => {
            let name = d.time.as_deref().unwrap_or("");
            Err(err(
                path,
                format!(
                    "{}row {}, t = {t} s: the time does not increase (previous {prev} s)",
                    s.in_record(slot, d),
                    row + 1
                ),
            )
            .in_column(name)
            .at_row(row + 1))
        }
        Some(Stop::Uneven { row, slot }) => {
            let name = d.time.as_deref().unwrap_or("");
            Err(err(
                path,
                format!(
                    "{}row {}: the time step changes more than {STEP_CHANGES} times: the samples must be evenly \
                     spaced (with gaps between evenly sampled pieces at most)",
                    s.in_record(slot, d),
                    row + 1
                ),
            )
            .in_column(name)
            .at_row(row + 1))
        }
    }
}

/// No mapped column constant, none whose spread is outside [`MAGNITUDE`], and none with a
/// value over [`OUTLIER`] interquartile ranges
/// from its median (its first row and how many such values found by a second read of
/// that column).
pub(super) fn check_values(source: &Source, c: &Columns, s: &Scanned) -> Result<(), DataError> {
    let path = source.path();
    for (j, col) in s.columns.iter().enumerate() {
        let name = c.mapped[j].2.as_str();
        let rows: usize = s.records.iter().map(|r| r.rows).sum();
        if rows > 1 && !col.varies {
            return Err(err(
                path,
                format!(
                    "column {name:?} is constant ({}): a measured response varies",
                    col.first
                ),
            )
            .in_column(name));
        }
        if rows == 0 {
            continue;
        }
        let [q1, median, q3] = col.quartiles();
        let iqr = q3 - q1;
        let spread = iqr * c.mapped[j].1.abs();
        if iqr > 0.0 && !(MAGNITUDE.0..=MAGNITUDE.1).contains(&spread) {
            return Err(err(
                path,
                format!(
                    "column {name:?}: its middle half spans {:e} (scaled by [data.scale]): the identification's \
                     moments raise the values to powers of 12 and more, which leave the floating-point range for \
                     values outside {:e}…{:e}: give the column a unit of order 1 with [data.scale] (e.g. \
                     {name} = {:e})",
                    sig6(spread),
                    MAGNITUDE.0,
                    MAGNITUDE.1,
                    sig6(c.mapped[j].1 / spread)
                ),
            )
            .in_column(name));
        }
        let distance = |x: f64| (x - median).abs() / iqr;
        if iqr <= 0.0 || (distance(col.low.0) <= OUTLIER && distance(col.high.0) <= OUTLIER) {
            continue;
        }
        let (mut first, mut count) = (None, 0usize);
        source.for_each_row_ahead(&[c.wanted[j]], &mut Labels::default(), &mut |r, v| {
            if distance(v[0]) > OUTLIER {
                first.get_or_insert((r, v[0]));
                count += 1;
            }
            Ok(true)
        })?;
        let Some((row, value)) = first else { continue };
        let d = distance(value);
        return Err(err(
            path,
            format!(
                "row {}, column {name:?}: {value} lies {} interquartile ranges from the column's median ({}; the \
                 middle half within [{}, {}]): a lost decimal point, a logger glitch? {count} value(s) lie over \
                 {OUTLIER} interquartile ranges out, which a stationary response does not reach; correct or remove \
                 them (with `split_gaps = true` the rows around a removed one become records of their own)",
                row + 1,
                if d < 1e4 { format!("{d:.0}") } else { format!("{d:.1e}") },
                sig6(median),
                sig6(q1),
                sig6(q3),
            ),
        )
        .in_column(name)
        .at_row(row + 1));
    }
    Ok(())
}

/// The sample interval from the first steps of a table's first record: their median, to
/// nine digits (a difference of two printed times carries their rounding:
/// 0.10000000000000142 for 0.1).
pub(super) fn interval_of(steps: &[f64]) -> Option<f64> {
    let mut steps = steps.to_vec();
    steps.sort_by(f64::total_cmp);
    let h = *steps.get(steps.len() / 2)?;
    let h = format!("{h:.8e}").parse::<f64>().unwrap_or(h);
    (h > 0.0).then_some(h)
}

/// The pieces of a record (their lengths): the whole record, or with `split` the runs
/// between its time gaps (steps of [`GAP`] sample intervals or more). Refused, naming the
/// record, the row and the time: an uneven step, a gap when not splitting.
pub(super) fn pieces(
    source: &Source,
    s: &Scanned,
    slot: usize,
    d: &DataMapping,
    h: f64,
    notes: &mut Vec<String>,
) -> Result<Vec<usize>, DataError> {
    let rec = &s.records[slot];
    // Where each piece starts: its first sample, its time, the step (gap) before it.
    let mut starts: Vec<(usize, f64, f64)> = vec![(0, rec.first_time, 0.0)];
    for run in &rec.runs {
        if (run.step - h).abs() <= 1e-6 * h {
            continue;
        }
        let at = |what: String| {
            err(
                source.path(),
                format!(
                    "{}row {}, t = {} s: {what}",
                    s.in_record(slot, d),
                    run.row + 1,
                    run.time
                ),
            )
            .in_column(d.time.as_deref().unwrap_or(""))
            .at_row(run.row + 1)
        };
        let (dt, h) = (sig6(run.step), sig6(h));
        if dt < GAP * h {
            return Err(at(format!(
                "time step {dt} s where the sampling is every {h} s: the samples must be evenly spaced"
            )));
        }
        if !d.split_gaps {
            return Err(at(format!(
                "a gap of {dt} s where the sampling is every {h} s; set `split_gaps = true` in [data] to make \
                 each piece between gaps a record of its own (or split it with the record column)"
            )));
        }
        for k in 0..run.count {
            starts.push((run.at + k, run.time + k as f64 * run.step, run.step));
        }
    }
    let mut lengths: Vec<usize> = starts.windows(2).map(|w| w[1].0 - w[0].0).collect();
    lengths.push(rec.rows - starts.last().expect("a start").0);
    if lengths.len() > 1 {
        let shown: Vec<String> = (0..lengths.len().min(6))
            .map(|k| {
                let a = starts[k].1;
                let b = starts.get(k + 1).map_or(rec.last_time, |next| next.1 - next.2);
                format!(
                    "piece {} from t = {} s, {} samples ({} s)",
                    k + 1,
                    sig6(a),
                    lengths[k],
                    sig6(b - a)
                )
            })
            .collect();
        notes.push(format!(
            "{} split at {} time gap(s) into {} records: {}{}",
            s.id(slot, d)
                .map_or("the record".to_string(), |id| format!("record {id}")),
            lengths.len() - 1,
            lengths.len(),
            shown.join("; "),
            if lengths.len() > 6 { "; …" } else { "" }
        ));
    }
    Ok(lengths)
}

/// `x` to six significant digits: a time difference's rounding in the last bits is no
/// news to a reader.
pub(super) fn sig6(x: f64) -> f64 {
    format!("{x:.5e}").parse::<f64>().unwrap_or(x)
}

//! Dead stretches: a column that holds one value, exactly, over a long stretch of a record
//! — a sensor that stopped, a cable that came loose on a logger that repeats its last
//! reading, a channel exported as zeros for one run. The table's own check refuses a
//! column constant over the whole table; this one finds the stretch inside one record of
//! many (a velocity dead in one run of four moves the estimates by ten standard errors
//! and more, and no other check sees it).
//!
//! A stretch counts when it lasts [`MIN_SAMPLES`] samples and [`MIN_SHARE`] of its record
//! and its value is not the column's least or greatest (those are clipping, which the
//! sensor correction counts). A continuous random response sampled at any resolution
//! does not repeat a value that long away from its extremes: a coarse converter at a
//! thousand samples per period holds one code for a few percent of a period at a peak.

use super::SampleCheck;
use crate::ident::accumulate::{Accumulator, Sample};

/// Least length of a dead stretch, in samples.
pub(crate) const MIN_SAMPLES: usize = 200;

/// Least length of a dead stretch as a share of its record.
pub(crate) const MIN_SHARE: f64 = 0.05;

/// A run of equal values: its value, first time and length.
#[derive(Debug, Clone, Copy)]
struct Run {
    value: f64,
    start: f64,
    len: usize,
}

/// Per record and column, the longest run of one value; per column, its extremes.
pub(crate) struct DeadStretches {
    width: usize,
    /// Per record: its samples, and per column the current and the longest run.
    records: Vec<(usize, Vec<(Run, Run)>)>,
    low: Vec<f64>,
    high: Vec<f64>,
}

impl DeadStretches {
    pub(crate) fn new(width: usize) -> DeadStretches {
        DeadStretches {
            width,
            records: Vec::new(),
            low: vec![f64::INFINITY; width],
            high: vec![f64::NEG_INFINITY; width],
        }
    }
}

impl Accumulator for DeadStretches {
    fn push(&mut self, s: &Sample) {
        let r = s.trajectory as usize;
        if self.records.len() <= r {
            let empty = Run {
                value: f64::NAN,
                start: 0.0,
                len: 0,
            };
            self.records.resize(r + 1, (0, vec![(empty, empty); self.width]));
        }
        let (count, runs) = &mut self.records[r];
        *count += 1;
        for (j, (&x, (current, longest))) in s.row.iter().zip(runs.iter_mut()).enumerate() {
            if x == current.value {
                current.len += 1;
            } else {
                *current = Run {
                    value: x,
                    start: s.t,
                    len: 1,
                };
            }
            if current.len > longest.len {
                *longest = *current;
            }
            self.low[j] = self.low[j].min(x);
            self.high[j] = self.high[j].max(x);
        }
    }
}

impl SampleCheck for DeadStretches {
    fn name(&self) -> &'static str {
        "dead stretch"
    }

    fn findings(&self, columns: &[String]) -> Vec<String> {
        let mut found = Vec::new();
        for (r, (count, runs)) in self.records.iter().enumerate() {
            for (j, (_, run)) in runs.iter().enumerate() {
                let extreme = run.value == self.low[j] || run.value == self.high[j];
                if extreme || run.len < MIN_SAMPLES || (run.len as f64) < MIN_SHARE * *count as f64 {
                    continue;
                }
                found.push(format!(
                    "{} holds {} for {} samples ({:.0} % of record {}) from t = {} s of the record on: a \
                     stopped sensor, a loose cable on a logger that repeats its last reading, or a run exported \
                     as a constant; a random response does not stand still away from its extremes. Remove the \
                     record or its stretch (with `split_gaps = true` the rows around removed ones become records \
                     of their own)",
                    columns.get(j).map_or("?", String::as_str),
                    run.value,
                    run.len,
                    100.0 * run.len as f64 / *count as f64,
                    r + 1,
                    run.start
                ));
            }
        }
        found
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `records` of `n` samples of two columns, a sine and a cosine of incommensurate
    /// frequency, with `dead(record, k)` holding column 1 at 0.25.
    fn scan(records: u32, n: usize, dead: impl Fn(u32, usize) -> bool) -> Vec<String> {
        let mut check = DeadStretches::new(2);
        for r in 0..records {
            for k in 0..n {
                let t = 0.01 * k as f64;
                let v = if dead(r, k) { 0.25 } else { (1.3 * t + r as f64).cos() };
                check.push(&Sample {
                    trajectory: r,
                    t,
                    batch: 0,
                    row: &[(t * 2.0f64.sqrt()).sin(), v],
                });
            }
        }
        check.findings(&["x_m1".into(), "v_m1".into()])
    }

    #[test]
    fn a_column_dead_in_one_record_of_four_is_named_with_its_record_and_time() {
        let found = scan(4, 5000, |r, k| r == 2 && (1000..1600).contains(&k));
        assert_eq!(found.len(), 1, "{found:?}");
        assert!(
            found[0].starts_with("v_m1 holds 0.25 for 600 samples (12 % of record 3) from t = 10 s of the record on"),
            "{}",
            found[0]
        );
    }

    #[test]
    fn short_stretches_and_clipped_extremes_are_not_dead() {
        // 150 samples: under the least length.
        assert!(scan(4, 5000, |r, k| r == 1 && (0..150).contains(&k)).is_empty());
        // 240 of 5000 samples: under the least share.
        assert!(scan(4, 5000, |r, k| r == 1 && (0..240).contains(&k)).is_empty());
        // A stretch at the column's greatest value is clipping.
        assert!(one_column((0..5000).map(|k| (0.013 * k as f64).sin().min(0.9))).is_empty());
    }

    /// The findings on one record of one column.
    fn one_column(values: impl Iterator<Item = f64>) -> Vec<String> {
        let mut check = DeadStretches::new(1);
        for (k, x) in values.enumerate() {
            check.push(&Sample {
                trajectory: 0,
                t: k as f64,
                batch: 0,
                row: &[x],
            });
        }
        check.findings(&["x".into()])
    }

    #[test]
    fn a_quantised_slow_response_is_not_dead() {
        // An 8-bit converter at a thousand samples per period: one code holds for a few
        // percent of a period at each peak.
        let values = (0..200_000).map(|k| {
            let phase = std::f64::consts::TAU * k as f64 / 1000.0;
            (phase.sin() * (1.0 + 0.3 * (0.001 * phase).sin()) * 127.0).round() / 127.0
        });
        assert!(one_column(values).is_empty());
    }
}

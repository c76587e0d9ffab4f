//! Clipped accelerations and forces: samples that pile up at a channel's largest or
//! smallest value — an accelerometer or a force cell beyond its range, an amplifier or a
//! converter at its rail, whether the clipped values repeat exactly or jitter by the
//! converter's last bits. The sensor-noise estimate counts such pile-ups on displacements
//! and velocities (their `at_limits`); this check covers the measured accelerations and
//! forces, which no noise estimate reads, and runs whether or not anything else does.
//!
//! Per column, the [`Tail::KEPT`] largest and smallest values are kept with the column's
//! sums: a continuous random record's next-to-largest value lies tenths of a standard
//! deviation below its largest, so a full tail within [`PILE_UP`] standard deviations of
//! the extreme is a limit, not the signal's tail (the rule of the noise estimate's
//! count).

use super::SampleCheck;
use crate::ident::accumulate::{Accumulator, Sample};
use crate::ident::noise::{Tail, PILE_UP};

/// One column's sums and tails.
#[derive(Debug, Clone)]
struct Column {
    at: usize,
    n: f64,
    sum: f64,
    squares: f64,
    /// The largest values, and the largest of the negated (the smallest).
    tails: [Tail; 2],
}

/// The pile-up check of some columns.
pub(crate) struct PileUps {
    columns: Vec<Column>,
}

impl PileUps {
    /// The check of `input`'s measured (not derived) accelerations and forces.
    pub(crate) fn of(input: &crate::pipeline::Input, data: &crate::io::table::Measured) -> PileUps {
        let scenario = &input.info.scenario;
        let layout = crate::model::Model::new(scenario).columns();
        let measured = |c: usize| data.present.get(c).copied().unwrap_or(false) && !data.derived(c);
        let candidates = (0..scenario.masses.len())
            .map(|i| layout.a(i))
            .chain((0..scenario.excitations.len()).map(|e| layout.force(e)));
        PileUps::new(candidates.filter(|&c| measured(c)).collect())
    }

    /// The check of the columns `at`.
    pub(crate) fn new(at: Vec<usize>) -> PileUps {
        let column = |at| Column {
            at,
            n: 0.0,
            sum: 0.0,
            squares: 0.0,
            tails: [Tail::new(), Tail::new()],
        };
        PileUps {
            columns: at.into_iter().map(column).collect(),
        }
    }
}

impl Accumulator for PileUps {
    fn push(&mut self, s: &Sample) {
        for c in &mut self.columns {
            let y = s.row[c.at];
            if !y.is_finite() {
                continue;
            }
            c.n += 1.0;
            c.sum += y;
            c.squares += y * y;
            c.tails[0].push(y);
            c.tails[1].push(-y);
        }
    }
}

impl SampleCheck for PileUps {
    fn name(&self) -> &'static str {
        "clipping"
    }

    fn findings(&self, columns: &[String]) -> Vec<String> {
        let mut found = Vec::new();
        for c in &self.columns {
            let std = (c.squares / c.n - (c.sum / c.n).powi(2)).max(0.0).sqrt();
            if std.is_nan() || std <= 0.0 {
                continue;
            }
            let sides: Vec<&str> = ["largest", "smallest"]
                .into_iter()
                .zip(&c.tails)
                .filter(|(_, tail)| tail.near_top(PILE_UP * std) == Tail::KEPT as u64)
                .map(|(side, _)| side)
                .collect();
            if sides.is_empty() {
                continue;
            }
            found.push(format!(
                "{} piles up at its {} value ({} samples or more within {PILE_UP} of its std, {std:.4e}): a sensor, \
                 amplifier or converter clipped at its range, which biases every moment and which no correction \
                 undoes: measure with a range that holds the signal (docs/measurement.md)",
                columns.get(c.at).map_or("?", String::as_str),
                sides.join(" and "),
                Tail::KEPT
            ));
        }
        found
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A random signal (a sum of incommensurate sines with a pseudo-random phase walk),
    /// clipped at `limit` times its amplitude scale with a jitter of `jitter`: the findings.
    fn scan(limit: f64, jitter: f64) -> Vec<String> {
        let mut check = PileUps::new(vec![0]);
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let mut uniform = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for k in 0..100_000 {
            let t = 0.01 * k as f64;
            let y = (1.3 * t).sin() + 0.7 * (2.9 * t + 0.4).sin() + 0.5 * (5.3 * t + 1.1).cos() + 0.3 * uniform();
            let y = if y > limit {
                limit + jitter * (uniform() - 0.5)
            } else {
                y
            };
            check.push(&Sample {
                trajectory: 0,
                t,
                batch: 0,
                row: &[y],
            });
        }
        check.findings(&["a_m1".into()])
    }

    #[test]
    fn a_clipped_acceleration_is_named_whether_its_limit_repeats_or_jitters() {
        assert!(scan(f64::INFINITY, 0.0).is_empty(), "{:?}", scan(f64::INFINITY, 0.0));
        for jitter in [0.0, 1e-4] {
            let found = scan(1.2, jitter);
            assert_eq!(found.len(), 1, "{found:?}");
            assert!(
                found[0].starts_with("a_m1 piles up at its largest value"),
                "{}",
                found[0]
            );
        }
    }
}

//! Periods end to end in one record: a rig that measures a multisine over several of its
//! periods without a break hands them over as one record. Found by the force's
//! autocorrelation (a period of at least [`LEAST_COMPARED`] samples at which the force
//! repeats itself to 0.9 after falling below 0.5 within the period, and again at twice it
//! where the record holds three), each such record is cut into its whole periods, the
//! leading remainder dropped as the transient, and the periods become records of their own
//! — which the averaging of repeated records ([`super::periods`]) then finds to be one
//! realisation and averages (docs/data.md, "Periodic records").
//!
//! Only a measured force is looked at: a lightly damped response repeats itself nearly as
//! well over a few of its own periods, a shaker's signal does not unless it is periodic.
//! Tables without a record column are left as they are (the cut pieces need one).

use super::periods::{compared_force, Record, LEAST_COMPARED};
use super::{DataError, Labels, Source};
use crate::io::table::Table;
use crate::scenario::DataMapping;

/// Correlation at the period (and twice it) from which a record repeats one realisation
/// end to end: noise of a third of the signal's std still correlates at 0.9.
pub const REPEATS: f64 = 0.9;

/// Within a period the signal must fall below this correlation with itself: a force that
/// stays correlated over a whole "period" (a slow coloured noise) is not periodic.
const DECORRELATES: f64 = 0.5;

/// A record's first samples of the force looked at for a period.
pub(super) const HEAD: usize = 1 << 16;

/// Bytes of a table held in memory to cut it, at most (8 per value).
const BUDGET: usize = 1 << 30;

/// What was cut.
#[derive(Debug, Clone, PartialEq)]
pub struct Cut {
    /// The table column whose autocorrelation found the period.
    pub column: String,
    /// The period, in samples.
    pub period: usize,
    /// Per record cut: its number (1-based, in the order the tables hold them), the whole
    /// periods it held and the samples dropped before the first.
    pub records: Vec<(usize, usize, usize)>,
    /// The least correlation at the period over the records cut.
    pub correlation: f64,
}

impl Cut {
    pub fn note(&self) -> String {
        let list: Vec<String> = (self.records.iter())
            .map(|(r, k, d)| format!("record {r}: {k} periods, {d} samples dropped"))
            .collect();
        format!(
            "periods end to end: {}'s autocorrelation finds a period of {} samples (correlation {:.4} or more): \
             each record cut into its whole periods, the samples before the first dropped as the transient ({}); \
             the periods are records of their own below (docs/data.md, \"Periodic records\")",
            self.column,
            self.period,
            self.correlation,
            list.join("; ")
        )
    }
}

/// The period of `x` in samples and its correlation there, if `x` repeats itself end to
/// end (see the module's rule).
pub fn period_of(x: &[f64]) -> Option<(usize, f64)> {
    use realfft::RealFftPlanner;
    let n = x.len();
    if n < 2 * LEAST_COMPARED {
        return None;
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let len = (2 * n).next_power_of_two();
    let mut planner = RealFftPlanner::<f64>::new();
    let (fwd, inv) = (planner.plan_fft_forward(len), planner.plan_fft_inverse(len));
    let mut buf = fwd.make_input_vec();
    for (b, &v) in buf.iter_mut().zip(x) {
        *b = v - mean;
    }
    let mut spec = fwd.make_output_vec();
    fwd.process(&mut buf, &mut spec).ok()?;
    for c in spec.iter_mut() {
        *c = realfft::num_complex::Complex::new(c.norm_sqr(), 0.0);
    }
    let mut r = inv.make_output_vec();
    inv.process(&mut spec, &mut r).ok()?;
    // Σ x[i]x[i+lag] over the overlap, normalised by both stretches' energies.
    let mut energy = vec![0.0; n + 1];
    for i in 0..n {
        energy[i + 1] = energy[i] + (x[i] - mean).powi(2);
    }
    let corr = |lag: usize| {
        let (head, tail) = (energy[n - lag], energy[n] - energy[lag]);
        match head > 0.0 && tail > 0.0 {
            true => r[lag] / len as f64 / (head * tail).sqrt(),
            false => 0.0,
        }
    };
    // The shortest lag as good as the best (the best may be a multiple of the period, to
    // rounding), at its local peak.
    let best = (LEAST_COMPARED..=n / 2).map(corr).fold(f64::NEG_INFINITY, f64::max);
    let first = (LEAST_COMPARED..=n / 2).find(|&lag| corr(lag) >= best - 0.01)?;
    let period = (first..=n / 2)
        .take_while(|&lag| lag == first || corr(lag) >= corr(lag - 1))
        .last()?;
    let c = corr(period);
    let decorrelated = (LEAST_COMPARED..period).any(|lag| corr(lag) < DECORRELATES)
        || (1..LEAST_COMPARED.min(period)).any(|lag| corr(lag) < DECORRELATES);
    let again = 2 * period > n - period || corr(2 * period) >= REPEATS;
    (c >= REPEATS && decorrelated && again).then_some((period, c))
}

/// Cut every record of `sources` that repeats one period end to end into its periods (see
/// the module); the sources as they were when none does. `heads`: the sources' records as
/// their scan kept them (`periods::heads_of`: each record's first [`HEAD`] values of the
/// force).
pub(super) fn cut_periods(
    sources: Vec<Source>,
    d: &DataMapping,
    heads: Option<&[Record]>,
) -> Result<(Vec<Source>, Option<Cut>), DataError> {
    let (Some(column), Some(record), Some(heads)) = (compared_force(d), d.record.as_deref(), heads) else {
        return Ok((sources, None));
    };
    let found: Vec<Option<(usize, f64)>> = heads
        .iter()
        .map(|r| {
            r.head
                .iter()
                .all(|v| v.is_finite())
                .then(|| period_of(&r.head))
                .flatten()
        })
        .collect();
    let Some(&(period, _)) = found.iter().flatten().next() else {
        return Ok((sources, None));
    };
    let cut: Vec<usize> = (0..heads.len())
        .filter(|&j| found[j].is_some_and(|(p, _)| p == period) && heads[j].rows / period >= 2)
        .collect();
    if cut.is_empty() {
        return Ok((sources, None));
    }
    // Then every table whole, in memory (up to BUDGET): its columns and each row's record.
    let mut held = 0usize;
    let mut tables: Vec<(Table, Vec<u64>)> = Vec::new();
    for source in &sources {
        let rec = source.column(record, "the record column")?;
        let width = source.names().len();
        let mut columns = vec![Vec::new(); width];
        let mut keys = Vec::new();
        let wanted: Vec<usize> = (0..width).collect();
        let mut labels = Labels::default();
        source.for_each_row_ahead(&wanted, &mut labels, &mut |_, v| {
            for (c, x) in v.iter().enumerate() {
                columns[c].push(*x);
            }
            keys.push((v[rec] + 0.0).to_bits());
            held += 8 * (width + 1);
            Ok(held <= BUDGET)
        })?;
        if held > BUDGET {
            return Ok((sources, None));
        }
        tables.push((
            Table {
                path: source.path().to_path_buf(),
                names: source.names().to_vec(),
                columns,
                record_labels: None,
            },
            keys,
        ));
    }
    // Each record's rows, in the order the heads found them.
    let mut records: Vec<(usize, u64, Vec<usize>)> = heads.iter().map(|r| (r.source, r.key, Vec::new())).collect();
    for (s, (_, keys)) in tables.iter().enumerate() {
        for (row, &k) in keys.iter().enumerate() {
            if let Some(r) = records.iter_mut().find(|(t, key, _)| *t == s && *key == k) {
                r.2.push(row);
            }
        }
    }
    // New record ids, in the order of the records and their periods.
    let mut next = 1.0;
    let mut out: Vec<Table> = tables
        .iter()
        .map(|(t, _)| Table {
            path: t.path.clone(),
            names: t.names.clone(),
            columns: vec![Vec::new(); t.names.len()],
            record_labels: None,
        })
        .collect();
    let mut done = Vec::new();
    for (j, (s, _, rows)) in records.iter().enumerate() {
        let (t, _) = &tables[*s];
        let rec = t.names.iter().position(|n| n == record).expect("read above");
        let (keep, pieces) = match cut.contains(&j) {
            true => {
                let k = rows.len() / period;
                done.push((j + 1, k, rows.len() - k * period));
                (&rows[rows.len() - k * period..], k)
            }
            false => (&rows[..], 1),
        };
        let per = keep.len() / pieces;
        for (i, &row) in keep.iter().enumerate() {
            for (c, col) in t.columns.iter().enumerate() {
                let v = if c == rec { next + (i / per) as f64 } else { col[row] };
                out[*s].columns[c].push(v);
            }
        }
        next += pieces as f64;
    }
    let correlation = cut.iter().filter_map(|&j| found[j].map(|f| f.1)).fold(1.0, f64::min);
    Ok((
        out.into_iter().map(Source::Memory).collect(),
        Some(Cut {
            column: column.to_string(),
            period,
            records: done,
            correlation,
        }),
    ))
}

#[cfg(test)]
mod tests {
    use super::super::periods::tests::noise;
    use super::*;

    /// A period of 300 random samples repeated with 20 % noise is found at 300 (not at
    /// 600), with its correlation; random noise, a slow coloured noise and a lightly
    /// damped oscillator under noise are not periodic.
    #[test]
    fn a_repeated_period_is_found_and_nothing_else_is() {
        let p = noise(1, 300);
        let x: Vec<f64> = (0..1500)
            .map(|i| p[i % 300])
            .zip(noise(2, 1500))
            .map(|(a, e)| a + 0.2 * e)
            .collect();
        let (period, c) = period_of(&x).expect("periodic");
        assert_eq!(period, 300);
        assert!(c > 0.9, "{c}");
        assert_eq!(period_of(&noise(3, 3000)), None);
        // First-order coloured noise, correlation time 2000 samples.
        let mut slow = vec![0.0; 3000];
        let e = noise(4, 3000);
        for i in 1..3000 {
            slow[i] = slow[i - 1] * (1.0 - 1.0 / 2000.0) + e[i];
        }
        assert_eq!(period_of(&slow), None);
        // A lightly damped oscillator (1 % damping, 50 samples a period) under white noise.
        let (theta, e) = (2.0 * std::f64::consts::PI / 50.0, noise(5, 6000));
        let r = (-0.01 * theta).exp();
        let mut ring = vec![0.0; 6000];
        for i in 2..6000 {
            ring[i] = 2.0 * r * theta.cos() * ring[i - 1] - r * r * ring[i - 2] + e[i];
        }
        assert_eq!(period_of(&ring), None);
    }

    /// A table of two records, each four noisy periods of its own realisation after a
    /// transient of 50 samples, and one record of plain noise: the two are cut into four
    /// records each (transient dropped, ids in order), the third left whole.
    #[test]
    fn records_of_periods_end_to_end_are_cut_into_their_periods() {
        let (a, b) = (noise(10, 400), noise(11, 400));
        let periods = |p: &[f64], seed| -> Vec<f64> {
            let mut v = noise(seed + 100, 50);
            v.extend(
                (0..1600)
                    .map(|i| p[i % 400])
                    .zip(noise(seed, 1600))
                    .map(|(x, e)| x + 0.1 * e),
            );
            v
        };
        let recs = [(1.0, periods(&a, 1)), (2.0, periods(&b, 2)), (3.0, noise(12, 1000))];
        let (mut run, mut u, mut t) = (Vec::new(), Vec::new(), Vec::new());
        for (r, v) in &recs {
            run.extend(std::iter::repeat_n(*r, v.len()));
            t.extend((0..v.len()).map(|i| i as f64 * 0.01));
            u.extend(v);
        }
        let table = Table {
            path: "t.csv".into(),
            names: vec!["run".into(), "t".into(), "u".into()],
            columns: vec![run, t, u],
            record_labels: None,
        };
        let d = DataMapping {
            record: Some("run".into()),
            time: Some("t".into()),
            columns: vec![("p_u".into(), "u".into())],
            ..Default::default()
        };
        let sources = vec![Source::Memory(table)];
        let heads = super::super::periods::records(&sources, &d, "u", HEAD).unwrap();
        let (sources, cut) = cut_periods(sources, &d, Some(&heads)).unwrap();
        let cut = cut.expect("cut");
        assert_eq!(cut.period, 400);
        assert_eq!(cut.records, vec![(1, 4, 50), (2, 4, 50)]);
        let Source::Memory(t) = &sources[0] else { panic!() };
        assert_eq!(t.rows(), 2 * 1600 + 1000);
        let ids: Vec<f64> = [0, 399, 400, 1599, 1600, 3199, 3200, 4199]
            .iter()
            .map(|&i| t.columns[0][i])
            .collect();
        assert_eq!(ids, vec![1.0, 1.0, 2.0, 4.0, 5.0, 8.0, 9.0, 9.0]);
        // The periods keep their samples: the first kept one is the record's 51st.
        assert_eq!(t.columns[2][0], recs[0].1[50]);
        assert!(cut.note().contains("a period of 400 samples"), "{}", cut.note());
    }
}

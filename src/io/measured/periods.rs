//! Records that repeat one realisation of a periodic excitation: a multisine measured
//! period by period, each period given as a record. Their samples are not independent
//! draws of the stationary density — they are one draw and its measurement noise, so a
//! jackknife over them would measure the noise, not the sampling variability. They are
//! found by the correlation of their force (else their first mapped column) and averaged
//! period by period, as the field does: the noise drops by the square root of the
//! periods, and each realisation becomes one record (docs/data.md, "Periodic records").
//!
//! This reads the tables as written (before `[data]`'s scale, offsets and derivatives,
//! which are linear and so commute with the average) and hands back in-memory tables of
//! the averaged periods, one per realisation, for `super::measured` to read as any other.

use super::{err, DataError, Labels, Source};
use crate::io::table::Table;
use crate::scenario::DataMapping;

/// Samples of each record compared.
const COMPARED: usize = 4096;

/// Fewest samples a record needs for the comparison to mean anything: two independent
/// Gaussian records of 256 samples correlate beyond [`SAME`] with a chance below 1e-15.
pub(super) const LEAST_COMPARED: usize = 256;

/// Correlation of two records' first samples from which they are one realisation: noise
/// up to the signal's own standard deviation still correlates at 0.5, independent
/// realisations at about `1/√n`.
pub const SAME: f64 = 0.5;

/// Bytes of averaged periods held in memory, at most (8 per value).
const BUDGET: usize = 1 << 30;

/// What was found and done.
#[derive(Debug, Clone, PartialEq)]
pub struct Repeated {
    /// The table column whose correlation was compared.
    pub column: String,
    /// Per realisation of two records or more: the records' numbers (1-based, in the order
    /// the tables hold them).
    pub groups: Vec<Vec<usize>>,
    /// The least correlation within a group, and the largest between two records of
    /// different realisations (0 with none).
    pub within: f64,
    pub between: f64,
    /// Records before and after the averaging.
    pub records: usize,
    pub realisations: usize,
}

impl Repeated {
    /// The note for the report.
    pub fn note(&self) -> String {
        let groups: Vec<String> = self
            .groups
            .iter()
            .map(|g| match g.as_slice() {
                [a, .., b] if b - a + 1 == g.len() => format!("{a}–{b}"),
                _ => g.iter().map(usize::to_string).collect::<Vec<_>>().join(", "),
            })
            .collect();
        let errors = if self.realisations >= 2 {
            "the standard errors come from the realisations' differences"
        } else {
            "one realisation is left: the standard errors come from stretches of its period, \
             whose lines' random phases make it a stretch of stationary noise; they do not \
             measure a new realisation's spread if the phases were not random"
        };
        format!(
            "periodic records: records {} repeat one realisation each (their {}'s correlation {:.4} or more, \
             against {:.3} at most between realisations): averaged period by period, {} records → {} \
             (docs/data.md, \"Periodic records\"); {errors}",
            groups.join("; "),
            self.column,
            self.within,
            self.between,
            self.records,
            self.realisations
        )
    }
}

/// One record of a table, as read: its key, its rows' first values of the compared column
/// and its length.
pub(super) struct Record {
    pub(super) source: usize,
    pub(super) key: u64,
    pub(super) head: Vec<f64>,
    pub(super) rows: usize,
}

/// What the searches compare: the compared table column and how many of each record's
/// first values they look at — the search for periods end to end within a record
/// (`super::period_cut`, which needs a measured force and a record column) looks further
/// than this module's. `None` with nothing to compare.
pub(super) fn compared_head(d: &DataMapping) -> Option<(&str, usize)> {
    let cut_reads = compared_force(d).is_some() && d.record.is_some();
    compared_column(d).map(|c| (c, if cut_reads { super::period_cut::HEAD } else { COMPARED }))
}

/// The records of the sources' scans (each made keeping [`compared_head`]'s values), in
/// the order the tables hold them: the same as reading them anew.
pub(super) fn heads_of(scans: &mut [super::scan::Scanned]) -> Vec<Record> {
    let mut out = Vec::new();
    for (source, scan) in scans.iter_mut().enumerate() {
        out.extend(scan.records.iter_mut().map(|r| Record {
            source,
            key: super::key(r.id),
            head: std::mem::take(&mut r.head),
            rows: r.rows,
        }));
    }
    out
}

/// The records of every source in the order the tables hold them (a record's rows need
/// not be contiguous in its table); `column` the compared table column, `head` the values
/// kept of each.
pub(super) fn records(
    sources: &[Source],
    d: &DataMapping,
    column: &str,
    head: usize,
) -> Result<Vec<Record>, DataError> {
    let mut out: Vec<Record> = Vec::new();
    for (s, source) in sources.iter().enumerate() {
        let compared = source.column(column, "the compared column")?;
        let record = match &d.record {
            Some(r) => Some(source.column(r, "the record column")?),
            None => None,
        };
        let wanted: Vec<usize> = [Some(compared), record].into_iter().flatten().collect();
        // A record key → its entry in `out` (a logger's interleaved records change record
        // at every row).
        let mut index = std::collections::HashMap::new();
        let mut last = usize::MAX;
        source.for_each_row_ahead(&wanted, &mut Labels::default(), &mut |_, v| {
            let key = v.get(1).map_or(0, |&id| (id + 0.0).to_bits());
            let at = if last != usize::MAX && out[last].key == key {
                last
            } else {
                *index.entry(key).or_insert_with(|| {
                    out.push(Record {
                        source: s,
                        key,
                        head: Vec::new(),
                        rows: 0,
                    });
                    out.len() - 1
                })
            };
            last = at;
            let r = &mut out[at];
            if r.head.len() < head {
                r.head.push(v[0]);
            }
            r.rows += 1;
            Ok(true)
        })?;
    }
    Ok(out)
}

/// Correlation of two equally long stretches (0 for a constant one).
fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let (ma, mb) = (a.iter().sum::<f64>() / n as f64, b.iter().sum::<f64>() / n as f64);
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        ab += (x - ma) * (y - mb);
        aa += (x - ma) * (x - ma);
        bb += (y - mb) * (y - mb);
    }
    if aa > 0.0 && bb > 0.0 {
        ab / (aa * bb).sqrt()
    } else {
        0.0
    }
}

/// The column compared: the first measured force's, else the first mapped column's.
fn compared_column(d: &DataMapping) -> Option<&str> {
    compared_force(d).or(d.columns.first().map(|(_, c)| c.as_str()))
}

/// The first measured force's table column.
pub(super) fn compared_force(d: &DataMapping) -> Option<&str> {
    d.columns
        .iter()
        .find(|(log, _)| log.starts_with("p_"))
        .map(|(_, c)| c.as_str())
}

/// Find records that repeat one realisation; when there are, return the tables of their
/// averaged periods (one in-memory table per realisation, a record left alone where it
/// repeats nothing) and what was done, else the sources as they were. `heads`: the
/// sources' records as their scan kept them ([`heads_of`]), else they are read here.
pub(super) fn average_repeated(
    sources: Vec<Source>,
    d: &DataMapping,
    heads: Option<Vec<Record>>,
) -> Result<(Vec<Source>, Option<Repeated>), DataError> {
    let Some(column) = compared_column(d) else {
        return Ok((sources, None));
    };
    // Errors of the tables are the reading's to report (`super::measured`), with their rows.
    let Some(mut recs) = heads.or_else(|| records(&sources, d, column, COMPARED).ok()) else {
        return Ok((sources, None));
    };
    for r in &mut recs {
        r.head.truncate(COMPARED);
    }
    if recs.len() < 2 || recs.iter().any(|r| r.head.iter().any(|x| !x.is_finite())) {
        return Ok((sources, None));
    }
    // Realisations: records of one length whose first samples correlate beyond SAME.
    let mut of: Vec<usize> = (0..recs.len()).collect();
    let (mut within, mut between) = (1.0f64, 0.0f64);
    for j in 1..recs.len() {
        for i in 0..j {
            let (a, b) = (&recs[i], &recs[j]);
            if a.rows != b.rows || a.head.len() < LEAST_COMPARED {
                continue;
            }
            let c = correlation(&a.head, &b.head);
            if c >= SAME {
                if of[j] == j {
                    of[j] = of[i];
                }
                within = within.min(c);
            } else {
                between = between.max(c.abs());
            }
        }
    }
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (j, &g) in of.iter().enumerate() {
        match groups.iter_mut().find(|members| members[0] == g) {
            Some(members) => members.push(j),
            None => groups.push(vec![j]),
        }
    }
    if groups.len() == recs.len() {
        return Ok((sources, None));
    }
    let values: usize = groups
        .iter()
        .map(|g| recs[g[0]].rows * sources[recs[g[0]].source].names().len())
        .sum();
    if values.saturating_mul(8) > BUDGET {
        return Err(err(
            sources[0].path(),
            format!(
                "records repeat one realisation and would be averaged period by period, but their averages take \
                 {:.1} GB (over {:.1} GB): average the periods before (docs/data.md, \"Periodic records\")",
                values as f64 * 8e-9,
                BUDGET as f64 * 1e-9
            ),
        ));
    }
    let tables = averaged(&sources, d, &recs, &groups)?;
    let repeated = Repeated {
        column: column.to_string(),
        groups: groups
            .iter()
            .filter(|g| g.len() >= 2)
            .map(|g| g.iter().map(|j| j + 1).collect())
            .collect(),
        within,
        between,
        records: recs.len(),
        realisations: groups.len(),
    };
    Ok((tables.into_iter().map(Source::Memory).collect(), Some(repeated)))
}

/// Per realisation, a table of its records' average, row by row (every column; the time
/// and record columns are its first record's).
fn averaged(
    sources: &[Source],
    d: &DataMapping,
    recs: &[Record],
    groups: &[Vec<usize>],
) -> Result<Vec<Table>, DataError> {
    let group_of: Vec<usize> = {
        let mut g = vec![0; recs.len()];
        for (k, members) in groups.iter().enumerate() {
            for &j in members {
                g[j] = k;
            }
        }
        g
    };
    let mut tables: Vec<Table> = groups
        .iter()
        .map(|members| {
            let first = &recs[members[0]];
            let source = &sources[first.source];
            Table {
                path: source.path().to_path_buf(),
                names: source.names().to_vec(),
                columns: vec![vec![0.0; first.rows]; source.names().len()],
                record_labels: None,
            }
        })
        .collect();
    // Per record: the rows of it read so far.
    let mut seen = vec![0usize; recs.len()];
    let mut base = 0;
    for (s, source) in sources.iter().enumerate() {
        let width = source.names().len();
        let keep: Vec<usize> = [&d.time, &d.record]
            .into_iter()
            .flatten()
            .filter_map(|c| source.names().iter().position(|n| n == c))
            .collect();
        let record = match &d.record {
            Some(r) => Some(source.column(r, "the record column")?),
            None => None,
        };
        let wanted: Vec<usize> = (0..width).collect();
        let mut labels = Labels::default();
        let mine = recs.iter().filter(|r| r.source == s).count();
        source.for_each_row_ahead(&wanted, &mut labels, &mut |_, v| {
            let key = record.map_or(0, |k| (v[k] + 0.0).to_bits());
            let j = base
                + recs[base..base + mine]
                    .iter()
                    .position(|r| r.key == key)
                    .expect("read before");
            let g = group_of[j];
            let (row, first) = (seen[j], groups[g][0] == j);
            seen[j] += 1;
            let weight = 1.0 / groups[g].len() as f64;
            for (c, x) in v.iter().enumerate() {
                if keep.contains(&c) {
                    if first {
                        tables[g].columns[c][row] = *x;
                    }
                } else {
                    tables[g].columns[c][row] += weight * x;
                }
            }
            Ok(true)
        })?;
        if record.is_some() && !labels.names.is_empty() {
            for (g, members) in groups.iter().enumerate() {
                if recs[members[0]].source == s {
                    tables[g].record_labels = Some(labels.names.clone());
                }
            }
        }
        base += mine;
    }
    Ok(tables)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    fn table(records: &[(f64, Vec<f64>)]) -> Source {
        let (mut id, mut u) = (Vec::new(), Vec::new());
        for (r, values) in records {
            id.extend(std::iter::repeat_n(*r, values.len()));
            u.extend(values);
        }
        Source::Memory(Table {
            path: "t.csv".into(),
            names: vec!["run".into(), "u".into()],
            columns: vec![id, u],
            record_labels: None,
        })
    }

    fn mapping() -> DataMapping {
        DataMapping {
            record: Some("run".into()),
            columns: vec![("p_u".into(), "u".into())],
            ..Default::default()
        }
    }

    /// Uniform numbers in (−1, 1) from a xorshift stream.
    pub(in crate::io::measured) fn noise(mut state: u64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                2.0 * ((state >> 11) as f64 / (1u64 << 53) as f64) - 1.0
            })
            .collect()
    }

    #[test]
    fn periods_of_one_realisation_are_found_and_averaged() {
        // Two realisations of 1000 samples, three noisy periods each (noise at 30 % of the
        // signal), interleaved in the table's order; one record of another length.
        let (a, b) = (noise(1, 1000), noise(2, 1000));
        let period =
            |s: &[f64], seed| -> Vec<f64> { s.iter().zip(noise(seed, 1000)).map(|(x, e)| x + 0.3 * e).collect() };
        let recs = vec![
            (1.0, period(&a, 11)),
            (2.0, period(&b, 12)),
            (3.0, period(&a, 13)),
            (4.0, period(&b, 14)),
            (5.0, period(&a, 15)),
            (6.0, period(&b, 16)),
            (7.0, noise(3, 900)),
        ];
        let (sources, found) = average_repeated(vec![table(&recs)], &mapping(), None).unwrap();
        let found = found.expect("periodic records");
        assert_eq!(found.groups, vec![vec![1, 3, 5], vec![2, 4, 6]]);
        assert_eq!((found.records, found.realisations), (7, 3));
        assert!(found.within > 0.8 && found.between < 0.15, "{found:?}");
        assert_eq!(sources.len(), 3);
        let Source::Memory(t) = &sources[0] else { panic!() };
        assert_eq!(t.columns[0], vec![1.0; 1000], "the first period's record id");
        for k in [0, 499, 999] {
            let mean = (recs[0].1[k] + recs[2].1[k] + recs[4].1[k]) / 3.0;
            assert!((t.columns[1][k] - mean).abs() < 1e-12);
        }
        let Source::Memory(t) = &sources[2] else { panic!() };
        assert_eq!(t.columns[1], recs[6].1, "a record that repeats nothing is left alone");
        assert!(found.note().contains("records 1, 3, 5; 2, 4, 6"), "{}", found.note());
    }

    #[test]
    fn independent_realisations_are_left_alone() {
        let recs: Vec<(f64, Vec<f64>)> = (0..10).map(|r| (r as f64, noise(100 + r, 2000))).collect();
        let (sources, found) = average_repeated(vec![table(&recs)], &mapping(), None).unwrap();
        assert!(found.is_none());
        assert!(matches!(&sources[0], Source::Memory(t) if t.rows() == 20_000));
    }
}

//! The first pass over every source of measured data: each table scanned and checked
//! (`scan`, `check_values`), the sample interval found, and each source's reading planned
//! (its records in order, split into pieces at time gaps where the mapping asks), and how a
//! row's record id finds its record's slot on every later pass.

use super::scan::{Scanned, DENSE_IDS};
use super::{check_values, err, interval_of, pieces, scan, Columns, DataError, Plan, Source};
use crate::scenario::DataMapping;
use std::collections::HashMap;

/// What the first pass over every source finds: the sample interval, the notes, each
/// source's reading plan, every record piece's length and each mapped column's mean
/// crossings.
pub(super) struct Sources {
    pub interval: Option<f64>,
    pub notes: Vec<String>,
    pub plans: Vec<(Source, Plan)>,
    pub lengths: Vec<usize>,
    pub crossings: Vec<usize>,
    /// The columns of `[data] remove_mean` and the mean taken out of each (the table's
    /// units).
    pub removed_means: Vec<(String, f64)>,
}

/// Scan every source (`scan`, `check_values`) and plan its reading: its records in
/// order, split into pieces at time gaps where the mapping asks; the columns of
/// `[data] remove_mean` offset by their mean over every source, or by `means` where given
/// (held-out data read with the identification's offsets). `scanned`: the sources'
/// scans where they were made before (one per source, in order).
pub(super) fn plan_sources(
    sources: Vec<Source>,
    d: &DataMapping,
    names: &[String],
    means: Option<&[(String, f64)]>,
    scanned: Option<Vec<Scanned>>,
) -> Result<Sources, DataError> {
    let mut scanned = scanned.map(Vec::into_iter);
    let mut interval: Option<f64> = d.sample_interval;
    let mut notes = Vec::new();
    let mut plans = Vec::new();
    let mut lengths = Vec::new();
    let mut crossings = vec![0usize; d.columns.len()];
    // Per mapped column: the sum of its values and their count.
    let mut sums = vec![(0.0f64, 0usize); d.columns.len()];
    for source in sources {
        let c = Columns::of(&source, d, names)?;
        let s = match scanned.as_mut().and_then(Iterator::next) {
            Some(s) => s,
            None => scan(&source, &c, d, None)?,
        };
        check_values(&source, &c, &s)?;
        for (total, n) in crossings.iter_mut().zip(&s.crossings) {
            *total += n;
        }
        for r in &s.records {
            for (sum, x) in sums.iter_mut().zip(&r.sums) {
                *sum = (sum.0 + x, sum.1 + r.rows);
            }
        }
        if s.records.is_empty() {
            continue;
        }
        if interval.is_none() {
            interval =
                interval_of(&s.first_steps).or_else(|| s.records.iter().find_map(|r| r.runs.first()).map(|r| r.step));
        }
        let h = interval.ok_or_else(|| {
            err(
                source.path(),
                "no sample interval: give [data] sample_interval, or a time column with two samples in a record",
            )
        })?;
        let mut pieces_of = vec![(0u32, Vec::new()); s.records.len()];
        for slot in s.order() {
            let p = if c.time_at.is_some() {
                pieces(&source, &s, slot, d, h, &mut notes)?
            } else {
                vec![s.records[slot].rows]
            };
            pieces_of[slot] = (lengths.len() as u32, p.clone());
            lengths.extend(p);
        }
        plans.push((
            source,
            Plan {
                mapped: c.mapped.iter().map(|&(k, scale, _)| (k, scale, 0.0)).collect(),
                wanted: c.wanted,
                record_at: c.record_at,
                slots: s.slots,
                pieces: pieces_of,
            },
        ));
    }
    let mut removed_means = Vec::new();
    for column in &d.remove_mean {
        let j = d
            .columns
            .iter()
            .position(|(_, c)| c == column)
            .expect("checked by the model file");
        let mean = match means.and_then(|m| m.iter().find(|(c, _)| c == column)) {
            Some(&(_, given)) => given,
            None => sums[j].0 / sums[j].1.max(1) as f64,
        };
        for (_, plan) in &mut plans {
            plan.mapped[j].2 = mean;
        }
        let how = if means.is_some() {
            "the identification's data's"
        } else {
            "its"
        };
        notes.push(format!(
            "{column}: {how} mean, {mean:.6e}, taken out ([data] remove_mean)"
        ));
        removed_means.push((column.clone(), mean));
    }
    Ok(Sources {
        interval,
        notes,
        plans,
        lengths,
        crossings,
        removed_means,
    })
}

/// Record ids that are all small whole numbers (trajectory numbers, text ids as numbered)
/// as a table indexed by the id: a pass looks every row's id up, and a hash per row cost
/// more than the row's own work.
pub(super) fn dense_slots(slots: &HashMap<u64, usize>) -> Option<Vec<usize>> {
    let ids: Vec<(f64, usize)> = slots.iter().map(|(&k, &s)| (f64::from_bits(k), s)).collect();
    if !ids
        .iter()
        .all(|&(id, _)| (0.0..DENSE_IDS as f64).contains(&id) && id.fract() == 0.0)
    {
        return None;
    }
    let mut table = vec![usize::MAX; ids.iter().map(|p| p.0 as usize + 1).max().unwrap_or(0)];
    for (id, s) in ids {
        table[id as usize] = s;
    }
    Some(table)
}

/// The slot of record id `id`: by `dense` ([`dense_slots`]) where there is one, else by
/// its key.
pub(super) fn slot_of(dense: Option<&[usize]>, slots: &HashMap<u64, usize>, id: f64) -> Option<usize> {
    match dense {
        Some(table) => (id >= 0.0 && id.fract() == 0.0)
            .then(|| table.get(id as usize).copied())
            .flatten()
            .filter(|&s| s != usize::MAX),
        None => slots.get(&super::key(id)).copied(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Small whole ids are looked up by index, anything else by its key, with the same
    /// answers; an id not among the records has no slot either way.
    #[test]
    fn a_record_id_finds_its_slot_by_index_or_by_key() {
        let map = |ids: &[f64]| -> HashMap<u64, usize> {
            ids.iter()
                .enumerate()
                .map(|(s, &id)| (super::super::key(id), s))
                .collect()
        };
        let small = map(&[0.0, 3.0, 7.0]);
        let dense = dense_slots(&small).expect("small whole ids");
        for (id, want) in [
            (0.0, Some(0)),
            (-0.0, Some(0)),
            (3.0, Some(1)),
            (7.0, Some(2)),
            (5.0, None),
            (9.0, None),
            (3.5, None),
            (-1.0, None),
            (f64::NAN, None),
        ] {
            assert_eq!(slot_of(Some(&dense), &small, id), want, "id {id}");
            assert_eq!(slot_of(None, &small, id), want, "id {id} by key");
        }
        for ids in [&[0.0, 2.5][..], &[1.0, 70_000.0], &[-2.0, 1.0]] {
            let m = map(ids);
            assert!(dense_slots(&m).is_none(), "{ids:?}");
            assert_eq!(slot_of(None, &m, ids[1]), Some(1));
        }
    }
}

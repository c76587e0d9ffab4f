//! Checks of measured samples themselves for a rig's faults, made while the first pass
//! reads them (docs/methods.md, "Checks"): each is an
//! [`Accumulator`](crate::ident::accumulate::Accumulator) that, once the pass is over,
//! names what it found. The verdict stage turns every finding into a failed check (exit 1):
//! an estimate made from a stuck sensor's record is not an estimate of the rig.
//!
//! The checks: [`dead_stretches`] (a column that stands still inside a record),
//! [`lags`] (a measured derivative delayed against its quantity) and [`pile_ups`] (a
//! measured acceleration or force clipped at its range).
//!
//! A new check is one file here implementing [`SampleCheck`] and one line in [`all`].

mod dead_stretches;
mod lags;
mod pile_ups;

use crate::ident::accumulate::Accumulator;

/// A check of the samples, run in the first pass.
pub(crate) trait SampleCheck: Accumulator {
    /// Its name in `report.json`'s `failed_checks`.
    fn name(&self) -> &'static str;
    /// What it found once the pass is over, one message per fault: the column, the record
    /// and the time, and what may cause it. `columns` are the log's column names.
    fn findings(&self, columns: &[String]) -> Vec<String>;
}

/// Every check that applies to the samples of `input` (measured tables only: a
/// simulation's samples have no rig).
pub(crate) fn all(input: &super::Input) -> Vec<Box<dyn SampleCheck>> {
    let Some(data) = input.measured() else {
        return Vec::new();
    };
    let width = input.info.columns.len();
    vec![
        Box::new(dead_stretches::DeadStretches::new(width)),
        Box::new(lags::Lags::of(input, data)),
        Box::new(pile_ups::PileUps::of(input, data)),
    ]
}

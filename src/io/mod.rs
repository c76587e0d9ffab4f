//! File formats: the MCAP run log, exports for other tools and measured data tables.
//!
//! Everything here converts between files and the library's in-memory types; the
//! numerics (`model`, `sim`) never import this module.

pub mod decode;
mod delimited;
pub mod export;
pub mod log;
mod measured;
pub mod output;
pub mod reader;
pub mod table;
mod units;

use crate::scenario::{Scenario, ScenarioError};
use std::path::Path;

/// A scenario file read to be run: its `--set` overrides applied, and the tables of its
/// recorded signals (`kind = "recorded"`, docs/excitations.md) read, CSV or `.npy`,
/// relative to the file.
pub fn scenario_file(path: &Path, sets: &[String]) -> Result<Scenario, ScenarioError> {
    let mut s = Scenario::from_file_with(path, sets)?;
    let label = if sets.is_empty() {
        path.display().to_string()
    } else {
        format!("{} with --set {}", path.display(), sets.join(" --set "))
    };
    let read = |p: &Path| {
        table::read_table(p, &[])
            .map(|t| (t.names, t.columns))
            .map_err(|e| e.to_string())
    };
    s.read_recordings(&label, path.parent().unwrap_or(Path::new("")), &read)?;
    Ok(s)
}

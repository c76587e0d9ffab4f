//! File formats: the MCAP run log and exports for other tools.
//!
//! Everything here converts between files and the library's in-memory types; the
//! numerics (`model`, `sim`) never import this module.

pub mod export;
pub mod log;
pub mod reader;

use std::path::{Path, PathBuf};

/// `path` with `.partial` appended: where output is written until it is complete.
pub fn partial_path(path: &Path) -> PathBuf {
    let mut p = path.as_os_str().to_owned();
    p.push(".partial");
    PathBuf::from(p)
}

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

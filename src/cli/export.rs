//! `fpkbench export`: a log's samples as CSV or NPY.

use anyhow::Context;
use fpkbench::io::export::{export, Format};
use fpkbench::io::log::read_info;
use fpkbench::io::output::refuse_same_file;
use std::path::PathBuf;
use std::process::ExitCode;

/// Export a run log's samples to CSV (spreadsheets) or NPY (numpy structured array).
#[derive(clap::Args)]
pub struct Args {
    /// MCAP log written by `fpkbench simulate` or `run`.
    pub log: PathBuf,
    /// Output format.
    #[arg(long, value_enum)]
    pub format: Format,
    /// Output file [default: the log's path with the format's extension].
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Export what a truncated log (a killed writer) still holds instead of refusing it.
    #[arg(long)]
    pub allow_truncated: bool,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let mut info = read_info(&args.log)?;
    info.accept_truncated = args.allow_truncated;
    let dest = args
        .output
        .unwrap_or_else(|| args.log.with_extension(args.format.extension()));
    refuse_same_file(&args.log, &dest)?;
    let n = export(&info, args.format, &dest).with_context(|| format!("exporting {}", args.log.display()))?;
    let expected = info.expected_samples();
    if n < expected {
        eprintln!(
            "warning: the log is truncated: exported the {n} samples it still holds, of {expected} the run was to write"
        );
    }
    eprintln!("wrote {} samples to {}", n, dest.display());
    Ok(ExitCode::SUCCESS)
}

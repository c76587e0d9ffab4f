//! `fpkbench export`: a log's samples as CSV or NPY.

use anyhow::Context;
use fpkbench::io::export::{export, Format};
use fpkbench::io::log::read_info;
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
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let info = read_info(&args.log)?;
    let dest = args
        .output
        .unwrap_or_else(|| args.log.with_extension(args.format.extension()));
    let n = export(&info, args.format, &dest).with_context(|| format!("exporting {}", args.log.display()))?;
    eprintln!("wrote {} samples to {}", n, dest.display());
    Ok(ExitCode::SUCCESS)
}

//! `fpkbench study`: a scenario over seeds × record lengths × sample intervals × methods,
//! sharded for a cluster (`--shard i/n`, or Slurm / Kubernetes indices from the
//! environment), resumable, and `study merge` to summarize any set of shards' rows.

use fpkbench::io::output::write_atomic;
use fpkbench::pipeline::study::{self, gather, summarize, Row, Study};
use fpkbench::report::study::{plot_study, study_markdown};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Run a study file's items (this shard's), one file of rows per item under DIR/items/;
/// when every item is done, write the summary (summary.json, summary.md, study.svg).
#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct Args {
    #[command(subcommand)]
    pub merge: Option<Merge>,
    /// Study file (TOML): scenario, seeds, record_lengths, sample_intervals, methods, set
    /// (docs/studies.md).
    pub study: Option<PathBuf>,
    /// This shard, INDEX/COUNT (0-based), e.g. 3/16: items whose number ≡ INDEX mod
    /// COUNT [default: from SLURM_ARRAY_TASK_ID/_MIN/_COUNT or JOB_COMPLETION_INDEX, else
    /// 0/1].
    #[arg(long, value_parser = parse_shard)]
    pub shard: Option<(usize, usize)>,
    /// The shard count where the environment gives only the index (a Kubernetes Indexed
    /// Job's completions).
    #[arg(long)]
    pub shard_count: Option<usize>,
    /// Output folder [default: out/study-<study name>/].
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// Keep every item's MCAP log under DIR/logs/ (by default items simulate straight into
    /// the estimators and nothing but rows is written).
    #[arg(long)]
    pub keep_logs: bool,
    /// Print the items this shard would run, and stop.
    #[arg(long)]
    pub dry_run: bool,
}

#[derive(clap::Subcommand)]
pub enum Merge {
    /// Summarize the rows of one study from any set of shard folders (duplicate rows must
    /// agree; conflicting rows or rows of another study are refused).
    Merge {
        /// Folders holding items/*.jsonl (or .jsonl files).
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Where the summary goes [default: the first folder].
        #[arg(short, long)]
        out: Option<PathBuf>,
    },
}

fn parse_shard(s: &str) -> Result<(usize, usize), String> {
    let (i, n) = s.split_once('/').ok_or("INDEX/COUNT expected, e.g. 0/4")?;
    let i: usize = i.trim().parse().map_err(|_| format!("{i:?} is not an index"))?;
    let n: usize = n.trim().parse().map_err(|_| format!("{n:?} is not a count"))?;
    if n == 0 || i >= n {
        return Err(format!("shard {i}/{n}: the index must be below the count"));
    }
    Ok((i, n))
}

fn item_files(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    if dir.is_file() {
        return Ok(vec![dir.to_path_buf()]);
    }
    let items = dir.join("items");
    let mut out: Vec<PathBuf> = match std::fs::read_dir(&items) {
        Ok(rd) => rd
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "jsonl"))
            .collect(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
        Err(e) => anyhow::bail!("{}: {e}", items.display()),
    };
    out.sort();
    Ok(out)
}

/// summary.json, summary.md and study.svg of `rows` into `dir`.
fn write_summary(name: &str, rows: &[Row], dir: &Path) -> anyhow::Result<()> {
    let summary = summarize(rows);
    write_atomic(
        &dir.join("summary.json"),
        serde_json::to_string_pretty(&summary)?.as_bytes(),
    )?;
    write_atomic(
        &dir.join("summary.md"),
        study_markdown(name, rows.len(), &summary).as_bytes(),
    )?;
    plot_study(&summary, &dir.join("study.svg")).map_err(|e| anyhow::anyhow!("study.svg: {e}"))?;
    println!(
        "{}",
        study_markdown(name, rows.len(), &summary)
            .lines()
            .filter(|l| l.starts_with('|'))
            .take(2 + summary.len())
            .collect::<Vec<_>>()
            .join("\n")
    );
    eprintln!("wrote {}/summary.json, summary.md, study.svg", dir.display());
    Ok(())
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if let Some(Merge::Merge { dirs, out }) = args.merge {
        let files = dirs
            .iter()
            .map(|d| item_files(d))
            .collect::<anyhow::Result<Vec<_>>>()?
            .concat();
        if files.is_empty() {
            anyhow::bail!(
                "no rows: none of {} holds items/*.jsonl",
                dirs.iter()
                    .map(|d| d.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        let rows = gather(&files).map_err(|e| anyhow::anyhow!(e))?;
        let dir = out.unwrap_or_else(|| dirs[0].clone());
        std::fs::create_dir_all(&dir)?;
        let name = dir.file_name().and_then(|n| n.to_str()).unwrap_or("study").to_string();
        write_summary(&name, &rows, &dir)?;
        return Ok(ExitCode::SUCCESS);
    }
    let Some(file) = args.study else {
        anyhow::bail!("a study file is needed: fpkbench study STUDY.toml (or fpkbench study merge DIR…)");
    };
    let study = Study::from_file(&file)?;
    let (index, count) = study::shard_from(args.shard, args.shard_count, |k| std::env::var(k).ok())
        .map_err(|e| anyhow::anyhow!("shard: {e}"))?;
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join(format!("study-{}", study.name)));
    let items_dir = dir.join("items");
    std::fs::create_dir_all(&items_dir)?;
    let all = study.items();
    let mine: Vec<_> = all.iter().filter(|i| i.index % count == index).collect();
    let todo: Vec<_> = mine
        .iter()
        .filter(|i| !items_dir.join(format!("{}.jsonl", i.key())).exists())
        .collect();
    eprintln!(
        "study {}: {} items in all; shard {index}/{count} has {}, {} already done",
        study.name,
        all.len(),
        mine.len(),
        mine.len() - todo.len()
    );
    if args.dry_run {
        for i in &todo {
            println!("{} seed {}", i.key(), i.seed);
        }
        return Ok(ExitCode::SUCCESS);
    }
    let logs = args.keep_logs.then(|| dir.join("logs"));
    if let Some(l) = &logs {
        std::fs::create_dir_all(l)?;
    }
    let bar = ProgressBar::new(todo.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} items, eta {eta}").expect("template"),
    );
    // Items in parallel (each simulation is deterministic by its own seed, so the rows do
    // not depend on the order or the thread count); each item's rows land atomically.
    use rayon::prelude::*;
    todo.par_iter().try_for_each(|item| -> anyhow::Result<()> {
        let rows = study
            .run_item(item, logs.as_deref())
            .map_err(|e| anyhow::anyhow!("item {} (seed {}): {e}", item.key(), item.seed))?;
        let mut text = String::new();
        for r in &rows {
            text += &serde_json::to_string(r)?;
            text.push('\n');
        }
        write_atomic(&items_dir.join(format!("{}.jsonl", item.key())), text.as_bytes())?;
        bar.inc(1);
        Ok(())
    })?;
    bar.finish_and_clear();
    // The summary once every item of the study is here (the last shard to finish writes it).
    let files = item_files(&dir)?;
    if files.len() == all.len() {
        let rows = gather(&files).map_err(|e| anyhow::anyhow!(e))?;
        write_summary(&study.name, &rows, &dir)?;
    } else {
        eprintln!(
            "{} of {} items are in {}; the summary is written when all are (or by `fpkbench study merge`)",
            files.len(),
            all.len(),
            dir.display()
        );
    }
    Ok(ExitCode::SUCCESS)
}

//! `fpkbench study`: a scenario over seeds × record lengths × sample intervals × methods,
//! sharded for a cluster (`--shard i/n`, or Slurm / Kubernetes indices from the
//! environment), resumable, and `study merge` to summarize any set of shards' rows.

use fpkbench::io::output::{at, write_atomic};
use fpkbench::pipeline::study::{self, gather, summarize, Item, Row, Study};
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
    /// Study file (TOML): scenario, seeds, record_lengths, sample_intervals, noise_levels,
    /// methods, set (docs/studies.md).
    pub study: Option<PathBuf>,
    /// This shard, INDEX/COUNT (0-based), e.g. 3/16: items whose number ≡ INDEX mod
    /// COUNT (to run or resubmit one piece by hand) [default: from the scheduler's index,
    /// SLURM_ARRAY_TASK_ID or JOB_COMPLETION_INDEX, else 0/1].
    #[arg(long, value_parser = parse_shard, conflicts_with = "shard_count")]
    pub shard: Option<(usize, usize)>,
    /// The whole study's shard count, with a scheduler's index: keeps a resubmitted task
    /// (`sbatch --array=5`) shard 5 of N, and places tasks of an array with gaps; needed
    /// for a Kubernetes Indexed Job [default for a Slurm array 0-(N-1): N].
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    pub shard_count: Option<u64>,
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
    /// Instead of a study file: the scenario, with the grid from the flags below (the study
    /// file's keys; `--print` shows the file they make).
    #[arg(long, conflicts_with = "study")]
    pub scenario: Option<PathBuf>,
    /// Seeds per configuration (with --scenario) [default: 10].
    #[arg(long, requires = "scenario")]
    pub seeds: Option<usize>,
    /// The study's seed (with --scenario) [default: 0].
    #[arg(long, requires = "scenario")]
    pub seed: Option<u64>,
    /// A record length per trajectory, s (repeatable; with --scenario) [default: the
    /// scenario's].
    #[arg(long = "record-length", requires = "scenario")]
    pub record_lengths: Vec<f64>,
    /// A sample interval, s (repeatable; with --scenario) [default: the scenario's].
    #[arg(long = "sample-interval", requires = "scenario")]
    pub sample_intervals: Vec<f64>,
    /// A sensor noise level: noise of this fraction of each channel's std on every
    /// displacement and velocity, the same motion at every level (repeatable; with
    /// --scenario) [default: the scenario's [measurement]].
    #[arg(long = "noise-level", requires = "scenario")]
    pub noise_levels: Vec<f64>,
    /// A method (repeatable; with --scenario) [default: the scenario's].
    #[arg(long = "method", value_parser = crate::cli::identify::method_parser(), requires = "scenario")]
    pub methods: Vec<fpkbench::scenario::Method>,
    /// An override KEY=VALUE applied first, as for `run` (repeatable; with --scenario).
    #[arg(long = "set", requires = "scenario")]
    pub set: Vec<String>,
    /// Structure selection on every item (with --scenario; docs/selection.md): the
    /// candidates of the scenario's own `[identify.select]`, else its unknown terms, as
    /// `run --select`.
    #[arg(long, requires = "scenario")]
    pub select: bool,
    /// Structure selection with the candidate powers 1..=N on every link's stiffness and
    /// damping (with --scenario; implies --select).
    #[arg(long, value_name = "N", requires = "scenario", value_parser = clap::value_parser!(u32).range(1..=15))]
    pub select_powers: Option<u32>,
    /// Compare every method with this one on the same samples (with --scenario).
    #[arg(long, requires = "scenario")]
    pub reference: Option<String>,
    /// Print the study file the flags make, and stop.
    #[arg(long, requires = "scenario")]
    pub print: bool,
    /// Estimate the integrator's bias on every item (with --scenario; as `run
    /// --integrator-bias`: every item simulated again at half the step on the same paths,
    /// about doubling the study's time); the summary sets it beside the standard errors.
    #[arg(long, requires = "scenario")]
    pub integrator_bias: bool,
}

/// The study file `--scenario` and its flags stand for.
fn study_text(args: &Args, scenario: &Path) -> String {
    let mut t = toml::Table::new();
    t.insert("scenario".into(), scenario.display().to_string().into());
    t.insert("seeds".into(), (args.seeds.unwrap_or(10) as i64).into());
    t.insert("seed".into(), (args.seed.unwrap_or(0) as i64).into());
    let floats = |v: &[f64]| toml::Value::Array(v.iter().map(|&x| x.into()).collect());
    let strings = |v: &[String]| toml::Value::Array(v.iter().map(|x| x.clone().into()).collect());
    if !args.record_lengths.is_empty() {
        t.insert("record_lengths".into(), floats(&args.record_lengths));
    }
    if !args.sample_intervals.is_empty() {
        t.insert("sample_intervals".into(), floats(&args.sample_intervals));
    }
    if !args.noise_levels.is_empty() {
        t.insert("noise_levels".into(), floats(&args.noise_levels));
    }
    if !args.methods.is_empty() {
        let names: Vec<String> = args.methods.iter().map(|m| m.name().to_string()).collect();
        t.insert("methods".into(), strings(&names));
    }
    let mut set = args.set.clone();
    if let Some(n) = args.select_powers {
        let powers: Vec<String> = (1..=n).map(|p| p.to_string()).collect();
        for kind in ["stiffness", "damping"] {
            set.push(format!("identify.select.{kind}=[{}]", powers.join(", ")));
        }
    } else if args.select && !declares_select(scenario, &args.set) {
        // A scenario with its own `[identify.select]` keeps its candidates; without one,
        // the unknown terms are the candidates.
        set.push("identify.select={}".into());
    }
    if !set.is_empty() {
        t.insert("set".into(), strings(&set));
    }
    if let Some(r) = &args.reference {
        t.insert("reference".into(), r.clone().into());
    }
    if args.integrator_bias {
        t.insert("integrator_bias".into(), true.into());
    }
    format!(
        "# fpkbench study from flags\n{}",
        toml::to_string(&t).expect("a table of plain values")
    )
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
        /// Compare every method with this one on the same samples (the study file's
        /// `reference`).
        #[arg(long)]
        reference: Option<String>,
        /// Summarize even when items of the study are missing (a shard not run or not
        /// copied): the summary says which. Without it such a merge is refused (exit 2).
        #[arg(long)]
        partial: bool,
    },
}

fn parse_shard(s: &str) -> Result<(usize, usize), String> {
    let (i, n) = s.split_once('/').ok_or("INDEX/COUNT expected, e.g. 0/4")?;
    let digits = |x: &str| !x.is_empty() && x.bytes().all(|b| b.is_ascii_digit());
    if !digits(i) || !digits(n) {
        return Err(format!(
            "{s:?}: INDEX/COUNT as whole numbers without spaces expected, e.g. 0/4"
        ));
    }
    let i: usize = i.parse().map_err(|_| format!("{i:?} is not an index"))?;
    let n: usize = n.parse().map_err(|_| format!("{n:?} is not a count"))?;
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

/// summary.json, summary.md, study.html and study.svg (.png, .pdf) of `rows` into `dir` (with the paired
/// differences from `reference`, if given).
/// The summary of `rows` in `dir`; `note` (a partial merge's) goes under the title and into
/// summary.json.
fn write_summary(
    name: &str,
    rows: &[Row],
    dir: &Path,
    reference: Option<&str>,
    note: Option<&str>,
) -> anyhow::Result<()> {
    let summary = summarize(rows);
    let paired = reference.map_or(Vec::new(), |r| study::paired(rows, r));
    if let Some(r) = reference {
        if !rows.iter().any(|x| x.method == r) {
            anyhow::bail!("the reference method {r:?} has no rows in this study");
        }
    }
    write_atomic(
        &dir.join("summary.json"),
        serde_json::to_string_pretty(&serde_json::json!({ "summary": summary, "paired": paired, "note": note }))?
            .as_bytes(),
    )?;
    let mut markdown = study_markdown(name, rows.len(), &summary, &paired);
    if let Some(n) = note {
        let title = markdown.find("\n\n").map_or(0, |i| i + 2);
        markdown.insert_str(title, &format!("{n}\n\n"));
    }
    plot_study(&summary, rows, &dir.join("study.svg")).map_err(|e| anyhow::anyhow!("study.svg: {e}"))?;
    write_atomic(&dir.join("summary.md"), markdown.as_bytes())?;
    let html = fpkbench::report::html::page(&format!("fpkbench study: {name}"), &markdown, dir)?;
    write_atomic(&dir.join("study.html"), html.as_bytes())?;
    println!(
        "{}",
        markdown
            .lines()
            .filter(|l| l.starts_with('|'))
            .take(2 + summary.len())
            .collect::<Vec<_>>()
            .join("\n")
    );
    eprintln!(
        "wrote {}/summary.json, summary.md, study.html, study.svg (.png, .pdf)",
        dir.display()
    );
    Ok(())
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if let Some(Merge::Merge {
        dirs,
        out,
        reference,
        partial,
    }) = &args.merge
    {
        merge(dirs, out.as_deref(), reference.as_deref(), *partial)?;
        return Ok(ExitCode::SUCCESS);
    }
    let Some(study) = study_of(&args)? else {
        return Ok(ExitCode::SUCCESS);
    };
    let (index, count) = study::shard_from(args.shard, args.shard_count.map(|n| n as usize), |k| {
        std::env::var(k).ok()
    })
    .map_err(|e| anyhow::anyhow!("shard: {e}"))?;
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join(format!("study-{}", study.name)));
    let items_dir = dir.join("items");
    let all = study.items();
    let mine: Vec<_> = all.iter().filter(|i| i.index % count == index).collect();
    // Done: a complete item file of this study with a row for every method, none failed.
    // Anything else (missing, empty, cut short, a method's row missing, failed before) is
    // run again, and said so.
    let item_file = |i: &Item| items_dir.join(format!("{}.jsonl", i.key()));
    let mut todo = Vec::new();
    for i in &mine {
        match study::item_done(&study, &item_file(i)) {
            Ok(()) => {}
            Err(why) => {
                if item_file(i).exists() {
                    eprintln!("item {}: {why}; running it again", i.key());
                }
                todo.push(*i);
            }
        }
    }
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
    std::fs::create_dir_all(&items_dir).map_err(|e| at(&items_dir, "creating the study folder", e))?;
    let logs = args.keep_logs.then(|| dir.join("logs"));
    if let Some(l) = &logs {
        std::fs::create_dir_all(l).map_err(|e| at(l, "creating the logs folder", e))?;
    }
    let bar = ProgressBar::new(todo.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} items, eta {eta}").expect("template"),
    );
    // Items in parallel (each simulation is deterministic by its own seed, so the rows do
    // not depend on the order or the thread count); each item's rows land atomically. An
    // item that cannot be run (a diverging simulation) is a row per method, `failed` with
    // the reason; the study goes on and says so at the end.
    use rayon::prelude::*;
    let failed = std::sync::atomic::AtomicUsize::new(0);
    todo.par_iter().try_for_each(|item| -> anyhow::Result<()> {
        let rows = study.run_item(item, logs.as_deref()).unwrap_or_else(|e| {
            failed.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            bar.suspend(|| eprintln!("item {} (seed {}) failed: {e}", item.key(), item.seed));
            study.failed_rows(item, &e.to_string())
        });
        write_atomic(&item_file(item), study::item_text(&rows)?.as_bytes())?;
        bar.inc(1);
        Ok(())
    })?;
    bar.finish_and_clear();
    // The summary once every item of the study is here (the last shard to finish writes it),
    // from this study's item files only: a file of another study left in the folder (a
    // grid run there before) is named, not counted.
    let own: Vec<PathBuf> = all.iter().map(&item_file).collect();
    let done = all
        .iter()
        .filter(|i| study::item_done(&study, &item_file(i)).is_ok())
        .count();
    let foreign: Vec<PathBuf> = (item_files(&dir)?.into_iter()).filter(|f| !own.contains(f)).collect();
    if !foreign.is_empty() {
        eprintln!(
            "{} file(s) in {} are no item of this study (another study's run in the same folder?), \
             left out of its summary: {}",
            foreign.len(),
            items_dir.display(),
            foreign
                .iter()
                .map(|f| f.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    if done == all.len() {
        let rows = gather(&own).map_err(|e| anyhow::anyhow!(e))?;
        write_summary(&study.name, &rows, &dir, study.file.reference.as_deref(), None)?;
    } else {
        eprintln!(
            "{done} of {} items are done in {}; the summary is written when all are (or by `fpkbench study merge`)",
            all.len(),
            dir.display()
        );
    }
    let failed = failed.into_inner();
    if failed > 0 {
        eprintln!(
            "{failed} of {} items of this shard could not be run (their rows say why); a re-run tries them again",
            todo.len()
        );
        return Ok(ExitCode::from(2));
    }
    Ok(ExitCode::SUCCESS)
}

/// Whether `scenario` (with the `--set` overrides) declares `[identify.select]`; a
/// scenario that cannot be read is reported when the study is made from it.
fn declares_select(scenario: &Path, set: &[String]) -> bool {
    fpkbench::Scenario::from_file_with(scenario, set).is_ok_and(|s| s.identify.select.is_some())
}

/// `fpkbench study merge`: the summary of the items in `dirs`, written to `out` (the first
/// folder when not given); refused where items of the study are missing, unless `partial`.
fn merge(dirs: &[PathBuf], out: Option<&Path>, reference: Option<&str>, partial: bool) -> anyhow::Result<()> {
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
    let note = match study::missing_items(&rows) {
        None => {
            eprintln!(
                "these rows do not record how many items their study has (written by an older fpkbench): \
                 whether a shard is missing cannot be told"
            );
            None
        }
        Some((_, missing)) if missing.is_empty() => None,
        Some((of, missing)) => {
            let what = format!(
                "{} of the study's {of} items are missing (items {})",
                missing.len(),
                study::item_list(&missing)
            );
            if !partial {
                anyhow::bail!(
                    "{what}: a shard was not run or not copied here; run it (fpkbench study STUDY.toml \
                     --shard I/N) and merge again, or summarize what is here with --partial"
                );
            }
            eprintln!("partial summary: {what}");
            Some(format!(
                "**Partial**: {what}; the statistics are over the items present."
            ))
        }
    };
    let dir = out.map_or_else(|| dirs[0].clone(), Path::to_path_buf);
    std::fs::create_dir_all(&dir).map_err(|e| at(&dir, "creating the summary folder", e))?;
    let name = dir.file_name().and_then(|n| n.to_str()).unwrap_or("study").to_string();
    write_summary(&name, &rows, &dir, reference, note.as_deref())?;
    Ok(())
}

/// The study to run: from its file, or made from `--scenario` and the grid flags; none
/// when `--print` only shows the study file the flags make.
fn study_of(args: &Args) -> anyhow::Result<Option<Study>> {
    Ok(Some(match (&args.study, &args.scenario) {
        (Some(file), _) => {
            // The grid flags build a study from --scenario; with a study file they would be
            // silently outvoted by the file's keys.
            let flags = [
                ("--seeds", args.seeds.is_some()),
                ("--seed", args.seed.is_some()),
                ("--record-length", !args.record_lengths.is_empty()),
                ("--sample-interval", !args.sample_intervals.is_empty()),
                ("--noise-level", !args.noise_levels.is_empty()),
                ("--method", !args.methods.is_empty()),
                ("--set", !args.set.is_empty()),
                ("--reference", args.reference.is_some()),
                ("--print", args.print),
                ("--integrator-bias", args.integrator_bias),
                ("--select", args.select),
                ("--select-powers", args.select_powers.is_some()),
            ];
            let given: Vec<&str> = flags.iter().filter(|f| f.1).map(|f| f.0).collect();
            if !given.is_empty() {
                anyhow::bail!(
                    "{}: {} describe a study made with --scenario; a study file has its own keys \
                     (seeds, seed, record_lengths, sample_intervals, noise_levels, methods, set, reference, \
                     integrator_bias; a selection is its scenario's [identify.select]): edit the file, \
                     or run fpkbench study --scenario SCENARIO with the flags",
                    file.display(),
                    given.join(", ")
                );
            }
            Study::from_file(file)?
        }
        (None, Some(scenario)) => {
            let text = study_text(args, scenario);
            if args.print {
                print!("{text}");
                return Ok(None);
            }
            let name = scenario.file_stem().and_then(|s| s.to_str()).unwrap_or("study");
            Study::from_text(&text, Path::new("(flags)"), name, Path::new("."))?
        }
        (None, None) => anyhow::bail!(
            "a study is needed: fpkbench study STUDY.toml, fpkbench study --scenario SCENARIO [--seeds N …], or fpkbench study merge DIR…"
        ),
    }))
}

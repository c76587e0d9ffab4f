//! `fpkbench sweep`: the paper's iterative procedure against the strength of the
//! unmeasured disturbance — one simulated log per level, identified like `run` does.

use super::simulate::simulate_to;
use fpkbench::io::log::Compression;
use fpkbench::pipeline::{identify_log, Options};
use fpkbench::report;
use fpkbench::report::{Sweep, SweepPoint};
use std::path::PathBuf;
use std::process::ExitCode;

/// Sweep the disturbance strength of a scenario with `[identify.disturbance]`: for each
/// level (standard deviation of the unmeasured force over that of the measured one; 0 =
/// no disturbance) simulate, run the iterative procedure, and report step-0, final and
/// measured-disturbance errors (sweep.json, sweep.md, sweep.svg).
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML) with `[identify.disturbance]`, e.g. scenarios/disturbed2dof.toml.
    pub scenario: PathBuf,
    /// Vary a scenario key without editing the file (repeatable): KEY=VALUE with KEY a
    /// dotted path (simulation.seed, link.1.damping.1) and VALUE in TOML; validated like
    /// the file, recorded in the log and the report; the default output folder is named
    /// after the variant (out/<name>--seed=7/).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Levels, comma-separated [default: the scenario's `[identify.disturbance] sweep`].
    #[arg(long, value_delimiter = ',')]
    pub levels: Vec<f64>,
    /// Directory for the sweep's files [default: out/<scenario>/sweep/].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Keep each level's log (level-<x>.mcap) instead of deleting it once identified.
    #[arg(long)]
    pub keep_logs: bool,
    /// Print the sweep as JSON on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let scenario = fpkbench::io::scenario_file(&args.scenario, &args.set)?;
    let Some(d) = &scenario.identify.disturbance else {
        anyhow::bail!(
            "{}: no [identify.disturbance] section: the sweep varies the unmeasured disturbance of the paper's section-4 procedure",
            args.scenario.display()
        );
    };
    let levels = if args.levels.is_empty() {
        d.sweep.clone()
    } else {
        args.levels.clone()
    };
    if let Some(bad) = levels.iter().find(|l| !(l.is_finite() && **l >= 0.0)) {
        anyhow::bail!("--levels: levels are finite numbers >= 0, got {bad}");
    }
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| super::default_output(&scenario.variant_name(), "sweep"));
    let _lock = fpkbench::io::output::FolderLock::acquire(&dir)?;
    let mut sweep = Sweep {
        scenario: scenario.name.clone(),
        names: Vec::new(),
        truth: Vec::new(),
        points: Vec::new(),
    };
    for &level in &levels {
        let s = scenario.with_disturbance_level(level);
        let log = dir.join(format!("level-{level}.mcap"));
        let sim = simulate_to(&s, &log, Compression::None)?;
        let r = identify_log(
            &log,
            &Options {
                validate: false,
                ..Options::default()
            },
        )?;
        if !args.keep_logs {
            std::fs::remove_file(&log).map_err(|e| fpkbench::io::output::at(&log, "removing the log", e))?;
        }
        let p = SweepPoint::from_report(level, &r).expect("the scenario has [identify.disturbance]");
        if let Some(it) = r.iterations.first() {
            sweep.names = it.iteration.names.clone();
            sweep.truth = it.truth.clone();
        }
        let finals: Vec<String> = p
            .sequences
            .iter()
            .map(|q| {
                format!(
                    "{} {:.2} % after {} steps ({}; bound {:.2} %)",
                    q.method,
                    100.0 * q.final_worst_rel_error,
                    q.steps,
                    q.stopped_by,
                    100.0 * q.bound_worst_rel_error
                )
            })
            .collect();
        eprintln!(
            "level {level}: step 0 {:.2} %, {} ({:.1} s)",
            100.0 * p.step0_worst_rel_error,
            finals.join(", "),
            sim.seconds + r.timings_s.identify
        );
        sweep.points.push(p);
    }
    let files = report::write_sweep(&sweep, &dir)?;
    if args.json {
        super::emit(&(serde_json::to_string(&sweep)? + "\n"))?;
    } else {
        let mut text = report::sweep_summary(&sweep);
        text += &format!(
            "\nwrote {}\n",
            files
                .iter()
                .map(|f| f.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
        super::emit(&text)?;
    }
    Ok(ExitCode::SUCCESS)
}

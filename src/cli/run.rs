//! `fpkbench run`: simulate, log, identify, report — the bench's main job.

use super::identify::{finish, IdentifyArgs};
use fpkbench::io::output::{refuse_same_file, FolderLock, Staging};
use fpkbench::pipeline::identify_log;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// Simulate a scenario, write its log, identify the unknowns back from the log, and report
/// the accuracy against the truth with plots (all under out/<scenario>/).
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML), e.g. scenarios/duffing2dof.toml.
    pub scenario: PathBuf,
    /// Vary a scenario key without editing the file (repeatable): KEY=VALUE with KEY a
    /// dotted path (simulation.seed, link.1.damping.1) and VALUE in TOML; validated like
    /// the file, recorded in the log and the report; the default output folder is named
    /// after the variant (out/<name>--seed=7/).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Estimate the integrator's bias on every estimate (Richardson): simulate again at
    /// half the step on the same Brownian paths, identify alike, and name the parameters
    /// whose bias exceeds a quarter of their standard error (about doubles the run's time).
    #[arg(long)]
    pub integrator_bias: bool,
    #[command(flatten)]
    pub identify: IdentifyArgs,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let start = Instant::now();
    let scenario = fpkbench::io::scenario_file(&args.scenario, &args.set)?;
    // Unknowns no data could separate are refused before the simulation, not after it.
    if let Err(why) =
        fpkbench::pipeline::preflight(&scenario, args.identify.selection().as_ref(), &args.identify.methods)
    {
        anyhow::bail!("{}: {why}", args.scenario.display());
    }
    let dir = args
        .identify
        .out
        .clone()
        .unwrap_or_else(|| super::default_output(&scenario.variant_name(), ""));
    for f in std::iter::once("run.mcap".to_string()).chain(fpkbench::report::files()) {
        refuse_same_file(&args.scenario, &dir.join(f))?;
    }
    // One run per folder at a time: a second one is refused, not interleaved. The log,
    // report and figures are staged and moved into place together.
    let lock = FolderLock::acquire(&dir)?;
    let staging = Staging::new(&dir)?;
    let staged_log = staging.path().join("run.mcap");
    let sim = super::simulate::simulate_to(&scenario, &staged_log, fpkbench::io::log::Compression::None)?;
    let log = dir.join("run.mcap");
    if !args.identify.json {
        eprintln!(
            "simulated {} samples in {:.2} s -> {} ({:.1} MB)",
            sim.samples,
            sim.seconds,
            log.display(),
            sim.bytes as f64 / 1e6
        );
        eprint!("{}", super::simulate::clipped_line(sim.clipped, sim.samples));
    }
    let mut report = identify_log(&staged_log, &args.identify.options())?;
    if args.integrator_bias {
        if !args.identify.json {
            eprintln!("integrator bias: simulating again at half the step on the same paths");
        }
        report.integrator_bias = Some(fpkbench::pipeline::integrator_bias(
            &scenario,
            &args.identify.options(),
            &report,
        )?);
    }
    report.log = log.display().to_string();
    report.timings_s.simulate = sim.seconds;
    report.timings_s.total = start.elapsed().as_secs_f64();
    let mut a = args.identify.clone();
    a.out = Some(dir);
    finish(&report, &a, Some((lock, staging)))
}

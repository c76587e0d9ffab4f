//! `fpkbench simulate`: scenario in, MCAP log out.

use anyhow::Context;
use fpkbench::io::log::Compression;
use fpkbench::io::output::{refuse_same_file, FolderLock};
use fpkbench::pipeline::{simulate_log, Simulated};
use fpkbench::Scenario;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Simulate a scenario and write its stationary response as an MCAP log.
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
    /// Output log [default: out/<scenario name>/run.mcap].
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Chunk compression of the log. zstd saves little on 8-byte floats and costs several
    /// times the simulation's own time; uncompressed logs are the fast default.
    #[arg(long, value_enum, default_value_t = Compress::None)]
    pub compress: Compress,
    /// Print a JSON summary on stdout instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Chunk compression choices.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum Compress {
    None,
    Zstd,
}

impl From<Compress> for Compression {
    fn from(c: Compress) -> Compression {
        match c {
            Compress::None => Compression::None,
            Compress::Zstd => Compression::Zstd,
        }
    }
}

/// Simulate `scenario` into `output` with a progress bar on stderr.
pub fn simulate_to(scenario: &Scenario, output: &Path, compression: Compression) -> anyhow::Result<Simulated> {
    let sim = &scenario.simulation;
    let total = (sim.trajectories * sim.samples_per_trajectory()) as u64;
    let bar = ProgressBar::new(total);
    bar.set_style(
        ProgressStyle::with_template("simulating {bar:40} {percent:>3}% {human_pos}/{human_len} samples, eta {eta}")
            .expect("valid template"),
    );
    let s = simulate_log(scenario, output, compression, &|n| bar.set_position(n))
        .with_context(|| format!("simulating {}", scenario.name))?;
    bar.finish_and_clear();
    Ok(s)
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let scenario = fpkbench::io::scenario_file(&args.scenario, &args.set)?;
    let output = args
        .output
        .unwrap_or_else(|| super::default_output(&scenario.variant_name(), "run.mcap"));
    refuse_same_file(&args.scenario, &output)?;
    let dir = output
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let _lock = FolderLock::acquire(dir)?;
    let s = simulate_to(&scenario, &output, args.compress.into())?;
    let sim = &scenario.simulation;
    let text = if args.json {
        serde_json::json!({
            "scenario": scenario.name,
            "log": s.log,
            "samples": s.samples,
            "trajectories": sim.trajectories,
            "record_length_s": sim.record_length,
            "sample_interval_s": sim.sample_interval,
            "bytes": s.bytes,
            "bytes_per_sample": s.bytes as f64 / s.samples.max(1) as f64,
            "integration_steps": s.steps,
            "seconds": s.seconds,
            "adc_clipped": s.clipped,
        })
        .to_string()
            + "\n"
    } else {
        format!(
            "wrote {}\n  {} samples ({} trajectories x {} s, every {} s), {:.1} MB ({:.1} bytes/sample)\n  {:.3e} integration steps in {:.2} s ({:.3e} steps/s)\n",
            s.log.display(),
            s.samples,
            sim.trajectories,
            sim.record_length,
            sim.sample_interval,
            s.bytes as f64 / 1e6,
            s.bytes as f64 / s.samples.max(1) as f64,
            s.steps as f64,
            s.seconds,
            s.steps as f64 / s.seconds,
        ) + &clipped_line(s.clipped, s.samples)
    };
    super::emit(&text)?;
    Ok(ExitCode::SUCCESS)
}

/// What the sensors' ADC clipped, as a line (empty when nothing).
pub(super) fn clipped_line(clipped: u64, samples: u64) -> String {
    if clipped == 0 {
        return String::new();
    }
    format!(
        "  WARNING: the ADC ([measurement] adc_range) clipped {clipped} sensor values in \
         {samples} samples: clipping biases every moment; widen adc_range\n"
    )
}

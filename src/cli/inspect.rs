//! `fpkbench inspect`: what a log holds.

use fpkbench::io::log::{read_info, read_samples, LogError};
use std::path::PathBuf;
use std::process::ExitCode;

/// Describe a run log: channels, sample count, record length, truth, scenario.
#[derive(clap::Args)]
pub struct Args {
    /// MCAP log written by `fpkbench simulate` or `run`.
    pub log: PathBuf,
    /// Print JSON on stdout instead of text.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let info = read_info(&args.log)?;
    // Count samples and per-trajectory time span in one streaming pass.
    let mut t_max = 0.0f64;
    let mut trajectories = std::collections::BTreeSet::new();
    let counted = read_samples(&info, |traj, t, _| {
        t_max = t_max.max(t);
        trajectories.insert(traj);
    });
    let (samples, problem) = match counted {
        Ok(n) => (n, None),
        // A truncated or damaged log: describe it and say how much is readable (exit 2).
        Err(LogError::Truncated { readable, .. } | LogError::Corrupt { readable, .. }) => {
            (readable, Some(counted.unwrap_err().to_string()))
        }
        Err(e) => return Err(e.into()),
    };
    let sc = &info.scenario;
    if args.json {
        let v = serde_json::json!({
            "log": info.path,
            "scenario": sc.name,
            "library": info.library,
            "topic": fpkbench::io::log::TOPIC,
            "columns": info.columns,
            "channel_metadata": info.channel_metadata,
            "samples": samples,
            "expected_samples": info.expected_samples(),
            "trajectories": trajectories.len(),
            "record_length_s": t_max,
            "truth": info.truth.iter().map(|(k, v)| (k.clone(), serde_json::json!(v))).collect::<serde_json::Map<_, _>>(),
            "run": info.run,
            "problem": problem,
            "scenario_toml": sc.source,
        });
        super::emit(&(v.to_string() + "\n"))?;
    } else {
        let mut s = String::new();
        s += &format!("log        {}\n", info.path.display());
        s += &format!("written by {}\n", info.library);
        s += &format!(
            "scenario   {}{}\n",
            sc.name,
            if sc.description.is_empty() {
                String::new()
            } else {
                format!(" — {}", sc.description)
            }
        );
        s += &format!("channel    {} (ros2msg/cdr)\n", fpkbench::io::log::TOPIC);
        let units = info.channel_metadata.get("units").cloned().unwrap_or_default();
        s += &format!(
            "columns    {} (one message per instant; each column but t an array over the trajectories)\n",
            units.replace(',', ", ")
        );
        let unmeasured = info.channel_metadata.get("unmeasured").cloned().unwrap_or_default();
        s += &format!(
            "unmeasured {}\n",
            if unmeasured.is_empty() { "none" } else { &unmeasured }
        );
        let averaged = info
            .channel_metadata
            .get("interval_averaged")
            .cloned()
            .unwrap_or_default();
        s += &format!(
            "averaged   {} (mean over the preceding sample interval)\n",
            if averaged.is_empty() { "none" } else { &averaged }
        );
        s += &format!(
            "samples    {} of {} expected, {} trajectories, record length {} s per trajectory\n",
            samples,
            info.expected_samples(),
            trajectories.len(),
            t_max
        );
        s += "run        ";
        s += &info
            .run
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(" ");
        s += "\ntruth\n";
        for (k, v) in &info.truth {
            s += &format!("  {k:<24} {v}\n");
        }
        s += "scenario.toml\n";
        for line in sc.source.lines() {
            s += &format!("  | {line}\n");
        }
        if let Some(p) = &problem {
            s += &format!("PROBLEM: {p}\n");
        }
        super::emit(&s)?;
    }
    Ok(if problem.is_some() {
        ExitCode::from(2)
    } else {
        ExitCode::SUCCESS
    })
}

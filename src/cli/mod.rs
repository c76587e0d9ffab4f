//! Command-line interface: clap subcommands, one module each. Errors print their whole
//! chain to stderr (and, with `--json`, a JSON error object on stdout); exit codes: 0 ok,
//! 1 a run finished but an accuracy gate was exceeded, 2 a method was refused or failed,
//! or a usage, input or I/O error. A closed stdout (broken pipe) exits 0.

mod export;
mod identify;
mod inspect;
mod run;
mod simulate;
mod study;
mod sweep;

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

/// fpkbench: simulate randomly excited nonlinear multi-mass systems, log their response
/// as MCAP, and identify spring and damper characteristics back from the stationary
/// density (Fokker–Planck–Kolmogorov method).
#[derive(Parser)]
#[command(name = "fpkbench", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Run(run::Args),
    Identify(identify::Args),
    Simulate(simulate::Args),
    Inspect(inspect::Args),
    Export(export::Args),
    Sweep(sweep::Args),
    Study(study::Args),
}

pub fn main() -> ExitCode {
    // Ctrl-C, kill or a closed terminal: remove the temporary files of unfinished output
    // (a complete file is already renamed; nothing half-written stays behind).
    let _ = ctrlc::set_handler(|| {
        fpkbench::io::output::remove_all_pending();
        eprintln!("interrupted: unfinished output removed");
        std::process::exit(130);
    });
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    // With --json a failure is a JSON object on stdout too, so a script reading stdout
    // always gets JSON.
    let json = match &cli.command {
        Command::Run(a) => a.identify.json,
        Command::Identify(a) => a.identify.json,
        Command::Sweep(a) => a.json,
        _ => false,
    };
    let result = match cli.command {
        Command::Run(a) => run::run(a),
        Command::Identify(a) => identify::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Inspect(a) => inspect::run(a),
        Command::Export(a) => export::run(a),
        Command::Sweep(a) => sweep::run(a),
        Command::Study(a) => study::run(a),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            if is_broken_pipe(&e) {
                return ExitCode::SUCCESS;
            }
            eprintln!("error: {e}");
            // A cause an error already quotes in its own message (`path: cause`) is not
            // repeated.
            let mut said = e.to_string();
            let mut causes = Vec::new();
            for cause in e.chain().skip(1) {
                let text = cause.to_string();
                if !said.ends_with(&text) {
                    eprintln!("  caused by: {text}");
                    causes.push(text.clone());
                }
                said = text;
            }
            if json {
                let object = serde_json::json!({ "error": e.to_string(), "causes": causes, "exit_code": 2 });
                let _ = emit(&format!("{object}\n"));
            }
            ExitCode::from(2)
        }
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// `out/<scenario name>/<file>`.
pub fn default_output(scenario: &str, file: &str) -> PathBuf {
    PathBuf::from("out").join(scenario).join(file)
}

/// Print to stdout, turning a closed pipe into an error the caller maps to exit 0.
pub fn emit(text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()?;
    Ok(())
}

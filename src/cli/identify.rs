//! `fpkbench identify`: identify the unknowns of a run log and report the accuracy.

use clap::builder::TypedValueParser;
use fpkbench::io::output::{refuse_same_file, FolderLock, Staging};
use fpkbench::model::Term;
use fpkbench::pipeline::{identify, GridSettings, Input, Options, Settings, StrongDensity};
use fpkbench::report;
use fpkbench::report::{MethodReport, Report};
use fpkbench::scenario::{Method, Select};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// `--method`: the registry's names, each with its one-line help.
pub fn method_parser() -> impl TypedValueParser<Value = Method> {
    let values = Method::REGISTERED
        .iter()
        .map(|m| clap::builder::PossibleValue::new(m.name()).help(m.help()));
    clap::builder::PossibleValuesParser::new(values).map(|name| name.parse::<Method>().expect("a registered name"))
}

/// The strong form's density estimate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DensityArg {
    /// Gaussian kernel estimates of the density and its fluxes (default).
    Kernel,
    /// The paper's histogram and central differences (3.12)–(3.15).
    Histogram,
}

/// Options shared by `identify` and `run`.
#[derive(clap::Args, Debug, Clone)]
pub struct IdentifyArgs {
    /// Methods to run (repeatable) [default: the scenario's `[identify] methods`].
    #[arg(long = "method", value_parser = method_parser())]
    pub methods: Vec<Method>,
    /// Print the report as JSON on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Print each stage's wall time on stderr (docs/architecture.md, "Stages and passes";
    /// also in report.json's `timings_s.stages`).
    #[arg(long, short = 'v')]
    pub verbose: bool,
    /// Strong form: how the density is estimated. `kernel`: Gaussian kernel estimates of
    /// the density and of every probability flux, whose smoothing adds no bias; `histogram`:
    /// the paper's procedure as written (histogram, central differences; --bins, --span,
    /// --min-count apply) [default: kernel].
    #[arg(long, value_enum)]
    pub density: Option<DensityArg>,
    /// Strong form (kernel): the kernel's width in standard deviations of each state
    /// variable [default: 1.3·(N/1e5)^(−1/5) for N samples].
    #[arg(long, value_parser = positive)]
    pub smoothing: Option<f64>,
    /// Strong form: bins per dimension, 3..=4096 [default: 26 in 2-D, 20 beyond, fewer when
    /// the samples would fill fewer than 20 per cell on average].
    #[arg(long, value_parser = bins)]
    pub bins: Option<usize>,
    /// Strong form: half-width of the grid box in standard deviations [default: 4.5 in 2-D, 3 beyond].
    #[arg(long, value_parser = positive)]
    pub span: Option<f64>,
    /// Strong form: smallest count of every cell in a difference stencil, >= 1 [default: 5].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub min_count: Option<u32>,
    /// Iterative procedure (`[identify.disturbance]`): stop after this many steps.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=1000))]
    pub max_steps: Option<u64>,
    /// Iterative procedure: stop when every coefficient changes by less than this fraction.
    #[arg(long, value_parser = positive)]
    pub tolerance: Option<f64>,
    /// Structure selection (docs/selection.md): take the unknown terms as candidates
    /// (`[identify.select]`'s, else each link's `[identify.links]`) and identify only those
    /// the data need, chosen by GMM-BIC over the weak form's equations; the report shows
    /// the evidence.
    #[arg(long)]
    pub select: bool,
    /// Structure selection with the candidates powers 1..=N on every link's stiffness and
    /// damping (implies --select).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=15))]
    pub select_powers: Option<u32>,
    /// Skip the validation by re-simulating the identified model.
    #[arg(long)]
    pub no_validate: bool,
    /// Write no figures (SVG, PNG, PDF) and gather nothing only they show: the report's
    /// pages, the log and the numbers are the same.
    #[arg(long)]
    pub no_figures: bool,
    /// Directory for report.json, report.md and the plots [default: out/<scenario>/].
    #[arg(long)]
    pub out: Option<PathBuf>,
}

impl IdentifyArgs {
    /// The pipeline's options. What is not given stays unset: the pipeline resolves it
    /// from the problem's own state (its dimension includes any filter states).
    pub fn options(&self) -> Options {
        let grid = GridSettings {
            bins: self.bins,
            span_std: self.span,
            min_count: self.min_count,
        };
        // Histogram settings given without --density: the histogram is meant.
        let histogram = self.density == Some(DensityArg::Histogram)
            || (self.density.is_none() && grid.is_set() && self.smoothing.is_none());
        Options {
            methods: self.methods.clone(),
            estimators: Settings {
                density: if histogram {
                    StrongDensity::Histogram
                } else {
                    StrongDensity::Kernel
                },
                smoothing: self.smoothing,
                grid,
            },
            validate: !self.no_validate,
            plots: !self.no_figures,
            max_steps: self.max_steps.map(|m| m as usize),
            tolerance: self.tolerance,
            select: self.selection(),
            ..Options::default()
        }
    }
}

impl IdentifyArgs {
    /// `--select`, `--select-powers`: the selection asked for on the command line.
    pub fn selection(&self) -> Option<Select> {
        let powers = self.select_powers.map(|n| (1..=n).map(Term::Power).collect::<Vec<_>>());
        (self.select || powers.is_some()).then(|| Select {
            stiffness: powers.clone(),
            damping: powers,
        })
    }
}

fn bins(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if (3..=4096).contains(&n) => Ok(n),
        _ => Err(format!(
            "must be a whole number 3..=4096 (a difference stencil needs 3 bins), got {s:?}"
        )),
    }
}

fn positive(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        _ => Err(format!("must be a finite number > 0, e.g. 1e-3, got {s:?}")),
    }
}

/// Identify the log and return the report.
#[derive(clap::Args)]
pub struct Args {
    /// MCAP log written by `fpkbench simulate` or `run` (scenario and truth are read from it).
    #[arg(required_unless_present = "model")]
    pub log: Option<PathBuf>,
    /// Model file for measured data (the scenario format with a [data] section; the
    /// coefficients to identify need no values): see docs/data.md.
    #[arg(long, requires = "data", conflicts_with = "log")]
    pub model: Option<PathBuf>,
    /// Measured data: CSV or .npy files, or MCAP files of another tool (the [data] topic's
    /// JSON, ROS 2 CDR or protobuf messages); each file (or each value of the [data]
    /// record column) an independent record.
    #[arg(long, num_args = 1.., requires = "model")]
    pub data: Vec<PathBuf>,
    /// Held-out measured data in the same layout as --data (e.g. a benchmark's test
    /// segment): every identified model is driven by their measured forces from their
    /// first measured state and its displacements compared with theirs sample by sample —
    /// the free-run simulation error (docs/methods.md, "Prediction"). Every excitation's
    /// force must be mapped in [data.columns].
    #[arg(long, num_args = 1.., requires = "model")]
    pub predict: Vec<PathBuf>,
    /// Identify a truncated log (a killed writer) from the samples it still holds, instead
    /// of refusing it; the report says how many of the promised samples were used.
    #[arg(long)]
    pub allow_truncated: bool,
    #[command(flatten)]
    pub identify: IdentifyArgs,
}

/// Write the report files into `staged` (or, without it, a staging folder of the report
/// folder, locked) and move them into place together; print the summary or JSON. Exit 0
/// if every gated method gave estimates within its gate, 1 if one exceeded it, 2 if one
/// was refused or failed (docs/methods.md, "Outcomes and exit codes").
pub fn finish(report: &Report, args: &IdentifyArgs, staged: Option<(FolderLock, Staging)>) -> anyhow::Result<ExitCode> {
    let (_lock, staging) = match staged {
        Some(s) => s,
        None => {
            let dir = report_dir(args, &report.scenario);
            let lock = FolderLock::acquire(&dir)?;
            let staging = Staging::new(&dir)?;
            (lock, staging)
        }
    };
    let writing = std::time::Instant::now();
    report::write_all(report, staging.path())?;
    let writing = writing.elapsed().as_secs_f64();
    // A run's staged log moves in with the report; `identify` never removes a log.
    let files = staging.commit(&report::files())?;
    if args.json {
        super::emit(&(serde_json::to_string(report)? + "\n"))?;
    } else {
        let mut text = report::summary(report);
        text += &report::fit(&format!(
            "\nwrote {} files to {}: {}\n",
            files.len(),
            files
                .first()
                .and_then(|f| f.parent())
                .unwrap_or(Path::new("."))
                .display(),
            files_in_short(&files)
        ));
        super::emit(&text)?;
    }
    let undecided: Vec<&MethodReport> = report
        .methods
        .iter()
        .filter(|m| m.gated && m.outcome.error().is_some())
        .collect();
    for m in &undecided {
        eprintln!(
            "{} {}: {}",
            m.method,
            m.outcome.kind().name(),
            m.outcome.error().unwrap_or("no reason given")
        );
    }
    if args.verbose {
        // The files are written after report.json's timings are taken: their time is
        // printed here only.
        eprintln!(
            "{}  {:<18} {:>8.3} s (report files and figures, after the identification)",
            stage_times(report),
            "writing",
            writing
        );
    }
    for c in &report.failed_checks {
        eprintln!("check failed: {} ({}): {}", c.check, c.method, c.message);
    }
    Ok(if !undecided.is_empty() {
        ExitCode::from(2)
    } else if report.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// The stages' wall times, one line each, and their sum against the identification's.
fn stage_times(report: &Report) -> String {
    let t = &report.timings_s;
    let mut s = String::from("stages (wall time):\n");
    for st in &t.stages {
        s += &format!("  {:<18} {:>8.3} s\n", st.stage, st.s);
    }
    let sum: f64 = t.stages.iter().map(|st| st.s).sum();
    s += &format!("  {:<18} {:>8.3} s (identify {:.3} s", "sum", sum, t.identify);
    if t.simulate > 0.0 {
        s += &format!(", simulate {:.3} s, total {:.3} s", t.simulate, t.total);
    }
    s + ")\n"
}

/// Where the report files go: `--out`, or `out/<scenario>/`.
pub fn report_dir(args: &IdentifyArgs, scenario: &str) -> PathBuf {
    args.out.clone().unwrap_or_else(|| Path::new("out").join(scenario))
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let (input, files) = match (&args.log, &args.model) {
        (Some(log), _) => {
            let mut info = fpkbench::io::log::read_info(log)?;
            info.accept_truncated = args.allow_truncated;
            (Input::log(info), vec![log.clone()])
        }
        (None, Some(model)) => (
            measured_input(
                model,
                &args.data,
                args.identify.selection().as_ref(),
                &args.identify.methods,
            )?,
            args.data.clone(),
        ),
        (None, None) => unreachable!("clap requires one"),
    };
    let dir = report_dir(&args.identify, &input.info.scenario.name);
    for file in files.iter().chain(&args.model) {
        for f in report::files() {
            refuse_same_file(file, &dir.join(f))?;
        }
    }
    let mut options = args.identify.options();
    if !args.predict.is_empty() {
        let model = args.model.as_deref().expect("clap requires --model with --predict");
        options.predict = Some(std::sync::Arc::new(held_out(model, &input, &args.predict)?));
    }
    let report = identify(&input, &options)?;
    finish(&report, &args.identify, None)
}

/// The files written, figures once with their formats: `report.html, report.json,
/// report.md, run.mcap; figures characteristics, densities (.svg, .png, .pdf)`.
fn files_in_short(files: &[std::path::PathBuf]) -> String {
    let names: Vec<String> = files
        .iter()
        .filter_map(|f| f.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    let is_figure = |n: &str| [".svg", ".png", ".pdf"].iter().any(|e| n.ends_with(e));
    let mut figures: Vec<&str> = names
        .iter()
        .filter(|n| is_figure(n))
        .filter_map(|n| n.rsplit_once('.').map(|x| x.0))
        .collect();
    figures.dedup();
    let others: Vec<&str> = names.iter().map(String::as_str).filter(|n| !is_figure(n)).collect();
    let mut s = others.join(", ");
    if !figures.is_empty() {
        s += &format!("; figures {} (.svg, .png, .pdf)", figures.join(", "));
    }
    s
}

/// The model file and its measured data, checked before any identification.
fn measured_input(
    model: &Path,
    data: &[PathBuf],
    select: Option<&Select>,
    methods: &[Method],
) -> anyhow::Result<Input> {
    let scenario = fpkbench::Scenario::from_file(model)?;
    let Some(mapping) = &scenario.data else {
        anyhow::bail!(
            "{}: a model file needs a [data] section mapping the model's quantities onto the data's columns (docs/data.md)",
            model.display()
        );
    };
    let tables = data
        .iter()
        .map(|p| fpkbench::io::table::read_for(p, mapping))
        .collect::<Result<Vec<_>, _>>()?;
    let measured = fpkbench::io::table::measured(&scenario, tables)?;
    let input = Input::tables(scenario, measured);
    fpkbench::pipeline::preflight(&input.info.scenario, select, methods)
        .map_err(|e| anyhow::anyhow!("{}: {e}", model.display()))?;
    fpkbench::pipeline::check_measured(&input).map_err(|e| anyhow::anyhow!("{}: {e}", data[0].display()))?;
    Ok(input)
}

/// `--predict`'s records, read through the model file's [data] like the identification's
/// (a table without its record column is one record); refused unless every excitation's
/// force is in them.
fn held_out(model: &Path, input: &Input, files: &[PathBuf]) -> anyhow::Result<fpkbench::io::table::Measured> {
    let mut scenario = input.info.scenario.clone();
    let mapping = scenario.data.as_mut().expect("a model file has [data]");
    let tables = files
        .iter()
        .map(|p| fpkbench::io::table::read_for(p, mapping))
        .collect::<Result<Vec<_>, _>>()?;
    if let Some(record) = &mapping.record {
        if tables.iter().all(|t| !t.names().contains(record)) {
            mapping.record = None;
        }
    }
    let scenario = &scenario;
    let means = input.measured().map(|d| d.removed_means.as_slice());
    let measured = fpkbench::io::table::measured_with(scenario, tables, means)?;
    let m = fpkbench::model::Model::new(scenario);
    let c = m.columns();
    for (e, name) in m.excitation_names.iter().enumerate() {
        if !measured.present[c.force(e)] {
            anyhow::bail!(
                "{}: --predict drives the identified model by the measured forces, but the excitation `{name}` \
                 has no force column (map `p_{name}` in [data.columns])",
                model.display()
            );
        }
    }
    if !(0..m.masses()).any(|i| measured.present[c.x(i)] && !measured.derived(c.x(i))) {
        anyhow::bail!(
            "{}: --predict compares displacements, and no mass's displacement is mapped in [data.columns]",
            model.display()
        );
    }
    Ok(measured)
}

//! `fpkbench identify`: identify the unknowns of a run log and report the accuracy.

use fpkbench::ident::kernel::KernelOptions;
use fpkbench::ident::strong::GridOptions;
use fpkbench::io::output::{refuse_same_file, FolderLock};
use fpkbench::pipeline::{identify, Options, StrongDensity};
use fpkbench::report;
use fpkbench::report::Report;
use fpkbench::scenario::Method;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Identification method.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum MethodArg {
    /// Weak form: stationarity of test-function expectations from raw moments (default).
    Weak,
    /// Strong form: the paper's FPK residual (3.8) point by point, from kernel estimates of the
    /// density and its fluxes (`--density histogram`: the paper's histogram as written).
    Strong,
    /// Strong form with the product of marginal densities (the paper's experiment, 3.21).
    StrongMarginals,
    /// Baseline (not FPK, ungated): regression of velocity increments on the drift.
    Increments,
    /// Baseline (not FPK, ungated): binned conditional mean increments, then the drift.
    KramersMoyal,
    /// Oracle bound (not FPK, ungated): equation error with the measured forces.
    ForceRegression,
}

impl From<MethodArg> for Method {
    fn from(m: MethodArg) -> Method {
        match m {
            MethodArg::Weak => Method::Weak,
            MethodArg::Strong => Method::Strong,
            MethodArg::StrongMarginals => Method::StrongMarginals,
            MethodArg::Increments => Method::Increments,
            MethodArg::KramersMoyal => Method::KramersMoyal,
            MethodArg::ForceRegression => Method::ForceRegression,
        }
    }
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
    #[arg(long = "method", value_enum)]
    pub methods: Vec<MethodArg>,
    /// Print the report as JSON on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
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
    /// Skip the validation by re-simulating the identified model.
    #[arg(long)]
    pub no_validate: bool,
    /// Directory for report.json, report.md and the plots [default: out/<scenario>/].
    #[arg(long)]
    pub out: Option<PathBuf>,
}

impl IdentifyArgs {
    pub fn options(&self, dim_hint: usize) -> Options {
        let grid = if self.bins.is_some() || self.span.is_some() || self.min_count.is_some() {
            let auto = GridOptions::auto(dim_hint, u64::MAX);
            Some(GridOptions {
                bins: self.bins.unwrap_or(auto.bins),
                span_std: self.span.unwrap_or(auto.span_std),
                min_count: self.min_count.unwrap_or(auto.min_count),
            })
        } else {
            None
        };
        let kernel = self.smoothing.map(|smoothing| KernelOptions {
            smoothing,
            ..KernelOptions::auto(dim_hint, u64::MAX)
        });
        // Histogram settings given without --density: the histogram is meant.
        let histogram = self.density == Some(DensityArg::Histogram)
            || (self.density.is_none() && grid.is_some() && kernel.is_none());
        Options {
            methods: self.methods.iter().map(|&m| m.into()).collect(),
            density: if histogram {
                StrongDensity::Histogram
            } else {
                StrongDensity::Kernel
            },
            kernel,
            grid,
            validate: !self.no_validate,
            max_steps: self.max_steps.map(|m| m as usize),
            tolerance: self.tolerance,
            ..Options::default()
        }
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
    /// Identify a truncated log (a killed writer) from the samples it still holds, instead
    /// of refusing it; the report says how many of the promised samples were used.
    #[arg(long)]
    pub allow_truncated: bool,
    #[command(flatten)]
    pub identify: IdentifyArgs,
}

/// Write the report files, print the summary or JSON; exit 0 if every gate passed, else 1.
pub fn finish(report: &Report, args: &IdentifyArgs) -> anyhow::Result<ExitCode> {
    let dir = report_dir(args, &report.scenario);
    let _lock = FolderLock::acquire(&dir)?;
    let files = report::write_all(report, &dir)?;
    if args.json {
        super::emit(&(serde_json::to_string(report)? + "\n"))?;
    } else {
        let mut text = report::summary(report);
        text += "\nwrote ";
        text += &files
            .iter()
            .map(|f| f.display().to_string())
            .collect::<Vec<_>>()
            .join(", ");
        text += "\n";
        super::emit(&text)?;
    }
    Ok(if report.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// Where the report files go: `--out`, or `out/<scenario>/`.
pub fn report_dir(args: &IdentifyArgs, scenario: &str) -> PathBuf {
    args.out.clone().unwrap_or_else(|| Path::new("out").join(scenario))
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let (info, inputs) = match (&args.log, &args.model) {
        (Some(log), _) => {
            let mut info = fpkbench::io::log::read_info(log)?;
            info.accept_truncated = args.allow_truncated;
            (info, vec![log.clone()])
        }
        (None, Some(model)) => (measured_info(model, &args.data)?, args.data.clone()),
        (None, None) => unreachable!("clap requires one"),
    };
    let dir = report_dir(&args.identify, &info.scenario.name);
    for input in inputs.iter().chain(&args.model) {
        for f in report::files() {
            refuse_same_file(input, &dir.join(f))?;
        }
    }
    let report = identify(&info, &args.identify.options(info.scenario.masses.len() * 2))?;
    finish(&report, &args.identify)
}

/// The model file and its measured data, checked before any identification.
fn measured_info(model: &Path, data: &[PathBuf]) -> anyhow::Result<fpkbench::io::log::LogInfo> {
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
    let measured = fpkbench::io::table::measured(&scenario, &tables)?;
    let info = fpkbench::io::log::LogInfo::of_measured(scenario, measured);
    fpkbench::pipeline::preflight(&info.scenario).map_err(|e| anyhow::anyhow!("{}: {e}", model.display()))?;
    fpkbench::pipeline::check_measured(&info).map_err(|e| anyhow::anyhow!("{}: {e}", data[0].display()))?;
    Ok(info)
}

//! The native part of the `fpkbench` Python package: thin calls into the library. Each
//! call's work runs on a thread of its own while the calling thread waits with the GIL
//! released, looking every [`LOOK`] at Python's signals — Ctrl-C stops the work
//! (`fpkbench::interrupt`) and raises `KeyboardInterrupt` — and handing progress to an
//! optional callback. Errors come back sorted by kind into the package's exception classes
//! (`fpkbench/__init__.py`: `ScenarioError`, `DataError`, `IdentifiabilityError`,
//! `SimulationError`, all `fpkbench.Error`, a `ValueError`). The Python side turns the plain
//! results into numpy arrays and a `Result`.

use fpkbench::ident::IdentError;
use fpkbench::io::log::read_info;
use fpkbench::io::table::{measured, DataError, Table};
use fpkbench::pipeline::{self, Input, Options, PipelineError};
use fpkbench::scenario::{Method, ScenarioError};
use fpkbench::sim::{simulate, ForEach, SimError};
use fpkbench::{interrupt, Model, Scenario};
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc;
use std::time::Duration;

/// How often a waiting call looks at Python's signals and reports progress.
const LOOK: Duration = Duration::from_millis(50);

/// The package's exception class a failure belongs to.
#[derive(Debug, Clone, Copy)]
enum Kind {
    /// A scenario or model that is not valid (its key named), or an argument.
    Scenario,
    /// Measured data that cannot be used as they are (column and row named).
    Data,
    /// The data cannot separate the unknowns (which, and why).
    Identifiability,
    /// The simulation diverged (when, where).
    Simulation,
    /// Anything else the library reports (an unreadable log).
    Other,
}

/// An error on its way to Python: its class, message and what it points at.
#[derive(Debug)]
struct Failure {
    kind: Kind,
    message: String,
    column: Option<String>,
    row: Option<usize>,
    key: Option<String>,
}

impl Failure {
    fn new(kind: Kind, message: impl std::fmt::Display) -> Failure {
        Failure {
            kind,
            message: message.to_string(),
            column: None,
            row: None,
            key: None,
        }
    }

    /// The Python exception: the class by kind, with `column`, `row` and `key` attributes.
    fn into_py(self, py: Python<'_>) -> PyErr {
        let class = match self.kind {
            Kind::Scenario => "ScenarioError",
            Kind::Data => "DataError",
            Kind::Identifiability => "IdentifiabilityError",
            Kind::Simulation => "SimulationError",
            Kind::Other => "Error",
        };
        let made = (|| -> PyResult<PyErr> {
            let cls = py.import("fpkbench")?.getattr(class)?;
            let e = cls.call1((self.message.clone(),))?;
            e.setattr("column", self.column.clone())?;
            e.setattr("row", self.row)?;
            e.setattr("key", self.key.clone())?;
            Ok(PyErr::from_value(e))
        })();
        made.unwrap_or_else(|e| e)
    }
}

impl From<ScenarioError> for Failure {
    /// A dict's mistake is named by its key path, not by a line of the TOML text the
    /// dict was turned into (the user never wrote it).
    fn from(e: ScenarioError) -> Failure {
        match e {
            ScenarioError::Invalid { path, key, message, .. } if path == DICT => Failure {
                key: Some(key.clone()),
                ..Failure::new(Kind::Scenario, format!("{path}, key `{key}`: {message}"))
            },
            ScenarioError::Invalid { ref key, .. } => Failure {
                key: Some(key.clone()),
                ..Failure::new(Kind::Scenario, &e)
            },
            e => Failure::new(Kind::Scenario, e),
        }
    }
}

impl From<DataError> for Failure {
    fn from(e: DataError) -> Failure {
        Failure {
            column: e.column.clone(),
            row: e.row,
            ..Failure::new(Kind::Data, &e)
        }
    }
}

impl From<IdentError> for Failure {
    fn from(e: IdentError) -> Failure {
        let kind = match e {
            IdentError::NotIdentifiable { .. }
            | IdentError::Symmetric { .. }
            | IdentError::Inseparable(_)
            | IdentError::TooLittleData(_) => Kind::Identifiability,
            IdentError::NonFinite(_) | IdentError::ForceModelRejected(_) => Kind::Data,
            _ => Kind::Scenario,
        };
        Failure::new(kind, e)
    }
}

impl From<PipelineError> for Failure {
    fn from(e: PipelineError) -> Failure {
        match e {
            PipelineError::Ident(e) => e.into(),
            PipelineError::Data(e) => e.into(),
            e @ PipelineError::Sim(SimError::Diverged { .. }) => Failure::new(Kind::Simulation, e),
            e => Failure::new(Kind::Other, e),
        }
    }
}

/// Where a dict's mistakes point (`fpkbench/__init__.py` passes it as the label).
const DICT: &str = "<dict>";

/// A scenario or model from its TOML text, or from JSON (a Python dict) turned into TOML.
fn parse(text: &str, label: &str, json: bool) -> Result<Scenario, Failure> {
    let toml_text = if json {
        let v: toml::Value = serde_json::from_str(text).map_err(|e| Failure::new(Kind::Scenario, e))?;
        toml::to_string(&v).map_err(|e| Failure::new(Kind::Scenario, format!("{label}: {e}")))?
    } else {
        text.to_string()
    };
    let stem = std::path::Path::new(label)
        .file_stem()
        .and_then(|s| s.to_str())
        .filter(|_| label != DICT)
        .unwrap_or("scenario")
        .to_string();
    Ok(Scenario::parse(&toml_text, label, &stem)?)
}

fn options(methods: Vec<String>, validate: bool) -> Result<Options, Failure> {
    let methods = methods
        .iter()
        .map(|m| m.parse::<Method>().map_err(|e| Failure::new(Kind::Scenario, e)))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Options {
        methods,
        validate,
        ..Options::default()
    })
}

/// Progress of a call, as the waiting thread reads it: the stage, and within it the
/// samples done and to do.
#[derive(Default)]
struct Progress {
    simulated: AtomicU64,
    /// Samples the simulation will give (0: no simulation).
    to_simulate: u64,
}

impl Progress {
    /// `(stage, done, total)` now, the identification's passes counted from what `input`
    /// has read.
    fn now(&self, input: Option<&Input>) -> (String, u64, u64) {
        let simulated = self.simulated.load(Ordering::Relaxed);
        match input {
            Some(input) if simulated >= self.to_simulate => {
                let per_pass = input.expected_samples().max(1);
                let read = input.samples_read();
                let pass = read.div_ceil(per_pass).max(1);
                (format!("identify, pass {pass}"), read - (pass - 1) * per_pass, per_pass)
            }
            // Measured data being read and checked: no count to show.
            None if self.to_simulate == 0 => ("read data".to_string(), 0, 1),
            _ => ("simulate".to_string(), simulated, self.to_simulate),
        }
    }
}

/// Run `work` on a thread of its own; wait for it with the GIL released, looking every
/// [`LOOK`] at Python's signals and calling `callback(stage, done, total)` when `now()`
/// changed. On a signal's exception (Ctrl-C: `KeyboardInterrupt`) the work is asked to
/// stop, and the exception is raised once it has.
fn interruptible<T: Send>(
    py: Python<'_>,
    callback: Option<&Bound<'_, PyAny>>,
    now: &(dyn Fn() -> (String, u64, u64) + Sync),
    work: impl FnOnce() -> Result<T, Failure> + Send,
) -> PyResult<T> {
    std::thread::scope(|scope| {
        let (tx, rx) = mpsc::channel();
        let worker = scope.spawn(move || {
            let _ = tx.send(work());
        });
        let (mut shown, mut rx) = (None, rx);
        loop {
            // The receiver goes along (it is `Send`, not `Sync`) and comes back.
            let (got, back) = py.detach(move || (rx.recv_timeout(LOOK), rx));
            rx = back;
            match got {
                Ok(result) => {
                    let _ = worker.join();
                    // The finished state, so that a bar ends full.
                    if let (Some(cb), Ok(_)) = (callback, &result) {
                        let state = now();
                        if shown.as_ref() != Some(&state) {
                            cb.call1(state)?;
                        }
                    }
                    return result.map_err(|f| f.into_py(py));
                }
                Err(mpsc::RecvTimeoutError::Timeout) => {}
                // The work panicked: raise its panic here.
                Err(mpsc::RecvTimeoutError::Disconnected) => match worker.join() {
                    Err(panic) => std::panic::resume_unwind(panic),
                    Ok(()) => unreachable!("the worker sends before it ends"),
                },
            }
            let stop = py.check_signals().err().or_else(|| {
                let state = now();
                let changed = shown.as_ref() != Some(&state);
                shown = Some(state.clone());
                callback.filter(|_| changed)?.call1(state).err()
            });
            if let Some(e) = stop {
                interrupt::request();
                let _ = py.detach(|| worker.join());
                interrupt::clear();
                return Err(e);
            }
        }
    })
}

/// Simulate a scenario in memory: (column names, trajectory ids, times, row-major values
/// as little-endian float64 bytes, truth).
#[pyfunction]
#[pyo3(signature = (text, label, json, progress=None))]
#[allow(clippy::type_complexity)]
fn simulate_scenario(
    py: Python<'_>,
    text: &str,
    label: &str,
    json: bool,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<(Vec<String>, Vec<u32>, Vec<f64>, Vec<u8>, Vec<(String, f64)>)> {
    let s = parse(text, label, json).map_err(|f| f.into_py(py))?;
    let n = s.simulation.samples_per_trajectory() * s.simulation.trajectories;
    let p = Progress {
        to_simulate: n as u64,
        ..Progress::default()
    };
    interruptible(py, progress, &|| p.now(None), || {
        let model = Model::new(&s);
        let columns = model.column_names();
        let (mut traj, mut time, mut values) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n * columns.len() * 8),
        );
        let mut sink = ForEach(|j: u32, t: f64, row: &[f64]| {
            traj.push(j);
            time.push(t);
            for v in row {
                values.extend_from_slice(&v.to_le_bytes());
            }
        });
        simulate(&model, &s.simulation, &mut sink, &|k| {
            p.simulated.store(k, Ordering::Relaxed)
        })
        .map_err(|e| Failure::from(PipelineError::from(e)))?;
        Ok((columns, traj, time, values, s.truth()))
    })
}

/// Identify measured columns (each the bytes of a little-endian float64 array) with a model
/// file: the report as JSON.
#[pyfunction]
#[pyo3(signature = (model_text, label, json, names, columns, methods, validate, progress=None))]
#[allow(clippy::too_many_arguments)]
fn identify_table(
    py: Python<'_>,
    model_text: &str,
    label: &str,
    json: bool,
    names: Vec<String>,
    columns: Vec<Vec<u8>>,
    methods: Vec<String>,
    validate: bool,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<String> {
    let prepared = (|| {
        let model = parse(model_text, label, json)?;
        let options = options(methods, validate)?;
        if model.data.is_none() {
            return Err(Failure::new(
                Kind::Scenario,
                format!("{label}: a model needs a [data] section (a \"data\" table) mapping its quantities onto the data's columns"),
            ));
        }
        // Each column arrives as the bytes of a contiguous little-endian float64 array.
        let columns: Vec<Vec<f64>> = columns
            .iter()
            .map(|b| {
                b.chunks_exact(8)
                    .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
                    .collect()
            })
            .collect();
        let table = Table {
            path: PathBuf::from("<data>"),
            names,
            columns,
            record_labels: None,
        };
        Ok((model, table, options))
    })();
    let (model, table, options) = prepared.map_err(|f| f.into_py(py))?;
    let p = Progress::default();
    // Reading and checking the table is a pass over it too: interruptible like the rest.
    let input: std::sync::OnceLock<Input> = std::sync::OnceLock::new();
    interruptible(py, progress, &|| p.now(input.get()), || {
        let data = measured(&model, vec![table.into()])?;
        let read = Input::tables(model, data);
        pipeline::preflight(&read.info.scenario, None, &[]).map_err(|e| Failure {
            message: format!("{label}: {e}"),
            ..Failure::from(e)
        })?;
        pipeline::check_measured(&read).map_err(|e| Failure::new(Kind::Data, format!("<data>: {e}")))?;
        let report = pipeline::identify(input.get_or_init(|| read), &options)?;
        Ok(serde_json::to_string(&report).expect("a report serializes"))
    })
}

/// Simulate a scenario into a temporary log and identify it, as `fpkbench run` does: the
/// report as JSON.
#[pyfunction]
#[pyo3(signature = (text, label, json, methods, validate, progress=None))]
fn run_scenario(
    py: Python<'_>,
    text: &str,
    label: &str,
    json: bool,
    methods: Vec<String>,
    validate: bool,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<String> {
    let (s, options) =
        (|| Ok((parse(text, label, json)?, options(methods, validate)?)))().map_err(|f: Failure| f.into_py(py))?;
    let p = Progress {
        to_simulate: (s.simulation.samples_per_trajectory() * s.simulation.trajectories) as u64,
        ..Progress::default()
    };
    let input = std::sync::OnceLock::<Input>::new();
    interruptible(py, progress, &|| p.now(input.get()), || {
        pipeline::preflight(&s, None, &[]).map_err(|e| Failure {
            message: format!("{label}: {e}"),
            ..Failure::from(e)
        })?;
        static RUNS: AtomicU64 = AtomicU64::new(0);
        let n = RUNS.fetch_add(1, Ordering::Relaxed);
        let log = std::env::temp_dir().join(format!("fpkbench-py-{}-{n}.mcap", std::process::id()));
        let result = (|| {
            let sim = pipeline::simulate_log(&s, &log, Default::default(), &|k| {
                p.simulated.store(k, Ordering::Relaxed)
            })?;
            let info = read_info(&sim.log)?;
            let input = input.get_or_init(|| Input::log(info));
            let mut r = pipeline::identify(input, &options)?;
            r.timings_s.simulate = sim.seconds;
            Ok(serde_json::to_string(&r).expect("a report serializes"))
        })();
        let _ = std::fs::remove_file(&log);
        result.map_err(|e: PipelineError| e.into())
    })
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(simulate_scenario, m)?)?;
    m.add_function(wrap_pyfunction!(identify_table, m)?)?;
    m.add_function(wrap_pyfunction!(run_scenario, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

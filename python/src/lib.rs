//! The native part of the `fpkbench` Python package: thin calls into the library, with
//! the GIL released while they work. The Python side (`fpkbench/__init__.py`) turns their
//! plain results into numpy arrays and a `Result`.

use fpkbench::pipeline::Input;
use fpkbench::io::table::{measured, Table};
use fpkbench::pipeline::{self, Options};
use fpkbench::scenario::Method;
use fpkbench::sim::{simulate, ForEach};
use fpkbench::{Model, Scenario};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;

fn err(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// A scenario or model from its TOML text, or from JSON (a Python dict) turned into TOML.
fn parse(text: &str, label: &str, json: bool) -> PyResult<Scenario> {
    let toml_text = if json {
        let v: toml::Value = serde_json::from_str(text).map_err(err)?;
        toml::to_string(&v).map_err(err)?
    } else {
        text.to_string()
    };
    let stem = std::path::Path::new(label)
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("scenario")
        .to_string();
    Scenario::parse(&toml_text, label, &stem).map_err(err)
}

fn options(methods: Vec<String>, validate: bool) -> PyResult<Options> {
    let methods = methods
        .iter()
        .map(|m| m.parse::<Method>().map_err(err))
        .collect::<PyResult<Vec<_>>>()?;
    Ok(Options {
        methods,
        validate,
        ..Options::default()
    })
}

/// Simulate a scenario in memory: (column names, trajectory ids, times, row-major values
/// as little-endian float64 bytes, truth).
#[pyfunction]
#[allow(clippy::type_complexity)]
fn simulate_scenario(
    py: Python<'_>,
    text: &str,
    label: &str,
    json: bool,
) -> PyResult<(Vec<String>, Vec<u32>, Vec<f64>, Vec<u8>, Vec<(String, f64)>)> {
    let s = parse(text, label, json)?;
    py.detach(|| {
        let model = Model::new(&s);
        let columns = model.column_names();
        let n = s.simulation.samples_per_trajectory() * s.simulation.trajectories;
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
        simulate(&model, &s.simulation, &mut sink, &|_| {}).map_err(err)?;
        Ok((columns, traj, time, values, s.truth()))
    })
}

/// Identify measured columns (each the bytes of a little-endian float64 array) with a model
/// file: the report as JSON.
#[pyfunction]
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
) -> PyResult<String> {
    let model = parse(model_text, label, json)?;
    let options = options(methods, validate)?;
    py.detach(|| {
        // Each column arrives as the bytes of a contiguous little-endian float64 array.
        let columns: Vec<Vec<f64>> = columns
            .iter()
            .map(|b| {
                b.chunks_exact(8)
                    .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
                    .collect()
            })
            .collect();
        if model.data.is_none() {
            return Err(err(format!("{label}: a model needs a [data] section (a \"data\" table) mapping its quantities onto the data's columns")));
        }
        let table = Table {
            path: PathBuf::from("<data>"),
            names,
            columns,
            record_labels: None,
        };
        let data = measured(&model, &[table]).map_err(err)?;
        let input = Input::tables(model, data);
        pipeline::preflight(&input.info.scenario).map_err(|e| err(format!("{label}: {e}")))?;
        pipeline::check_measured(&input).map_err(|e| err(format!("<data>: {e}")))?;
        let report = pipeline::identify(&input, &options).map_err(err)?;
        serde_json::to_string(&report).map_err(err)
    })
}

/// Simulate a scenario into a temporary log and identify it, as `fpkbench run` does: the
/// report as JSON.
#[pyfunction]
fn run_scenario(
    py: Python<'_>,
    text: &str,
    label: &str,
    json: bool,
    methods: Vec<String>,
    validate: bool,
) -> PyResult<String> {
    let s = parse(text, label, json)?;
    let options = options(methods, validate)?;
    py.detach(|| {
        pipeline::preflight(&s).map_err(|e| err(format!("{label}: {e}")))?;
        static RUNS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = RUNS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let log = std::env::temp_dir().join(format!("fpkbench-py-{}-{n}.mcap", std::process::id()));
        let result = pipeline::simulate_log(&s, &log, Default::default(), &|_| {})
            .map_err(err)
            .and_then(|sim| {
                let mut r = pipeline::identify_log(&sim.log, &options).map_err(err)?;
                r.timings_s.simulate = sim.seconds;
                serde_json::to_string(&r).map_err(err)
            });
        let _ = std::fs::remove_file(&log);
        result
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

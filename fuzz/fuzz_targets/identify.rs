//! The identifier on arbitrary sample values: the bytes are read as `f64` values (finite
//! or not) and written, cyclically, over every value of a small log, which is then
//! identified with the weak and strong forms. Identification must end in a report or an
//! error; a method without an error must give finite estimates.
#![no_main]

use fpkbench::io::log::{read_info, read_samples, LogWriter};
use fpkbench::model::Model;
use fpkbench::pipeline::{identify_log, Options};
use fpkbench::sim::{SampleBatch, SampleSink};
use fpkbench::Scenario;
use libfuzzer_sys::fuzz_target;

const SCENARIO: &str = r#"
name = "fuzz"
[[mass]]
name = "m1"
value = 1.0
[[link]]
ends = ["ground", "m1"]
stiffness = { 1 = 10.0, 3 = 20.0 }
damping = { 1 = 0.5 }
[[excitation]]
kind = "white"
sigma = 1.0
acts_on = ["m1"]
[simulation]
dt = 1e-3
record_length = 20.0
sample_interval = 0.1
trajectories = 2
[identify]
methods = ["weak", "strong"]
"#;

fuzz_target!(|data: &[u8]| {
    let values: Vec<f64> = data
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
        .collect();
    if values.is_empty() {
        return;
    }
    let s = Scenario::parse(SCENARIO, "fuzz.toml", "fuzz").unwrap();
    let model = Model::new(&s);
    let path = std::env::temp_dir().join(format!("fpkbench-fuzz-identify-{}.mcap", std::process::id()));
    let mut w = LogWriter::create(&path, &s, &model).unwrap();
    let (cols, traj) = (model.column_names().len(), s.simulation.trajectories);
    let instants = s.simulation.samples_per_trajectory();
    let batch = SampleBatch {
        columns: cols,
        trajectories: traj,
        time: (1..=instants)
            .map(|k| k as f64 * s.simulation.sample_interval)
            .collect(),
        values: (0..instants * cols * traj).map(|i| values[i % values.len()]).collect(),
    };
    w.write(batch).unwrap();
    w.finish().unwrap();
    // The reader refuses non-finite values; identify what it accepts.
    let readable = read_info(&path).is_ok_and(|i| read_samples(&i, |_, _, _| {}).is_ok());
    let options = Options {
        validate: false,
        ..Options::default()
    };
    if let Ok(report) = identify_log(&path, &options) {
        assert!(readable);
        let out = std::env::temp_dir().join(format!("fpkbench-fuzz-identify-{}", std::process::id()));
        fpkbench::report::write_all(&report, &out).unwrap();
        for m in &report.methods {
            assert!(m.outcome.error().is_some() || m.parameters.iter().all(|p| p.estimate.is_finite()));
        }
    }
});

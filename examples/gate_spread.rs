//! Spread over seeds of each method's worst relative error on a scenario at a given
//! record length, through the real pipeline (log written, identified back). The CI
//! accuracy regression's thresholds come from this:
//! `cargo run --release --example gate_spread -- SCENARIO RECORD_LENGTH SEEDS [LEVEL]`
//! (LEVEL: the disturbance level of a scenario with `[identify.disturbance]`).

use fpkbench::io::log::Compression;
use fpkbench::pipeline::{identify_log, simulate_log, Options};
use fpkbench::Scenario;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let mut s = Scenario::from_file(std::path::Path::new(&a[1])).unwrap();
    s.simulation.record_length = a[2].parse().unwrap();
    let seeds: u64 = a[3].parse().unwrap();
    if let Some(level) = a.get(4) {
        s = s.with_disturbance_level(level.parse().unwrap());
    }
    let dir = tempfile::tempdir().unwrap();
    let mut worst: std::collections::BTreeMap<String, Vec<f64>> = Default::default();
    for seed in 0..seeds {
        s.simulation.seed = 1000 + seed;
        let path = dir.path().join("run.mcap");
        simulate_log(&s, &path, Compression::None, &|_| {}).unwrap();
        let r = identify_log(
            &path,
            &Options {
                validate: false,
                ..Options::default()
            },
        )
        .unwrap();
        for mr in &r.methods {
            worst.entry(mr.method.name()).or_default().push(mr.worst_rel_error);
        }
    }
    for (m, mut v) in worst {
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        v.sort_by(|a, b| a.partial_cmp(b).unwrap());
        println!(
            "{m:<17} worst rel error over {} seeds: min {:.4}, median {:.4}, mean {:.4}, sd {:.4}, max {:.4}",
            v.len(),
            v[0],
            v[v.len() / 2],
            mean,
            sd,
            v[v.len() - 1]
        );
    }
}

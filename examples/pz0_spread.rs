//! Spread over seeds of the iterative procedure with no disturbance (`P_z = 0`): how far
//! each sequence's final iterate (and the one-step `direct-force` estimate) moves from step
//! 0, per parameter, in units of the seed standard deviation of step 0. The tolerance of
//! the test `tests/disturbance.rs::with_no_disturbance_the_measured_force_sequence_stays_at_step_0`
//! comes from this:
//! `cargo run --release --example pz0_spread -- SCENARIO RECORD_LENGTH SEEDS`.

use fpkbench::io::log::Compression;
use fpkbench::pipeline::{identify_log, simulate_log, Options};
use fpkbench::scenario::ReportMethod;
use fpkbench::Scenario;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let s = Scenario::from_file(std::path::Path::new(&a[1])).unwrap();
    let mut s = s.with_disturbance_level(0.0);
    s.simulation.record_length = a[2].parse().unwrap();
    let seeds: u64 = a[3].parse().unwrap();
    let dir = tempfile::tempdir().unwrap();
    // Per seed: step 0, then each sequence's final iterate.
    let mut runs: Vec<Vec<Vec<f64>>> = Vec::new();
    let mut names = Vec::new();
    let mut methods = Vec::new();
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
        names = r.iterations[0].iteration.names.clone();
        methods = r.iterations.iter().map(|it| it.method.clone()).collect();
        methods.push(ReportMethod::DirectForce);
        let mut run = vec![r.iterations[0].iteration.steps[0].values.clone()];
        run.extend(r.iterations.iter().map(|it| it.iteration.last().to_vec()));
        let direct = r
            .methods
            .iter()
            .find(|m| m.method == ReportMethod::DirectForce)
            .unwrap();
        run.push(direct.parameters.iter().map(|p| p.estimate).collect());
        runs.push(run);
    }
    let n = runs.len() as f64;
    let stats = |v: Vec<f64>| {
        let mean = v.iter().sum::<f64>() / n;
        let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let max = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        (mean, sd, max)
    };
    for (k, name) in names.iter().enumerate() {
        let (mean0, sd0, _) = stats(runs.iter().map(|r| r[0][k]).collect());
        println!("{name:<16} step 0: mean {mean0:.5}, seed sd {sd0:.5}");
        for (j, m) in methods.iter().enumerate() {
            let (dm, dsd, dmax) = stats(runs.iter().map(|r| (r[j + 1][k] - r[0][k]) / sd0).collect());
            println!("  {m:<15} (final - step 0) / sd0: mean {dm:+.3}, sd {dsd:.3}, max |.| {dmax:.3}");
        }
    }
}

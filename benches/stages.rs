//! The identification's stages on the default scenario, samples in memory: what each stage
//! costs, and what the pass driver's parallelism gives. Run: `cargo bench --bench stages`
//! (add `-- --quick` for a cheap pass).
//!
//! duffing2dof at 64 trajectories × 500 s (320,000 samples) is simulated once and kept;
//! every iteration identifies it with the scenario's methods (weak, strong, strong on the
//! marginals) and the Fisher information, force spectra and distributions beside them,
//! validation and figures off. Criterion times the whole identification on one thread and
//! on all; after it, a summary gives per stage the fastest of interleaved repetitions on
//! each side and their ratio, measured in this one run. A pass runs its accumulators in
//! parallel, each over every sample in order (docs/architecture.md, "Stages and passes"):
//! its ratio is bounded by its slowest accumulator, not by the thread count.

use criterion::{Criterion, Throughput};
use fpkbench::pipeline::{identify, Input, Options};
use fpkbench::report::Report;
use fpkbench::Scenario;
use std::collections::BTreeMap;

fn main() {
    let src = std::fs::read_to_string("scenarios/duffing2dof.toml").unwrap();
    let mut s = Scenario::parse(&src, "duffing2dof.toml", "duffing2dof").unwrap();
    s.simulation.record_length = 500.0;
    let samples = (s.simulation.trajectories * s.simulation.samples_per_trajectory()) as u64;
    let input = Input::simulation(s);
    let options = Options {
        validate: false,
        plots: false,
        ..Options::default()
    };
    // The first identification simulates and keeps the samples; the others replay them.
    identify(&input, &options).unwrap();
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let run = |single: bool| -> Report {
        match single {
            true => one.install(|| identify(&input, &options).unwrap()),
            false => identify(&input, &options).unwrap(),
        }
    };

    let mut cr = Criterion::default().sample_size(10).configure_from_args();
    let mut g = cr.benchmark_group("stages duffing2dof");
    g.throughput(Throughput::Elements(samples));
    g.bench_function("identify, 1 thread", |b| b.iter(|| run(true)));
    g.bench_function("identify, all threads", |b| b.iter(|| run(false)));
    g.finish();

    // Per stage, the fastest of interleaved repetitions on each side.
    let mut best: BTreeMap<(usize, String), [f64; 2]> = BTreeMap::new();
    for _ in 0..5 {
        for (side, single) in [(0, true), (1, false)] {
            let r = run(single);
            for (k, st) in r.timings_s.stages.iter().enumerate() {
                let e = best.entry((k, st.stage.clone())).or_insert([f64::INFINITY; 2]);
                e[side] = e[side].min(st.s);
            }
        }
    }
    println!(
        "\nstages of the identification, {samples} samples in memory, {} threads against 1 (fastest of 5):",
        rayon::current_num_threads()
    );
    println!("{:<20} {:>10} {:>10} {:>8}", "stage", "1 thread", "all", "ratio");
    for ((_, stage), [single, all]) in &best {
        if single.max(*all) >= 1e-3 {
            println!(
                "{stage:<20} {:>8.1} ms {:>7.1} ms {:>8.2}",
                1e3 * single,
                1e3 * all,
                single / all
            );
        }
    }
}

//! A study's items against their simulation floor, measured in one run. Run:
//! `cargo bench --bench study` (add `-- --quick` for a cheap pass).
//!
//! Four items of the default scenario's study (duffing2dof, 64 trajectories × 5000 s,
//! 3.2·10⁶ samples each, the study's own seeds) run as `fpkbench study` runs them: the
//! items in parallel on the thread pool, each simulated in memory and identified, no logs.
//! The floor is the same four items' simulations alone, run the same way, their samples
//! taken at the items' interval and discarded: what a study cannot do without. Criterion
//! times both with the weak form alone; after it, a summary gives the fastest of
//! interleaved repetitions of the floor, the weak form alone and the three default
//! methods, and each study's ratio to the floor (targets: ≤ 1.3 for the weak form, ≤ 1.8
//! for the three methods; docs/performance.md, "Runs and studies"). The study keeps its
//! large tables from one item for the next, as a long study does after its first items.

use criterion::Criterion;
use fpkbench::model::Model;
use fpkbench::pipeline::study::Study;
use fpkbench::report::Outcome;
use fpkbench::sim::{simulate, Discard};
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

/// Items per repetition: two per core on this machine's two cores.
const ITEMS: usize = 4;

fn study(methods: &str) -> Study {
    let text = format!("scenario = \"scenarios/duffing2dof.toml\"\nseeds = {ITEMS}\n{methods}");
    Study::from_text(&text, Path::new("bench study"), "bench", Path::new(".")).unwrap()
}

/// Every item of `study`, in parallel, as `fpkbench study` runs them.
fn run_items(study: &Study) {
    study.items().par_iter().for_each(|item| {
        let rows = study.run_item(item, None).unwrap();
        assert!(
            rows.iter().all(|r| r.outcome != Outcome::Failed),
            "a method failed on an item"
        );
    });
}

/// Every item's simulation alone, in parallel, its samples discarded.
fn simulate_items(study: &Study) {
    study.items().par_iter().for_each(|item| {
        let s = study.scenario_of(item).unwrap();
        simulate(&Model::new(&s), &s.simulation, &mut Discard::default(), &|_| {}).unwrap();
    });
}

fn seconds(f: &mut dyn FnMut()) -> f64 {
    let t = Instant::now();
    f();
    t.elapsed().as_secs_f64()
}

fn main() {
    let weak = study("methods = [\"weak\"]");
    let three = study("");
    let mut c = Criterion::default().sample_size(10).configure_from_args();
    let mut g = c.benchmark_group(format!("study duffing2dof, {ITEMS} items"));
    g.bench_function("the simulation alone (the floor)", |b| b.iter(|| simulate_items(&weak)));
    g.bench_function("the weak form alone", |b| b.iter(|| run_items(&weak)));
    g.finish();

    // The fastest of interleaved repetitions (the machine's cores are shared: contention
    // only ever adds time), after one untimed round that fills the studies' kept tables.
    let mut jobs: [(&str, &mut dyn FnMut()); 3] = [
        ("the simulation alone (the floor)", &mut || simulate_items(&weak)),
        ("the weak form alone", &mut || run_items(&weak)),
        ("weak, strong, strong-marginals", &mut || run_items(&three)),
    ];
    for (_, job) in jobs.iter_mut() {
        job();
    }
    let mut best = [f64::INFINITY; 3];
    for _ in 0..3 {
        for (b, (_, job)) in best.iter_mut().zip(jobs.iter_mut()) {
            *b = b.min(seconds(&mut **job));
        }
    }
    println!(
        "\n== a study's items against their simulation floor ({ITEMS} items of duffing2dof, {} threads, fastest of 3) ==",
        rayon::current_num_threads()
    );
    for ((name, _), t) in jobs.iter().zip(best) {
        println!(
            "{name:<34} {t:>7.3} s = {:.3} s per item = {:.2}x the floor",
            t / ITEMS as f64,
            t / best[0]
        );
    }
    println!("targets: the weak form alone <= 1.3x, the three methods <= 1.8x");
}

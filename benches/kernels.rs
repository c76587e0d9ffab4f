//! The simulator's steppers against one another: the shaped kernel (up to four masses,
//! the shape compiled in), the blocked kernel (any shape, read at run time) and the
//! generic stepper (the reference), on chains of 2–6 masses with a white force on every
//! mass. Run: `cargo bench --bench kernels` (add `-- --quick` for a cheap pass).
//!
//! After criterion's figures, a summary prints trajectory-steps/s on one thread per chain
//! and stepper, and the ratio the target is stated in, measured in this one run: the
//! blocked kernel on five masses ÷ the shaped kernel on four (target ≥ 0.6). The machine's
//! cores are shared, so each figure is the fastest of interleaved repetitions.

use criterion::{Criterion, Throughput};
use fpkbench::model::Model;
use fpkbench::sim::{simulate_stepping, SampleBatch, SampleSink, Stepping, LANES};
use fpkbench::Scenario;
use std::hint::black_box;
use std::time::Instant;

/// A chain ground–m1–…–mn–ground, cubic springs at both walls and in the middle, a
/// white force on every mass; one lane group, no burn-in, one sample at the end.
fn chain(n: usize) -> Scenario {
    let mut t = String::new();
    for i in 1..=n {
        t += &format!("[[mass]]\nname = \"m{i}\"\nvalue = {}\n", 1.0 + 0.25 * i as f64);
    }
    let ends: Vec<String> = std::iter::once("ground".to_string())
        .chain((1..=n).map(|i| format!("m{i}")))
        .chain(std::iter::once("ground".to_string()))
        .collect();
    for (l, pair) in ends.windows(2).enumerate() {
        let cubic = if l == 0 || l == n || l == n / 2 {
            ", 3 = 10.0"
        } else {
            ""
        };
        t += &format!(
            "[[link]]\nends = [\"{}\", \"{}\"]\nstiffness = {{ 1 = 6.0{cubic} }}\ndamping = {{ 1 = 0.3 }}\n",
            pair[0], pair[1]
        );
    }
    for i in 1..=n {
        t += &format!("[[excitation]]\nkind = \"white\"\nsigma = 1.0\nacts_on = [\"m{i}\"]\n");
    }
    t += &format!(
        "[simulation]\ndt = 1e-3\nrecord_length = 50.0\nburn_in = 0.0\nsample_interval = 50.0\ntrajectories = {LANES}\nseed = 1\n"
    );
    Scenario::parse(&t, "chain.toml", "chain").unwrap()
}

/// Drops the samples.
#[derive(Default)]
struct Discard;
impl SampleSink for Discard {
    fn write(&mut self, b: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
        black_box(b);
        Ok(())
    }
}

fn steps(s: &Scenario) -> u64 {
    let sim = &s.simulation;
    (sim.trajectories.div_ceil(LANES) * LANES * sim.samples_per_trajectory() * sim.steps_per_sample()) as u64
}

fn run(s: &Scenario, m: &Model, stepping: Stepping) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    pool.install(|| simulate_stepping(m, &s.simulation, &mut Discard, &|_| {}, stepping))
        .unwrap();
}

fn main() {
    let mut c = Criterion::default().sample_size(10).configure_from_args();
    let chains: Vec<(usize, Scenario, Model)> = (2..=6)
        .map(|n| {
            let s = chain(n);
            let m = Model::new(&s);
            (n, s, m)
        })
        .collect();
    let steppers = [
        ("shaped", Stepping::Fastest),
        ("blocked", Stepping::Blocked),
        ("generic", Stepping::Generic),
    ];
    let mut g = c.benchmark_group("steppers, 1 thread, one lane group");
    for (n, s, m) in &chains {
        g.throughput(Throughput::Elements(steps(s)));
        for (name, stepping) in steppers {
            // Beyond four masses "shaped" falls back to the blocked kernel.
            if *n > 4 && stepping == Stepping::Fastest {
                continue;
            }
            g.bench_function(format!("{n} masses, {name}"), |b| b.iter(|| run(s, m, stepping)));
        }
    }
    g.finish();
    c.final_summary();

    // Rates, one run: the fastest of interleaved repetitions.
    let mut best = vec![[f64::INFINITY; 3]; chains.len()];
    for _ in 0..7 {
        for (c, (n, s, m)) in chains.iter().enumerate() {
            for (k, (_, stepping)) in steppers.iter().enumerate() {
                if *n > 4 && *stepping == Stepping::Fastest {
                    continue;
                }
                let t = Instant::now();
                run(s, m, *stepping);
                best[c][k] = best[c][k].min(t.elapsed().as_secs_f64());
            }
        }
    }
    println!("\n== trajectory-steps/s on one thread, measured in this run ==");
    println!("{:>7} {:>12} {:>12} {:>12}", "masses", "shaped", "blocked", "generic");
    let rate = |c: usize, k: usize| steps(&chains[c].1) as f64 / best[c][k];
    for (c, (n, ..)) in chains.iter().enumerate() {
        let shaped = if *n > 4 {
            "-".to_string()
        } else {
            format!("{:.3e}", rate(c, 0))
        };
        println!("{n:>7} {shaped:>12} {:>12.3e} {:>12.3e}", rate(c, 1), rate(c, 2));
    }
    let (four, five) = (2, 3);
    println!(
        "blocked kernel, 5 masses / shaped kernel, 4 masses: {:.2} (target >= 0.6); \
         blocked / shaped on the same 4 masses: {:.2}; blocked / generic on 5 masses: {:.2}",
        rate(five, 1) / rate(four, 0),
        rate(four, 1) / rate(four, 0),
        rate(five, 1) / rate(five, 2)
    );
}

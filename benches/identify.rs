//! Identification throughput: weak-form moment accumulation (4-D samples per second per
//! core, 9 unknowns, target ≥ 3e7) and the strong form's 20⁴ grid (seconds per 1e7
//! samples, target ≤ 0.3), on duffing2dof samples held in memory.
//! Run: `cargo bench --bench identify` (add `-- --quick` for a cheap pass).

use criterion::{Criterion, Throughput};
use fpkbench::ident::data::StationaryData;
use fpkbench::ident::moments::RawMoments;
use fpkbench::ident::strong::{DensityGrid, GridOptions};
use fpkbench::ident::{weak, Problem};
use fpkbench::sim::{simulate, Collect};
use fpkbench::{Model, Scenario};
use std::hint::black_box;
use std::time::Instant;

fn main() {
    let src = std::fs::read_to_string("scenarios/duffing2dof.toml").unwrap();
    let mut s = Scenario::parse(&src, "duffing2dof.toml", "duffing2dof").unwrap();
    s.simulation.record_length = 12_500.0; // 16 × 125 000 = 2e6 samples
    let p = Problem::new(&s).unwrap();
    let mut c = Collect::default();
    simulate(&Model::new(&s), &s.simulation, &mut c, &|_| {}).unwrap();
    let mut rows: Vec<f64> = Vec::new();
    let mut full_rows: Vec<(u32, f64, Vec<f64>)> = Vec::new();
    for b in &c.batches {
        b.for_each_sample(|j, t, row| {
            rows.extend(p.columns.iter().map(|&k| row[k]));
            full_rows.push((j, t, row.to_vec()));
        });
    }
    let n = rows.len() / 4;
    let deg = weak::moment_degree(&p);

    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let mut cr = Criterion::default().sample_size(10).configure_from_args();
    let mut g = cr.benchmark_group("identification duffing2dof");
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("weak: raw moments to degree 6, 1 thread", |b| {
        b.iter(|| {
            one.install(|| {
                let mut m = weak::accumulator(&p);
                m.add_block(&rows);
                black_box(m.sums[1])
            })
        })
    });
    let grid0 = DensityGrid::new(
        &p,
        &{
            let mut m = RawMoments::new(4, 2);
            m.add_block(&rows);
            m
        },
        GridOptions {
            bins: 20,
            span_std: 3.0,
            min_count: 5,
        },
    )
    .unwrap();
    g.bench_function("strong: fill a 20^4 grid", |b| {
        b.iter(|| {
            let mut grid = grid0.clone();
            for (_, _, r) in &full_rows {
                grid.push(r);
            }
            black_box(grid.inside)
        })
    });
    g.finish();
    cr.final_summary();

    // Ratios in one run.
    let t = Instant::now();
    one.install(|| {
        let mut m = weak::accumulator(&p);
        m.add_block(&rows);
        black_box(m.sums[1]);
    });
    let weak_rate = n as f64 / t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut data = StationaryData::new(&p, deg, s.simulation.record_length, s.simulation.trajectories, 8);
    for (tr, tt, r) in &full_rows {
        data.push(*tr, *tt, r);
    }
    data.finish();
    let est = fpkbench::ident::identify_weak(&p, &data).unwrap();
    let weak_all = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut grid = grid0.clone();
    for (_, _, r) in &full_rows {
        grid.push(r);
    }
    let fill = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let typical = p.typical(&data.total());
    let _ = black_box(fpkbench::ident::identify_strong(&p, &grid, false, &typical));
    let solve = t.elapsed().as_secs_f64();
    println!(
        "\n== identification figures measured in this run (duffing2dof, 4-D state, {} unknowns, {n} samples) ==",
        est.values.len()
    );
    println!(
        "weak form, {} moments to degree {deg}, 1 thread {:>10.3e} samples/s per core (target >= 3e7)",
        weak::accumulator(&p).monomials().len() - 1,
        weak_rate
    );
    println!(
        "weak form, whole estimate (2 threads)       {:>10.3} s for {n} samples",
        weak_all
    );
    println!(
        "strong form, fill 20^4 grid                 {:>10.3} s per 1e7 samples (target <= 0.3)",
        fill / n as f64 * 1e7
    );
    println!(
        "strong form, FPK residual + least squares   {:>10.3} s (independent of the sample count)",
        solve
    );
}

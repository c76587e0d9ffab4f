//! Identification throughput on duffing2dof samples held in memory: weak-form moment
//! accumulation (4-D samples per second per core, 9 unknowns, target ≥ 3e7), the strong
//! form's 20⁴ grid (seconds per 1e7 samples, target ≤ 0.3), the kernel lattice's flux
//! spreading and the kernel form's estimate with its jackknife replicates; the drift's
//! parts (what the pair regressions and the kernel strong form evaluate per sample) one
//! state at a time against 64 states at once, as a ratio; and
//! structure selection among 30 candidates (powers 1..5 on every stiffness and damping)
//! against the weak form's estimate of the 30-term candidate model from the same moments
//! (target: selection ≤ 2× that estimate, docs/selection.md); and the Fisher information of
//! the Cramér–Rao bound, an auxiliary of the second pass, against the weak form's moments
//! on the same samples (target: no dearer than the estimator it serves).
//! Run: `cargo bench --bench identify` (add `-- --quick` for a cheap pass).

use criterion::{Criterion, Throughput};
use fpkbench::ident::accumulate::Accumulator;
use fpkbench::ident::data::StationaryData;
use fpkbench::ident::fisher::FisherInformation;
use fpkbench::ident::moments::RawMoments;
use fpkbench::ident::poly::Compiled;
use fpkbench::ident::strong_histogram::{DensityGrid, GridOptions};
use fpkbench::ident::strong_kernel::{FluxLattice, KernelOptions};
use fpkbench::ident::{weak, Problem};
use fpkbench::sim::{simulate, Collect};
use fpkbench::{Model, Scenario};
use std::hint::black_box;
use std::time::Instant;

/// The samples every bench reads, and what is built from them once.
struct Fixture {
    s: Scenario,
    p: Problem,
    rows: Vec<f64>,
    full_rows: Vec<(u32, f64, Vec<f64>)>,
    n: usize,
    deg: u32,
    candidates: Problem,
    cdata: StationaryData,
    grid0: DensityGrid,
    block_rows: Vec<f64>,
}

impl Fixture {
    fn new() -> Fixture {
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

        // Structure selection: the candidate model's moments, then the search against the
        // weak estimate of the candidate model itself.
        let powers: Vec<fpkbench::model::Term> = (1..=5).map(fpkbench::model::Term::Power).collect();
        let select = fpkbench::scenario::Select {
            stiffness: Some(powers.clone()),
            damping: Some(powers),
        };
        let candidates = Problem::from_spec(
            &fpkbench::ident::Specification::with_links(&s, &select.candidates(&s.links, &s.identify.links)),
            &[],
        )
        .unwrap();
        let mut cdata = StationaryData::for_weak_forms(
            &candidates,
            &[&p],
            s.simulation.record_length,
            s.simulation.trajectories,
            32,
        );
        for (tr, tt, r) in &full_rows {
            cdata.push(*tr, *tt, r);
        }
        cdata.finish();

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
        let block_rows: Vec<f64> = rows
            .chunks_exact(4 * 64)
            .flat_map(|b| (0..4).flat_map(move |j| (0..64).map(move |l| b[l * 4 + j])))
            .collect();
        Fixture {
            s,
            p,
            rows,
            full_rows,
            n,
            deg,
            candidates,
            cdata,
            grid0,
            block_rows,
        }
    }

    /// The drift's parts: known forces, then every unit force per mass.
    fn parts(&self) -> Compiled {
        Compiled::new(self.p.known_force.iter().chain(self.p.unit_force.iter().flatten()))
    }
}

fn main() {
    let f = Fixture::new();
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    benches(&f, &one);
    ratios(&f, &one);
}

/// The criterion benches.
fn benches(f: &Fixture, one: &rayon::ThreadPool) {
    let Fixture {
        s,
        p,
        rows,
        full_rows,
        n,
        candidates,
        cdata,
        grid0,
        block_rows,
        ..
    } = f;
    let n = *n;
    let mut cr = Criterion::default().sample_size(10).configure_from_args();
    let mut g = cr.benchmark_group("identification duffing2dof");
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("weak: raw moments to degree 6, 1 thread", |b| {
        b.iter(|| {
            one.install(|| {
                let mut m = weak::accumulator(p);
                m.add_block(rows);
                black_box(m.sums[1])
            })
        })
    });
    g.bench_function("strong: fill a 20^4 grid", |b| {
        b.iter(|| {
            let mut grid = grid0.clone();
            for (_, _, r) in full_rows.iter() {
                grid.push(r);
            }
            black_box(grid.inside)
        })
    });
    // The kernel strong form's accumulation: every sample's fluxes spread over the lattice
    // (automatic options for 2e6 4-D samples), no jackknife groups.
    let (mean, std): (Vec<f64>, Vec<f64>) = {
        let mut m = RawMoments::new(4, 2);
        m.add_block(rows);
        (0..4).map(|j| (m.mean(j), m.std(j))).unzip()
    };
    let arenas = std::sync::Arc::new(fpkbench::ident::Arenas::default());
    g.bench_function("strong: spread the kernel lattice's fluxes", |b| {
        b.iter(|| {
            let mut l = FluxLattice::new(p, &mean, &std, KernelOptions::auto(4, n as u64), 0, &arenas).unwrap();
            for (_, _, r) in full_rows.iter() {
                l.push_in(0, r);
            }
            l.finish();
            black_box(l.inside)
        })
    });
    // The kernel strong form's estimate from its filled lattice with jackknife groups (32
    // batches): the residual's pieces filtered from the record's lattice and from each
    // group's replicate, each replicate solved (independent of the sample count).
    let (lattice, typical) = {
        let mut data = StationaryData::new(
            p,
            weak::moment_degree(p),
            s.simulation.record_length,
            s.simulation.trajectories,
            32,
        );
        let batching = data.batching();
        let mut l = FluxLattice::new(p, &mean, &std, KernelOptions::auto(4, n as u64), 32, &arenas).unwrap();
        for (tr, tt, r) in full_rows.iter() {
            data.push(*tr, *tt, r);
            l.push_in(batching.batch_of(*tr, *tt), r);
        }
        data.finish();
        l.finish();
        (l, p.typical(&data.total()))
    };
    g.bench_function(
        "strong: the kernel form's estimate with its jackknife replicates",
        |b| b.iter(|| black_box(fpkbench::ident::identify_kernel(p, &lattice, &typical).unwrap().values[0])),
    );
    // The drift's parts: known forces, then every unit force per mass.
    let parts = || f.parts();
    let width = parts().len();
    g.bench_function("drift parts, one state at a time", |b| {
        let (mut c, mut out) = (parts(), vec![0.0; width]);
        b.iter(|| {
            let mut acc = 0.0;
            for y in rows.chunks_exact(4) {
                c.eval(y, &mut out);
                acc += out[width - 1];
            }
            black_box(acc)
        })
    });
    g.bench_function("drift parts, 64 states at once", |b| {
        let (mut c, mut out) = (parts(), vec![0.0; width * 64]);
        b.iter(|| {
            let mut acc = 0.0;
            for y in block_rows.chunks_exact(4 * 64) {
                c.eval_block(y, 64, &mut out);
                acc += out[width * 64 - 1];
            }
            black_box(acc)
        })
    });
    g.bench_function("Fisher information, 1 thread", |b| {
        b.iter(|| black_box(fisher(p, full_rows)))
    });
    g.bench_function("selection among 30 candidates", |b| {
        b.iter(|| black_box(fpkbench::ident::select::select(candidates, cdata).unwrap().criterion))
    });
    g.bench_function("weak estimate of the 30-term candidate model", |b| {
        b.iter(|| black_box(fpkbench::ident::identify_weak(candidates, cdata).unwrap().values[0]))
    });
    g.finish();
    cr.final_summary();
}

/// The Fisher information of every sample and its bound for a path of 1 s.
fn fisher(p: &Problem, rows: &[(u32, f64, Vec<f64>)]) -> Option<Vec<f64>> {
    let mut fi = FisherInformation::new(p).unwrap();
    for (_, _, r) in rows {
        fi.push(r);
    }
    fi.finish();
    fi.bound(1.0)
}

/// Ratios measured in one run.
fn ratios(f: &Fixture, one: &rayon::ThreadPool) {
    let Fixture {
        s,
        p,
        rows,
        full_rows,
        n,
        deg,
        candidates,
        cdata,
        grid0,
        block_rows,
    } = f;
    let (n, deg) = (*n, *deg);
    let parts = || f.parts();
    let width = parts().len();
    let t = Instant::now();
    one.install(|| {
        let mut m = weak::accumulator(p);
        m.add_block(rows);
        black_box(m.sums[1]);
    });
    let weak_rate = n as f64 / t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut data = StationaryData::new(p, deg, s.simulation.record_length, s.simulation.trajectories, 8);
    for (tr, tt, r) in full_rows.iter() {
        data.push(*tr, *tt, r);
    }
    data.finish();
    let est = fpkbench::ident::identify_weak(p, &data).unwrap();
    let weak_all = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut grid = grid0.clone();
    for (_, _, r) in full_rows.iter() {
        grid.push(r);
    }
    let fill = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let typical = p.typical(&data.total());
    let _ = black_box(fpkbench::ident::identify_strong(p, &grid, false, &typical));
    let solve = t.elapsed().as_secs_f64();
    let (mut c, mut out) = (parts(), vec![0.0; width * 64]);
    let t = Instant::now();
    for y in rows.chunks_exact(4) {
        c.eval(y, &mut out[..width]);
        black_box(out[0]);
    }
    let one_by_one = t.elapsed().as_secs_f64();
    let t = Instant::now();
    for y in block_rows.chunks_exact(4 * 64) {
        c.eval_block(y, 64, &mut out);
        black_box(out[0]);
    }
    let blocked = t.elapsed().as_secs_f64();
    let t = Instant::now();
    black_box(fisher(p, full_rows));
    let fisher_time = t.elapsed().as_secs_f64();
    // Each the median of 9 runs, interleaved (one run each is too noisy at tens of ms).
    let chosen = fpkbench::ident::select::select(candidates, cdata).unwrap();
    let (mut sel, mut est_times) = (Vec::new(), Vec::new());
    for _ in 0..9 {
        let t = Instant::now();
        black_box(fpkbench::ident::select::select(candidates, cdata).unwrap());
        sel.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        black_box(fpkbench::ident::identify_weak(candidates, cdata).unwrap());
        est_times.push(t.elapsed().as_secs_f64());
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (selection, candidate_estimate) = (median(&mut sel), median(&mut est_times));
    println!(
        "\n== identification figures measured in this run (duffing2dof, 4-D state, {} unknowns, {n} samples) ==",
        est.values.len()
    );
    println!(
        "weak form, {} moments to degree {deg}, 1 thread {:>10.3e} samples/s per core (target >= 3e7)",
        weak::accumulator(p).monomials().len() - 1,
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
    println!(
        "drift parts ({width} polynomials), 64 at once  {:>10.2}x the rate one state at a time ({:.3e} states/s)",
        one_by_one / blocked,
        (block_rows.len() / 4) as f64 / blocked
    );
    println!(
        "Fisher information (Cramér–Rao), 1 thread  {:>10.2}x the weak form's moments' time ({:.3e} samples/s; target <= 1)",
        fisher_time * weak_rate / n as f64,
        n as f64 / fisher_time
    );
    println!(
        "selection among {} candidates              {:>10.2}x the candidate model's weak estimate ({:.3} s against {:.3} s; target <= 2)",
        chosen.candidates.len(),
        selection / candidate_estimate,
        selection,
        candidate_estimate
    );
}

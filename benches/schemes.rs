//! The integrators' stationary bias against their cost: the table behind the choice of
//! scheme (docs/methods.md, "The integrator's bias"). Run: `cargo bench --bench schemes`.
//!
//! Cost: wall time per simulated second of 64 trajectories on two threads, samples every
//! 0.1 s dropped, the fastest of interleaved repetitions (the machine is shared:
//! contention only adds time), as a ratio to the semi-implicit scheme at `dt = 1e-3` on its
//! fastest kernel, measured in this run.
//!
//! Bias, on systems whose answer is exact:
//! - the linear SDOF (k 10, c 0.5) and the linear 2-DOF chain of `zoo`: the largest
//!   relative error of the sampled stationary variances, from each recursion's discrete
//!   Lyapunov equation (`zoo::sampled_stationary_covariance`, tested against the
//!   simulator in tests/heun.rs and tests/simulation.rs);
//! - the SDOF Duffing oscillator (k1 10, k3 20, c 0.5), whose stationary density is known:
//!   Richardson's estimate of each scheme's bias on `E[x²]` and `E[v²]` from runs at `h`
//!   and `h/2` on the same Brownian paths (the pair's difference is the integrator's, free
//!   of the sampling error), at coarser steps where the biases stand above the pairing's
//!   noise; each scheme's order carries them to the table's steps.

use fpkbench::model::Model;
use fpkbench::scenario::Scheme;
use fpkbench::sim::{simulate_stepping, Discard, Moments, Stepping};
use fpkbench::{zoo, Scenario};
use std::time::Instant;

/// The schemes and steps compared: the reference first.
const CASES: [(Scheme, f64); 6] = [
    (Scheme::SemiImplicit, 1e-3),
    (Scheme::SemiImplicit, 2e-3),
    (Scheme::Heun, 2e-3),
    (Scheme::Heun, 2.5e-3),
    (Scheme::Heun, 3e-3),
    (Scheme::Heun, 4e-3),
];

fn with(s: &Scenario, scheme: Scheme, dt: f64, record: f64) -> Scenario {
    let mut s = s.clone();
    s.simulation.scheme = scheme;
    s.simulation.dt = dt;
    s.simulation.substeps = 1;
    s.simulation.record_length = record;
    s.simulation.burn_in = 10.0;
    s.simulation.sample_interval = 0.1;
    s.simulation.trajectories = 64;
    s
}

/// Seconds per simulated second (of all trajectories), the fastest of `reps`
/// interleaved repetitions of each case.
fn costs(s: &Scenario, reps: usize) -> Vec<f64> {
    let record = 100.0;
    let runs: Vec<(Model, Scenario)> = CASES
        .iter()
        .map(|&(scheme, dt)| {
            let c = with(s, scheme, dt, record);
            (Model::new(&c), c)
        })
        .collect();
    let mut best = vec![f64::INFINITY; runs.len()];
    for _ in 0..reps {
        for (b, (m, c)) in best.iter_mut().zip(&runs) {
            let t = Instant::now();
            simulate_stepping(m, &c.simulation, &mut Discard::default(), &|_| {}, Stepping::Fastest).unwrap();
            *b = b.min(t.elapsed().as_secs_f64() / (record + 10.0));
        }
    }
    best
}

/// The largest relative bias of the sampled stationary variances of a linear model.
fn exact_bias(s: &Scenario, scheme: Scheme, dt: f64) -> f64 {
    let m = Model::new(s);
    let exact = zoo::stationary_covariance(&m).unwrap();
    let d = zoo::sampled_stationary_covariance(&m, scheme, dt).unwrap();
    (0..d.nrows())
        .map(|i| (d[(i, i)] / exact[(i, i)] - 1.0).abs())
        .fold(0.0, f64::max)
}

/// Richardson's bias of `(E[x²], E[v²])` at step `dt`, relative to the exact values.
fn richardson(s: &Scenario, scheme: Scheme, dt: f64, exact: (f64, f64)) -> (f64, f64) {
    let var = |substeps: usize, stepping: Stepping| {
        let mut c = with(s, scheme, dt, 2500.0);
        c.simulation.trajectories = 32;
        c.simulation.substeps = substeps;
        let m = Model::new(&c);
        let mut mo = Moments::new(m.column_names().len());
        simulate_stepping(&m, &c.simulation, &mut mo, &|_| {}, stepping).unwrap();
        (mo.covariance(0, 0), mo.covariance(1, 1))
    };
    let (coarse, fine) = (var(1, Stepping::Fastest), var(2, Stepping::Refined));
    let factor = 1.0 / (1.0 - 0.5f64.powi(scheme.weak_order() as i32));
    (
        factor * (coarse.0 - fine.0) / exact.0,
        factor * (coarse.1 - fine.1) / exact.1,
    )
}

fn main() {
    let sim = "dt = 1e-3\nrecord_length = 1.0\nsample_interval = 0.1";
    let sdof = zoo::linear_sdof(1.0, 10.0, 0.5, 1.0, sim);
    let chain = zoo::linear_2dof(sim);
    let duffing = {
        let src = std::fs::read_to_string("scenarios/sdof_duffing.toml").unwrap();
        Scenario::parse(&src, "sdof_duffing.toml", "sdof_duffing").unwrap()
    };
    let duffing2dof = {
        let src = std::fs::read_to_string("scenarios/duffing2dof.toml").unwrap();
        Scenario::parse(&src, "duffing2dof.toml", "duffing2dof").unwrap()
    };
    let reps = if std::env::args().any(|a| a == "--quick") {
        3
    } else {
        10
    };

    println!("\nThe integrators' stationary bias against their cost (one run)\n");
    let cost_chain = costs(&chain, reps);
    let cost_duffing = costs(&duffing2dof, reps);
    println!("| scheme | dt | cost: linear 2-DOF | cost: duffing2dof | bias: linear SDOF | bias: linear 2-DOF |");
    println!("|---|---:|---:|---:|---:|---:|");
    let (b_sdof, b_chain) = (
        exact_bias(&sdof, CASES[0].0, CASES[0].1),
        exact_bias(&chain, CASES[0].0, CASES[0].1),
    );
    for (k, &(scheme, dt)) in CASES.iter().enumerate() {
        let (s1, c1) = (exact_bias(&sdof, scheme, dt), exact_bias(&chain, scheme, dt));
        println!(
            "| {} | {dt:e} | {:.2} | {:.2} | {s1:.2e} ({:.3}) | {c1:.2e} ({:.3}) |",
            scheme.name(),
            cost_chain[k] / cost_chain[0],
            cost_duffing[k] / cost_duffing[0],
            s1 / b_sdof,
            c1 / b_chain,
        );
    }
    println!(
        "\ncost: time per simulated second ÷ the semi-implicit scheme's at 1e-3 ({:.3e} s and {:.3e} s for 64 \
         trajectories); bias: the largest relative error of a stationary variance (÷ the semi-implicit \
         scheme's at 1e-3)\n",
        cost_chain[0], cost_duffing[0]
    );

    // The Duffing SDOF's density is exact: E[v²] = σ²/2cm, E[x²] by quadrature.
    let (c, sigma) = (0.5, 1.0);
    let mom = zoo::duffing_displacement_moments(10.0, 20.0, c, sigma, 2);
    let exact = (mom[2], sigma * sigma / (2.0 * c));
    println!("SDOF Duffing, Richardson's bias on the same paths (32 × 2500 s), at coarse steps:\n");
    println!("| scheme | dt | E[x²] | E[v²] | carried to the table's step |");
    println!("|---|---:|---:|---:|---|");
    for (scheme, dt, to) in [
        (Scheme::SemiImplicit, 1e-2, 1e-3),
        (Scheme::SemiImplicit, 2e-2, 1e-3),
        (Scheme::Heun, 1e-2, 3e-3),
        (Scheme::Heun, 2e-2, 3e-3),
    ] {
        let (bx, bv) = richardson(&duffing, scheme, dt, exact);
        let scale = (to / dt).powi(scheme.weak_order() as i32);
        println!(
            "| {} | {dt:e} | {bx:+.2e} | {bv:+.2e} | at {to:e}: {:+.2e}, {:+.2e} |",
            scheme.name(),
            bx * scale,
            bv * scale
        );
    }
}

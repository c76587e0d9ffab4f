//! Spread over seeds of the statistics the simulator tests assert, so their tolerances are
//! derived from measurement (run: `cargo run --release --example seed_spread`).

use fpkbench::model::Model;
use fpkbench::scenario::Scheme;
use fpkbench::sim::{simulate, Moments};
use fpkbench::zoo;

fn var(s: &fpkbench::Scenario) -> Moments {
    let m = Model::new(s);
    let mut mo = Moments::new(m.column_names().len());
    simulate(&m, &s.simulation, &mut mo, &|_| {}).unwrap();
    mo
}

fn stats(name: &str, v: &[f64]) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let worst = v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    println!(
        "{name:<44} mean {mean:+.5}  sd {sd:.5}  max|.| {worst:.5}  (n = {})",
        v.len()
    );
}

fn main() {
    let seeds = 10;
    // Semi-implicit linear SDOF (m 1, k 10, c 5): relative variance errors.
    let (ex, ev) = zoo::linear_sdof_variances(1.0, 10.0, 5.0, 1.0);
    for (k, c) in [(10.0, 5.0), (10.0, 0.5)] {
        let s = zoo::linear_sdof(1.0, k, c, 1.0, "dt = 1e-3\nrecord_length = 1.0\nsample_interval = 0.1");
        let m = Model::new(&s);
        let (x, v) = zoo::linear_sdof_variances(1.0, k, c, 1.0);
        for scheme in [Scheme::SemiImplicit, Scheme::EulerMaruyama] {
            let d = zoo::discrete_stationary_covariance(&m, scheme, 1e-3).unwrap();
            println!(
                "theory k {k} c {c} {scheme:?}: var x {:+.6}, var v {:+.6} relative",
                d[(0, 0)] / x - 1.0,
                d[(1, 1)] / v - 1.0
            );
        }
    }
    let (mut rx, mut rv) = (vec![], vec![]);
    for seed in 0..seeds {
        let s = zoo::linear_sdof(
            1.0,
            10.0,
            5.0,
            1.0,
            &format!("dt = 1e-3\nrecord_length = 6250.0\nsample_interval = 0.1\ntrajectories = 32\nseed = {seed}"),
        );
        let m = var(&s);
        rx.push(m.covariance(0, 0) / ex - 1.0);
        rv.push(m.covariance(1, 1) / ev - 1.0);
    }
    stats("SI sdof(k10,c5) var x rel err, T=2e5 s", &rx);
    stats("SI sdof(k10,c5) var v rel err, T=2e5 s", &rv);

    // EM vs SI, common random numbers, reference SDOF (k 10, c 0.5).
    let (mut ratio_x, mut ratio_v) = (vec![], vec![]);
    let base = "dt = 1e-3\nrecord_length = 6250.0\nsample_interval = 0.1\ntrajectories = 32\n";
    for seed in 0..seeds {
        let si = zoo::linear_sdof(1.0, 10.0, 0.5, 1.0, &format!("{base}seed = {seed}"));
        let mut em = si.clone();
        em.simulation.scheme = Scheme::EulerMaruyama;
        let (a, b) = (var(&si), var(&em));
        ratio_x.push(b.covariance(0, 0) / a.covariance(0, 0) - 1.0);
        ratio_v.push(b.covariance(1, 1) / a.covariance(1, 1) - 1.0);
    }
    stats("EM/SI - 1, var x, sdof(k10,c0.5), T=2e5 s", &ratio_x);
    stats("EM/SI - 1, var v, sdof(k10,c0.5), T=2e5 s", &ratio_v);

    // Linear 2-DOF: covariance entries relative to sqrt(var_i var_j).
    let mut worst = vec![];
    for seed in 0..seeds {
        let s = zoo::linear_2dof(&format!(
            "dt = 1e-3\nrecord_length = 6250.0\nsample_interval = 0.1\ntrajectories = 32\nseed = {seed}"
        ));
        let model = Model::new(&s);
        let exact = zoo::stationary_covariance(&model).unwrap();
        let m = var(&s);
        // columns: x1 v1 a1 x2 v2 a2 P1 P2; exact: x1 x2 v1 v2
        let col = [0usize, 3, 1, 4];
        let mut w: f64 = 0.0;
        for i in 0..4 {
            for j in 0..4 {
                let e = (m.covariance(col[i], col[j]) - exact[(i, j)]) / (exact[(i, i)] * exact[(j, j)]).sqrt();
                w = w.max(e.abs());
            }
        }
        worst.push(w);
    }
    stats("2dof worst normalised cov error, T=2e5 s", &worst);

    // OU force variance A²/(2B).
    let mut ou = vec![];
    for seed in 0..seeds {
        let s = zoo::filtered_sdof(
            1.0,
            10.0,
            1.0,
            20.0,
            5.0,
            &format!("dt = 1e-3\nrecord_length = 1250.0\nsample_interval = 0.1\ntrajectories = 32\nseed = {seed}"),
        );
        let m = var(&s);
        ou.push(m.covariance(3, 3) / (20.0f64 * 20.0 / 10.0) - 1.0);
    }
    stats("OU var P rel err (A20,B5), T=4e4 s", &ou);
}

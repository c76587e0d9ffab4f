//! The stochastic Heun scheme (`scheme = "heun"`, docs/methods.md "The integrator's
//! bias"): its recursion's stationary bias against the semi-implicit scheme's (exact, from
//! the discrete Lyapunov equations), and the simulator against that recursion (paired runs
//! on the same Brownian paths, whose difference holds the integrators' errors without the
//! sampling error).

use fpkbench::model::Model;
use fpkbench::scenario::Scheme;
use fpkbench::sim::{simulate_stepping, Moments, Stepping};
use fpkbench::{zoo, Scenario};
use nalgebra::{DMatrix, DVector};

fn moments(s: &Scenario, stepping: Stepping) -> Moments {
    let m = Model::new(s);
    let mut mo = Moments::new(m.column_names().len());
    simulate_stepping(&m, &s.simulation, &mut mo, &|_| {}, stepping).unwrap();
    mo
}

/// Largest relative error of the sampled stationary variances (the diagonal) of `scheme`
/// at step `h` against the exact ones.
fn variance_bias(model: &Model, scheme: Scheme, h: f64) -> f64 {
    let exact = zoo::stationary_covariance(model).unwrap();
    let s = zoo::sampled_stationary_covariance(model, scheme, h).unwrap();
    (0..s.nrows())
        .map(|i| (s[(i, i)] / exact[(i, i)] - 1.0).abs())
        .fold(0.0, f64::max)
}

#[test]
fn heuns_stationary_bias_is_of_second_order_and_a_fraction_of_the_semi_implicit_schemes() {
    let sdof = zoo::linear_sdof(
        1.0,
        10.0,
        0.5,
        1.0,
        "dt = 1e-3\nrecord_length = 1.0\nsample_interval = 0.1",
    );
    let chain = zoo::linear_2dof("dt = 1e-3\nrecord_length = 1.0\nsample_interval = 0.1");
    for s in [&sdof, &chain] {
        let m = Model::new(s);
        let si = variance_bias(&m, Scheme::SemiImplicit, 1e-3);
        let (h2, h4) = (
            variance_bias(&m, Scheme::Heun, 2e-3),
            variance_bias(&m, Scheme::Heun, 4e-3),
        );
        // Second order: halving the step quarters the bias.
        assert!(
            (h4 / h2 - 4.0).abs() < 0.2,
            "{}: Heun's bias at 4e-3 / 2e-3 = {}",
            s.name,
            h4 / h2
        );
        // Two force evaluations per step: at twice the step Heun costs what the
        // semi-implicit scheme does (per force evaluation; benches/simulate.rs measures the
        // kernels), and must be well under a third of its bias there, and at four times.
        assert!(
            h2 < si / 10.0,
            "{}: Heun at 2e-3 {h2:.3e} against semi-implicit at 1e-3 {si:.3e}",
            s.name
        );
        assert!(
            h4 < si / 3.0,
            "{}: Heun at 4e-3 {h4:.3e} against semi-implicit at 1e-3 {si:.3e}",
            s.name
        );
    }
}

#[test]
fn heun_simulation_follows_its_recursion_on_a_linear_chain() {
    // At a coarse step (0.02 s) both schemes' biases are large enough to see, and the two
    // runs share their normals, so the ratio of their variances is precise: the Heun
    // recursion predicts it to within the pairing's spread. Over seeds 1–10 the measured
    // minus predicted ratio was at most 1.6e-4 in any variance (mean |·| 5e-5); the bound is
    // 4e-4. A first-order slip in the scheme (a noise or drift weight off by h/2) moves
    // these ratios by c·h/2m ≈ 1 %.
    let sim = |scheme: &str| {
        format!(
            "dt = 0.02\nrecord_length = 2500.0\nsample_interval = 0.1\ntrajectories = 32\nseed = 7\n\
             scheme = \"{scheme}\""
        )
    };
    let heun = zoo::linear_2dof(&sim("heun"));
    let si = zoo::linear_2dof(&sim("semi-implicit"));
    let (a, b) = (moments(&heun, Stepping::Fastest), moments(&si, Stepping::Fastest));
    let m = Model::new(&heun);
    let ph = zoo::sampled_stationary_covariance(&m, Scheme::Heun, 0.02).unwrap();
    let ps = zoo::sampled_stationary_covariance(&m, Scheme::SemiImplicit, 0.02).unwrap();
    let col = [0usize, 3, 1, 4]; // x1 x2 v1 v2 in the log's column order
    for (i, &c) in col.iter().enumerate() {
        let measured = a.covariance(c, c) / b.covariance(c, c) - 1.0;
        let predicted = ph[(i, i)] / ps[(i, i)] - 1.0;
        println!("state {i}: Heun/semi-implicit − 1 measured {measured:+.5}, predicted {predicted:+.5}");
        assert!(
            (measured - predicted).abs() < 4e-4,
            "state {i}: Heun/semi-implicit − 1 measured {measured:+.5}, predicted {predicted:+.5}"
        );
    }
}

/// The stationary covariance of `(x, v, P)` that the Heun step applies to `m ẍ + c ẋ + k x
/// = P`, `dP = −B P dt + A dW` (the force's exact transition first, then the drift at the
/// step's start with `P_n` and at the predicted end with `P_(n+1)`), written out here in
/// scalars, apart from the simulator's lanes: each column of the one-step map is the step
/// applied to a unit state with no noise, the noise column the step applied to a unit
/// normal from rest.
fn heun_filtered_covariance(m: f64, k: f64, c: f64, a: f64, b: f64, h: f64) -> DMatrix<f64> {
    let rho = (-b * h).exp();
    let sd = a * ((1.0 - rho * rho) / (2.0 * b)).sqrt();
    let step = |y: [f64; 3], z: f64| {
        let [x, v, p] = y;
        let p1 = rho * p + sd * z;
        let f0 = -k * x - c * v + p;
        let (xb, vb) = (x + h * v, v + h * f0 / m);
        let f1 = -k * xb - c * vb + p1;
        [x + h * (v + vb) / 2.0, v + h * (f0 + f1) / (2.0 * m), p1]
    };
    let mut phi = DMatrix::zeros(3, 3);
    for j in 0..3 {
        let mut e = [0.0; 3];
        e[j] = 1.0;
        let col = step(e, 0.0);
        for i in 0..3 {
            phi[(i, j)] = col[i];
        }
    }
    let g = DVector::from_column_slice(&step([0.0; 3], 1.0));
    let q = &g * g.transpose();
    let big = DMatrix::<f64>::identity(9, 9) - phi.kronecker(&phi);
    let sol = big.lu().solve(&DVector::from_column_slice(q.as_slice())).unwrap();
    DMatrix::from_column_slice(3, 3, sol.as_slice())
}

#[test]
fn a_refined_heun_run_measures_its_own_bias_under_a_filtered_force() {
    // Richardson with Heun's order 2, (θ_h − θ_h/2) · 4/3 on the same paths, against the
    // same combination of the recursion above at h and h/2 (which holds its higher-order
    // terms: at h = 0.05, B·h = 0.25, the recursion's bias on the displacement's variance
    // is +0.784 % and Richardson's reading of it +0.836 %). Over seeds 1–10 the paired
    // estimate was within −8.3 % … +12.6 % of the prediction (mean +0.3 %, sd 4.6 %); the
    // bound is 20 %. The velocity's: −9.4 % … +19 % (it shares the pairing's noise).
    let (m, k, c, a, b, h) = (1.0, 10.0, 1.0, 20.0, 5.0, 0.05);
    let sim = |substeps: usize| {
        format!(
            "dt = {h:?}\nrecord_length = 2500.0\nsample_interval = 0.1\ntrajectories = 32\nseed = 3\n\
             scheme = \"heun\"\nsubsteps = {substeps}"
        )
    };
    let coarse = moments(&zoo::filtered_sdof(m, k, c, a, b, &sim(1)), Stepping::Fastest);
    let refined = moments(&zoo::filtered_sdof(m, k, c, a, b, &sim(2)), Stepping::Refined);
    let exact = zoo::stationary_covariance(&Model::new(&zoo::filtered_sdof(m, k, c, a, b, &sim(1)))).unwrap();
    let (at_h, at_half) = (
        heun_filtered_covariance(m, k, c, a, b, h),
        heun_filtered_covariance(m, k, c, a, b, h / 2.0),
    );
    let predicted = 4.0 / 3.0 * (at_h[(0, 0)] - at_half[(0, 0)]) / exact[(0, 0)];
    let richardson = 4.0 / 3.0 * (coarse.covariance(0, 0) - refined.covariance(0, 0)) / exact[(0, 0)];
    assert!(
        (richardson / predicted - 1.0).abs() < 0.2,
        "Richardson {richardson:.6} against the recursion's {predicted:.6}"
    );
    // The filtered force itself is exact in law whatever the scheme (column 3).
    assert_eq!(coarse.count, refined.count);
    let p = coarse.covariance(3, 3) / exact[(2, 2)] - 1.0;
    assert!(p.abs() < 0.03, "the force's variance {p:+.4} off A²/2B");
}

/// Heun is the default scheme, and every shipped scenario names its own: the gates and
/// documented figures of a scenario were measured with the scheme it states, so a default
/// that changes must not change them (docs/simulation.md).
#[test]
fn the_default_scheme_is_heun_and_every_shipped_scenario_states_its_own() {
    let sdof = zoo::linear_sdof(
        1.0,
        10.0,
        0.5,
        1.0,
        "dt = 1e-3\nrecord_length = 10.0\nsample_interval = 0.1",
    );
    assert_eq!(sdof.simulation.scheme, Scheme::Heun);
    let mut files: Vec<_> = std::fs::read_dir("scenarios")
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 10, "{files:?}");
    for path in files {
        let text = std::fs::read_to_string(&path).unwrap();
        let raw: toml::Table = toml::from_str(&text).unwrap();
        let stated = raw
            .get("simulation")
            .and_then(|s| s.get("scheme"))
            .and_then(|s| s.as_str());
        let s = Scenario::from_file(&path).unwrap();
        assert_eq!(stated, Some(s.simulation.scheme.name()), "{}", path.display());
    }
}

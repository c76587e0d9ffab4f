//! The acceleration-augmented drift (docs/theory.md §3) against a noiseless trajectory: with the
//! filtered forces decaying as `Ṗ = −B P`, `ȧ_i` from finite differences of the simulated
//! acceleration must equal the drift [`Problem`] assembles — checking the `K'`, `C'` and `B`
//! terms. The even powers of the m1–m2 link are bounded by the cubic terms of the ground
//! links (a model with a stationary density).

use super::*;
use crate::scenario::Scenario;

const SRC: &str = r#"
[[mass]]
name = "m1"
value = 1.0
[[mass]]
name = "m2"
value = 2.0
[[link]]
ends = ["ground", "m1"]
stiffness = { 1 = 10.0, 3 = 20.0 }
damping = { 1 = 0.5, 3 = 0.1 }
[[link]]
ends = ["m1", "m2"]
stiffness = { 1 = 5.0, 2 = 1.5 }
damping = { 1 = 0.2, 2 = 0.3 }
[[link]]
ends = ["ground", "m2"]
stiffness = { 1 = 8.0, 3 = 10.0 }
damping = { 1 = 0.3, 3 = 0.05 }
[[excitation]]
kind = "filtered"
A = 5.0
B = 3.0
acts_on = ["m1"]
[[excitation]]
kind = "filtered"
A = 4.0
B = 7.0
acts_on = ["m2"]
[simulation]
dt = 1e-3
record_length = 1.0
sample_interval = 0.1
"#;

/// State (x1, v1, x2, v2, P1, P2) derivative.
fn rhs(m: &Model, b: [f64; 2], s: &[f64; 6]) -> [f64; 6] {
    let (x, v) = ([s[0], s[2]], [s[1], s[3]]);
    let mut f = [0.0; 2];
    m.link_forces(&x, &v, &mut f);
    [
        s[1],
        (s[4] + f[0]) / m.mass[0],
        s[3],
        (s[5] + f[1]) / m.mass[1],
        -b[0] * s[4],
        -b[1] * s[5],
    ]
}

fn rk4(m: &Model, b: [f64; 2], s: &mut [f64; 6], h: f64) {
    let add = |a: &[f64; 6], k: &[f64; 6], c: f64| -> [f64; 6] { std::array::from_fn(|i| a[i] + c * k[i]) };
    let k1 = rhs(m, b, s);
    let k2 = rhs(m, b, &add(s, &k1, h / 2.0));
    let k3 = rhs(m, b, &add(s, &k2, h / 2.0));
    let k4 = rhs(m, b, &add(s, &k3, h));
    for i in 0..6 {
        s[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
}

/// The augmented state (x1, v1, a1, x2, v2, a2) of a full state.
fn augmented(m: &Model, b: [f64; 2], s: &[f64; 6]) -> [f64; 6] {
    let d = rhs(m, b, s);
    [s[0], s[1], d[1], s[2], s[3], d[3]]
}

#[test]
fn augmented_drift_matches_finite_differences_of_a_noiseless_trajectory() {
    let sc = Scenario::parse(SRC, "test", "aug").unwrap();
    let m = Model::new(&sc);
    let p = Problem::new(&sc).unwrap();
    assert_eq!(p.layout, crate::ident::Layout::Augmented);
    let b = [3.0, 7.0];
    let truth = Truth::from_pairs(&sc.truth()).expect("a scenario's own truth parses");
    let theta: Vec<f64> = p.true_values(&truth);
    let h = 1e-4;
    let mut s = [0.3, -0.2, -0.1, 0.4, 2.0, -1.5];
    let mut worst: f64 = 0.0;
    for step in 0..20_000 {
        rk4(&m, b, &mut s, h);
        if step % 1000 != 999 {
            continue;
        }
        // Central difference of the acceleration over ±h.
        let (mut up, mut dn) = (s, s);
        rk4(&m, b, &mut up, h);
        rk4(&m, b, &mut dn, -h);
        let (yu, yd, y) = (augmented(&m, b, &up), augmented(&m, b, &dn), augmented(&m, b, &s));
        for (i, col) in [(0usize, 2usize), (1, 5)] {
            let fd = (yu[col] - yd[col]) / (2.0 * h);
            let drift = p.noise_drift(i, &y, &theta);
            let scale = 1.0 + fd.abs();
            worst = worst.max((drift - fd).abs() / scale);
        }
    }
    assert!(
        worst < 1e-6,
        "augmented drift vs finite differences: worst relative mismatch {worst:e}"
    );
    // And a wrong B is caught: the same check with B of mass 1 off by 10 % fails clearly.
    let filters = [
        crate::ident::Filter {
            excitation: 0,
            a: 5.0,
            b: 3.3,
        },
        crate::ident::Filter {
            excitation: 1,
            a: 4.0,
            b: 7.0,
        },
    ];
    let wrong = Problem::with_filters(&sc, &filters).unwrap();
    let mut s = [0.3, -0.2, -0.1, 0.4, 2.0, -1.5];
    for _ in 0..1000 {
        rk4(&m, b, &mut s, h);
    }
    let y = augmented(&m, b, &s);
    let (mut up, mut dn) = (s, s);
    rk4(&m, b, &mut up, h);
    rk4(&m, b, &mut dn, -h);
    let fd = (augmented(&m, b, &up)[2] - augmented(&m, b, &dn)[2]) / (2.0 * h);
    assert!((wrong.noise_drift(0, &y, &theta) - fd).abs() > 1e-3 * (1.0 + fd.abs()));
}

//! Spectral estimate and rational fit (3.20) against a simulated OU force.

use fpkbench::ident::spectrum::{fit_ou, ou_density, sampled_ou_density, Welch};
use fpkbench::sim::{simulate, ForEach};
use fpkbench::{zoo, Model};

#[test]
fn sampled_ou_density_tends_to_the_rational_density_and_integrates_to_the_variance() {
    let (a, b) = (20.0, 5.0);
    for w in [0.5, 3.0, 10.0] {
        let r = sampled_ou_density(a, b, 1e-5, w) / ou_density(a, b, w);
        assert!((r - 1.0).abs() < 1e-4, "{r}");
    }
    // ∫ over (−π/Δ, π/Δ) of the sampled density = A²/(2B).
    let dt = 0.1;
    let n = 200_000;
    let h = 2.0 * std::f64::consts::PI / dt / n as f64;
    let integral: f64 = (0..n)
        .map(|k| sampled_ou_density(a, b, dt, -std::f64::consts::PI / dt + (k as f64 + 0.5) * h) * h)
        .sum();
    assert!((integral / (a * a / (2.0 * b)) - 1.0).abs() < 1e-6, "{integral}");
}

#[test]
fn welch_and_fit_recover_a_and_b_of_a_simulated_ou_force() {
    // A 20, B 5, sampled every 0.1 s, 32 × 1250 s. Over seeds 0–9 (example
    // spectral_spread): A relative error mean −0.03 %, sd 0.17 %, max 0.31 %; B mean
    // −0.17 %, sd 0.25 %, max 0.59 %. Tolerances: A 1 %, B 1.5 % (≥ 4 sd).
    let s = zoo::filtered_sdof(
        1.0,
        10.0,
        1.0,
        20.0,
        5.0,
        "dt = 1e-3\nrecord_length = 1250.0\nsample_interval = 0.1\ntrajectories = 32\nseed = 77",
    );
    let len = Welch::segment_for(5.0, 0.1, s.simulation.samples_per_trajectory());
    let mut welch = Welch::new(len, 0.1, 32);
    let mut feed = ForEach(|traj, _, row: &[f64]| welch.push(traj as usize, row[3]));
    simulate(&Model::new(&s), &s.simulation, &mut feed, &|_| {}).unwrap();
    let spec = welch.spectrum();
    // Parseval: the density integrates (both sides) to the variance A²/(2B) = 40.
    let dw = spec.omega[1] - spec.omega[0];
    let var: f64 = 2.0 * spec.density.iter().sum::<f64>() * dw;
    assert!((var / 40.0 - 1.0).abs() < 0.03, "variance from the spectrum {var}");
    let fit = fit_ou(&spec);
    assert!((fit.a / 20.0 - 1.0).abs() < 0.01, "A = {}", fit.a);
    assert!((fit.b / 5.0 - 1.0).abs() < 0.015, "B = {}", fit.b);
    assert!(fit.rms_log_residual < 2.0 * fit.expected_rms, "{fit:?}");
}

#[test]
fn cross_spectra_give_the_spectrum_of_any_combination() {
    use fpkbench::ident::spectrum::CrossWelch;
    // Two correlated signals: r an AR(1), q partly r, partly its own noise.
    let (mut q, mut r) = (Vec::new(), Vec::new());
    let mut state = 0.0f64;
    let mut u = 12345u64;
    let mut noise = || {
        u = u.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (u >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for _ in 0..20_000 {
        state = 0.9 * state + noise();
        r.push(state);
        q.push(0.7 * state + noise());
    }
    let mut cw = CrossWelch::new(256, 0.01, 2);
    for (k, (&a, &b)) in q.iter().zip(&r).enumerate() {
        cw.push(k % 2, a, b);
    }
    for c in [0.0, -1.3, 2.5] {
        let mut w = Welch::new(256, 0.01, 2);
        for (k, (&a, &b)) in q.iter().zip(&r).enumerate() {
            w.push(k % 2, a + c * b);
        }
        let (x, y) = (cw.spectrum_of(c), w.spectrum());
        assert_eq!(x.segments, y.segments);
        for (dx, dy) in x.density.iter().zip(&y.density) {
            assert!((dx - dy).abs() <= 1e-9 * dy.abs().max(1e-12), "c = {c}: {dx} vs {dy}");
        }
    }
}

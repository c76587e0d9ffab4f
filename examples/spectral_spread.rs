//! Spread over seeds of the fitted A and B of a simulated OU force (the spectral-fit
//! test's tolerance): `cargo run --release --example spectral_spread`.

use fpkbench::ident::spectrum::{fit_ou, Welch};
use fpkbench::sim::{simulate, ForEach};
use fpkbench::{zoo, Model};

fn main() {
    for (a, b, dt, rec) in [(20.0, 5.0, 0.1, 1250.0), (250.0, 50.0, 0.01, 312.5)] {
        let (mut ea, mut eb) = (vec![], vec![]);
        for seed in 0..10 {
            let s = zoo::filtered_sdof(
                1.0,
                10.0,
                1.0,
                a,
                b,
                &format!("dt = 1e-3\nrecord_length = {rec}\nsample_interval = {dt}\ntrajectories = 32\nseed = {seed}"),
            );
            let len = Welch::segment_for(b, dt, s.simulation.samples_per_trajectory());
            let mut welch = Welch::new(len, dt, 32);
            let mut feed = ForEach(|traj, _, row: &[f64]| welch.push(traj as usize, row[3]));
            simulate(&Model::new(&s), &s.simulation, &mut feed, &|_| {}).unwrap();
            let fit = fit_ou(&welch.spectrum());
            ea.push(fit.a / a - 1.0);
            eb.push(fit.b / b - 1.0);
            if seed == 0 {
                println!(
                    "A {a} B {b} dt {dt}: segment {len}, {} segments, rms log residual {:.3} (expected {:.3})",
                    welch.spectrum().segments,
                    fit.rms_log_residual,
                    fit.expected_rms
                );
            }
        }
        let st = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
            (m, sd, v.iter().fold(0.0f64, |a, x| a.max(x.abs())))
        };
        println!(
            "  A rel error mean/sd/max {:?}\n  B rel error mean/sd/max {:?}",
            st(&ea),
            st(&eb)
        );
    }
}

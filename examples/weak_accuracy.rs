//! Weak-form accuracy on a scenario versus record length and seed, straight from the
//! simulator (no log): `cargo run --release --example weak_accuracy -- SCENARIO RECORD SEEDS`.

use fpkbench::ident::data::StationaryData;
use fpkbench::ident::{identify_weak, weak, Problem};
use fpkbench::sim::{simulate, ForEach};
use fpkbench::{Model, Scenario};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mut s = Scenario::from_file(std::path::Path::new(&args[1])).unwrap();
    s.simulation.record_length = args[2].parse().unwrap();
    if let Some(dt) = args.get(4) {
        s.simulation.dt = dt.parse().unwrap();
    }
    let seeds: u64 = args[3].parse().unwrap();
    let p = Problem::new(&s).unwrap();
    let truth = fpkbench::zoo::true_values(&s, &p);
    let mut worst_all = vec![];
    let mut signed_all: Vec<Vec<f64>> = vec![];
    for seed in 0..seeds {
        s.simulation.seed = seed;
        let m = Model::new(&s);
        let mut d = StationaryData::new(
            &p,
            weak::moment_degree(&p),
            s.simulation.record_length,
            s.simulation.trajectories,
            8,
        );
        let t = std::time::Instant::now();
        simulate(
            &m,
            &s.simulation,
            &mut ForEach(|traj, t, row: &[f64]| d.push(traj, t, row)),
            &|_| {},
        )
        .unwrap();
        d.finish();
        let e = identify_weak(&p, &d).unwrap();
        let signed: Vec<f64> = e.values.iter().zip(&truth).map(|(v, t)| (v - t) / t).collect();
        let errs: Vec<f64> = signed.iter().map(|x| x.abs()).collect();
        signed_all.push(signed.clone());
        let worst = errs.iter().cloned().fold(0.0, f64::max);
        worst_all.push(worst);
        if seeds <= 5 {
            println!(
                "seed {seed}: worst {:.4}  [{}]  sv_ratio {:.2e}  ({:.1} s)",
                worst,
                errs.iter()
                    .zip(&p.names)
                    .map(|(e, n)| format!("{n} {e:.3}"))
                    .collect::<Vec<_>>()
                    .join(", "),
                e.diagnostics.sv_ratio,
                t.elapsed().as_secs_f64()
            );
        }
    }
    let ns = signed_all.len() as f64;
    for (k, name) in p.names.iter().enumerate() {
        let m = signed_all.iter().map(|v| v[k]).sum::<f64>() / ns;
        let sd = (signed_all.iter().map(|v| (v[k] - m).powi(2)).sum::<f64>() / (ns - 1.0)).sqrt();
        println!(
            "{name:<16} mean signed rel error {m:+.4} ± {:.4} (sd {sd:.4})",
            sd / ns.sqrt()
        );
    }
    worst_all.sort_by(|a, b| a.partial_cmp(b).unwrap());
    println!(
        "median worst {:.4}, max {:.4}",
        worst_all[worst_all.len() / 2],
        worst_all.last().unwrap()
    );
}

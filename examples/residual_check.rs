//! Diagnostic: the weak-form residual at the TRUE parameters, per test function, against
//! its scatter over time batches — any equation with a significant residual is violated
//! by the data (model or data defect). `cargo run --release --example residual_check -- SCENARIO`.

use fpkbench::ident::data::StationaryData;
use fpkbench::ident::poly::{exponent, monomials};
use fpkbench::ident::{weak, Problem};
use fpkbench::sim::{simulate, ForEach};
use fpkbench::{Model, Scenario};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let s = Scenario::from_file(std::path::Path::new(&a[1])).unwrap();
    let p = Problem::new(&s).unwrap();
    let truth = fpkbench::zoo::true_values(&s, &p);
    let mut d = StationaryData::new(
        &p,
        weak::moment_degree(&p),
        s.simulation.record_length,
        s.simulation.trajectories,
        16,
    );
    simulate(
        &Model::new(&s),
        &s.simulation,
        &mut ForEach(|traj, t, row: &[f64]| d.push(traj, t, row)),
        &|_| {},
    )
    .unwrap();
    d.finish();
    let total = weak::pieces(&p, &d.total());
    let (r, _) = p.residual(&total, &truth);
    let per: Vec<Vec<f64>> = d
        .batches()
        .iter()
        .map(|b| p.residual(&weak::pieces(&p, b), &truth).0.iter().copied().collect())
        .collect();
    let tests = monomials(p.dim(), weak::test_degree(&p));
    let nb = per.len() as f64;
    let mut rows: Vec<(f64, String)> = (0..r.len())
        .map(|k| {
            let m = per.iter().map(|b| b[k]).sum::<f64>() / nb;
            let sd = (per.iter().map(|b| (b[k] - m).powi(2)).sum::<f64>() / (nb - 1.0)).sqrt() / nb.sqrt();
            let name: Vec<String> = (0..p.dim())
                .filter(|&j| exponent(tests[k], j) > 0)
                .map(|j| format!("{}^{}", p.state_names[j], exponent(tests[k], j)))
                .collect();
            (
                r[k] / sd,
                format!("{:<28} residual {:+.3e}  t = {:+.1}", name.join(" "), r[k], r[k] / sd),
            )
        })
        .collect();
    rows.sort_by(|a, b| b.0.abs().partial_cmp(&a.0.abs()).unwrap());
    for (_, line) in rows.iter().take(12) {
        println!("{line}");
    }
}

//! Identification against known answers: exact densities and exact moments.

use fpkbench::ident::moments::RawMoments;
use fpkbench::ident::poly::exponent;
use fpkbench::ident::{weak, Problem};
use fpkbench::{zoo, Model, Scenario};

const SIM: &str = "dt = 1e-3\nrecord_length = 10.0\nsample_interval = 0.1";

fn sdof_duffing(identify: &str) -> Scenario {
    let src = format!(
        "[[mass]]\nname = \"m1\"\nvalue = 1.0\n[[link]]\nends = [\"ground\", \"m1\"]\nstiffness = {{ 1 = 10.0, 3 = 20.0 }}\ndamping = {{ 1 = 0.5 }}\n\
         [[excitation]]\nkind = \"white\"\nsigma = 1.0\nacts_on = [\"m1\"]\n[simulation]\n{SIM}\n{identify}"
    );
    Scenario::parse(&src, "test", "sdof_duffing").unwrap()
}

/// Exact moments of the SDOF Duffing state (x, v): independent, v Gaussian.
fn sdof_exact(deg: u32) -> RawMoments {
    let mx = zoo::duffing_displacement_moments(10.0, 20.0, 0.5, 1.0, deg);
    let var_v: f64 = 1.0 / (2.0 * 0.5 * 1.0);
    let gauss = |b: u32| {
        if b % 2 == 1 {
            0.0
        } else {
            (1..b).step_by(2).map(|k| k as f64).product::<f64>() * var_v.powi(b as i32 / 2)
        }
    };
    RawMoments::exact(2, deg, |e| {
        mx[exponent(e, 0) as usize] * gauss(exponent(e, 1))
    })
}

#[test]
fn weak_form_with_exact_expectations_recovers_sdof_duffing() {
    let p = Problem::new(&sdof_duffing("")).unwrap();
    assert_eq!(p.names, ["k1[ground-m1]", "k3[ground-m1]", "c1[ground-m1]"]);
    let mom = sdof_exact(weak::moment_degree(&p));
    let pc = weak::pieces(&p, &mom);
    let (est, diag) = p.solve(&pc, &p.typical(&mom));
    for (e, t) in est.iter().zip(&p.truth) {
        assert!(((e - t) / t).abs() < 1e-7, "estimate {e} vs truth {t}");
    }
    assert_eq!(diag.rank, 3);
}

#[test]
fn weak_form_with_exact_gaussian_moments_recovers_linear_2dof() {
    let s = zoo::linear_2dof(SIM);
    let p = Problem::new(&s).unwrap();
    assert_eq!(p.names.len(), 6);
    let cov4 = zoo::stationary_covariance(&Model::new(&s)).unwrap();
    // Lyapunov order x1 x2 v1 v2 → problem order x1 v1 x2 v2.
    let perm = [0usize, 2, 1, 3];
    let cov = nalgebra::DMatrix::from_fn(4, 4, |i, j| cov4[(perm[i], perm[j])]);
    let mom = RawMoments::exact(4, weak::moment_degree(&p), |e| {
        zoo::gaussian_moment(&cov, e)
    });
    let pc = weak::pieces(&p, &mom);
    let (est, _) = p.solve(&pc, &p.typical(&mom));
    for ((e, t), n) in est.iter().zip(&p.truth).zip(&p.names) {
        assert!(
            ((e - t) / t).abs() < 1e-10,
            "{n}: estimate {e} vs truth {t}"
        );
    }
}

//! The acceleration-augmented state (docs/theory.md §3) with exact moments: the weak form
//! recovers filtered systems, with known and unknown corners. (The augmented drift against a
//! noiseless trajectory is a unit test of `ident::problem`.)

use fpkbench::ident::Problem;
use fpkbench::{Model, Scenario};

#[test]
fn augmented_weak_form_with_exact_gaussian_moments_recovers_a_linear_sdof() {
    use fpkbench::ident::moments::RawMoments;
    use fpkbench::ident::weak;
    let (m, k, c, a, b) = (1.5, 10.0, 0.8, 3.0, 4.0);
    let s = fpkbench::zoo::filtered_sdof(m, k, c, a, b, "dt = 1e-3\nrecord_length = 10.0\nsample_interval = 0.1");
    let cov = fpkbench::zoo::stationary_covariance(&Model::new(&s)).unwrap(); // (x, v, P)
                                                                              // (x, v, a) = T (x, v, P) with a = (P − k x − c v)/m.
    let t = nalgebra::DMatrix::from_row_slice(3, 3, &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, -k / m, -c / m, 1.0 / m]);
    let cov = &t * cov * t.transpose();
    let p = Problem::new(&s).unwrap();
    assert_eq!(p.layout, fpkbench::ident::Layout::Augmented);
    let mom = RawMoments::exact(3, weak::moment_degree(&p), |e| fpkbench::zoo::gaussian_moment(&cov, e));
    let (est, _) = p.solve(&weak::pieces(&p, &mom), &p.typical(&mom), None);
    for ((e, tr), n) in est.iter().zip(&fpkbench::zoo::true_values(&s, &p)).zip(&p.names) {
        assert!(((e - tr) / tr).abs() < 1e-9, "{n}: {e} vs {tr}");
    }
}

#[test]
fn unknown_corner_is_identified_through_the_bilinear_monomials() {
    use fpkbench::ident::moments::RawMoments;
    use fpkbench::ident::weak;
    let (m, k, c, a, b) = (1.5, 10.0, 0.8, 3.0, 4.0);
    let src = format!(
        "[[mass]]\nname = \"m1\"\nvalue = {m:?}\n[[link]]\nends = [\"ground\", \"m1\"]\nstiffness = {{ 1 = {k:?} }}\ndamping = {{ 1 = {c:?} }}\n\
         [[excitation]]\nname = \"p\"\nkind = \"filtered\"\nA = {a:?}\nB = {b:?}\nacts_on = [\"m1\"]\n\
         [simulation]\ndt = 1e-3\nrecord_length = 10.0\nsample_interval = 0.1\n[identify]\nunknown_corners = [\"p\"]\n"
    );
    let s = Scenario::parse(&src, "test", "corner").unwrap();
    let p = Problem::new(&s).unwrap();
    let text = |names: &[fpkbench::model::UnknownName]| names.iter().map(ToString::to_string).collect::<Vec<_>>();
    assert_eq!(
        text(&p.names),
        [
            "k1[ground-m1]",
            "c1[ground-m1]",
            "B[p]*k1[ground-m1]",
            "B[p]*c1[ground-m1]",
            "B[p]"
        ]
    );
    let cov = fpkbench::zoo::stationary_covariance(&Model::new(&s)).unwrap();
    let t = nalgebra::DMatrix::from_row_slice(3, 3, &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, -k / m, -c / m, 1.0 / m]);
    let cov = &t * cov * t.transpose();
    // Stage 1: the distinct monomials of the unknown drift part (x, v, a here) by linear
    // least squares; stage 2: B, k, c from them.
    let (mono, map) = p.monomial_form();
    assert_eq!(mono.unknowns.len(), 3, "{:?}", mono.names);
    let mom = RawMoments::exact(3, weak::moment_degree(&p), |e| fpkbench::zoo::gaussian_moment(&cov, e));
    let (coefs, diag) = mono.solve(&weak::pieces(&mono, &mom), &mono.typical(&mom), None);
    assert_eq!(diag.rank, 3, "{diag:?}");
    // The monomials' true values: the map applied to the true coefficients and products.
    let true_coefs = fpkbench::zoo::true_values(&s, &p);
    let true_mono = &map * nalgebra::DVector::from_column_slice(&true_coefs[..map.ncols()]);
    for ((e, tr), n) in coefs.iter().zip(true_mono.iter()).zip(&mono.names) {
        assert!(((e - tr) / tr).abs() < 1e-8, "{n}: {e} vs {tr}");
    }
    let (phys, d) = p.recover_physical(&map, &coefs, 1.0);
    assert_eq!(d.rank, 3);
    let truth = fpkbench::zoo::true_values(&s, &p.physical());
    assert_eq!(text(&p.physical().names), ["k1[ground-m1]", "c1[ground-m1]", "B[p]"]);
    for (e, tr) in phys.iter().zip(&truth) {
        assert!(((e - tr) / tr).abs() < 1e-7, "{e} vs {tr}");
    }
}

//! The weak form with the measured force as an input (docs/methods.md, "The weak form with
//! the measured force"): with exact moments it recovers a system under a force it has no
//! model of.

use fpkbench::ident::moments::RawMoments;
use fpkbench::ident::{measured_force, weak, Problem, Specification, Unknown};
use fpkbench::{Model, Scenario};

/// A linear oscillator under a first-order filtered force (3.20), its exact stationary
/// Gaussian moments of `(x, v, P)`; the force read as a measured input. With the mass
/// known every coefficient comes back to 1e-8 — the force's `A` and `B` never enter (its
/// process is not modelled). With the mass unknown the equations have rank 2 of 3, their
/// null direction the mass against the stiffness: of a linear system the one-time moments
/// give `c = E[vP]/E[v²]` and `k E[x²] − m E[v²] = E[xP]` only — the mass is seen in the
/// resonance, which one-time moments do not hold (docs/methods.md).
#[test]
fn exact_moments_give_the_coefficients_without_a_model_of_the_force_and_not_a_linear_mass() {
    let (m, k, c, a, b) = (1.5, 10.0, 0.8, 3.0, 4.0);
    let s = fpkbench::zoo::filtered_sdof(m, k, c, a, b, "dt = 1e-3\nrecord_length = 10.0\nsample_interval = 0.1");
    let cov = fpkbench::zoo::stationary_covariance(&Model::new(&s)).unwrap(); // (x, v, P)
    let exact = |p: &Problem| RawMoments::exact(3, weak::moment_degree(p), |e| fpkbench::zoo::gaussian_moment(&cov, e));
    for unknown_mass in [false, true] {
        let mut spec = Specification::from_scenario(&s);
        if unknown_mass {
            spec.unknown_masses = vec![0];
        }
        // The mechanical problem, the filter taken as white noise of any level: the level
        // is replaced by the measured force. (An unknown mass under white noise alone is
        // the fluctuation–dissipation symmetry, so the white problem is built unchecked.)
        let white = spec.whitened(&spec.given_filters());
        let mechanical = Problem::from_spec_unchecked(&white, &[]).unwrap();
        let p = measured_force::problem(&mechanical, &[0]).unwrap();
        assert_eq!((p.inputs, p.white.len(), p.dim()), (1, 0, 3));
        assert_eq!(p.state_names, ["x_m1", "v_m1", "p_m1"]);
        assert!(fpkbench::ident::exact_symmetry(&p).is_none());
        let mom = exact(&p);
        let (est, diag) = p.solve(&weak::pieces(&p, &mom), &p.typical(&mom), None);
        if unknown_mass {
            assert_eq!(p.unknowns[2], Unknown::Mass(0));
            assert_eq!(diag.rank, 2, "{diag:?}");
            let d = &diag.weakest_direction;
            assert!(d[0].abs() > 0.3 && d[1].abs() < 1e-9 && d[2].abs() > 0.3, "{diag:?}");
            continue;
        }
        assert_eq!(diag.rank, p.unknowns.len(), "{diag:?}");
        let truth = fpkbench::zoo::true_values(&s, &p);
        for ((e, tr), n) in est.iter().zip(&truth).zip(&p.names) {
            assert!(
                ((e - tr) / tr).abs() < 1e-8,
                "mass unknown {unknown_mass}: {n}: {e} vs {tr}"
            );
        }
    }
}

/// A white force stays noise: the method says it has nothing to read, and a force whose
/// intensity is itself an unknown is refused with the reason.
#[test]
fn white_forces_stay_noise() {
    let src = std::fs::read_to_string("scenarios/sdof_duffing.toml").unwrap();
    let s = Scenario::parse(&src, "sdof_duffing.toml", "t").unwrap();
    let mut spec = Specification::from_scenario(&s);
    spec.unknown_intensities = vec![0];
    let p = Problem::from_spec_unchecked(&spec, &[]).unwrap();
    let err = measured_force::problem(&p, &[0]).unwrap_err().to_string();
    assert!(err.contains("intensity") && err.contains("unknown"), "{err}");
}

//! The term paths of [`super::Problem`] against the polynomial ones, and its limits.

use super::*;
use crate::scenario::Scenario;

/// Known terms kept beside the polynomial part (the place of a term without a
/// polynomial form) enter the moment equations through their polynomial form exactly as the
/// polynomial part does, white and filtered.
#[test]
fn known_terms_enter_the_drift_as_their_polynomial_form() {
    for file in ["duffing2dof", "filtered2dof"] {
        let path = format!("{}/scenarios/{file}.toml", env!("CARGO_MANIFEST_DIR"));
        let mut s = Scenario::parse(&std::fs::read_to_string(&path).unwrap(), &path, "t").unwrap();
        // Identify the first link only; the others are known.
        s.identify.links.retain(|l| l.link == 0);
        let spec = Specification::from_scenario(&s);
        let mut moved = spec.clone();
        moved.model = spec.model.with_powers_as_other_terms();
        assert!(!moved.model.other_terms.is_empty());
        let filters = spec.given_filters();
        let (a, b) = (
            Problem::from_spec(&spec, &filters).unwrap(),
            Problem::from_spec(&moved, &filters).unwrap(),
        );
        assert_eq!(a.known_force, b.known_force, "{file}");
        assert_eq!(a.unit_force, b.unit_force, "{file}");
        assert_eq!((a.pmax, &a.names), (b.pmax, &b.names), "{file}");
    }
}

/// More variables than a monomial holds (thirteen masses: 26) are refused with the reason,
/// never packed into wrong exponents.
#[test]
fn a_state_beyond_the_monomials_variables_is_refused() {
    let mut t = String::new();
    for i in 1..=13 {
        t += &format!("[[mass]]\nname = \"m{i}\"\nvalue = 1.0\n");
        let from = if i == 1 {
            "ground".to_string()
        } else {
            format!("m{}", i - 1)
        };
        t += &format!("[[link]]\nends = [\"{from}\", \"m{i}\"]\nstiffness = {{ 1 = 10.0 }}\ndamping = {{ 1 = 0.5 }}\n");
        t += &format!("[[excitation]]\nkind = \"white\"\nsigma = 1.0\nacts_on = [\"m{i}\"]\n");
    }
    t += "[simulation]\ndt = 1e-3\nrecord_length = 10.0\nsample_interval = 0.1\n";
    let s = Scenario::parse(&t, "chain13.toml", "chain13").unwrap();
    match Problem::new(&s) {
        Err(IdentError::Unsupported(why)) => {
            assert!(why.contains("at most 25 variables") && why.contains("has 26"), "{why}")
        }
        other => panic!("{other:?}"),
    }
    // Twelve masses (24 variables) are still taken.
    let twelve = t.split("[[mass]]\nname = \"m13\"").next().unwrap().to_string()
        + "[simulation]\ndt = 1e-3\nrecord_length = 10.0\nsample_interval = 0.1\n";
    assert!(Problem::new(&Scenario::parse(&twelve, "chain12.toml", "chain12").unwrap()).is_ok());
}

/// `file`'s scenario at `record_length` × 32 trajectories with its first link known (its
/// terms enter the known force), the others unknown, and its samples.
fn first_link_known(file: &str, record_length: f64) -> (Scenario, crate::sim::Collect) {
    let path = format!("{}/scenarios/{file}.toml", env!("CARGO_MANIFEST_DIR"));
    let mut s = Scenario::parse(&std::fs::read_to_string(&path).unwrap(), &path, "t").unwrap();
    s.simulation.record_length = record_length;
    s.simulation.trajectories = 32;
    s.identify.links.retain(|l| l.link != 0);
    let mut samples = crate::sim::Collect::default();
    crate::sim::simulate(&Model::new(&s), &s.simulation, &mut samples, &|_| {}).unwrap();
    (s, samples)
}

/// The same names, and estimates and standard errors within 1e-6 of a standard error.
fn assert_same_estimates(a: &crate::ident::Estimate, b: &crate::ident::Estimate, what: &str) {
    assert_eq!(a.names, b.names);
    for k in 0..a.values.len() {
        let (x, y) = (a.values[k], b.values[k]);
        assert!(
            (x - y).abs() <= 1e-6 * a.std_error[k],
            "{what} {}: {x} against {y}",
            a.names[k]
        );
        let (x, y) = (a.std_error[k], b.std_error[k]);
        assert!(
            (x - y).abs() <= 1e-6 * x,
            "{what} {} standard error: {x} against {y}",
            a.names[k]
        );
    }
}

/// The weak form through [`Atom`]s — generalised moments `E[t(z) y^β]` accumulated from
/// each sample's link motion, the path of a term without a polynomial form — gives the
/// estimates and standard errors of the polynomial path on the same samples, white and
/// filtered, known and unknown terms alike.
#[test]
fn the_weak_form_through_atoms_matches_the_polynomial_form() {
    use crate::ident::{data::StationaryData, identify_weak, weak};
    for file in ["duffing2dof", "filtered2dof"] {
        let (s, samples) = first_link_known(file, 2500.0);
        let spec = Specification::from_scenario(&s);
        let filters = spec.given_filters();
        let poly = Problem::from_spec(&spec, &filters).unwrap();
        // Every link white; the filtered state's slopes double the atoms, so two links.
        let links: &[usize] = if file == "duffing2dof" { &[0, 1, 2] } else { &[1, 2] };
        let atoms = Problem::with_terms_as_atoms(&spec, &filters, links).unwrap();
        assert!(
            poly.atoms.is_empty() && atoms.atoms.len() >= 6,
            "{file}: {} atoms",
            atoms.atoms.len()
        );
        let estimate = |p: &Problem| {
            let mut data = StationaryData::new(p, weak::moment_degree(p), 2500.0, 32, 8);
            for b in &samples.batches {
                b.for_each_sample(|j, t, row| data.push(j, t, row));
            }
            data.finish();
            identify_weak(p, &data).unwrap()
        };
        assert_same_estimates(&estimate(&poly), &estimate(&atoms), file);
    }
}

/// The strong forms through [`Atom`]s — the kernel form valuing each sample's terms from
/// its link motion, the histogram forms valuing them at the cells' stencil points from the
/// state — give the estimates and standard errors of the polynomial path on the same
/// samples.
#[test]
fn the_strong_forms_through_atoms_match_the_polynomial_form() {
    use crate::ident::data::StationaryData;
    use crate::ident::strong_histogram::{DensityGrid, GridOptions};
    use crate::ident::strong_kernel::{FluxLattice, KernelOptions};
    use crate::ident::{identify_kernel, identify_strong, weak};
    let (s, samples) = first_link_known("duffing2dof", 1250.0);
    let spec = Specification::from_scenario(&s);
    let poly = Problem::from_spec(&spec, &[]).unwrap();
    let atoms = Problem::with_terms_as_atoms(&spec, &[], &[0, 1, 2]).unwrap();
    assert!(atoms.atoms.len() >= 6 && atoms.density_dim() == poly.dim());
    let arenas = std::sync::Arc::new(crate::ident::Arenas::default());
    let estimates = |p: &Problem| {
        let mut data = StationaryData::new(p, weak::moment_degree(p), 1250.0, 32, 8);
        for b in &samples.batches {
            b.for_each_sample(|j, t, row| data.push(j, t, row));
        }
        data.finish();
        let total = data.total();
        let d = p.density_dim();
        let (mean, std): (Vec<f64>, Vec<f64>) = (0..d).map(|j| (total.mean(j), total.std(j))).unzip();
        let mut lattice = FluxLattice::new(
            p,
            &mean,
            &std,
            KernelOptions::auto(d, total.count),
            data.batch_count(),
            &arenas,
        )
        .unwrap();
        let mut grid = DensityGrid::new(p, &total, GridOptions::auto(d, total.count))
            .unwrap()
            .with_batches(data.batch_count());
        for b in &samples.batches {
            b.for_each_sample(|j, t, row| {
                let batch = data.batch_of(j, t);
                lattice.push_in(batch, row);
                grid.push_in(batch, row);
            });
        }
        lattice.finish();
        grid.finish();
        let typical = p.typical(&total);
        [
            identify_kernel(p, &lattice, &typical).unwrap(),
            identify_strong(p, &grid, false, &typical).unwrap(),
            identify_strong(p, &grid, true, &typical).unwrap(),
        ]
    };
    for (a, b) in estimates(&poly).iter().zip(&estimates(&atoms)) {
        assert_same_estimates(a, b, a.method);
    }
}

/// The increment regression and the force regression through [`Atom`]s — the terms valued
/// from each sample's link motion, and at the force regression's interpolated states from
/// the state — give the estimates of the polynomial path on the same samples.
#[test]
fn the_increment_regressions_through_atoms_match_the_polynomial_form() {
    use crate::ident::baseline::{force_columns, DriftRule, Increments};
    let (s, samples) = first_link_known("duffing2dof", 500.0);
    let spec = Specification::from_scenario(&s);
    let poly = Problem::from_spec(&spec, &[]).unwrap();
    let atoms = Problem::with_terms_as_atoms(&spec, &[], &[0, 1, 2]).unwrap();
    assert!(atoms.atoms.len() >= 6, "{} atoms", atoms.atoms.len());
    let h = s.simulation.sample_interval;
    let rules = [DriftRule::GaussLegendre, DriftRule::EulerStep { semi_implicit: true }];
    for forces in [None, Some(rules[0]), Some(rules[1])] {
        let estimate = |p: &Problem| {
            let mut inc = match forces {
                None => Increments::new(p, h, 8),
                Some(rule) => Increments::with_forces(p, h, 8, force_columns(p, &[true, true]).unwrap(), rule),
            };
            for b in &samples.batches {
                b.for_each_sample(|j, t, row| inc.push(j as usize, t, (j as usize) % 8, row));
            }
            inc.finish();
            inc.estimate(&p.typical(&crate::ident::moments::RawMoments::new(p.dim(), 2)))
                .unwrap()
        };
        let (a, b) = (estimate(&poly), estimate(&atoms));
        assert_eq!(a.names, b.names);
        for k in 0..a.values.len() {
            let (x, y) = (a.values[k], b.values[k]);
            assert!(
                (x - y).abs() <= 1e-9 * x.abs().max(1e-3),
                "forces {forces:?}: {}: {x} against {y}",
                a.names[k]
            );
        }
    }
}

//! Characteristic terms beyond powers (docs/scenario.md "Terms"): the weak form's identity
//! on an exact stationary density, identification of simulated friction and clearance
//! systems, the profile of a gap, and what the scenario refuses.

use fpkbench::ident::moments::RawMoments;
use fpkbench::ident::poly::exponent;
use fpkbench::ident::{weak, Problem};
use fpkbench::{zoo, Scenario};
use std::process::Command;

/// A one-mass system with linear damping `c` and the stiffness `stiffness` (TOML), white
/// force of intensity 1, every coefficient unknown.
fn sdof(stiffness: &str, c: f64) -> Scenario {
    let src = format!(
        "[[mass]]\nname = \"m1\"\nvalue = 1.0\n[[link]]\nends = [\"ground\", \"m1\"]\nstiffness = {stiffness}\n\
         damping = {{ 1 = {c} }}\n[[excitation]]\nkind = \"white\"\nsigma = 1.0\nacts_on = [\"m1\"]\n\
         [simulation]\ndt = 1e-3\nrecord_length = 10.0\nsample_interval = 0.1\n"
    );
    Scenario::parse(&src, "test.toml", "sdof").unwrap()
}

/// `z^β_var` times every atom of `p` (of characteristic `kind`, or all) valued at `z` to its
/// power in the monomial `e`: a term, or its slope (a hinge's step, for its local test
/// functions). Taken as the mean of `z`'s two sides, so at a knot on a Simpson panel
/// boundary the quadrature stays exact per piece.
fn integrand(p: &Problem, e: u128, var: usize, kind: Option<fpkbench::model::Characteristic>, z: f64) -> f64 {
    let d = p.density_dim();
    let at = |z: f64| {
        let mut f = z.powi(exponent(e, var) as i32);
        for (a, atom) in p
            .atoms
            .iter()
            .enumerate()
            .filter(|(_, a)| kind.is_none_or(|k| a.kind == k))
        {
            let q = exponent(e, d + a);
            if q > 0 {
                let t = if atom.slope {
                    atom.term.slope(z)
                } else {
                    atom.term.value(z)
                };
                f *= t.powi(q as i32);
            }
        }
        f
    };
    0.5 * (at(z - 1e-9) + at(z + 1e-9))
}

/// With linear damping `c` the stationary density of `m ẍ + c ẋ + K(x) = σ ξ` is exactly
/// `exp(−(2c/σ²)(m v²/2 + U(x)))`, `U' = K`, whatever the terms of `K`: the displacement
/// and the velocity independent, the velocity Gaussian. Every generalised moment
/// `E[x^a t₁(x)^b₁ … v^c]` the weak form reads is then an integral over `x` (Simpson on a
/// fine grid) times a Gaussian moment, and the weak form must return the true coefficients
/// of every term.
#[test]
fn the_weak_form_is_exact_on_the_exact_density_of_every_stiffness_term() {
    let c = 0.5;
    for stiffness in [
        r#"{ 1 = 10.0, 3 = 20.0, "gap(0.3)" = 30.0 }"#,
        r#"{ 1 = 6.0, "tanh(0.2)" = 8.0, "hinge(0.25)" = 5.0, "hinge(-0.4)" = 3.0 }"#,
        r#"{ 1 = 4.0, sign = 2.0, 3 = 10.0 }"#,
    ] {
        let s = sdof(stiffness, c);
        let p = Problem::new(&s).unwrap();
        assert!(!p.atoms.is_empty(), "{stiffness}: the non-power terms are atoms");
        let curve = &s.links[0].stiffness;
        // U(x) by Simpson's rule on the grid, from 0.
        // h = 1e-4: every knot and gap (±0.25, 0.3, −0.4) an even multiple, a Simpson
        // panel boundary.
        let (n, lim) = (80_001usize, 4.0);
        let h = 2.0 * lim / (n - 1) as f64;
        let xs: Vec<f64> = (0..n).map(|i| -lim + i as f64 * h).collect();
        let k: Vec<f64> = xs.iter().map(|&x| curve.eval(x)).collect();
        let mut u = vec![0.0; n];
        for i in 1..n {
            // Trapezoid with the end correction of the derivatives' difference: fine here
            // (h = 1e-4; the kinks' error is O(h²) per kink).
            u[i] = u[i - 1] + 0.5 * h * (k[i] + k[i - 1]);
        }
        let beta = 2.0 * c;
        let u0 = u[(n - 1) / 2];
        let w: Vec<f64> = (0..n)
            .map(|i| {
                let simpson = if i == 0 || i == n - 1 {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                simpson * (-beta * (u[i] - u0)).exp()
            })
            .collect();
        let z: f64 = w.iter().sum();
        let var_v = 1.0 / (2.0 * c);
        let gauss = |b: u32| match b % 2 {
            1 => 0.0,
            _ => (1..b).step_by(2).map(|k| k as f64).product::<f64>() * var_v.powi(b as i32 / 2),
        };
        let mom = RawMoments::exact_monomials(p.dim(), weak::moment_degree(&p), &weak::required_moments(&p), |e| {
            let sum: f64 = (0..n).map(|i| w[i] * integrand(&p, e, 0, None, xs[i])).sum();
            sum / z * gauss(exponent(e, 1))
        });
        let pc = weak::pieces(&p, &mom);
        let (est, diag) = p.solve(&pc, &p.typical(&mom), None);
        assert_eq!(diag.rank, p.names.len(), "{stiffness}");
        for ((e, t), name) in est.iter().zip(&zoo::true_values(&s, &p)).zip(&p.names) {
            assert!(
                ((e - t) / t).abs() < 1e-4,
                "{stiffness}: {name}: estimate {e} vs truth {t}"
            );
        }
    }
}

/// Hinges in a damping are seen by their local test functions (docs/theory.md §5): on the
/// exact density of a linear damper (`x` and `v` independent, `v` Gaussian) a damping
/// modelled as `c·w` plus eight hinges, and a stiffness with two hinges beside its powers,
/// must come out as the truth — every hinge coefficient 0 to 1e-6 of the characteristic's
/// scale, at full rank. With polynomial test functions alone the same model was refused as
/// numerically rank-deficient.
#[test]
fn local_test_functions_recover_hinges_exactly_on_an_exact_density() {
    let (c, k1, k3) = (0.5, 10.0, 20.0);
    let src = format!(
        "[[mass]]\nname = \"m1\"\nvalue = 1.0\n[[link]]\nends = [\"ground\", \"m1\"]\n\
         stiffness = {{ 1 = {k1}, 3 = {k3} }}\ndamping = {{ 1 = {c} }}\n[[excitation]]\nkind = \"white\"\n\
         sigma = 1.0\nacts_on = [\"m1\"]\n[simulation]\ndt = 1e-3\nrecord_length = 10.0\nsample_interval = 0.1\n\
         [identify.links.ground-m1]\nstiffness = [1, 3, \"hinge(0.4)\", \"hinge(-0.4)\"]\n\
         damping = [1, \"hinge(-0.1)\", \"hinge(0.1)\", \"hinge(-0.3)\", \"hinge(0.3)\", \"hinge(-0.8)\", \
         \"hinge(0.8)\", \"hinge(-1.6)\", \"hinge(1.6)\"]\n"
    );
    let s = Scenario::parse(&src, "test.toml", "sdof").unwrap();
    let p = Problem::new(&s).unwrap();
    let local = weak::local_tests(&p);
    assert_eq!(
        local.len(),
        10 * weak::LOCAL_POWERS as usize,
        "a local family per unknown hinge"
    );
    assert!(weak::test_degree(&p) <= 4, "hinges do not raise the polynomial degree");
    // Simpson weights on a grid of 40,001 points over [-lim, lim] times the density `f`.
    // Every knot lies on a panel boundary and the integrand is taken there as the mean of
    // its two sides, so the steps' jumps cost no accuracy (Simpson is exact per piece).
    let grid = |lim: f64, f: &dyn Fn(f64) -> f64| -> (Vec<f64>, Vec<f64>) {
        let n = 40_001usize;
        let h = 2.0 * lim / (n - 1) as f64;
        let xs: Vec<f64> = (0..n).map(|i| -lim + i as f64 * h).collect();
        let w: Vec<f64> = (0..n)
            .map(|i| {
                let simpson = match i {
                    0 => 1.0,
                    i if i == n - 1 => 1.0,
                    i if i % 2 == 1 => 4.0,
                    _ => 2.0,
                };
                simpson * f(xs[i])
            })
            .collect();
        let z: f64 = w.iter().sum();
        (xs, w.into_iter().map(|v| v / z).collect())
    };
    let beta = 2.0 * c;
    // h = 2e-4 and 4e-4: the knots (±0.4; ±0.1, ±0.3, ±0.8, ±1.6) are even multiples.
    let (xs, wx) = grid(4.0, &|x| (-beta * (k1 * x * x / 2.0 + k3 * x.powi(4) / 4.0)).exp());
    let (vs, wv) = grid(8.0, &|v| (-beta * v * v / 2.0).exp());
    use fpkbench::model::Characteristic;
    let mom = RawMoments::exact_monomials(p.dim(), weak::moment_degree(&p), &weak::required_moments(&p), |e| {
        let part = |points: &[f64], weights: &[f64], var: usize, kind| -> f64 {
            points
                .iter()
                .zip(weights)
                .map(|(&z, &wz)| wz * integrand(&p, e, var, Some(kind), z))
                .sum()
        };
        part(&xs, &wx, 0, Characteristic::Stiffness) * part(&vs, &wv, 1, Characteristic::Damping)
    });
    let pc = weak::pieces(&p, &mom);
    let (est, diag) = p.solve(&pc, &p.typical(&mom), None);
    assert_eq!(diag.rank, p.names.len());
    for (e, name) in est.iter().zip(&p.names) {
        let name = name.to_string();
        let truth = match name.as_str() {
            "k1[ground-m1]" => k1,
            "k3[ground-m1]" => k3,
            "c1[ground-m1]" => c,
            _ => 0.0,
        };
        // The characteristics' scales: k1·σ_x and c·σ_v are both ≈ 1.
        assert!(
            (e - truth).abs() < 1e-6 * truth.abs().max(1.0),
            "{name}: estimate {e} vs truth {truth}"
        );
    }
}

/// Runs `fpkbench` with `args`, returning the exit code, stdout and stderr.
fn fpkbench(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The report of method `name` in a `--json` report.
fn method_of(r: &serde_json::Value, name: &str) -> serde_json::Value {
    r["methods"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["method"] == name)
        .unwrap()
        .clone()
}

/// A method report's parameter `name`.
fn parameter_of<'a>(m: &'a serde_json::Value, name: &str) -> &'a serde_json::Value {
    m["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == name)
        .unwrap()
}

/// A method report's relative L2 error of `link`'s characteristic `kind`.
fn curve_error(m: &serde_json::Value, link: &str, kind: &str) -> f64 {
    m["curves"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["link"] == link && c["kind"] == kind)
        .unwrap()["rel_l2_error"]
        .as_f64()
        .unwrap()
}

/// The friction SDOF simulated and identified with its own terms by the weak form, the
/// increment regression and the oracle; the powers-only comparison's damping curve far
/// from the truth. At 1e4 s (a tenth of the shipped record) over 10 seeds the weak form's
/// F and c had spreads of 4.4 % and 6.5 %; the bounds here are 4 of those spreads.
#[test]
fn friction_is_identified_with_its_own_terms_and_powers_are_biased() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let (code, stdout, stderr) = fpkbench(&[
        "run",
        "scenarios/friction_sdof.toml",
        "--set",
        "simulation.record_length=312.5",
        "--method",
        "weak",
        "--method",
        "force-regression",
        "--json",
        "--no-validate",
        "--out",
        out,
    ]);
    assert!(code == Some(0) || code == Some(1), "{code:?}: {stderr}");
    let r: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let method = |name: &str| method_of(&r, name);
    let weak = method("weak");
    let err = |m: &serde_json::Value, p: &str| parameter_of(m, p)["rel_error"].as_f64().unwrap().abs();
    assert!(err(&weak, "csign[ground-m1]") < 0.18, "{weak}");
    assert!(err(&weak, "c1[ground-m1]") < 0.26, "{weak}");
    assert!(err(&weak, "k1[ground-m1]") < 0.03, "{weak}");
    // The oracle takes the term too (its error at 0.1 s samples is the interval's smoothing
    // of the jump, 25 %: it is not compared here).
    assert_eq!(method("force-regression")["outcome"], "estimated");
    let powers = method("weak [powers]");
    assert!(curve_error(&powers, "ground-m1", "damping") > 0.5, "{powers}");
    // The powers' coefficients of a damping that cannot represent a friction estimate no
    // true ones and are not graded (null), the curve is (before: hinge "errors" of 1000 %
    // against the characteristic's scale made the worst error); the stiffness is graded.
    let c1 = parameter_of(&powers, "c1[ground-m1]");
    assert!(c1["rel_error"].is_null(), "{c1}");
    assert!(err(&powers, "k1[ground-m1]") < 0.03, "{powers}");
    // Eight hinges, two 0.08 m/s apart beside the jump: at a tenth of the record too few
    // samples fall between them, and they are refused (seeds 1–10: on 9), naming why.
    let hinges = method("weak [hinges]");
    assert_eq!(hinges["outcome"], "refused", "{hinges}");
    assert!(
        hinges["error"].as_str().unwrap().contains("cannot be separated"),
        "{hinges}"
    );
}

/// The shipped eight hinges on the friction SDOF's damping at the shipped record (10⁵ s),
/// told apart by their local test functions (before them: refused as rank-deficient): the
/// curve within a few percent of a truth that jumps at 0 (seeds 1–10 and 1001–1010: median
/// 2.61 %, max 4.30 %, floor 1.73 %; docs/results.md), the powers' 65–176 % off.
#[test]
fn eight_hinges_follow_a_friction_damper_at_the_shipped_record() {
    let dir = tempfile::tempdir().unwrap();
    let (code, stdout, stderr) = fpkbench(&[
        "run",
        "scenarios/friction_sdof.toml",
        "--set",
        "simulation.seed=1001",
        "--method",
        "weak",
        "--json",
        "--no-validate",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{stderr}");
    let r: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let method = |name: &str| method_of(&r, name);
    let curve = |m: &serde_json::Value| curve_error(m, "ground-m1", "damping");
    let (hinges, powers) = (method("weak [hinges]"), method("weak [powers]"));
    assert_eq!(hinges["outcome"], "estimated", "{hinges}");
    assert!(curve(&hinges) < 0.06 && curve(&powers) > 0.5, "{hinges}");
    // Hinges cannot represent a friction: their coefficients are not graded, the curve and
    // the stiffness's coefficients are, and the worst error is the largest of those.
    let p = parameter_of(&hinges, "chinge(0.04)[ground-m1]");
    assert!(p["rel_error"].is_null(), "{p}");
    let graded = hinges["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|p| p["rel_error"].as_f64())
        .chain(
            hinges["curves"]
                .as_array()
                .unwrap()
                .iter()
                .map(|c| c["rel_l2_error"].as_f64().unwrap()),
        )
        .fold(0.0, f64::max);
    assert_eq!(hinges["worst_rel_error"].as_f64(), Some(graded), "{hinges}");
}

/// The clearance's gap profiled over ±50 %: the report's profile, the gap chosen within
/// the interval it gives, the profiled coefficient graded against the true one.
#[test]
fn a_gap_is_profiled_and_its_position_reported() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let (code, stdout, stderr) = fpkbench(&[
        "run",
        "scenarios/clearance2dof.toml",
        "--set",
        "simulation.record_length=312.5",
        "--set",
        "simulation.dt=1e-3",
        "--method",
        "weak",
        "--json",
        "--no-validate",
        "--out",
        out,
    ]);
    assert!(code == Some(0) || code == Some(1), "{code:?}: {stderr}");
    let r: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let p = &r["profile"];
    assert_eq!(p["points"].as_array().unwrap().len(), 31, "{p}");
    assert_eq!(p["truth"].as_f64(), Some(0.15), "{p}");
    let chosen = p["chosen"].as_f64().unwrap();
    let (lo, hi) = (p["interval"][0].as_f64().unwrap(), p["interval"][1].as_f64().unwrap());
    assert!(lo <= chosen && chosen <= hi && (0.075..=0.225).contains(&chosen), "{p}");
    let name = p["chosen_parameter"].as_str().unwrap();
    let weak = r["methods"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["method"] == "weak")
        .unwrap();
    let gap = weak["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|x| x["name"] == name)
        .unwrap();
    assert_eq!(gap["true_value"].as_f64(), Some(40.0), "{gap}");
    // The shape not known: six hinges, none at the gap, against powers to 5. At this length
    // (seeds 1–10) the coupling's curve is 2.2–9.5 % off with hinges, 10.7–64 % with powers,
    // the hinges better on every seed.
    let coupling = |name: &str| {
        let m = method_of(&r, name);
        assert_eq!(m["outcome"], "estimated", "{m}");
        curve_error(&m, "m1-m2", "stiffness")
    };
    let (hinges, powers) = (coupling("weak [hinges]"), coupling("weak [powers]"));
    assert!(hinges < 0.2 && hinges < powers, "hinges {hinges}, powers {powers}");
    let md = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    assert!(md.contains("## Profile") && md.contains("J − J_min"), "{md}");
}

/// Positions beyond the stroke (a profile range up to 1e20): each refused position names
/// the gap whose term never acts there, and the terminal writes the positions as the
/// term's name does (3.333333333e18), not in twenty digits.
#[test]
fn a_profiled_position_beyond_the_stroke_names_the_term_that_never_acts() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let (code, stdout, stderr) = fpkbench(&[
        "run",
        "scenarios/clearance2dof.toml",
        "--set",
        "simulation.record_length=200",
        "--set",
        "identify.profile.range=[0.1, 1e20]",
        "--method",
        "weak",
        "--no-validate",
        "--out",
        out,
    ]);
    assert!(code == Some(0) || code == Some(1), "{code:?}: {stderr}");
    assert!(
        stdout.contains("3.333333333e18: refused") && !stdout.contains("3333333333000000000"),
        "{stdout}"
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap()).unwrap();
    let refused = r["profile"]["points"][1]["refused"].as_str().unwrap();
    assert!(
        refused.contains("kgap(3.333333333e18)[m1-m2] never acts on these data"),
        "{refused}"
    );
}

/// Terms in a scenario: a bad term, a one-sided hinge that lets the mass escape, friction
/// alone as the damping, and a profile of a term without a position, each with its place.
#[test]
fn terms_that_make_no_sense_are_refused_where_they_are_written() {
    let base = |stiffness: &str, damping: &str, extra: &str| {
        format!(
            "[[mass]]\nname = \"m1\"\nvalue = 1.0\n[[link]]\nends = [\"ground\", \"m1\"]\nstiffness = {stiffness}\n\
             damping = {damping}\n[[excitation]]\nkind = \"white\"\nsigma = 1.0\nacts_on = [\"m1\"]\n\
             [simulation]\ndt = 1e-3\nrecord_length = 10.0\nsample_interval = 0.1\n{extra}"
        )
    };
    let parse = |src: String| Scenario::parse(&src, "t.toml", "t").map_err(|e| e.to_string());
    let e = parse(base(r#"{ 1 = 1.0, "gap(0)" = 3.0 }"#, "{ 1 = 0.5 }", "")).unwrap_err();
    assert!(
        e.contains("t.toml:6") && e.contains("stiffness.gap(0)") && e.contains("must be positive"),
        "{e}"
    );
    let e = parse(base("{ abs3 = 1.0 }", "{ 1 = 0.5 }", "")).unwrap_err();
    assert!(e.contains("write 3"), "{e}");
    let e = parse(base(r#"{ "hinge(0.2)" = 5.0 }"#, "{ 1 = 0.5 }", "")).unwrap_err();
    assert!(e.contains("acts on the side > 0 only"), "{e}");
    // Friction alone dissipates; a clearance alone confines.
    parse(base(r#"{ "gap(0.1)" = 5.0 }"#, "{ sign = 0.5 }", "")).unwrap();
    let e = parse(base(
        "{ 1 = 1.0, 3 = 2.0 }",
        "{ 1 = 0.5 }",
        "[identify.profile]\nparameter = \"k3[ground-m1]\"\nrange = [1, 2]\n",
    ))
    .unwrap_err();
    assert!(
        e.contains("identify.profile.parameter") && e.contains("no position"),
        "{e}"
    );
    let e = parse(base(
        r#"{ 1 = 1.0, "gap(0.1)" = 2.0 }"#,
        "{ 1 = 0.5 }",
        "[identify.profile]\nparameter = \"kgap(0.1)[ground-m1]\"\nrange = [-0.1, 0.2]\n",
    ))
    .unwrap_err();
    assert!(e.contains("identify.profile.range") && e.contains("positive"), "{e}");
}

/// A density where displacement and velocity are not independent: energy-dependent damping
/// `ẍ + ẋ·g(H) + k x = σ ξ`, `H = ẋ²/2 + k x²/2`, `g(H) = c₀ + c₁ H`, has the closed-form
/// stationary density `exp(−(2/σ²)(c₀ H + c₁ H²/2))`. Its drift
/// `−k x − c₀ v − (c₁/2) v³ − (c₁ k/2) x² v` holds the cross term `x² v`, which no link
/// characteristic (a function of `u` or of `w`) has, so the weak form is checked in its
/// monomial form (one unknown per monomial of the drift, as for an unknown filter corner):
/// on the exact moments it must return every monomial coefficient to 1e-6.
#[test]
fn the_weak_form_is_exact_on_an_energy_dependent_dampings_density() {
    use fpkbench::ident::poly::{var, Poly};
    use fpkbench::ident::Unknown;
    use fpkbench::model::UnknownName;
    let (k, c0, c1) = (4.0, 0.3, 0.5);
    let src = "[[mass]]\nname = \"m1\"\nvalue = 1.0\n[[link]]\nends = [\"ground\", \"m1\"]\n\
               stiffness = { 1 = 4.0 }\ndamping = { 1 = 0.3, 3 = 0.1 }\n[[excitation]]\nkind = \"white\"\n\
               sigma = 1.0\nacts_on = [\"m1\"]\n[simulation]\ndt = 1e-3\nrecord_length = 10.0\nsample_interval = 0.1\n";
    let s = Scenario::parse(src, "test.toml", "energy").unwrap();
    let (mut p, _) = Problem::new(&s).unwrap().monomial_form();
    let x2v = 2 * var(p.x(0)) + var(p.v(0));
    p.unknowns.push(Unknown::Monomial(0, x2v));
    p.unit_force.push(vec![Poly::monomial(x2v, 1.0)]);
    p.start.push(0.0);
    p.names.push(UnknownName::Monomial {
        mass: "m1".into(),
        monomial: "x_m1^2*v_m1".into(),
    });
    let truth = |e: u128| match e {
        e if e == var(p.x(0)) => -k,
        e if e == var(p.v(0)) => -c0,
        e if e == 3 * var(p.v(0)) => -c1 / 2.0,
        e if e == x2v => -c1 * k / 2.0,
        _ => panic!("unexpected monomial"),
    };
    // The density on a 2-D Simpson grid.
    let (n, lim) = (1201usize, 4.0);
    let h = 2.0 * lim / (n - 1) as f64;
    let simpson = |i: usize| match i {
        0 => 1.0,
        i if i == n - 1 => 1.0,
        i if i % 2 == 1 => 4.0,
        _ => 2.0,
    };
    let mut points = Vec::with_capacity(n * n);
    for i in 0..n {
        for j in 0..n {
            let (x, v) = (-lim + i as f64 * h, -lim + j as f64 * h);
            let energy = v * v / 2.0 + k * x * x / 2.0;
            let f = (-2.0 * (c0 * energy + c1 * energy * energy / 2.0)).exp();
            points.push((x, v, simpson(i) * simpson(j) * f));
        }
    }
    let z: f64 = points.iter().map(|p| p.2).sum();
    let (xi, vi) = (p.x(0), p.v(0));
    let mom = RawMoments::exact_monomials(p.dim(), weak::moment_degree(&p), &weak::required_moments(&p), |e| {
        let (a, b) = (exponent(e, xi) as i32, exponent(e, vi) as i32);
        points.iter().map(|&(x, v, w)| w * x.powi(a) * v.powi(b)).sum::<f64>() / z
    });
    let pc = weak::pieces(&p, &mom);
    let (est, diag) = p.solve(&pc, &p.typical(&mom), None);
    assert_eq!(diag.rank, p.names.len());
    for ((e, u), name) in est.iter().zip(&p.unknowns).zip(&p.names) {
        let Unknown::Monomial(_, m) = *u else {
            panic!("{name}: not a monomial")
        };
        let t = truth(m);
        assert!(((e - t) / t).abs() < 1e-6, "{name}: estimate {e} vs truth {t}");
    }
}

/// The force regression on fpkbench's own log of every integration step takes the drift
/// where the Euler scheme took it (`DriftRule::EulerStep`), so its equation error is
/// rounding alone: every coefficient of every term kind, on a grounded and a coupling
/// link, comes back to machine precision — the simulator and the identifier evaluate each
/// term alike (sign conventions, gaps, knots, scales). Both Euler schemes; sampled every
/// 20th step the regression keeps Gauss–Legendre and its interval bias.
#[test]
fn the_force_regression_recovers_every_term_to_machine_precision_on_its_own_steps() {
    let src = r#"
[[mass]]
name = "m1"
value = 1.0
[[mass]]
name = "m2"
value = 0.5
[[link]]
ends = ["ground", "m1"]
stiffness = { 1 = 10.0, 3 = 20.0, "tanh(0.3)" = 5.0 }
damping = { 1 = 0.4, sign = 0.3, abs2 = 0.2 }
[[link]]
ends = ["m1", "m2"]
stiffness = { 1 = 4.0, "gap(0.15)" = 40.0, "hinge(0.1)" = 3.0 }
damping = { 1 = 0.3, "hinge(-0.2)" = 0.5 }
[[excitation]]
kind = "white"
sigma = 1.0
acts_on = ["m1"]
[[excitation]]
kind = "white"
sigma = 0.5
acts_on = ["m2"]
[simulation]
dt = 0.005
record_length = 20.0
sample_interval = 0.005
trajectories = 16
"#;
    let base = Scenario::parse(src, "terms.toml", "terms").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let run = |s: &Scenario| {
        let log = dir.path().join("run.mcap");
        let m = fpkbench::model::Model::new(s);
        let mut w = fpkbench::io::log::LogWriter::create(&log, s, &m).unwrap();
        fpkbench::sim::simulate(&m, &s.simulation, &mut w, &|_| {}).unwrap();
        w.finish().unwrap();
        let options = fpkbench::pipeline::Options {
            methods: vec![fpkbench::scenario::Method::ForceRegression],
            validate: false,
            ..fpkbench::pipeline::Options::default()
        };
        let r = fpkbench::pipeline::identify_log(&log, &options).unwrap();
        let m = &r.methods[0];
        let facts = format!("{:?}", m.facts);
        let errors: Vec<(String, f64)> = m
            .parameters
            .iter()
            .map(|p| (p.name.to_string(), p.rel_error.abs()))
            .collect();
        (errors, facts)
    };
    for scheme in [
        fpkbench::scenario::Scheme::SemiImplicit,
        fpkbench::scenario::Scheme::EulerMaruyama,
    ] {
        let mut s = base.clone();
        s.simulation.scheme = scheme;
        let (errors, facts) = run(&s);
        println!("{scheme:?}: {errors:?}");
        assert!(facts.contains("integration step's start"), "{facts}");
        assert_eq!(errors.len(), 11, "{errors:?}");
        for (name, e) in &errors {
            assert!(*e < 1e-9, "{scheme:?}: {name} off by {e}");
        }
    }
    // Sampled every 20th step the rule is Gauss–Legendre over the interval, and its bias
    // (order h²) is far above rounding.
    let mut s = base.clone();
    s.simulation.dt = 2.5e-4;
    s.simulation.record_length = 5.0;
    let (errors, facts) = run(&s);
    assert!(facts.contains("Gauss–Legendre"), "{facts}");
    let worst = errors.iter().map(|e| e.1).fold(0.0, f64::max);
    assert!(worst > 1e-6, "{errors:?}");
}

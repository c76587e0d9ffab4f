//! Checks of the method's own premises (docs/methods.md, "Checks"): a measured force whose
//! spectrum rejects the first-order filter (3.20) refuses every method that needs it and
//! leaves the force regression standing; an Ornstein–Uhlenbeck force of the same rig is not
//! rejected. The tables are made by a small integrator of the tests' own, as a lab's would
//! be: nothing of fpkbench's simulator is in them (`tables`).

mod tables;

use fpkbench::io::table::{measured, read_for};
use fpkbench::pipeline::{identify, Input, Options};
use fpkbench::report::{MethodOutcome, Outcome, Report};
use fpkbench::scenario::{Method, ReportMethod};
use fpkbench::Scenario;
use std::fmt::Write;
use tables::*;

const MODEL: &str = r#"
name = "rig"
[[mass]]
name = "m1"
value = 1.0
[[link]]
ends = ["ground", "m1"]
[[excitation]]
name = "shaker"
kind = "filtered"
A = 1.0
B = 1.0
acts_on = ["m1"]
[identify]
methods = ["weak", "force-regression"]
[identify.links.ground-m1]
stiffness = [1]
damping = [1]
[data]
time = "t"
record = "record"
[data.columns]
x_m1 = "x"
v_m1 = "v"
a_m1 = "a"
p_shaker = "p"
"#;

fn identify_table(csv: &str) -> Report {
    identify_with(csv, MODEL)
}

/// The same rig with the shaker's force read as its equivalent white noise.
fn equivalent_white_model() -> String {
    MODEL
        .replace("kind = \"filtered\"\nA = 1.0\nB = 1.0\n", "kind = \"white\"\n")
        .replace("[identify]\n", "[identify]\nequivalent_white = [\"shaker\"]\n")
}

fn identify_with(csv: &str, model: &str) -> Report {
    identify_methods(csv, model, vec![Method::Weak, Method::ForceRegression])
}

fn identify_methods(csv: &str, model: &str, methods: Vec<Method>) -> Report {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rig.csv");
    std::fs::write(&path, csv).unwrap();
    let model = Scenario::parse(model, "rig.toml", "rig").unwrap();
    let source = read_for(&path, model.data.as_ref().unwrap()).unwrap();
    let data = measured(&model, vec![source]).unwrap();
    let options = Options {
        validate: false,
        methods,
        ..Options::default()
    };
    identify(&Input::tables(model, data), &options).unwrap()
}

fn row(r: &Report, m: ReportMethod) -> &fpkbench::report::MethodReport {
    r.methods.iter().find(|x| x.method == m).unwrap()
}

/// A method's k1 and c1 against the rig's, within `k1_tol` and `c1_tol` (relative).
fn assert_rig(m: &fpkbench::report::MethodReport, k1_tol: f64, c1_tol: f64) {
    assert_eq!(m.outcome, MethodOutcome::Estimated);
    let value = |name: &str| m.parameters.iter().find(|p| p.name == name).unwrap().estimate;
    let (k1, c1) = (value("k1[ground-m1]"), value("c1[ground-m1]"));
    assert!((k1 / K1 - 1.0).abs() < k1_tol, "{}: k1 = {k1}", m.method);
    assert!((c1 / C1 - 1.0).abs() < c1_tol, "{}: c1 = {c1}", m.method);
}

#[test]
fn a_multisine_force_read_as_first_order_is_refused_and_the_force_regression_stands() {
    // A random-phase multisine flat from 0.1 to 20 Hz (four times the mode), a new
    // realisation per record: its spectrum is flat and then nothing, which no first-order
    // spectrum follows.
    let table = multisine_table(200, 0.1, 7);
    let r = identify_table(&table);
    let f = &r.filters[0];
    let ratio = f.rms_log_residual / f.expected_rms_log_residual;
    assert!(ratio > 3.0, "the first-order fit misses by {ratio:.2}× the averaging");
    let weak = row(&r, ReportMethod::Estimator(Method::Weak));
    assert_eq!(weak.outcome.kind(), Outcome::Refused, "{:?}", weak.outcome);
    let why = weak.outcome.error().unwrap();
    assert!(
        why.contains("force model is rejected") && why.contains("shaker"),
        "{why}"
    );
    assert!(weak.parameters.iter().all(|p| !p.estimate.is_finite()) || weak.parameters.is_empty());
    // The force regression reads the force itself: k1 and c1 within a few per cent.
    assert_rig(row(&r, ReportMethod::Estimator(Method::ForceRegression)), 0.02, 0.1);
    assert!(!r.passed);
}

#[test]
fn an_ornstein_uhlenbeck_force_of_the_same_rig_is_not_rejected() {
    // dP = −B P dt + A dW, exact in each step, B = 20 1/s (near the mode's 31 rad/s).
    let b = 20.0;
    let table = ou_table();
    let r = identify_table(&table);
    let f = &r.filters[0];
    let ratio = f.rms_log_residual / f.expected_rms_log_residual;
    // A right model's misfit is the averaging's: 0.98–1.03 on the shipped scenarios.
    assert!(
        ratio < 1.5,
        "the first-order fit misses an OU force by {ratio:.2}× the averaging"
    );
    let weak = row(&r, ReportMethod::Estimator(Method::Weak));
    assert_eq!(weak.outcome, MethodOutcome::Estimated);
    assert!((f.fitted_b / b - 1.0).abs() < 0.2, "B = {}", f.fitted_b);
    // With its force modelled right, the weak form agrees with the force regression.
    assert!(r.failed_checks.is_empty(), "{:?}", r.failed_checks);
}

#[test]
fn a_coloured_force_declared_white_contradicts_the_force_regression_and_fails_the_run() {
    // The OU force declared white at its low-frequency level σ = A/B: near the mode its
    // density is (B² + ω²)/B² ≈ 3.5 times lower than declared, and the weak form's damping
    // follows the declared level. The force regression reads the force itself.
    let model = MODEL.replace(
        "kind = \"filtered\"\nA = 1.0\nB = 1.0\n",
        "kind = \"white\"\nsigma = 10.0\n",
    );
    let r = identify_with(&ou_table(), &model);
    let weak = row(&r, ReportMethod::Estimator(Method::Weak));
    assert_eq!(weak.outcome, MethodOutcome::Estimated);
    assert_rig(row(&r, ReportMethod::Estimator(Method::ForceRegression)), 0.02, 0.1);
    let failed: Vec<_> = r.failed_checks.iter().filter(|c| c.check == "agreement").collect();
    assert_eq!(failed.len(), 1, "{:?}", r.failed_checks);
    assert_eq!(failed[0].method, "weak");
    assert!(
        failed[0].message.contains("c1[ground-m1]") && failed[0].message.contains("force regression"),
        "{}",
        failed[0].message
    );
    assert!(!r.passed);
}

#[test]
fn a_lag_the_model_lacks_splits_the_readings_of_the_measured_force_and_fails_the_run() {
    // The hardening rig (k3 x³ half the stiffness at one std) under a multisine, its model
    // right. With its velocity lagging the displacement's rate of change by a tenth of a
    // sample, the measured-force weak form and the regression, which read the same equation
    // with the same force, find dampings 11 % apart: more than a right model's data give
    // (at most 5.5 % on the Silverbox twin read as its record is, docs/methods.md "Checks"),
    // under the 15 % allowed a spectral model of the force, over the 10 % allowed the
    // readings of the force itself. With a velocity that is the rate of change, they agree.
    let model = equivalent_white_model()
        .replace("methods = [\"weak\", ", "methods = [\"weak-measured-force\", ")
        .replace("stiffness = [1]", "stiffness = [1, 3]");
    let run = |verlet| {
        let table = hardening_rig_table(8, 60.0, 5e4, verlet, multisine(200, 0.1, 7));
        identify_methods(&table, &model, vec![Method::WeakMeasuredForce, Method::ForceRegression])
    };
    let r = run(false);
    let failed: Vec<_> = r.failed_checks.iter().filter(|c| c.check == "agreement").collect();
    assert_eq!(failed.len(), 1, "{:?}", r.failed_checks);
    // c1, the last parameter (the stiffness's come first).
    let (message, c1) = (&failed[0].message, |m| {
        row(&r, ReportMethod::Estimator(m)).parameters.last().unwrap().estimate
    });
    let split = (c1(Method::WeakMeasuredForce) / c1(Method::ForceRegression) - 1.0).abs();
    assert!(split > 0.10 && split < 0.15, "{split}: {message}");
    assert_eq!(failed[0].method, "weak-measured-force");
    assert!(
        message.contains("c1[ground-m1]") && message.contains("a term or a dynamics"),
        "{message}"
    );
    assert!(run(true).failed_checks.is_empty());
}

#[test]
fn a_multisine_flat_over_the_response_band_is_its_equivalent_white_noise() {
    // The same multisine read as white: its level over the band where the velocity has its
    // energy gives the weak form the rig's stiffness and damping.
    let table = multisine_table(200, 0.1, 7);
    let r = identify_with(&table, &equivalent_white_model());
    let level = &r.white_levels[0];
    assert!(level.accepted, "{level:?}");
    // Lines of amplitude a have the two-sided density a²/(4·Δω) each side: σ² = 2π·that.
    let a = 4.0;
    let sigma = (2.0 * std::f64::consts::PI * a * a / (4.0 * 2.0 * std::f64::consts::PI * 0.1)).sqrt();
    assert!((level.sigma / sigma - 1.0).abs() < 0.05, "{level:?} against {sigma}");
    assert!(
        level.band_hz.0 < 5.0 && level.band_hz.1 > 5.0 && level.band_hz.1 < 20.0,
        "{level:?}"
    );
    assert_rig(row(&r, ReportMethod::Estimator(Method::Weak)), 0.03, 0.1);
    assert!(r.failed_checks.is_empty(), "{:?}", r.failed_checks);
}

#[test]
fn a_multisine_whose_band_ends_inside_the_resonance_is_not_read_as_white() {
    // Flat from 0.1 to 5 Hz, the mode: half the resonance has no force.
    let table = multisine_table(50, 0.1, 7);
    let r = identify_with(&table, &equivalent_white_model());
    let level = &r.white_levels[0];
    assert!(!level.accepted, "{level:?}");
    let weak = row(&r, ReportMethod::Estimator(Method::Weak));
    assert_eq!(weak.outcome.kind(), Outcome::Refused, "{:?}", weak.outcome);
    let why = weak.outcome.error().unwrap();
    assert!(why.contains("ends where the system still responds"), "{why}");
    assert_eq!(
        row(&r, ReportMethod::Estimator(Method::ForceRegression)).outcome,
        MethodOutcome::Estimated
    );
}

/// The study behind the edge limit (docs/methods.md, "The force model"): the rig under a
/// multisine flat from 0.1 Hz to `edge` times its 5 Hz mode, four seeds each, its force
/// read as white. Run with
/// `cargo test --release --test suite -- --ignored band_edge --nocapture`.
#[test]
#[ignore]
fn band_edge_study() {
    println!("edge/mode | edge share | c1 error (corrected) | c1 error (uncorrected) | k1 error | accepted");
    for edge in [1.2, 1.5, 2.0, 3.0, 4.0, 8.0] {
        for seed in 1..=4 {
            let lines = (5.0 * edge / 0.1) as usize;
            let r = identify_with(&multisine_table(lines, 0.1, seed), &equivalent_white_model());
            let l = &r.white_levels[0];
            let weak = row(&r, ReportMethod::Estimator(Method::Weak));
            // A refused row has no estimates (NaN in the table); "uncorrected" is what the
            // level without its edge correction gives (c1 scales with σ²).
            let value = |name: &str| {
                weak.parameters
                    .iter()
                    .find(|p| p.name == name)
                    .map_or(f64::NAN, |p| p.estimate)
            };
            let c1 = value("c1[ground-m1]") / C1 - 1.0;
            println!(
                "{edge:>9} | {:>10.4} | {:>+20.4} | {:>+22.4} | {:>+8.4} | {}",
                l.edge_share,
                c1,
                (1.0 + c1) / (1.0 - l.edge_share) - 1.0,
                value("k1[ground-m1]") / K1 - 1.0,
                l.accepted
            );
        }
    }
}

/// `csv` (record, t, x, v, a, p) with the sensors' DC offsets `dx` on x and `dp` on p.
fn with_offsets(csv: &str, dx: f64, dp: f64) -> String {
    let mut lines = csv.lines();
    let mut out = format!("{}\n", lines.next().unwrap());
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let x: f64 = f[2].parse().unwrap();
        let p: f64 = f[5].parse().unwrap();
        writeln!(out, "{},{},{:e},{},{},{:e}", f[0], f[1], x + dx, f[3], f[4], p + dp).unwrap();
    }
    out
}

/// `identify --predict` (docs/methods.md, "Prediction"): the rig identified from one
/// multisine's records, with offsets on its displacement and force sensors taken out by
/// `[data] remove_mean`, is driven by the force of another realisation's records (offset
/// alike) and reproduces their displacement: the force regression's model (k1 and c1 to a
/// fraction of a per cent here) within 1 % RMS of the response, the weak form's within its
/// coefficients' errors.
#[test]
fn an_identified_model_driven_by_held_out_forces_reproduces_their_response() {
    let model_src = equivalent_white_model().replace(
        "record = \"record\"\n",
        "record = \"record\"\nremove_mean = [\"x\", \"p\"]\n",
    );
    let model = Scenario::parse(&model_src, "rig.toml", "rig").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let read = |name: &str, seed: u64, means: Option<&[(String, f64)]>| {
        let path = dir.path().join(name);
        std::fs::write(&path, with_offsets(&multisine_table(200, 0.1, seed), 0.01, 2.0)).unwrap();
        let source = read_for(&path, model.data.as_ref().unwrap()).unwrap();
        fpkbench::io::table::measured_with(&model, vec![source], means).unwrap()
    };
    let train = read("train.csv", 7, None);
    let offsets: Vec<f64> = train.removed_means.iter().map(|m| m.1).collect();
    assert!(
        (offsets[0] - 0.01).abs() < 1e-3 && (offsets[1] - 2.0).abs() < 0.1,
        "{offsets:?}"
    );
    let test = read("test.csv", 8, Some(&train.removed_means));
    let options = Options {
        validate: false,
        methods: vec![Method::Weak, Method::ForceRegression],
        predict: Some(std::sync::Arc::new(test)),
        ..Options::default()
    };
    let r = identify(&Input::tables(model, train), &options).unwrap();
    assert_rig(row(&r, ReportMethod::Estimator(Method::ForceRegression)), 0.02, 0.1);
    let p = r.prediction.as_ref().expect("the prediction");
    assert_eq!((p.records, p.columns.len()), (8, 1), "{p:?}");
    let error = |m: Method| {
        let row = p.rows.iter().find(|x| x.method == ReportMethod::Estimator(m)).unwrap();
        assert!(row.error.is_none(), "{row:?}");
        // The offsets are the training data's, the same as the held-out data's.
        assert!(row.mean_error[0].abs() < 0.02 * p.columns[0].1, "{row:?}");
        row.rms_error[0] / p.columns[0].1
    };
    let (regression, weak) = (error(Method::ForceRegression), error(Method::Weak));
    eprintln!("prediction RMS error: force regression {regression:.4}, weak {weak:.4}");
    // Both within what their damping's error explains: a 5 %-damped response near its
    // mode scales as 1/c1, and the force regression's c1 is 10 % low on this rig (its
    // velocity is half an integration step off its displacement).
    assert!(regression < 0.1, "force regression: {regression}");
    assert!(weak < 0.15, "weak: {weak}");
}

/// The free run (`sim::driven`) of the rig's true model, driven by its sampled multisine
/// force from its first sampled state, against the rig's own integration at ten times
/// the rate with the force at every step: within 1 % RMS of the response.
#[test]
fn the_true_model_driven_by_the_sampled_force_reproduces_the_rig() {
    let table = multisine_table(200, 0.1, 9);
    let rows: Vec<Vec<f64>> = table
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .filter(|r: &Vec<f64>| r[0] == 0.0)
        .collect();
    let truth = MODEL.replace(
        "[[link]]\nends = [\"ground\", \"m1\"]\n",
        &format!("[[link]]\nends = [\"ground\", \"m1\"]\nstiffness = {{ 1 = {K1} }}\ndamping = {{ 1 = {C1} }}\n"),
    );
    let model = fpkbench::model::Model::new(&Scenario::parse(&truth, "rig.toml", "rig").unwrap());
    let force: Vec<f64> = rows.iter().map(|r| r[5]).collect();
    let run = fpkbench::sim::driven::free_run(&model, &[force], SAMPLE, 10, &[rows[0][2]], &[rows[0][3]]).unwrap();
    let (mut sq, mut var) = (0.0, 0.0);
    for (x, r) in run.displacement(0).zip(&rows) {
        sq += (x - r[2]).powi(2);
        var += r[2] * r[2];
    }
    let rel = (sq / var).sqrt();
    eprintln!("the true model's free run: RMS error {rel:.2e} of the response");
    assert!(rel < 0.01, "RMS error {rel} of the response");
}

/// Every method refused on measured data (the weak form alone, under a multisine read as
/// first-order): the refusal is the report, written whole — no characteristics figure,
/// which has nothing to draw, and the figures of what exists (issue 70: the report was lost
/// to "the SVG does not parse").
#[test]
fn a_run_whose_every_method_is_refused_still_writes_its_report() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rig.csv");
    std::fs::write(&path, multisine_table(200, 0.1, 7)).unwrap();
    let model = Scenario::parse(MODEL, "rig.toml", "rig").unwrap();
    let source = read_for(&path, model.data.as_ref().unwrap()).unwrap();
    let data = measured(&model, vec![source]).unwrap();
    let options = Options {
        validate: false,
        methods: vec![Method::Weak],
        ..Options::default()
    };
    let r = identify(&Input::tables(model, data), &options).unwrap();
    assert_eq!(r.methods[0].outcome.kind(), Outcome::Refused);
    let out = dir.path().join("report");
    std::fs::create_dir(&out).unwrap();
    let files = fpkbench::report::write_all(&r, &out).unwrap();
    let names: Vec<String> = files
        .iter()
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert!(
        names.contains(&"report.md".to_string()) && names.contains(&"spectrum.svg".to_string()),
        "{names:?}"
    );
    assert!(!names.iter().any(|n| n.starts_with("characteristics")), "{names:?}");
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("the force model is rejected") && !md.contains("characteristics.svg"));
}

#[test]
fn a_velocity_held_over_a_stretch_of_one_record_fails_the_run_naming_it() {
    // The OU rig's table, which passes every check, with record 1's velocity held at its
    // value at t = 10 s for 20 s (a logger repeating a stopped sensor's last reading).
    let mut held: Option<String> = None;
    let mut csv = String::new();
    for line in ou_table().lines() {
        let mut f: Vec<String> = line.split(',').map(str::to_string).collect();
        if f[0] == "1" && (10.0..30.0).contains(&f[1].parse::<f64>().unwrap()) {
            f[3] = held.get_or_insert_with(|| f[3].clone()).clone();
        }
        csv += &(f.join(",") + "\n");
    }
    let r = identify_table(&csv);
    let dead: Vec<_> = r.failed_checks.iter().filter(|c| c.check == "dead stretch").collect();
    assert_eq!(dead.len(), 1, "{:?}", r.failed_checks);
    assert!(
        dead[0].message.starts_with(&format!(
            "v_m1 (column \"v\") holds {} for ",
            held.unwrap().parse::<f64>().unwrap()
        )) && dead[0].message.contains(" samples (33 % of record 2) from t = 10"),
        "{}",
        dead[0].message
    );
    assert!(!r.passed);
}

#[test]
fn a_velocity_a_sample_late_in_one_record_fails_the_run_naming_it() {
    // The OU rig's table, which passes every check, with record 2's velocity one row late
    // against its displacement (a logger buffering one channel).
    let mut csv = String::new();
    let mut previous: Option<String> = None;
    for line in ou_table().lines() {
        let mut f: Vec<String> = line.split(',').map(str::to_string).collect();
        if f[0] == "1" {
            let now = f[3].clone();
            f[3] = previous.replace(now.clone()).unwrap_or(now);
        }
        csv += &(f.join(",") + "\n");
    }
    let r = identify_table(&csv);
    let lags: Vec<_> = r.failed_checks.iter().filter(|c| c.check == "lag").collect();
    assert!(!lags.is_empty() && !r.passed, "{:?}", r.failed_checks);
    assert!(
        lags[0]
            .message
            .starts_with("v_m1 (column \"v\") lags the central difference of x_m1 (column \"x\") by +1.0")
            && lags[0].message.contains(" in record 2 "),
        "{}",
        lags[0].message
    );
    // The clean table has no lag anywhere.
    assert!(identify_table(&ou_table())
        .failed_checks
        .iter()
        .all(|c| c.check != "lag"));
}

/// A displacement sensor that saturates at 1.5 of its std, its limit jittering by ±10⁻⁴
/// std (no two clipped samples equal): the run fails the clipping check naming the
/// column; the clean table passes it.
#[test]
fn a_jittering_clipped_channel_fails_the_run() {
    let clean = ou_table();
    let x: Vec<f64> = clean
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(2).unwrap().parse().unwrap())
        .collect();
    let sd = (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
    let mut u = Uniform(5);
    let mut csv = String::new();
    for (k, line) in clean.lines().enumerate() {
        let mut f: Vec<String> = line.split(',').map(str::to_string).collect();
        if k > 0 && x[k - 1] > 1.5 * sd {
            f[2] = format!("{}", 1.5 * sd + 1e-4 * sd * (2.0 * u.next() - 1.0));
        }
        csv += &(f.join(",") + "\n");
    }
    let r = identify_table(&csv);
    let clipped: Vec<_> = r.failed_checks.iter().filter(|c| c.check == "clipping").collect();
    assert!(!clipped.is_empty() && !r.passed, "{:?}", r.failed_checks);
    assert!(clipped[0].message.contains("x_m1"), "{}", clipped[0].message);
    assert!(identify_table(&clean)
        .failed_checks
        .iter()
        .all(|c| c.check != "clipping"));
}

/// A rig table (`rig_table`'s columns) with its force column, the last, times `factor`.
fn with_force_scaled(csv: &str, factor: f64) -> String {
    csv.lines()
        .enumerate()
        .map(|(k, line)| {
            if k == 0 {
                return format!("{line}\n");
            }
            let (rest, p) = line.rsplit_once(',').unwrap();
            format!("{rest},{:e}\n", p.parse::<f64>().unwrap() * factor)
        })
        .collect()
}

/// A rig in volts (docs/data.md, "A rig in volts"): the force column is the amplifier's
/// drive, `p / g` with a gain `g` nobody knows, so the model's mass is `1/g` and is left
/// without a value. The stationary density cannot tell the mass from the springs and the
/// damping (fluctuation–dissipation): the weak form is refused with that reason, not the
/// run. The linear rig's one-time moments do not fix the mass against the stiffness either
/// (`tests/measured_force.rs`): weak-measured-force is refused with the rank. The force
/// regression fixes it from the measured force — here to rounding, as the table's
/// acceleration is the equation of motion's at the sample — from a start (1) five decades
/// away.
#[test]
fn a_rig_in_volts_has_its_mass_from_the_force_regression_and_the_density_methods_say_why_not() {
    let gain = 2.0e5;
    let csv = with_force_scaled(&multisine_table(200, 0.1, 7), 1.0 / gain);
    let model = equivalent_white_model()
        .replace("value = 1.0\n", "")
        .replace("[identify]\n", "[identify]\nunknown_masses = [\"m1\"]\n");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rig.csv");
    std::fs::write(&path, &csv).unwrap();
    let model = Scenario::parse(&model, "rig.toml", "rig").unwrap();
    assert!(!model.masses[0].valued);
    let source = read_for(&path, model.data.as_ref().unwrap()).unwrap();
    let data = measured(&model, vec![source]).unwrap();
    let options = Options {
        validate: false,
        methods: vec![Method::Weak, Method::WeakMeasuredForce, Method::ForceRegression],
        ..Options::default()
    };
    let r = identify(&Input::tables(model, data), &options).unwrap();
    let weak = row(&r, ReportMethod::Estimator(Method::Weak));
    assert!(
        weak.outcome.error().unwrap().contains("fluctuation–dissipation"),
        "{:?}",
        weak.outcome
    );
    let wmf = row(&r, ReportMethod::Estimator(Method::WeakMeasuredForce));
    assert_eq!(wmf.outcome.kind(), Outcome::Refused, "{:?}", wmf.outcome);
    assert!(wmf.outcome.error().unwrap().contains("m[m1]"), "{:?}", wmf.outcome);
    let fr = row(&r, ReportMethod::Estimator(Method::ForceRegression));
    assert_eq!(fr.outcome, MethodOutcome::Estimated);
    let value = |name: &str| fr.parameters.iter().find(|p| p.name == name).unwrap();
    let m = value("m[m1]");
    assert!(m.true_value.is_nan(), "an unvalued mass has no truth: {m:?}");
    for (name, want) in [
        ("m[m1]", 1.0 / gain),
        ("k1[ground-m1]", K1 / gain),
        ("c1[ground-m1]", C1 / gain),
    ] {
        let got = value(name).estimate;
        assert!((got / want - 1.0).abs() < 1e-6, "{name}: {got} against {want}");
    }
}

/// The force scale check (docs/methods.md, "Checks"): the same rig's table with its force
/// column in kN (the model's unit is N) or its force cell mounted the other way fails the
/// run naming the mass the samples imply and the factor; the table as it is does not.
#[test]
fn a_force_in_other_units_or_reversed_fails_the_run_naming_the_factor() {
    let table = ou_table();
    let clean = identify_table(&table);
    assert!(
        !clean.failed_checks.iter().any(|c| c.check == "force scale"),
        "{:?}",
        clean.failed_checks
    );
    for (factor, shown) in [(1e-3, "a factor 0.0010"), (-1.0, "a factor -1.0000")] {
        let r = identify_table(&with_force_scaled(&table, factor));
        let check = r.failed_checks.iter().find(|c| c.check == "force scale");
        let check = check.unwrap_or_else(|| panic!("factor {factor}: {:?}", r.failed_checks));
        assert!(
            check.message.contains("m[m1]") && check.message.contains(shown),
            "{}",
            check.message
        );
        assert!(!r.passed);
    }
}

/// duffing2dof's links and forces as a rig's model file that knows only the links' powers
/// (reading the displacements and velocities of its export).
const CHAIN: &str = r#"
name = "chain"
[[mass]]
name = "m1"
value = 1.0
[[mass]]
name = "m2"
value = 2.0
[[link]]
name = "a"
ends = ["ground", "m1"]
[[link]]
name = "b"
ends = ["m1", "m2"]
[[link]]
name = "c"
ends = ["ground", "m2"]
[[excitation]]
kind = "white"
sigma = 1.0
acts_on = ["m1"]
[[excitation]]
kind = "white"
sigma = 1.0
acts_on = ["m2"]
[identify]
methods = ["weak"]
[identify.links.a]
stiffness = [1, 3]
damping = [1, 3]
[identify.links.b]
stiffness = [1]
damping = [1]
[identify.links.c]
stiffness = [1, 3]
damping = [1]
[data]
time = "t"
record = "trajectory"
[data.columns]
x_m1 = "x_m1"
v_m1 = "v_m1"
x_m2 = "x_m2"
v_m2 = "v_m2"
"#;

/// duffing2dof (`trajectories` × `record_length` s sampled every `interval`) exported
/// by fpkbench: its CSV text, every column.
fn chain_export(trajectories: usize, record_length: f64, interval: f64) -> String {
    let src = std::fs::read_to_string("scenarios/duffing2dof.toml").unwrap();
    let mut s = Scenario::parse(&src, "duffing2dof.toml", "duffing2dof").unwrap();
    (s.simulation.record_length, s.simulation.trajectories) = (record_length, trajectories);
    s.simulation.sample_interval = interval;
    let dir = tempfile::tempdir().unwrap();
    let (log, csv) = (dir.path().join("run.mcap"), dir.path().join("run.csv"));
    crate::common::fresh_log(&s, &log);
    crate::common::export(&log, "csv", &csv);
    std::fs::read_to_string(&csv).unwrap()
}

/// A 2-mass chain (duffing2dof's links and forces) read from its exported table by a rig's
/// model file that knows only the links' powers: as exported it passes the dissipativity
/// check; with the second mass's displacement and velocity negated (its sensors mounted
/// the other way) the coupling link's spring and damper come out negative — the exact
/// equivalent model of the reversed coordinate — and the failure names the reversed sensor
/// and the way to undo it, not another polynomial degree (issue 70).
#[test]
fn a_mass_measured_with_the_opposite_sign_is_named_not_put_down_to_the_degree() {
    let table = chain_export(8, 500.0, 0.1);
    let model = CHAIN;
    let weak_row = |csv: &str| {
        let r = identify_with(csv, model);
        row(&r, ReportMethod::Estimator(Method::Weak)).clone()
    };
    let clean = weak_row(&table);
    assert!(clean.dissipativity.iter().all(|d| d.holds), "{:?}", clean.dissipativity);
    // m2's displacement and velocity negated.
    let header: Vec<&str> = table.lines().next().unwrap().split(',').collect();
    let flip: Vec<usize> = ["x_m2", "v_m2"]
        .iter()
        .map(|c| header.iter().position(|h| h == c).unwrap())
        .collect();
    let mut reversed = String::new();
    for (i, line) in table.lines().enumerate() {
        let cells: Vec<String> = line
            .split(',')
            .enumerate()
            .map(|(j, c)| match i > 0 && flip.contains(&j) {
                true => format!("{}", -c.parse::<f64>().unwrap()),
                false => c.to_string(),
            })
            .collect();
        reversed += &(cells.join(",") + "\n");
    }
    let m = weak_row(&reversed);
    let failed: Vec<_> = m.dissipativity.iter().filter(|d| !d.holds).collect();
    assert_eq!(failed.len(), 2, "{:?}", m.dissipativity);
    for d in failed {
        assert_eq!(d.link, "b");
        assert!(
            d.message.contains("push m1 and m2 apart") && d.message.contains("opposite sign"),
            "{}",
            d.message
        );
        assert!(!d.message.contains("polynomial degree"), "{}", d.message);
    }
}

/// duffing2dof exported with every column (4 × 250 s at 0.02 s) and read by a rig's model
/// file that maps them all. As interval means (`acceleration_samples`, what the export
/// holds), the forces are their intervals' means and the accelerations half a sample behind
/// the velocity's difference: every check passes and the force regression's dampers are
/// within 2 % (measured on 8 × 500 s: c1[a] 0.50152 ± 0.00024 for 0.5). Read as values at
/// instants, the same table fails the lag check (half a sample) and the regression's dampers
/// are tens of per cent high (0.793 for 0.5 on 8 × 500 s).
#[test]
fn an_export_read_as_interval_means_passes_every_check_and_its_force_regression_is_exact() {
    let table = chain_export(4, 250.0, 0.02);
    let full = CHAIN
        .replace(
            "kind = \"white\"\nsigma = 1.0\nacts_on = [\"m1\"]",
            "name = \"f1\"\nkind = \"white\"\nsigma = 1.0\nacts_on = [\"m1\"]",
        )
        .replace(
            "kind = \"white\"\nsigma = 1.0\nacts_on = [\"m2\"]",
            "name = \"f2\"\nkind = \"white\"\nsigma = 1.0\nacts_on = [\"m2\"]",
        )
        .replace(
            "[data.columns]\n",
            "[data.columns]\na_m1 = \"a_m1\"\na_m2 = \"a_m2\"\np_f1 = \"p_m1\"\np_f2 = \"p_m2\"\n",
        );
    let means = full.replace("[data]\n", "[data]\nacceleration_samples = \"interval_means\"\n");
    let r = identify_with(&table, &means);
    assert!(r.failed_checks.is_empty(), "{:?}", r.failed_checks);
    let regression = row(&r, ReportMethod::Estimator(Method::ForceRegression));
    let c1 = regression.parameters.iter().find(|p| p.name == "c1[a]").unwrap();
    assert!((c1.estimate / 0.5 - 1.0).abs() < 0.02, "{c1:?}");
    let instants = identify_with(&table, &full);
    assert!(
        instants
            .failed_checks
            .iter()
            .any(|c| c.check == "lag" && c.message.starts_with("a_m1")),
        "{:?}",
        instants.failed_checks
    );
}

/// The same rig with the shaker's model chosen from its spectrum.
fn chosen_model() -> String {
    MODEL
        .replace("kind = \"filtered\"\nA = 1.0\nB = 1.0\n", "kind = \"white\"\n")
        .replace("[identify]\n", "[identify]\nchoose_force_model = [\"shaker\"]\n")
}

#[test]
fn a_measured_force_s_model_is_chosen_from_its_spectrum() {
    // A multisine flat over the response's band: white, and every number as when it is
    // declared an equivalent white noise.
    let table = multisine_table(200, 0.1, 7);
    let r = identify_with(&table, &chosen_model());
    assert_eq!(r.force_models[0].chosen, "white", "{:?}", r.force_models);
    let declared = identify_with(&table, &equivalent_white_model());
    let estimates = |r: &Report| -> Vec<f64> {
        let weak = row(r, ReportMethod::Estimator(Method::Weak));
        weak.parameters.iter().map(|p| p.estimate).collect()
    };
    assert_eq!(estimates(&r), estimates(&declared));
    assert!(r.failed_checks.is_empty(), "{:?}", r.failed_checks);
    // An Ornstein–Uhlenbeck force with its corner near the mode: first-order, fitted.
    let r = identify_with(&ou_table(), &chosen_model());
    let c = &r.force_models[0];
    assert_eq!(c.chosen, "first-order", "{c:?}");
    // White over the response's band is tolerated (1.9 times the averaging's misfit, the
    // limit 3) but misses a shape (3.20) follows to the averaging's own scatter.
    assert!(
        c.first_order.rms_log_residual < 1.2 * c.first_order.expected_rms,
        "{c:?}"
    );
    assert!((r.filters[0].fitted_b / 20.0 - 1.0).abs() < 0.2, "{:?}", r.filters[0]);
    assert_rig(row(&r, ReportMethod::Estimator(Method::Weak)), 0.05, 0.15);
    assert!(r.failed_checks.is_empty(), "{:?}", r.failed_checks);
}

#[test]
fn a_kanai_tajimi_force_is_named_second_order_and_refused_to_the_fpk_methods() {
    let r = identify_with(&kanai_tajimi_table(), &chosen_model());
    let c = &r.force_models[0];
    assert_eq!(c.chosen, "second-order", "{c:?}");
    let f = c.second_order.unwrap();
    assert!(
        (f.omega / 20.0 - 1.0).abs() < 0.05 && (f.zeta / 0.3 - 1.0).abs() < 0.2,
        "{f:?}"
    );
    let weak = row(&r, ReportMethod::Estimator(Method::Weak));
    assert_eq!(weak.outcome.kind(), Outcome::Refused, "{:?}", weak.outcome);
    let why = weak.outcome.error().unwrap();
    assert!(why.contains("second-order rational") && why.contains("shaker"), "{why}");
    assert_rig(row(&r, ReportMethod::Estimator(Method::ForceRegression)), 0.02, 0.1);
    assert!(!r.passed);
}

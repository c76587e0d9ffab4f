//! The paper's iterative procedure for an unmeasured disturbance (section 4): step 0 is the
//! ordinary identification, the sequence is reproducible, and its two stopping rules work.

use fpkbench::ident::disturbance::StopReason;
use fpkbench::io::log::Compression;
use fpkbench::pipeline::{identify_log, simulate_log, Options};
use fpkbench::report::Report;
use fpkbench::scenario::ReportMethod;
use fpkbench::Scenario;
use std::path::Path;

/// The paper's structure with a white measured force and no disturbance.
const WHITE: &str = r#"name = "paper_white"
[[mass]]
name = "m1"
value = 1.0

[[mass]]
name = "m2"
value = 2.0

[[link]]
ends = ["m1", "m2"]
stiffness = { 1 = 10.0 }

[[link]]
ends = ["ground", "m2"]
stiffness = { 1 = 10.0, 3 = 20.0 }
damping = { 1 = 0.5, 3 = 0.2 }

[[excitation]]
name = "p2"
kind = "white"
sigma = 2.0
acts_on = ["m2"]

[simulation]
dt = 1e-3
scheme = "semi-implicit"   # the scheme the figures below were measured with
record_length = 400.0
burn_in = 100.0
sample_interval = 0.05
trajectories = 32
seed = 5

[identify.links]
m1-m2 = { stiffness = [1] }
ground-m2 = { stiffness = [1, 3], damping = [1, 3] }
"#;

fn log_of(s: &Scenario, path: &Path) {
    simulate_log(s, path, Compression::None, &|_| {}).unwrap();
}

fn estimates(r: &Report, method: &str) -> Vec<f64> {
    let m = r.methods.iter().find(|m| m.method == method).unwrap();
    assert!(m.outcome.error().is_none(), "{method}: {:?}", m.outcome);
    m.parameters.iter().map(|p| p.estimate).collect()
}

fn quiet(max_steps: Option<usize>, tolerance: Option<f64>) -> Options {
    Options {
        validate: false,
        max_steps,
        tolerance,
        ..Options::default()
    }
}

#[test]
fn step_0_is_the_ordinary_identification_when_nothing_is_unmeasured() {
    let dir = tempfile::tempdir().unwrap();
    let plain = Scenario::parse(WHITE, "white.toml", "white").unwrap();
    let with_section = Scenario::parse(
        &format!("{WHITE}\n[identify.disturbance]\nmax_steps = 3\n"),
        "white_iterated.toml",
        "white",
    )
    .unwrap();
    let (a, b) = (dir.path().join("a.mcap"), dir.path().join("b.mcap"));
    log_of(&plain, &a);
    log_of(&with_section, &b);
    let ordinary = estimates(&identify_log(&a, &quiet(None, None)).unwrap(), "weak");
    let r = identify_log(&b, &quiet(None, None)).unwrap();
    let step0 = estimates(&r, "step-0");
    assert_eq!(ordinary.len(), 5);
    for (o, s) in ordinary.iter().zip(&step0) {
        assert!(
            (o - s).abs() <= 1e-9 * o.abs(),
            "ordinary {ordinary:?} vs step 0 {step0:?}"
        );
    }
    // And the iterate of step 0 is the one reported.
    assert_eq!(r.iterations[0].iteration.steps[0].values, step0);
    // Here step 0's model is exact (white P2, no disturbance), and the measured-force
    // sequence (with P2's Itô term) stays at it: over seeds 1000–1005 its final iterate was
    // within 0.8 of step 0's batch standard errors of it (sd 0.35 over all parameters).
    let force = &r.iterations[1];
    assert_eq!(force.method, "iterated-force");
    let step0_report = r.methods.iter().find(|m| m.method == "step-0").unwrap();
    for (k, p) in step0_report.parameters.iter().enumerate() {
        let moved = (force.iteration.last()[k] - step0[k]) / p.std_error;
        assert!(moved.abs() <= 2.0, "{} moved {moved:+.2} standard errors", p.name);
    }
    // The one-step solve of (4.8) (P2's Itô term included) agrees on K2, C2: over seeds
    // 1000–1007 they were within 2.54 of step 0's batch standard errors (sd 1.2 over the
    // 32 values). Its k1 comes from mass 2's equation alone and is much less precise than
    // step 0's: relative errors 0.083 ± 0.061 (max 0.22); the bound is mean + 4 sd.
    let direct = estimates(&r, "direct-force");
    for (k, p) in step0_report.parameters.iter().enumerate().skip(1) {
        let moved = (direct[k] - step0[k]) / p.std_error;
        assert!(
            moved.abs() <= 4.0,
            "direct-force {} moved {moved:+.2} standard errors",
            p.name
        );
    }
    assert_eq!(step0_report.parameters[0].name, "k1[m1-m2]");
    let k1_error = (direct[0] / step0_report.parameters[0].true_value - 1.0).abs();
    assert!(k1_error <= 0.33, "direct-force k1 off by {k1_error:.3}");
}

/// disturbed2dof at a short record.
fn disturbed(record_length: f64) -> Scenario {
    let mut s = Scenario::from_file(Path::new("scenarios/disturbed2dof.toml")).unwrap();
    s.simulation.record_length = record_length;
    s
}

/// Seed standard deviation of each step-0 estimate of `disturbed2dof` at level 0 and
/// 32 × 375 s (seeds 1000–1011, measured through the log pipeline),
/// in the order k1[m1-m2], k1, k3, c1, c3[ground-m2]. The study `studies/pz0.toml` (12
/// other seeds) gives 0.00660, 0.06713, 0.25614, 0.04419, 0.01018 and the paired table the
/// comments below quote.
const STEP0_SD: [f64; 5] = [0.00587, 0.09996, 0.24710, 0.04102, 0.01335];

#[test]
fn with_no_disturbance_the_measured_force_sequence_stays_at_step_0() {
    // With P_z = 0 step 0 is right (up to treating the band-limited P2 as white), so the
    // iteration should stay where it is. Over the 12 seeds the measured-force sequence's
    // final iterate moved from step 0 by (mean ± sd, in step-0 seed sds) k1[m1-m2]
    // +0.31 ± 0.33, k1 +0.89 ± 1.03, k3 +0.60 ± 1.05, c1 −0.10 ± 0.97, c3 −0.63 ± 1.05
    // (largest 2.7): the tolerance, 5 sds, is above mean + 4 sd for every parameter.
    // The paper's spectral sequence drifts instead (its documented bias: P3s contains the
    // state feedback k1 (x1 − x2)): c1 moved by +9.2 ± 0.45 sds (mean − 4 sd = 7.4).
    // `fpkbench study studies/pz0.toml` (12 other seeds, in units of its own step-0 sds):
    // the measured-force sequence moved k1[m1-m2] +0.26 ± 0.38, k1 +0.43 ± 0.78, k3
    // +1.24 ± 1.06, c1 +0.28 ± 1.08, c3 −1.07 ± 1.10, largest 2.78; the paper's c1
    // +8.60 ± 0.75 (smallest 7.5 of 12 seeds would be needed above 7: it was).
    let dir = tempfile::tempdir().unwrap();
    let s = disturbed(375.0).with_disturbance_level(0.0);
    let path = dir.path().join("run.mcap");
    log_of(&s, &path);
    let r = identify_log(&path, &quiet(None, None)).unwrap();
    let [paper, force] = [&r.iterations[0], &r.iterations[1]];
    assert_eq!(
        (&paper.method, &force.method),
        (&ReportMethod::Iterated, &ReportMethod::IteratedForce)
    );
    let step0 = &force.iteration.steps[0].values;
    assert_eq!(step0, &estimates(&r, "step-0"));
    assert_eq!(force.iteration.names[3], "c1[ground-m2]");
    assert!(force.iteration.converged, "{}", force.iteration.stopped_by);
    for st in &force.iteration.steps {
        for k in 0..5 {
            let moved = (st.values[k] - step0[k]) / STEP0_SD[k];
            assert!(
                moved.abs() <= 5.0,
                "step {}: {} moved {moved:+.2} sds from step 0",
                st.step,
                force.iteration.names[k]
            );
        }
    }
    let c1_drift = (paper.iteration.last()[3] - step0[3]) / STEP0_SD[3];
    assert!(c1_drift > 7.0, "the paper's sequence moved c1 by {c1_drift:+.2} sds");
}

#[test]
fn the_one_step_solve_stays_accurate_where_the_iteration_diverges() {
    // At disturbance level 2 the k1 equation of (4.7), which ignores P_z, pulls both
    // sequences away; the one-step solve of (4.8) never uses it. At 32 × 375 s over seeds
    // 1000–1011: direct-force worst error 0.030 ± 0.016 (max 0.063), the measured-force
    // sequence's final iterate 4.6 ± 1.0 (min 3.2). Bounds: mean + 4 sd, and mean − 4 sd.
    let dir = tempfile::tempdir().unwrap();
    let s = disturbed(375.0).with_disturbance_level(2.0);
    let path = dir.path().join("run.mcap");
    log_of(&s, &path);
    let r = identify_log(&path, &quiet(None, None)).unwrap();
    let worst = |m: &str| r.methods.iter().find(|x| x.method == m).unwrap().worst_rel_error;
    assert!(worst("direct-force") <= 0.095, "direct-force {}", worst("direct-force"));
    assert!(
        worst("iterated-force") >= 0.71,
        "iterated-force {}",
        worst("iterated-force")
    );
}

#[test]
fn the_sequence_is_reproducible_and_both_stopping_rules_work() {
    let dir = tempfile::tempdir().unwrap();
    let s = disturbed(200.0);
    let (a, b) = (dir.path().join("a.mcap"), dir.path().join("b.mcap"));
    log_of(&s, &a);
    // The same seed on one thread: the same numbers, bit for bit.
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| log_of(&s, &b));
    let first = identify_log(&a, &quiet(Some(4), Some(1e-12))).unwrap();
    let again = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| identify_log(&b, &quiet(Some(4), Some(1e-12))).unwrap());
    let steps = |r: &Report| -> Vec<Vec<f64>> {
        r.iterations
            .iter()
            .flat_map(|it| &it.iteration.steps)
            .map(|s| s.values.clone())
            .collect()
    };
    assert_eq!(steps(&first), steps(&again));

    // Both sequences (the paper's and the measured-force one) follow both rules.
    let loose = identify_log(&a, &quiet(Some(50), Some(0.02))).unwrap();
    for k in 0..2 {
        // Rule 1: a tolerance nothing meets; it stops after max_steps.
        let it = &first.iterations[k].iteration;
        assert_eq!(it.stopped_by, StopReason::MaxSteps);
        assert_eq!(it.steps.len(), 5, "step 0 and 4 steps");
        assert!(!it.converged);

        // Rule 2: a loose tolerance stops it early, at the first step whose changes are all
        // below it — and not before.
        let it = &loose.iterations[k].iteration;
        assert_eq!(it.stopped_by, StopReason::Tolerance);
        let n = it.steps.len() - 1;
        assert!(n < 50);
        assert!(
            it.steps[n].changes.iter().all(|(_, c)| *c < 0.02),
            "{:?}",
            it.steps[n].changes
        );
        for st in &it.steps[1..n] {
            assert!(
                st.changes.iter().any(|(_, c)| *c >= 0.02),
                "should have stopped at step {}",
                st.step
            );
        }
        // The sequence is the same as the max-steps run's as far as both go.
        for (x, y) in it.steps.iter().zip(&first.iterations[k].iteration.steps) {
            assert_eq!(x.values, y.values);
        }
    }
}

#[test]
fn disturbance_levels_scale_the_unmeasured_force_and_zero_removes_it() {
    let s = disturbed(100.0);
    let none = s.with_disturbance_level(0.0);
    // [simulation] edits made in memory survive.
    assert_eq!(none.simulation, s.simulation);
    assert_eq!(none.excitations.len(), 1);
    assert!(none.excitations[0].measured);
    assert!(none.identify.disturbance.is_some());
    let std = |e: &fpkbench::scenario::Excitation| match e.process {
        fpkbench::scenario::Process::Filtered { a, b } => a / (2.0 * b).sqrt(),
        _ => panic!("filtered"),
    };
    for level in [0.25, 1.0, 2.0] {
        let t = s.with_disturbance_level(level);
        let ratio = std(&t.excitations[1]) / std(&t.excitations[0]);
        assert!((ratio - level).abs() < 1e-12, "level {level}: ratio {ratio}");
        assert!(!t.excitations[1].measured);
        assert_eq!(t.excitations[1].acts_on, vec![0, 1]);
        // The source text as written plus the level (what a log stores) say the same.
        assert_eq!(t.disturbance_level, Some(level));
        let reparsed = Scenario::parse(&t.source, "x", "x").unwrap();
        assert_eq!(reparsed.with_disturbance_level(level).excitations, t.excitations);
    }
}

/// The validation re-simulates what the method knows: the unmeasured disturbance is left
/// out and named, so the model's responses are smaller than the data's (on disturbed2dof
/// at 32 × 1500 s by 17–33 % in std), never matched with the true `P_z` the method was not
/// told about.
#[test]
fn the_validation_leaves_out_the_disturbance_the_method_does_not_know() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    log_of(&disturbed(375.0), &path);
    let r = identify_log(&path, &Options::default()).unwrap();
    let text = fpkbench::report::text::summary(&r);
    assert!(
        text.contains("Left out of the re-simulation: the unmeasured excitation pz"),
        "{text}"
    );
    let v = r.validation.expect("validated");
    assert_eq!(v.left_out, ["pz"]);
    assert!(v.left_out_note().contains("unmeasured excitation pz"));
    for row in &v.rows {
        assert!(
            row.model_std < 0.9 * row.data_std,
            "{}: model {} against data {}",
            row.variable,
            row.model_std,
            row.data_std
        );
    }
}

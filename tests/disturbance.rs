//! The paper's iterative procedure for an unmeasured disturbance (section 4): step 0 is the
//! ordinary identification, the sequence is reproducible, and its two stopping rules work.

use fpkbench::bench::{identify_log, Options, Report};
use fpkbench::io::log::LogWriter;
use fpkbench::sim::simulate;
use fpkbench::{Model, Scenario};
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
    let m = Model::new(s);
    let mut w = LogWriter::create(path, s, &m).unwrap();
    simulate(&m, &s.simulation, &mut w, &|_| {}).unwrap();
    w.finish().unwrap();
}

fn estimates(r: &Report, method: &str) -> Vec<f64> {
    let m = r.methods.iter().find(|m| m.method == method).unwrap();
    assert!(m.error.is_none(), "{method}: {:?}", m.error);
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
    assert_eq!(r.iteration.as_ref().unwrap().iteration.steps[0].values, step0);
}

/// disturbed2dof at a short record.
fn disturbed(record_length: f64) -> Scenario {
    let mut s = Scenario::from_file(Path::new("scenarios/disturbed2dof.toml")).unwrap();
    s.simulation.record_length = record_length;
    s
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
        r.iteration
            .as_ref()
            .unwrap()
            .iteration
            .steps
            .iter()
            .map(|s| s.values.clone())
            .collect()
    };
    assert_eq!(steps(&first), steps(&again));

    // Rule 1: a tolerance nothing meets; it stops after max_steps.
    let it = &first.iteration.as_ref().unwrap().iteration;
    assert_eq!(it.stopped_by, "max_steps");
    assert_eq!(it.steps.len(), 5, "step 0 and 4 steps");
    assert!(!it.converged);

    // Rule 2: a loose tolerance stops it early, at the first step whose changes are all
    // below it — and not before.
    let r = identify_log(&a, &quiet(Some(50), Some(0.02))).unwrap();
    let it = &r.iteration.as_ref().unwrap().iteration;
    assert_eq!(it.stopped_by, "tolerance");
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
    for (x, y) in it.steps.iter().zip(&first.iteration.as_ref().unwrap().iteration.steps) {
        assert_eq!(x.values, y.values);
    }
}

#[test]
fn disturbance_levels_scale_the_unmeasured_force_and_zero_removes_it() {
    let s = disturbed(100.0);
    let none = s.with_disturbance_level(0.0).unwrap();
    assert_eq!(none.excitations.len(), 1);
    assert!(none.excitations[0].measured);
    assert!(none.identify.disturbance.is_some());
    let std = |e: &fpkbench::scenario::Excitation| match e.process {
        fpkbench::scenario::Process::Filtered { a, b } => a / (2.0 * b).sqrt(),
        _ => panic!("filtered"),
    };
    for level in [0.25, 1.0, 2.0] {
        let t = s.with_disturbance_level(level).unwrap();
        let ratio = std(&t.excitations[1]) / std(&t.excitations[0]);
        assert!((ratio - level).abs() < 1e-12, "level {level}: ratio {ratio}");
        assert!(!t.excitations[1].measured);
        assert_eq!(t.excitations[1].acts_on, vec![0, 1]);
        // The source text says the same (it is what a log stores).
        let reparsed = Scenario::parse(&t.source, "x", "x").unwrap();
        assert_eq!(reparsed.excitations, t.excitations);
    }
}

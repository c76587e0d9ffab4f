//! Structure selection at the process boundary (docs/selection.md): the terms chosen from
//! candidates on simulated data whose truth is known, the evidence in report.json and
//! report.md, the selection figure, and the scenario mistakes refused with their place.

use std::path::Path;
use std::process::{Command, Output};

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args(args)
        .output()
        .unwrap()
}

fn report(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
}

/// The names the report's selection kept.
fn selected(r: &serde_json::Value) -> Vec<String> {
    let s = &r["selection"];
    let names = s["candidates"].as_array().unwrap();
    let kept = s["selected"].as_array().unwrap();
    names
        .iter()
        .zip(kept)
        .filter(|(_, k)| k.as_bool().unwrap())
        .map(|(n, _)| n.as_str().unwrap().to_string())
        .collect()
}

fn method<'a>(r: &'a serde_json::Value, name: &str) -> &'a serde_json::Value {
    r["methods"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["method"] == name)
        .unwrap_or_else(|| panic!("no row {name}"))
}

#[test]
fn an_sdof_duffings_terms_are_chosen_from_powers_one_to_five() {
    // Candidates k1..k5 and c1..c5 on the one link; the truth is k1, k3, c1. Over 20
    // seeds at this record (32 × 312.5 s) the selection was exactly the truth on 19, one
    // kept c5 (docs/selection.md); the scenario's own seed is one of the exact ones.
    let dir = tempfile::tempdir().unwrap();
    let out = run(&[
        "run",
        "scenarios/sdof_duffing.toml",
        "--select-powers",
        "5",
        "--method",
        "weak",
        "--no-validate",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r = report(dir.path());
    assert_eq!(r["selection"]["candidates"].as_array().unwrap().len(), 10);
    assert_eq!(selected(&r), ["k1[ground-m1]", "k3[ground-m1]", "c1[ground-m1]"]);
    // Every method row says which terms it identified; the declared model is beside it.
    let weak = method(&r, "weak");
    assert_eq!(
        weak["selected"],
        serde_json::json!(["k1[ground-m1]", "k3[ground-m1]", "c1[ground-m1]"])
    );
    assert_eq!(weak["parameters"].as_array().unwrap().len(), 3);
    let declared = method(&r, "weak [declared terms]");
    assert!(declared.get("selected").is_none());
    // The evidence: the path from all ten terms down, the runners-up, the replicates.
    let sel = &r["selection"];
    assert_eq!(sel["path"][0]["terms"], 10);
    assert!(sel["runners_up"].as_array().unwrap().len() >= 2);
    let inclusion: Vec<f64> = sel["inclusion"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(inclusion.len(), 10);
    assert!(inclusion.iter().all(|f| (0.0..=1.0).contains(f)));
    for (k, name) in ["k1[ground-m1]", "k3[ground-m1]", "c1[ground-m1]"].iter().enumerate() {
        let i = sel["candidates"]
            .as_array()
            .unwrap()
            .iter()
            .position(|n| n == name)
            .unwrap();
        assert!(
            inclusion[i] > 0.9,
            "{name} ({k}) in {:.2} of the replicates",
            inclusion[i]
        );
    }
    assert!(stdout.contains("structure selection: 3 of 10 candidates"), "{stdout}");
    let md = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    assert!(
        md.contains("## Structure selection") && md.contains("runner-up"),
        "{md}"
    );
    let svg = std::fs::read_to_string(dir.path().join("selection.svg")).unwrap();
    assert!(svg.contains("elimination path"));
}

#[test]
fn extra_damping_powers_are_removed_and_the_curves_come_back() {
    // The case that motivated selection: damping powers 1, 2, 3 on every link of
    // duffing2dof (the truth has c3 on ground–m1 only). Identified with all of them the
    // ground–m2 damping curve was 16–55× less accurate and the run exited 1. Over 50 seeds
    // (docs/selection.md) the extras were removed on every seed.
    let dir = tempfile::tempdir().unwrap();
    let out = run(&[
        "run",
        "scenarios/duffing2dof.toml",
        "--set",
        "identify.select.damping=[1,2,3]",
        "--method",
        "weak",
        "--no-validate",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let r = report(dir.path());
    let truth: Vec<&str> = vec![
        "k1[ground-m1]",
        "k3[ground-m1]",
        "c1[ground-m1]",
        "c3[ground-m1]",
        "k1[m1-m2]",
        "c1[m1-m2]",
        "k1[ground-m2]",
        "k3[ground-m2]",
        "c1[ground-m2]",
    ];
    assert_eq!(selected(&r), truth);
    // The selected model is the declared one here: the same estimates, the gate held.
    let weak = method(&r, "weak");
    let declared = method(&r, "weak [declared terms]");
    assert_eq!(weak["worst_rel_error"], declared["worst_rel_error"]);
    assert_eq!(weak["passed"], true);
}

/// Candidates that lack a term of the declared structure (friction_sdof's Coulomb
/// friction, `sign`, among powers 1..3): the selection runs over the powers, and the
/// declared model it is compared with gathers its own moments (the panic of issue 70 was
/// its moments asked of the candidates' accumulator).
#[test]
fn candidates_without_the_declared_non_power_term_still_compare_with_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = run(&[
        "run",
        "scenarios/friction_sdof.toml",
        "--select-powers",
        "3",
        "--method",
        "weak",
        "--no-validate",
        "--set",
        "simulation.record_length=1250",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(matches!(out.status.code(), Some(0 | 1)), "{stderr}");
    let r = report(dir.path());
    assert!(!selected(&r).is_empty(), "{}", r["selection"]);
    let declared = method(&r, "weak [declared terms]");
    assert_eq!(declared["outcome"], "estimated", "{declared}");
    // The declared model is the truth's structure: its friction coefficient is estimated,
    // and its worst error is within the weak form's gate at this record (the accuracy
    // regression's, 0.103: mean + 4 sd over 12 seeds).
    let names: Vec<&str> = declared["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    assert!(names.iter().any(|n| n.contains("sign")), "{names:?}");
    assert!(declared["worst_rel_error"].as_f64().unwrap() < 0.103, "{declared}");
}

fn scenario_error(extra: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let src = std::fs::read_to_string("scenarios/sdof_duffing.toml").unwrap();
    let p = dir.path().join("s.toml");
    std::fs::write(&p, format!("{src}\n{extra}")).unwrap();
    let out = run(&["run", p.to_str().unwrap(), "--out", dir.path().to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(!dir.path().join("report.json").exists());
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn a_selection_that_cannot_run_is_refused_where_it_is_written() {
    let err = scenario_error("[identify.select]\nstiffness = [1, 0]\n");
    assert!(
        err.contains("identify.select.stiffness") && err.contains("1..=15"),
        "{err}"
    );
    let err = scenario_error("[identify.select]\ndamping = [1, 1]\n");
    assert!(err.contains("listed twice"), "{err}");
    // Selection chooses among spring and damper terms with everything else known.
    let src = std::fs::read_to_string("scenarios/sdof_duffing.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("s.toml");
    std::fs::write(
        &p,
        src.replace("[identify]\n", "[identify]\nunknown_intensities = [\"m1\"]\n") + "\n[identify.select]\n",
    )
    .unwrap();
    let out = run(&["run", p.to_str().unwrap(), "--out", dir.path().to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("s.toml:") && err.contains("`identify.select`") && err.contains("unknown intensities"),
        "{err}"
    );
}

/// The documented maximum, `--select-powers 15` on the two-mass chain: its candidate
/// model's moments (90 unknowns, degree 30) take 7.2 GB over their fine batches and the
/// weighting of its 4,844 equations 1.5 GB, which ran
/// past 8 GiB before anything said so. The tables are sized before they are allocated
/// and refused beyond the budget (half the machine's memory; here set lower, as
/// `FPKBENCH_MEMORY_BUDGET` lets a user do), with the sizes and what to ask instead.
#[test]
fn a_selection_whose_moments_exceed_the_memory_budget_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let started = std::time::Instant::now();
    let o = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args(["run", "scenarios/duffing2dof.toml", "--select-powers", "15"])
        .args([
            "--set",
            "simulation.record_length=100",
            "--out",
            dir.path().to_str().unwrap(),
        ])
        .env("FPKBENCH_MEMORY_BUDGET", "4000000000")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("90 unknowns, moments to degree 30, 4844 equations) would take 8.7 GB")
            && err.contains("moments over their fine batches 7.2 GB, the weighting of its equations 1.5 GB")
            && err.contains("more than the 4.0 GB")
            && err.contains("--select-powers"),
        "{err}"
    );
    assert!(
        started.elapsed().as_secs() < 60,
        "refused only after {:?}",
        started.elapsed()
    );
}

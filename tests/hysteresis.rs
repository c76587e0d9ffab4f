//! A hysteretic (Bouc–Wen) truth: simulated with its own state, refused where its
//! parameters make no loop, never graded, and caught by the validation (docs/results.md,
//! "The one-argument assumption").

use fpkbench::Scenario;
use std::process::Command;

fn run_json(args: &[&str]) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let mut all = vec!["run"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--json", "--out", dir.path().to_str().unwrap()]);
    let out = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args(&all)
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The shipped Bouc–Wen SDOF at its shipped length (2e4 s): nothing graded (no parameter
/// has a true value), and the validation says the model does not reproduce the data,
/// naming the spectrum of the displacement. Over seeds 1–10 the displacement spectrum's
/// RMS log ratio was 5.9 to 6.5 times what the averaging alone gives, against the misfit
/// threshold of 1.6; the kurtosis differed by 6.3 to 11.4 standard errors (threshold 4).
/// The Duffing SDOF's correct model, at the accuracy gate's length, reproduces its data
/// (over 27 runs of the shipped scenarios the largest ratio was 1.35, the largest std and
/// kurtosis differences 2.5 standard errors).
#[test]
fn a_hysteretic_truth_is_not_graded_and_the_validation_names_the_misfit() {
    let r = run_json(&["scenarios/boucwen_sdof.toml", "--method", "weak"]);
    let weak = &r["methods"][0];
    assert!(weak["worst_rel_error"].is_null(), "{weak}");
    for p in weak["parameters"].as_array().unwrap() {
        assert!(p["true_value"].is_null() && p["rel_error"].is_null(), "{p}");
        assert!(p["estimate"].as_f64().unwrap().is_finite(), "{p}");
    }
    let v = &r["validation"];
    assert_eq!(v["reproduces"], false, "{v}");
    let misfits = v["misfits"].as_array().unwrap();
    assert!(
        misfits
            .iter()
            .any(|m| m["statistic"] == "spectrum" && m["variable"] == "x_m1"),
        "{v}"
    );
    let r = run_json(&[
        "scenarios/sdof_duffing.toml",
        "--method",
        "weak",
        "--set",
        "simulation.record_length=312.5",
    ]);
    let v = &r["validation"];
    assert_eq!(v["reproduces"], true, "{v}");
    assert!(v["misfits"].as_array().unwrap().is_empty(), "{v}");
}

/// Far from its plateau (`β` tiny, so `z_max` = 10⁶ m) the element is a linear spring:
/// `z` follows `u` step by step (it is advanced with the velocity the displacement takes),
/// so the system is the linear oscillator with stiffness `k + k_z`, simulated on the same
/// random numbers — the stds agree to 1e-4 (measured: 2e-6). Had `z` been advanced with
/// the step's old velocity, it would lag `u` by `h·w`, a negative damping `k_z·h` that
/// raised the stds by 1.6 %. Both sit near the closed form `σ/√(2 c (k + k_z))` = 0.5 m and
/// `σ/√(2 c m)` (1.3 % off over this 1e5 s record, seed 1; allowed 5 %).
#[test]
fn a_bouc_wen_element_below_its_plateau_is_a_linear_spring() {
    let src = std::fs::read_to_string("scenarios/boucwen_sdof.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let stds = |name: &str, text: String| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let r = run_json(&[
            path.to_str().unwrap(),
            "--method",
            "weak",
            "--set",
            "simulation.record_length=3125.0",
        ]);
        let rows = r["validation"]["rows"].as_array().unwrap().clone();
        let std = |v: &str| {
            rows.iter().find(|x| x["variable"] == v).unwrap()["data_std"]
                .as_f64()
                .unwrap()
        };
        (std("x_m1"), std("v_m1"))
    };
    let hysteretic = stds(
        "hysteretic.toml",
        src.replace("beta = 1.5, gamma = 0.5", "beta = 1e-6, gamma = 0.0"),
    );
    let spring = stds(
        "spring.toml",
        src.replace("stiffness = { 1 = 4.0 }", "stiffness = { 1 = 10.0 }")
            .lines()
            .filter(|l| !l.starts_with("hysteresis"))
            .collect::<Vec<_>>()
            .join("\n"),
    );
    assert!(
        (hysteretic.0 / spring.0 - 1.0).abs() < 1e-4,
        "{hysteretic:?} {spring:?}"
    );
    assert!(
        (hysteretic.1 / spring.1 - 1.0).abs() < 1e-4,
        "{hysteretic:?} {spring:?}"
    );
    assert!((hysteretic.0 / 0.5 - 1.0).abs() < 0.05, "{hysteretic:?}");
    assert!((hysteretic.1 / 2.5f64.sqrt() - 1.0).abs() < 0.05, "{hysteretic:?}");
}

#[test]
fn a_loop_that_is_unbounded_or_gains_energy_is_refused_where_it_is_written() {
    let base = |hysteresis: &str| {
        format!(
            "[[mass]]\nname = \"m1\"\nvalue = 1.0\n[[link]]\nends = [\"ground\", \"m1\"]\nstiffness = {{ 1 = 4.0 }}\n\
             damping = {{ 1 = 0.2 }}\nhysteresis = {hysteresis}\n[[excitation]]\nkind = \"white\"\nsigma = 1.0\n\
             acts_on = [\"m1\"]\n[simulation]\ndt = 1e-3\nrecord_length = 10.0\nsample_interval = 0.1\n"
        )
    };
    let parse = |src: String| Scenario::parse(&src, "t.toml", "t").map_err(|e| e.to_string());
    parse(base("{ stiffness = 6.0, beta = 1.5, gamma = 0.5 }")).unwrap();
    let e = parse(base("{ stiffness = 6.0, beta = 1.5, gamma = -1.5 }")).unwrap_err();
    assert!(
        e.contains("t.toml:8") && e.contains("link[0].hysteresis.gamma") && e.contains("bounded"),
        "{e}"
    );
    let e = parse(base("{ stiffness = 6.0, beta = -1.0, gamma = 0.5 }")).unwrap_err();
    assert!(e.contains("link[0].hysteresis.beta") && e.contains("dissipates"), "{e}");
    let e = parse(base("{ stiffness = 6.0, beta = 1.0, gamma = 0.5, n = 0.5 }")).unwrap_err();
    assert!(
        e.contains("link[0].hysteresis.n") && e.contains("between 1 and 8"),
        "{e}"
    );
    let e = parse(base("{ stiffness = 6.0, beta = 1.0, gamma = 0.5, alpha = 0.5 }")).unwrap_err();
    assert!(e.contains("alpha"), "{e}");
}

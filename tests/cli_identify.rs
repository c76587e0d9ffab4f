//! `identify` and `run` at the process boundary: identifiability refusals, model mismatch
//! on simulated data, and the report's fields.

use std::path::Path;
use std::process::{Command, Output};

fn sdof_with(identify_lines: &str, seed: u64, dir: &Path) -> std::path::PathBuf {
    let src = std::fs::read_to_string("scenarios/sdof_duffing.toml").unwrap();
    let src = src
        .replace("[identify]", &format!("[identify]\n{identify_lines}"))
        .replace("seed = 1\n", &format!("seed = {seed}\n"));
    let p = dir.join("s.toml");
    std::fs::write(&p, src).unwrap();
    p
}

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args(args)
        .output()
        .unwrap()
}

/// Run with `identify_lines` and `seed`, expect a refusal naming `must_name`; return stderr.
fn refused(identify_lines: &str, seed: u64, must_name: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let s = sdof_with(identify_lines, seed, dir.path());
    let out = run(&["run", s.to_str().unwrap(), "--out", dir.path().to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("cannot be separated") && err.contains("No estimates"),
        "{err}"
    );
    for n in must_name {
        assert!(err.contains(n), "{n} not named: {err}");
    }
    assert!(
        out.stdout.is_empty(),
        "estimates printed: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(!dir.path().join("report.json").exists());
    err.into_owned()
}

/// The weakest direction's entry for `name` in a refusal message.
fn direction(err: &str, name: &str) -> f64 {
    let key = format!("{name}: ");
    let dir = &err[err.find("along [").expect("direction")..];
    let at = dir
        .find(&key)
        .unwrap_or_else(|| panic!("{name} not in the direction: {err}"));
    dir[at + key.len()..]
        .split([',', ']'])
        .next()
        .unwrap()
        .trim()
        .parse()
        .unwrap()
}

#[test]
fn damping_and_intensity_together_are_refused_before_simulating_on_every_seed() {
    // The exact (c, σ²) symmetry of the stationary density is recognised from the model,
    // so the verdict cannot depend on the seed (at 249e199 it missed 2 seeds in 20).
    for seed in 1..=5 {
        let err = refused("unknown_intensities = [\"m1\"]", seed, &["c1[ground-m1]", "sigma[m1]"]);
        let (c, s) = (direction(&err, "c1[ground-m1]"), direction(&err, "sigma[m1]"));
        assert!((c - 1.0).abs() < 1e-9 && (s - 0.5).abs() < 1e-9, "{err}");
        assert!(err.contains("whatever the data") && !err.contains("simulated"), "{err}");
    }
}

#[test]
fn mass_with_stiffness_and_damping_is_refused_before_simulating_on_every_seed() {
    // (k, c, m) → (λk, c/λ, λm) leaves the stationary density unchanged: k1, k3 and m move
    // together, c1 against them.
    for seed in 1..=5 {
        let err = refused(
            "unknown_masses = [\"m1\"]",
            seed,
            &["m[m1]", "k1[ground-m1]", "c1[ground-m1]"],
        );
        for (name, d) in [
            ("m[m1]", 1.0),
            ("k1[ground-m1]", 1.0),
            ("k3[ground-m1]", 1.0),
            ("c1[ground-m1]", -1.0),
        ] {
            assert!((direction(&err, name) - d).abs() < 1e-9, "{name}: {err}");
        }
    }
}

#[test]
fn extra_power_on_simulated_data_gives_a_small_k2_and_curve_error() {
    // Identify {1, 2, 3} on a {1, 3} truth, 1e4 s. Over seeds 1–10: k2's error relative to
    // the true characteristic's RMS had mean 0.33 %, max 1.04 %; the stiffness curve's L2
    // error mean 0.97 %, max 2.4 %. Tolerances: mean + 4 sd.
    let dir = tempfile::tempdir().unwrap();
    let s = sdof_with(
        "links.ground-m1 = { stiffness = [1, 2, 3], damping = [1] }",
        3,
        dir.path(),
    );
    let out = run(&[
        "run",
        s.to_str().unwrap(),
        "--method",
        "weak",
        "--json",
        "--no-validate",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(
        matches!(out.status.code(), Some(0) | Some(1)),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let m = &r["methods"][0];
    let k2 = m["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "k2[ground-m1]")
        .unwrap();
    assert_eq!(k2["true_value"], 0.0);
    assert!(k2["rel_error"].as_f64().unwrap() < 0.017, "{k2}");
    let curve = m["curves"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["kind"] == "stiffness")
        .unwrap();
    assert!(curve["rel_l2_error"].as_f64().unwrap() < 0.035, "{curve}");
}

#[test]
fn identify_reads_scenario_and_truth_from_the_log_and_writes_the_report() {
    let dir = tempfile::tempdir().unwrap();
    let s = sdof_with("", 1, dir.path());
    let log = dir.path().join("run.mcap");
    assert!(run(&["simulate", s.to_str().unwrap(), "-o", log.to_str().unwrap()])
        .status
        .success());
    let out_dir = dir.path().join("rep");
    let out = run(&[
        "identify",
        log.to_str().unwrap(),
        "--json",
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    assert!(
        matches!(out.status.code(), Some(0) | Some(1)),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in [
        "scenario",
        "record_length_s",
        "samples",
        "sample_interval_s",
        "timings_s",
        "methods",
        "validation",
    ] {
        assert!(!r[key].is_null(), "report lacks {key}");
    }
    for key in ["simulate", "identify", "total"] {
        assert!(r["timings_s"][key].is_number());
    }
    assert_eq!(r["samples"], 100_000);
    for m in r["methods"].as_array().unwrap() {
        for key in [
            "method",
            "parameters",
            "curves",
            "worst_rel_error",
            "threshold",
            "passed",
            "diagnostics",
        ] {
            assert!(!m[key].is_null(), "method lacks {key}");
        }
        for key in ["rank", "cols", "sv_ratio"] {
            assert!(m["diagnostics"][key].is_number());
        }
        for p in m["parameters"].as_array().unwrap() {
            for key in [
                "name",
                "true_value",
                "estimate",
                "std_error",
                "ci95",
                "differs_from_zero",
                "rel_error",
            ] {
                assert!(!p[key].is_null(), "parameter lacks {key}: {p}");
            }
            // The interval is the estimate ± t(0.975, dof) standard errors: 31 degrees of
            // freedom from the weak form's 32 batches, 15 from the strong form's 16 groups.
            let t = if m["method"] == "strong" { 2.1314 } else { 2.0395 };
            let (e, se) = (p["estimate"].as_f64().unwrap(), p["std_error"].as_f64().unwrap());
            let hi = p["ci95"][1].as_f64().unwrap();
            assert!(((hi - e) / se - t).abs() < 1e-3, "{}: {p}", m["method"]);
        }
    }
    // Where the report came from.
    let prov = &r["provenance"];
    assert_eq!(prov["version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(prov["scenario_sha256"].as_str().unwrap().len(), 64);
    // The exit code follows the gates.
    let passed = r["methods"].as_array().unwrap().iter().all(|m| m["passed"] == true);
    assert_eq!(out.status.code(), Some(if passed { 0 } else { 1 }));
    for f in ["report.json", "report.md", "characteristics.svg", "densities.svg"] {
        let p = out_dir.join(f);
        assert!(p.exists(), "{f}");
        if f.ends_with(".svg") {
            let t = std::fs::read_to_string(&p).unwrap();
            assert!(
                t.starts_with("<svg") && t.contains("</svg>") && t.contains("<text"),
                "{f} is not a complete SVG with text"
            );
        }
    }
    assert!(std::fs::read_dir(&out_dir)
        .unwrap()
        .all(|e| !e.unwrap().path().to_string_lossy().ends_with(".partial")));
}

#[test]
fn strong_form_grid_options_out_of_range_are_usage_errors() {
    for (flag, value) in [
        ("--bins", "0"),
        ("--bins", "2"),
        ("--span", "nan"),
        ("--span", "-1"),
        ("--min-count", "0"),
    ] {
        let o = run(&["identify", "no-such.mcap", &format!("{flag}={value}")]);
        assert_eq!(o.status.code(), Some(2), "{flag} {value}");
        assert!(String::from_utf8_lossy(&o.stderr).contains(flag), "{flag} {value}");
    }
}

#[test]
fn a_strong_form_that_does_not_apply_is_not_a_failed_gate() {
    // A 3-mass chain: a 6-D state whose 320 000 samples cannot fill even a 6^6 grid at 20
    // per cell. The strong form is reported as not applicable; the exit code follows the
    // weak form's gate alone.
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("chain3.toml");
    std::fs::write(&s, CHAIN3).unwrap();
    let out = run(&[
        "run",
        s.to_str().unwrap(),
        "--out",
        dir.path().to_str().unwrap(),
        "--json",
        "--no-validate",
    ]);
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let methods = r["methods"].as_array().unwrap();
    let strong = methods.iter().find(|m| m["method"] == "strong").unwrap();
    assert!(
        strong["not_applicable"].as_str().unwrap().contains("6-dimensional"),
        "{strong}"
    );
    assert!(strong["passed"].is_null() && strong["error"].is_null(), "{strong}");
    let weak = methods.iter().find(|m| m["method"] == "weak").unwrap();
    assert_eq!(r["passed"], weak["passed"]);
    assert_eq!(out.status.code(), Some(if weak["passed"] == true { 0 } else { 1 }));
}

const CHAIN3: &str = r#"name = "chain3"
[[mass]]
name = "m1"
value = 1.0
[[mass]]
name = "m2"
value = 1.0
[[mass]]
name = "m3"
value = 1.0
[[link]]
ends = ["ground", "m1"]
stiffness = { 1 = 10.0, 3 = 20.0 }
damping = { 1 = 0.5 }
[[link]]
ends = ["m1", "m2"]
stiffness = { 1 = 5.0 }
damping = { 1 = 0.2 }
[[link]]
ends = ["m2", "m3"]
stiffness = { 1 = 5.0 }
damping = { 1 = 0.2 }
[[link]]
ends = ["ground", "m3"]
stiffness = { 1 = 8.0 }
damping = { 1 = 0.3 }
[[excitation]]
kind = "white"
sigma = 1.0
acts_on = ["m1"]
[[excitation]]
kind = "white"
sigma = 1.0
acts_on = ["m3"]
[simulation]
dt = 1e-3
record_length = 1000.0
sample_interval = 0.1
trajectories = 32
seed = 1
[identify]
methods = ["weak", "strong"]
[accept]
worst_rel_error = 0.2
methods = { strong = 1.0 }
"#;

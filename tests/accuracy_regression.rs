//! CI accuracy regression: every scenario in `scenarios/` is run through the real binary
//! (`fpkbench run … --json`) at a reduced record length with a fixed seed, and each
//! method's worst relative error must stay under a threshold taken from its spread over
//! 12 seeds (seeds 1000–1011, measured through the log pipeline; today a study measures the
//! same spread: `fpkbench study --scenario scenarios/S.toml --record-length RECORD --seeds
//! 12`, docs/studies.md, with seeds of its own): threshold = mean + 4 sd of the worst
//! error, so a healthy build fails with probability well under 1 % while a real loss of
//! accuracy fails it.

use std::process::Command;

struct Gate {
    scenario: &'static str,
    /// Reduced record length per trajectory, s.
    record_length: f64,
    /// (method, threshold on the worst relative error).
    thresholds: &'static [(&'static str, f64)],
}

const SEED: u64 = 1000;

/// Scenarios run with only the named methods: sparse2dof's baselines are ungated here (and
/// tested in tests/baselines.rs), and its local-linear quasi-likelihood alone took 49 of
/// the run's 50 s.
const ONLY: &[(&str, &[&str])] = &[("sparse2dof", &["weak"])];

const GATES: &[Gate] = &[
    // A hysteretic truth: no one-argument model is right, nothing is graded (its validation
    // verdict is tested in tests/hysteresis.rs); the run must still succeed.
    Gate {
        scenario: "boucwen_sdof",
        record_length: 625.0,
        thresholds: &[],
    },
    // 32 × 3125 s (1e5 s) at dt 2.5e-4, the gap profiled: weak mean 0.133, sd 0.097, max
    // 0.317; strong mean 0.118, sd 0.089, max 0.319 (10 seeds; the worst is the soft
    // spring k1[m1-m2], which absorbs the profiled gap's error).
    Gate {
        scenario: "clearance2dof",
        record_length: 3125.0,
        thresholds: &[("weak", 0.52), ("strong", 0.473)],
    },
    // 32 × 1250 s (4e4 s). weak: mean 0.0329, sd 0.0185, max 0.063; strong: mean 0.0280,
    // sd 0.0160, max 0.055 (10 seeds).
    // 64 × 1250 s (8e4 s), Heun at 2.5 ms. weak: mean 0.0222, sd 0.0079, max 0.040 (20
    // seeds: a study of 12 and the 8 of docs/results.md's frame table).
    Gate {
        scenario: "frame4",
        record_length: 1250.0,
        thresholds: &[("weak", 0.054)],
    },
    Gate {
        scenario: "friction_sdof",
        record_length: 1250.0,
        thresholds: &[("weak", 0.103), ("strong", 0.092)],
    },
    // 32 × 312.5 s. weak: mean 0.0199, sd 0.0106, max 0.035; strong (kernel estimates of
    // the density and its fluxes; a study of 12 seeds): mean 0.0216, sd 0.0092, max 0.037.
    Gate {
        scenario: "sdof_duffing",
        record_length: 312.5,
        thresholds: &[("weak", 0.062), ("strong", 0.059)],
    },
    // 32 × 31.25 s (1e3 s, the record of the paper's experiment; the target there is ≤ 4 %).
    // weak (A, B fitted): mean 0.0118, sd 0.0058, max 0.019; strong (kernel; a study of 12
    // seeds): mean 0.0272, sd 0.0161, max 0.056; strong-marginals: mean 0.9596, sd 0.0022,
    // max 0.964.
    Gate {
        scenario: "silentblock",
        record_length: 31.25,
        thresholds: &[("weak", 0.035), ("strong", 0.093), ("strong-marginals", 0.969)],
    },
    // 64 × 625 s (4e4 s) at dt 2.5e-4. weak: mean 0.0475, sd 0.0251, max 0.101.
    Gate {
        scenario: "filtered2dof",
        record_length: 625.0,
        thresholds: &[("weak", 0.148)],
    },
    // 32 × 375 s (1.2e4 s). The iterative procedure's final estimates: the paper's sequence
    // ("iterated") mean 0.452, sd 0.0129, max 0.477 (its error is the procedure's bias, not
    // noise). The bound with the disturbance given as measured in the paper's white model
    // ("pz-measured"): mean 0.072, sd 0.042, max 0.147. The measured-force methods over 30
    // seeds (1000–1029; their 12-seed sds vary by half): the sequence ("iterated-force")
    // mean 0.0193, sd 0.0076, max 0.042; its bound ("pz-measured-force") mean 0.0157, sd
    // 0.0107, max 0.048; the one-step solve of (4.8) ("direct-force") mean 0.0164, sd
    // 0.0092, max 0.047.
    Gate {
        scenario: "disturbed2dof",
        record_length: 375.0,
        thresholds: &[
            ("iterated", 0.503),
            ("iterated-force", 0.050),
            ("pz-measured", 0.239),
            ("pz-measured-force", 0.058),
            ("direct-force", 0.053),
        ],
    },
    // At its shipped length, 16 × 3125 s every 0.5 s, 52 seeds (the 10 of the study
    // studies/sparse2dof.toml at 0.5 s and 42 of two flag studies, see the scenario's
    // comment): weak mean 0.077, sd 0.041, max 0.196. (The 10 alone, mean 0.052, sd 0.024,
    // gave 0.147, exceeded by 1 seed in 12 later.) The baselines are ungated.
    Gate {
        scenario: "sparse2dof",
        record_length: 3125.0,
        thresholds: &[("weak", 0.24)],
    },
    // 64 × 625 s with structure selection (candidate powers 1 and 3, and the candidate link
    // m1–m3), 20 seeds: the selected model's weak worst error mean 0.0288, sd 0.0111, max
    // 0.065; exact structure on 18 (docs/selection.md).
    Gate {
        scenario: "chain3",
        record_length: 625.0,
        thresholds: &[("weak", 0.073)],
    },
    // 64 × 1000 s, the weighted weak form with 1000 equations, 42 seeds (the 12 of
    // studies/chain5.toml and `fpkbench study --scenario scenarios/chain5.toml
    // --record-length 1000 --seeds 30 --seed 7`): weak mean 0.0371, sd 0.0170, median
    // 0.0326, max 0.103. (The 12 seeds alone gave sd 0.0123, max 0.058, and a gate of 0.083
    // that this seed's 0.091 exceeded: the tail is heavier than 12 seeds show.)
    Gate {
        scenario: "chain5",
        record_length: 1000.0,
        thresholds: &[("weak", 0.105)],
    },
    // The Silverbox twin at its shipped length (10 multisine blocks of 8192 samples at 610
    // Hz), 20 seeds: weak mean 0.0691, sd 0.0422, max 0.163; force regression mean 0.0106,
    // sd 0.0045, max 0.0193; weak-measured-force mean 0.0007, sd 0.0005, max 0.0019
    // (docs/results.md, "A twin of the benchmark").
    Gate {
        scenario: "silverbox_twin",
        record_length: 13.4217728,
        thresholds: &[
            ("weak", 0.24),
            ("weak-measured-force", 0.0027),
            ("force-regression", 0.029),
        ],
    },
    // 64 × 625 s. weak: mean 0.0477, sd 0.0288, max 0.112; strong (kernel estimates of the
    // density and its fluxes, a study of 12 seeds; the 4-D histogram, starved at 4e5
    // samples, gave mean 4.36): mean 0.0570, sd 0.0233, max 0.103; strong-marginals (the
    // coupling link comes out as 0, so 100 % error every time): mean 1.0001, sd 0.0002, max
    // 1.0004 — gated at 1.01.
    Gate {
        scenario: "duffing2dof",
        record_length: 625.0,
        thresholds: &[("weak", 0.163), ("strong", 0.150), ("strong-marginals", 1.01)],
    },
];

#[test]
fn every_scenario_meets_its_accuracy_gate_at_reduced_length() {
    let files = crate::common::files_in("scenarios", ".toml");
    assert!(!files.is_empty());
    let mut failures = Vec::new();
    for file in files {
        let stem = file.file_stem().unwrap().to_string_lossy().to_string();
        let gate = GATES.iter().find(|g| g.scenario == stem).unwrap_or_else(|| {
            panic!("scenario {stem} has no accuracy gate: measure its spread with `fpkbench study --scenario … --record-length … --seeds 12` and add it to GATES")
        });
        let src = std::fs::read_to_string(&file).unwrap();
        let reduced: String = src
            .lines()
            .map(|l| {
                let t = l.trim_start();
                if t.starts_with("record_length") {
                    format!("record_length = {:?}", gate.record_length)
                } else if t.starts_with("seed") {
                    format!("seed = {SEED}")
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n");
        assert!(
            reduced.contains(&format!("seed = {SEED}")),
            "{stem}: the scenario needs a `seed` line"
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(format!("{stem}.toml"));
        std::fs::write(&path, reduced).unwrap();
        let only = ONLY.iter().filter(|(s, _)| *s == stem).flat_map(|(_, m)| m.iter());
        let out = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
            .args([
                "run",
                path.to_str().unwrap(),
                "--json",
                "--no-validate",
                "--out",
                dir.path().to_str().unwrap(),
            ])
            .args(only.flat_map(|m| ["--method", m]))
            .output()
            .unwrap();
        let code = out.status.code();
        assert!(
            code == Some(0) || code == Some(1),
            "{stem}: exit {code:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        for (method, threshold) in gate.thresholds {
            let m = report["methods"]
                .as_array()
                .unwrap()
                .iter()
                .find(|m| m["method"] == *method);
            let Some(m) = m else {
                failures.push(format!("{stem}: method {method} missing from the report"));
                continue;
            };
            let worst = m["worst_rel_error"].as_f64().unwrap_or(f64::INFINITY);
            eprintln!("{stem:<14} {method:<17} worst relative error {worst:.4} (regression threshold {threshold})");
            // A NaN error fails too.
            if worst.is_nan() || worst > *threshold {
                failures.push(format!(
                    "{stem}: {method} worst relative error {worst:.4} > {threshold}"
                ));
            }
        }
        for f in ["report.json", "report.md", "characteristics.svg", "run.mcap"] {
            assert!(dir.path().join(f).exists(), "{stem}: {f} not written");
        }
    }
    assert!(failures.is_empty(), "accuracy regression:\n{}", failures.join("\n"));
}

#[test]
fn silentblock_at_its_shipped_length_meets_its_gate() {
    // The paper's experiment at 1e4 s: the weak form's worst error over k1, k3 had median
    // 0.44 %, mean 0.46 %, sd 0.28 %, max 1.06 % over 10 seeds (seeds 1000–1009). The issue's
    // target is ≤ 1 %; the shipped seed is asserted against it (one seed in ten exceeds it).
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args([
            "run",
            "scenarios/silentblock.toml",
            "--method",
            "weak",
            "--json",
            "--no-validate",
            "--out",
            dir.path().to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let weak = &r["methods"][0];
    assert_eq!(weak["method"], "weak");
    let worst = weak["worst_rel_error"].as_f64().unwrap();
    assert!(worst <= 0.01, "weak worst relative error {worst}");
    // The spectral fit of the moment is part of the report.
    let f = &r["filters"][0];
    assert!((f["fitted_b"].as_f64().unwrap() / 50.0 - 1.0).abs() < 0.01, "{f}");
    assert!(dir.path().join("spectrum.svg").exists());
}

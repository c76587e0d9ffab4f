//! Studies: rows independent of the sharding, resumable, merged from any shards, conflicts
//! refused; the shard taken from Slurm and Kubernetes environments.

use fpkbench::pipeline::study::{gather, item_text, shard_from, Study};
use std::path::Path;
use std::process::Command;

const STUDY: &str = r#"
scenario = "SCENARIO"
seeds = 2
seed = 11
sample_intervals = [0.1, 0.5]
methods = ["weak", "increments"]
"#;

fn fpk(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args(args)
        .output()
        .unwrap()
}

fn study_file(dir: &Path) -> String {
    let scenario = std::fs::canonicalize("scenarios/sdof_duffing.toml").unwrap();
    let p = dir.join("s.toml");
    std::fs::write(&p, STUDY.replace("SCENARIO", scenario.to_str().unwrap())).unwrap();
    p.to_str().unwrap().to_string()
}

fn rows(dir: &Path) -> Vec<fpkbench::pipeline::study::Row> {
    let mut files: Vec<_> = std::fs::read_dir(dir.join("items"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    gather(&files).unwrap()
}

#[test]
fn shards_give_the_rows_of_one_run_and_merge_refuses_conflicts() {
    let tmp = tempfile::tempdir().unwrap();
    let file = study_file(tmp.path());
    let one = tmp.path().join("one");
    let o = fpk(&["study", &file, "--out", one.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(one.join("summary.json").exists() && one.join("study.svg").exists());
    let svg = std::fs::read_to_string(one.join("study.svg")).unwrap();
    assert!(
        svg.contains("worst error against sample interval"),
        "two intervals: an axis to vary"
    );
    // Three shards into three folders, then merged: rows equal bit for bit.
    let (a, b, c) = (tmp.path().join("a"), tmp.path().join("b"), tmp.path().join("c"));
    for (shard, dir) in [("0/3", &a), ("1/3", &b), ("2/3", &c)] {
        let o = fpk(&["study", &file, "--shard", shard, "--out", dir.to_str().unwrap()]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(!dir.join("summary.json").exists(), "a partial study has no summary");
    }
    let merged = tmp.path().join("m");
    let o = fpk(&[
        "study",
        "merge",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        c.to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let strip = |mut r: Vec<fpkbench::pipeline::study::Row>| {
        for x in &mut r {
            (x.simulate_s, x.identify_s, x.item_s) = (0.0, 0.0, 0.0);
        }
        r
    };
    let (whole, parts) = (strip(rows(&one)), strip([rows(&a), rows(&b), rows(&c)].concat()));
    let mut parts = parts;
    parts.sort_by_key(|r| (r.item.index, r.method.clone()));
    let mut whole = whole;
    whole.sort_by_key(|r| (r.item.index, r.method.clone()));
    assert_eq!(whole.len(), 8);
    assert_eq!(whole, parts, "the same rows whatever the sharding");
    // Two shards of three: the merge says which items are missing and refuses, unless
    // --partial, which summarizes what is there and says so.
    let two = |extra: &[&str]| {
        let out = tmp.path().join("ab");
        let mut args = vec!["study", "merge", a.to_str().unwrap(), b.to_str().unwrap()];
        args.extend(["--out", out.to_str().unwrap()]);
        args.extend(extra);
        (fpk(&args), out)
    };
    let (o, ab) = two(&[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("1 of the study's 4 items are missing (items 2)"), "{err}");
    assert!(!ab.join("summary.json").exists(), "no summary that looks complete");
    let (o, ab) = two(&["--partial"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(ab.join("summary.md")).unwrap();
    assert!(md.contains("**Partial**: 1 of the study's 4 items are missing"), "{md}");
    // A re-run does nothing new.
    let o = fpk(&["study", &file, "--out", one.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("4 already done"));
    // A conflicting row (one estimate changed) is refused, naming the item.
    let f = std::fs::read_dir(a.join("items"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let text = std::fs::read_to_string(&f).unwrap();
    let mut row: serde_json::Value = serde_json::from_str(text.lines().next().unwrap()).unwrap();
    row["parameters"][0]["estimate"] = serde_json::json!(123.0);
    let c = tmp.path().join("c/items");
    std::fs::create_dir_all(&c).unwrap();
    // (Written whole, with its completeness mark: the conflict is what is refused.)
    let whole = |v: &serde_json::Value| item_text(&[serde_json::from_value(v.clone()).unwrap()]).unwrap();
    std::fs::write(c.join(f.file_name().unwrap()), whole(&row)).unwrap();
    let o = fpk(&[
        "study",
        "merge",
        a.to_str().unwrap(),
        c.parent().unwrap().to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("conflicts"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // Rows of another study are refused.
    row["study"] = serde_json::json!("0000000000000000");
    row["parameters"][0]["estimate"] = serde_json::json!(1.0);
    std::fs::write(c.join("other.jsonl"), whole(&row)).unwrap();
    std::fs::remove_file(c.join(f.file_name().unwrap())).unwrap();
    let o = fpk(&[
        "study",
        "merge",
        a.to_str().unwrap(),
        c.parent().unwrap().to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("another study")
            || String::from_utf8_lossy(&o.stderr).contains("of study")
    );
}

#[test]
fn item_seeds_do_not_depend_on_the_shard_count() {
    let tmp = tempfile::tempdir().unwrap();
    let s = Study::from_file(Path::new(&study_file(tmp.path()))).unwrap();
    let items = s.items();
    assert_eq!(items.len(), 4);
    let seeds: Vec<u64> = items.iter().map(|i| i.seed).collect();
    let mut unique = seeds.clone();
    unique.sort();
    unique.dedup();
    assert_eq!(unique.len(), 4, "distinct seeds: {seeds:?}");
    assert!(seeds.iter().all(|&x| x <= i64::MAX as u64));
}

#[test]
fn the_shard_comes_from_the_flag_slurm_or_kubernetes() {
    let env = |pairs: &'static [(&'static str, &'static str)]| {
        move |k: &str| pairs.iter().find(|p| p.0 == k).map(|p| p.1.to_string())
    };
    assert_eq!(shard_from(Some((2, 5)), None, env(&[])), Ok((2, 5)));
    assert_eq!(shard_from(None, None, env(&[])), Ok((0, 1)));
    // `--array=0-3`: task 2 is shard 2 of 4.
    let array = env(&[
        ("SLURM_ARRAY_TASK_ID", "2"),
        ("SLURM_ARRAY_TASK_MIN", "0"),
        ("SLURM_ARRAY_TASK_MAX", "3"),
        ("SLURM_ARRAY_TASK_COUNT", "4"),
    ]);
    assert_eq!(shard_from(None, None, array), Ok((2, 4)));
    // Resubmitting task 1 alone (`sbatch --array=1`): never the whole study as 0/1; with
    // the script's --shard-count it is shard 1 of 4 again.
    let resubmitted = env(&[
        ("SLURM_ARRAY_TASK_ID", "1"),
        ("SLURM_ARRAY_TASK_MIN", "1"),
        ("SLURM_ARRAY_TASK_MAX", "1"),
        ("SLURM_ARRAY_TASK_COUNT", "1"),
    ]);
    assert!(shard_from(None, None, resubmitted)
        .unwrap_err()
        .contains("--shard-count"));
    assert_eq!(shard_from(None, Some(4), resubmitted), Ok((1, 4)));
    // Arrays with gaps (`0-4:2`, `0,1,5`): refused up front by every task, or placed by
    // --shard-count.
    let stepped = env(&[
        ("SLURM_ARRAY_TASK_ID", "4"),
        ("SLURM_ARRAY_TASK_MIN", "0"),
        ("SLURM_ARRAY_TASK_MAX", "4"),
        ("SLURM_ARRAY_TASK_COUNT", "3"),
        ("SLURM_ARRAY_TASK_STEP", "2"),
    ]);
    assert!(shard_from(None, None, stepped).unwrap_err().contains("--shard-count"));
    assert_eq!(shard_from(None, Some(5), stepped), Ok((4, 5)));
    assert!(shard_from(None, Some(3), stepped).is_err());
    let listed = env(&[
        ("SLURM_ARRAY_TASK_ID", "0"),
        ("SLURM_ARRAY_TASK_MIN", "0"),
        ("SLURM_ARRAY_TASK_MAX", "5"),
        ("SLURM_ARRAY_TASK_COUNT", "3"),
    ]);
    assert!(shard_from(None, None, listed).is_err());
    // A count without an index is ambiguous.
    assert!(shard_from(None, Some(4), env(&[])).unwrap_err().contains("--shard I/4"));
    let k8s = env(&[("JOB_COMPLETION_INDEX", "3")]);
    assert_eq!(shard_from(None, Some(8), k8s), Ok((3, 8)));
    assert!(shard_from(None, None, env(&[("JOB_COMPLETION_INDEX", "3")]))
        .unwrap_err()
        .contains("--shard-count"));
    assert!(shard_from(None, Some(2), env(&[("JOB_COMPLETION_INDEX", "3")])).is_err());
    assert!(shard_from(
        None,
        None,
        env(&[("SLURM_ARRAY_TASK_ID", "x"), ("SLURM_ARRAY_TASK_COUNT", "2")])
    )
    .is_err());
}

#[test]
fn a_bad_study_file_names_the_line_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("bad.toml");
    std::fs::write(&p, "scenario = \"x.toml\"\nseeds = 2\nsample_interval = [0.1]\n").unwrap();
    let out = tmp.path().join("out");
    let o = fpk(&["study", p.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("bad.toml: line 3") && err.contains("sample_interval"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn grid_flags_beside_a_study_file_are_refused_not_ignored() {
    // They would be outvoted by the file's own keys without a word (a study of 100 seeds
    // run where 8 were asked for).
    let tmp = tempfile::tempdir().unwrap();
    let file = study_file(tmp.path());
    let out = tmp.path().join("out");
    for flags in [
        &["--seeds", "8"][..],
        &["--method", "weak", "--seed", "3"],
        &["--select"],
        &["--select-powers", "3"],
    ] {
        let o = fpk(&[&["study", &file, "--out", out.to_str().unwrap()][..], flags].concat());
        assert_eq!(o.status.code(), Some(2));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("s.toml") && err.contains(flags[0]), "{err}");
        assert!(!out.exists());
    }
}

#[test]
fn select_on_a_scenario_with_its_own_candidates_keeps_them() {
    // chain3 declares [identify.select]: `--select` runs its selection as declared, and
    // does not replace its candidates with none (which failed at `link[4]`).
    let printed = fpk(&["study", "--scenario", "scenarios/chain3.toml", "--select", "--print"]);
    assert!(printed.status.success(), "{}", String::from_utf8_lossy(&printed.stderr));
    let text = String::from_utf8(printed.stdout).unwrap();
    assert!(!text.contains("identify.select"), "{text}");
    // A scenario without candidates of its own gets the unknown terms as candidates.
    let printed = fpk(&[
        "study",
        "--scenario",
        "scenarios/sdof_duffing.toml",
        "--select",
        "--print",
    ]);
    let text = String::from_utf8(printed.stdout).unwrap();
    assert!(text.contains("identify.select={}"), "{text}");
}

#[test]
fn overrides_are_recorded_and_a_variant_varied_again_keeps_them() {
    use fpkbench::scenario::overrides::apply;
    let src = std::fs::read_to_string("scenarios/sdof_duffing.toml").unwrap();
    let once = apply("s.toml", &src, &["simulation.trajectories=16".into()]).unwrap();
    let twice = apply(
        "s.toml",
        &once,
        &["simulation.seed=9".into(), "link.0.damping.1=0.7".into()],
    )
    .unwrap();
    let s = fpkbench::Scenario::parse(&twice, "s.toml", "sdof_duffing").unwrap();
    assert_eq!(s.simulation.trajectories, 16);
    assert_eq!(s.simulation.seed, 9);
    assert_eq!(
        s.overrides(),
        [
            "simulation.trajectories=16",
            "simulation.seed=9",
            "link.0.damping.1=0.7"
        ]
    );
    assert_eq!(s.variant_name(), "sdof_duffing--trajectories=16--seed=9--damping.1=0.7");
    assert!(apply("s.toml", &src, &["nokey".into()]).is_err());
    assert!(apply("s.toml", &src, &["link.5.damping=1".into()]).is_err());
}

#[test]
fn flags_make_the_same_study_as_the_file_they_print() {
    // `--scenario` and the grid flags stand for a study file: `--print` shows it, and the
    // rows equal those of that file run as a file (the fingerprint covers the same text).
    let dir = tempfile::tempdir().unwrap();
    let scenario = std::fs::canonicalize("scenarios/sdof_duffing.toml").unwrap();
    let scenario = scenario.to_str().unwrap();
    let flags = [
        "study",
        "--scenario",
        scenario,
        "--seeds",
        "2",
        "--seed",
        "11",
        "--record-length",
        "100",
        "--method",
        "weak",
        "--method",
        "force-regression",
        "--reference",
        "weak",
    ];
    let printed = fpk(&[&flags[..], &["--print"]].concat());
    assert!(printed.status.success());
    let text = String::from_utf8(printed.stdout).unwrap();
    assert!(text.contains("methods = [\"weak\", \"force-regression\"]"), "{text}");
    let file = dir.path().join("flags.toml");
    std::fs::write(&file, &text).unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    let out = fpk(&[&flags[..], &["--out", a.to_str().unwrap()]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let out = fpk(&["study", file.to_str().unwrap(), "--out", b.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (ra, rb) = (rows(&a), rows(&b));
    assert_eq!(ra.len(), 4);
    for (x, y) in ra.iter().zip(&rb) {
        assert_eq!((&x.item, &x.method, &x.parameters), (&y.item, &y.method, &y.parameters));
    }
    // The reference's paired table is in the summary.
    let md = std::fs::read_to_string(a.join("summary.md")).unwrap();
    assert!(md.contains("## Paired differences from `weak`"), "{md}");
    // A misspelt method is refused by the flag, exit 2.
    let bad = fpk(&["study", "--scenario", scenario, "--method", "wek"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("force-regression"));
}

#[test]
fn a_study_of_one_configuration_plots_every_seed_per_method() {
    // Nothing varies but the seed: the figure shows the methods side by side, each seed's
    // worst error a point, instead of one lonely point per method on an interval axis.
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("one");
    let o = fpk(&[
        "study",
        "--scenario",
        "scenarios/sdof_duffing.toml",
        "--seeds",
        "3",
        "--record-length",
        "312.5",
        "--method",
        "weak",
        "--method",
        "increments",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let svg = std::fs::read_to_string(out.join("study.svg")).unwrap();
    assert!(svg.contains("worst error over the seeds, T = 312.5 s"), "{svg}");
    assert!(!svg.contains("against sample interval"));
    for method in ["weak", "increments"] {
        assert!(svg.contains(&format!(">{method}</text>")), "{method} names its column");
    }
    // Three seeds per method: six points and two coverage markers.
    assert_eq!(svg.matches("<circle").count(), 3 * 2 + 2, "{svg}");
}

#[test]
fn the_documented_sbatch_script_is_the_one_ci_submits() {
    // CI submits docs/slurm/study.sbatch to a real Slurm (tests/slurm/run.sh); the page
    // shows the same text.
    let script = std::fs::read_to_string("docs/slurm/study.sbatch").unwrap();
    let page = std::fs::read_to_string("docs/studies.md").unwrap();
    assert!(
        page.contains(script.trim_end()),
        "docs/studies.md does not show docs/slurm/study.sbatch as it is"
    );
    assert!(script.contains("--shard-count 4") && script.contains("#SBATCH --array=0-3"));
}

#[test]
fn a_noise_axis_measures_the_same_motion_at_every_level() {
    // Two levels × two seeds: the items of one seed index share the simulation seed (the
    // same motion, only the sensors differ), their files and rows name the level, the
    // summary has a configuration per level, and the figure draws the error against it.
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("noise");
    let o = fpk(&[
        "study",
        "--scenario",
        "scenarios/sdof_duffing.toml",
        "--seeds",
        "2",
        "--record-length",
        "312.5",
        "--noise-level",
        "0",
        "--noise-level",
        "0.3",
        "--method",
        "weak",
        "--set",
        "identify.sensor_noise=\"ignore\"",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("items/T312.5-h0.1-n0.3-s1.jsonl").exists());
    let rows = rows(&out);
    assert_eq!(rows.len(), 4);
    let of = |noise: f64, s: usize| {
        rows.iter()
            .find(|r| r.item.sensor_noise == Some(noise) && r.item.seed_index == s)
            .unwrap()
    };
    for s in 0..2 {
        let (clean, noisy) = (of(0.0, s), of(0.3, s));
        assert_eq!(clean.item.seed, noisy.item.seed);
        assert_eq!(clean.samples, noisy.samples);
        // Ignored, 30 % noise biases the cubic stiffness by tens of per cent
        // (docs/measurement.md); the clean samples are within a few.
        let worst = |r: &fpkbench::pipeline::study::Row| r.worst_rel_error.unwrap();
        assert!(
            worst(noisy) > 0.15 && worst(clean) < 0.1,
            "{} {}",
            worst(clean),
            worst(noisy)
        );
    }
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(
        md.contains("| sensor noise (of std) |") && md.contains("| 312.5 | 0.1 | 30 % | weak |"),
        "{md}"
    );
    let svg = std::fs::read_to_string(out.join("study.svg")).unwrap();
    assert!(svg.contains("worst error against sensor noise"), "{svg}");
    assert!(svg.contains("sensor noise std / response std (%)"));
    let bad = fpk(&[
        "study",
        "--scenario",
        "scenarios/sdof_duffing.toml",
        "--noise-level=-0.1",
        "--dry-run",
    ]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("noise_levels"));
}

#[test]
fn a_folder_holding_another_studys_item_still_gets_its_summary() {
    // A grid of four seeds run where one of ten ran before: the ten-seed study's extra
    // item file is named and left out; the four-seed study is complete and summarised
    // (before: "5 of 4 items are in …", no summary).
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("mixed");
    let run = |seeds: &str, shard: &[&str]| {
        let mut args = vec![
            "study",
            "--scenario",
            "scenarios/sdof_duffing.toml",
            "--seeds",
            seeds,
            "--record-length",
            "100",
            "--method",
            "weak",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(shard);
        fpk(&args)
    };
    let ten = run("10", &["--shard", "5/10"]);
    assert!(ten.status.success(), "{}", String::from_utf8_lossy(&ten.stderr));
    assert!(out.join("items/T100-h0.1-s5.jsonl").exists());
    let four = run("4", &[]);
    let stderr = String::from_utf8_lossy(&four.stderr);
    assert!(four.status.success(), "{stderr}");
    assert!(
        stderr.contains("T100-h0.1-s5.jsonl") && stderr.contains("no item of this study"),
        "{stderr}"
    );
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(summary.contains("| 100 | 0.1 | weak |"), "{summary}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let weak = json["summary"]
        .as_array()
        .unwrap()
        .iter()
        .find(|x| x["method"] == "weak")
        .unwrap();
    let items: u64 = ["items", "refused", "not_applicable", "failed"]
        .iter()
        .map(|k| weak[k].as_u64().unwrap())
        .sum();
    assert_eq!(items, 4, "the summary is over the four-seed study's items: {weak}");
}

//! Every method's outcome is its own, a refusal is a result, outputs are whole or absent,
//! and errors name their path: the reproducers of what once lost work or said too little.

use fpkbench::pipeline::study::{read_item, Study};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn fpk(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

fn scenario(name: &str) -> String {
    std::fs::canonicalize(format!("scenarios/{name}.toml"))
        .unwrap()
        .to_str()
        .unwrap()
        .to_string()
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Every file of a folder (not its hidden entries) with its bytes.
fn contents(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v: Vec<(PathBuf, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| !p.file_name().unwrap().to_string_lossy().starts_with('.'))
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap();
            (p, bytes)
        })
        .collect();
    v.sort();
    v
}

/// duffing2dof with the noise intensity of m2 unknown: the weak and strong forms cannot
/// separate it from the damping (they refuse), the product of marginals gives numbers.
const SIGMA_M2_UNKNOWN: &str = "identify.unknown_intensities=[\"m2\"]";

#[test]
fn one_methods_refusal_is_its_own_row_and_the_others_estimates_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let o = fpk(
        dir.path(),
        &[
            "run",
            &scenario("duffing2dof"),
            "--set",
            SIGMA_M2_UNKNOWN,
            "--set",
            "simulation.record_length=200.0",
            "--no-validate",
            "--json",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).expect("the report as JSON on stdout");
    let methods = report["methods"].as_array().unwrap();
    let row = |name: &str| methods.iter().find(|m| m["method"] == name).unwrap();
    for refused in ["weak", "strong"] {
        assert_eq!(row(refused)["outcome"], "refused");
        let why = row(refused)["error"].as_str().unwrap();
        assert!(
            why.contains("cannot be separated") && why.contains("singular values"),
            "{why}"
        );
        assert!(row(refused)["parameters"].as_array().unwrap().is_empty());
    }
    let marginals = row("strong-marginals");
    assert_eq!(marginals["outcome"], "estimated");
    assert!(!marginals["parameters"].as_array().unwrap().is_empty());
    // stderr names each refused method and why; the report files hold every row.
    let err = text(&o.stderr);
    assert!(
        err.contains("weak refused: ") && err.contains("strong refused: "),
        "{err}"
    );
    let written: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(written["methods"].as_array().unwrap().len(), 3);
    assert!(std::fs::read_to_string(out.join("report.md"))
        .unwrap()
        .contains("refused"));
}

#[test]
fn a_study_records_refusals_and_methods_that_do_not_apply_as_rows() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s");
    let o = fpk(
        dir.path(),
        &[
            "study",
            "--scenario",
            &scenario("duffing2dof"),
            "--seeds",
            "3",
            "--record-length",
            "200",
            "--set",
            SIGMA_M2_UNKNOWN,
            "--method",
            "weak",
            "--method",
            "strong-marginals",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    // Refusals are results: every item ran, so exit 0, with a row per item and method.
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let per = |m: &str| {
        summary["summary"]
            .as_array()
            .unwrap()
            .iter()
            .find(|x| x["method"] == m)
            .unwrap()
            .clone()
    };
    assert_eq!(
        (per("weak")["items"].as_u64(), per("weak")["refused"].as_u64()),
        (Some(0), Some(3))
    );
    assert_eq!(per("strong-marginals")["items"].as_u64(), Some(3));
    assert!(std::fs::read_to_string(out.join("summary.md"))
        .unwrap()
        .contains("| weak | 0 | 3 | 100 % |"));
    // The strong form's lattice in 10 dimensions (chain5) does not apply: a row that says
    // so, not an empty file.
    let chain = dir.path().join("c");
    let o = fpk(
        dir.path(),
        &[
            "study",
            "--scenario",
            &scenario("chain5"),
            "--seeds",
            "1",
            "--record-length",
            "50",
            "--method",
            "weak",
            "--method",
            "strong",
            "--out",
            chain.to_str().unwrap(),
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let file = std::fs::read_dir(chain.join("items"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let rows = read_item(&file).unwrap();
    let strong = rows.iter().find(|r| r.method == "strong").expect("a row for strong");
    assert_eq!(strong.outcome, fpkbench::report::Outcome::NotApplicable);
    assert!(
        strong.error.as_deref().unwrap().contains("dimensional"),
        "{:?}",
        strong.error
    );
}

#[test]
fn damaged_item_files_are_run_again_by_a_resume_and_refused_by_merge() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s");
    let args = [
        "study",
        "--scenario",
        &scenario("sdof_duffing"),
        "--seeds",
        "3",
        "--record-length",
        "50",
        "--method",
        "weak",
        "--method",
        "increments",
        "--out",
        out.to_str().unwrap(),
    ];
    assert!(fpk(dir.path(), &args).status.success());
    let mut files: Vec<PathBuf> = std::fs::read_dir(out.join("items"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    let whole: Vec<Vec<u8>> = files.iter().map(|f| std::fs::read(f).unwrap()).collect();
    // A 0-byte file, and a file with one method's row removed (its mark kept).
    std::fs::write(&files[0], "").unwrap();
    let t = String::from_utf8(whole[1].clone()).unwrap();
    let lines: Vec<&str> = t.lines().collect();
    std::fs::write(&files[1], format!("{}\n{}\n", lines[0], lines[2])).unwrap();
    let merge = fpk(
        dir.path(),
        &[
            "study",
            "merge",
            out.to_str().unwrap(),
            "--out",
            dir.path().join("m").to_str().unwrap(),
        ],
    );
    assert_eq!(merge.status.code(), Some(2));
    let err = text(&merge.stderr);
    assert!(err.contains(files[0].file_name().unwrap().to_str().unwrap()), "{err}");
    // The resume says why and runs both again: the same bytes as before.
    let o = fpk(dir.path(), &args);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let err = text(&o.stderr);
    assert!(
        err.contains("incomplete item file") && err.contains("checksum"),
        "{err}"
    );
    for (f, w) in files.iter().zip(&whole) {
        let now = text(&std::fs::read(f).unwrap());
        let strip = |s: &str| {
            s.lines()
                .map(|l| l.split("\"simulate_s\"").next().unwrap().to_string())
                .collect::<Vec<_>>()
        };
        assert_eq!(strip(&now).len(), strip(&text(w)).len(), "{}", f.display());
        assert_eq!(strip(&now)[..2], strip(&text(w))[..2], "{}", f.display());
    }
}

#[test]
fn the_fingerprint_follows_the_content_not_the_paths_spelling() {
    let dir = tempfile::tempdir().unwrap();
    let here = std::env::current_dir().unwrap();
    let spellings = [
        "scenarios/sdof_duffing.toml".to_string(),
        "./scenarios/../scenarios/sdof_duffing.toml".to_string(),
        scenario("sdof_duffing"),
    ];
    let prints: Vec<String> = spellings
        .iter()
        .map(|s| {
            let text = format!("scenario = {s:?}\nseeds = 2\n# a comment\n");
            Study::from_text(&text, Path::new("(flags)"), "x", &here)
                .unwrap()
                .fingerprint
        })
        .collect();
    assert!(prints.iter().all(|p| *p == prints[0]), "{prints:?}");
    let other = Study::from_text(
        &format!("scenario = {:?}\nseeds = 3\n", spellings[0]),
        Path::new("(flags)"),
        "x",
        &here,
    )
    .unwrap();
    assert_ne!(other.fingerprint, prints[0]);
    drop(dir);
}

#[test]
fn a_failed_run_leaves_the_previous_folder_whole() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let o = fpk(
        dir.path(),
        &[
            "run",
            &scenario("sdof_duffing"),
            "--method",
            "weak",
            "--no-validate",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let before = contents(&out);
    // A second identification into the same folder, the file size limited to 100 KiB: the
    // report fits, the first PNG does not (SIGXFSZ, as a full disk would stop it).
    let log = out.join("run.mcap");
    let cmd = format!(
        "ulimit -f 100; exec {} identify {} --method strong --no-validate --out {}",
        env!("CARGO_BIN_EXE_fpkbench"),
        log.display(),
        out.display()
    );
    let o = Command::new("bash").arg("-c").arg(&cmd).output().unwrap();
    assert!(!o.status.success(), "the limited run succeeded: {}", text(&o.stderr));
    assert_eq!(contents(&out), before, "the previous run's files changed");
    // The next run clears the dead one's staging folder and replaces the set as a whole.
    let o = fpk(
        dir.path(),
        &[
            "identify",
            log.to_str().unwrap(),
            "--method",
            "strong",
            "--no-validate",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let hidden: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".fpkbench-staging"))
        .collect();
    assert!(hidden.is_empty(), "{hidden:?}");
    let report = std::fs::read_to_string(out.join("report.json")).unwrap();
    assert!(report.contains("\"strong\"") && !report.contains("\"method\": \"weak\""));
}

#[test]
fn errors_name_the_path_and_json_failures_are_json() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("plain-file");
    std::fs::write(&file, "x").unwrap();
    let f = file.to_str().unwrap();
    for args in [
        vec!["run", &scenario("sdof_duffing"), "--out", f],
        vec![
            "study",
            "--scenario",
            &scenario("sdof_duffing"),
            "--seeds",
            "1",
            "-o",
            f,
        ],
    ] {
        let o = fpk(dir.path(), &args);
        assert_eq!(o.status.code(), Some(2));
        let err = text(&o.stderr);
        assert!(err.contains(f) && err.contains("creating the "), "{args:?}: {err}");
    }
    // --json: the error as a JSON object on stdout too.
    let o = fpk(dir.path(), &["run", &scenario("sdof_duffing"), "--json", "--out", f]);
    assert_eq!(o.status.code(), Some(2));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("a JSON error on stdout");
    assert!(v["error"].as_str().unwrap().contains(f) && v["exit_code"] == 2, "{v}");
    // A shard with a space, and --dry-run, write nothing.
    let o = fpk(
        dir.path(),
        &[
            "study",
            "--scenario",
            &scenario("sdof_duffing"),
            "--seeds",
            "1",
            "--shard",
            " 0/2",
        ],
    );
    assert_eq!(o.status.code(), Some(2));
    let dry = dir.path().join("dry");
    let o = fpk(
        dir.path(),
        &[
            "study",
            "--scenario",
            &scenario("sdof_duffing"),
            "--seeds",
            "2",
            "--dry-run",
            "-o",
            dry.to_str().unwrap(),
        ],
    );
    assert!(
        o.status.success() && text(&o.stdout).lines().count() == 2,
        "{}",
        text(&o.stderr)
    );
    assert!(!dry.exists(), "--dry-run created the folder");
}

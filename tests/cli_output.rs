//! Output safety through the real binary: no command writes over its own input, two
//! processes never write one folder, and no error or interrupt leaves a temporary file.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn fpkbench(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

/// Every file under `dir` whose name ends in `.partial`.
fn partials(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.to_string_lossy().ends_with(".partial") {
                out.push(p);
            }
        }
    }
    out
}

/// A short scenario in `dir`, with `record_length` s per trajectory.
fn scenario(dir: &Path, record_length: f64) -> PathBuf {
    let src = std::fs::read_to_string("scenarios/sdof_duffing.toml")
        .unwrap()
        .replace("record_length = 312.5", &format!("record_length = {record_length:?}"));
    let p = dir.join("s.toml");
    std::fs::write(&p, src).unwrap();
    p
}

#[test]
fn no_command_writes_over_its_own_input() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scenario(d, 20.0);
    let scenario_text = std::fs::read(d.join("s.toml")).unwrap();
    let o = fpkbench(d, &["simulate", "s.toml", "-o", "s.toml"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("would destroy the input"));
    assert_eq!(std::fs::read(d.join("s.toml")).unwrap(), scenario_text);

    assert!(fpkbench(d, &["simulate", "s.toml", "-o", "log.mcap"]).status.success());
    let log = std::fs::read(d.join("log.mcap")).unwrap();
    let o = fpkbench(d, &["export", "log.mcap", "--format", "csv", "-o", "./log.mcap"]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(std::fs::read(d.join("log.mcap")).unwrap(), log);
    // A log named like the export's default output.
    std::fs::copy(d.join("log.mcap"), d.join("data.npy")).unwrap();
    let o = fpkbench(d, &["export", "data.npy", "--format", "npy"]);
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read(d.join("data.npy")).unwrap(), log);
    // A log inside the report folder under a report's name.
    std::fs::create_dir_all(d.join("rep")).unwrap();
    std::fs::copy(d.join("log.mcap"), d.join("rep/report.json")).unwrap();
    let o = fpkbench(d, &["identify", "rep/report.json", "--out", "rep", "--no-validate"]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(std::fs::read(d.join("rep/report.json")).unwrap(), log);
    assert!(partials(d).is_empty());
}

#[test]
fn a_failed_rename_or_write_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scenario(d, 20.0);
    std::fs::create_dir_all(d.join("taken.mcap")).unwrap();
    let o = fpkbench(d, &["simulate", "s.toml", "-o", "taken.mcap"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("is a directory"));
    assert!(fpkbench(d, &["simulate", "s.toml", "-o", "log.mcap"]).status.success());
    std::fs::create_dir_all(d.join("taken.csv")).unwrap();
    let o = fpkbench(d, &["export", "log.mcap", "--format", "csv", "-o", "taken.csv"]);
    assert_eq!(o.status.code(), Some(2));
    // A report folder whose report.json is a directory: the error names the file.
    std::fs::create_dir_all(d.join("rep/report.json")).unwrap();
    let o = fpkbench(d, &["identify", "log.mcap", "--out", "rep", "--no-validate"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("report.json"));
    assert!(partials(d).is_empty(), "{:?}", partials(d));
}

#[test]
fn a_second_process_writing_the_same_folder_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scenario(d, 20.0);
    let out = d.join("out/sdof_duffing");
    let held = fpkbench::io::output::FolderLock::acquire(&out).unwrap();
    let o = fpkbench(d, &["run", "s.toml", "--no-validate"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("another fpkbench process is writing"));
    let o = fpkbench(d, &["simulate", "s.toml"]);
    assert_eq!(o.status.code(), Some(2));
    drop(held);
    assert!(fpkbench(d, &["run", "s.toml", "--no-validate"])
        .status
        .code()
        .is_some_and(|c| c < 2));
    assert!(partials(d).is_empty());
}

#[cfg(unix)]
#[test]
fn an_interrupted_simulation_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scenario(d, 50000.0);
    let mut child = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .current_dir(d)
        .args(["simulate", "s.toml", "-o", "long.mcap"])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while partials(d).is_empty() && start.elapsed().as_secs() < 30 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    assert_eq!(partials(d).len(), 1, "the log is being written");
    // SAFETY: sending a signal to our own child process.
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    assert!(partials(d).is_empty() && !d.join("long.mcap").exists());
}

/// The terminal report keeps within 100 columns (report::text::WIDTH): the parameters of
/// several methods in tables side by side only as far as they fit, the validation's compact
/// table, prose and the list of files written wrapped. A short run of the section-4
/// scenario has the most tables: three methods, two iterated sequences, the validation.
#[test]
fn the_terminal_report_fits_100_columns() {
    let dir = tempfile::tempdir().unwrap();
    let src = std::fs::read_to_string("scenarios/disturbed2dof.toml")
        .unwrap()
        .replace("record_length = 1500.0", "record_length = 100.0");
    let p = dir.path().join("d.toml");
    std::fs::write(&p, src).unwrap();
    let out = fpkbench(dir.path(), &["run", p.to_str().unwrap()]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("validation:") && text.contains("iterative procedure"),
        "{text}"
    );
    for line in text.lines() {
        assert!(line.chars().count() <= 100, "{} columns: {line}", line.chars().count());
    }
}

/// `--no-figures` writes the pages, the log and the same numbers, and no figure: a folder
/// that held a run with figures keeps none of them (they would no longer be of its report),
/// and the pages show none.
#[test]
fn no_figures_leaves_the_figures_out_and_the_numbers_alone() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scenario(d, 40.0);
    let estimates = |report: &Path| {
        let mut r: serde_json::Value = serde_json::from_slice(&std::fs::read(report).unwrap()).unwrap();
        for m in r["methods"].as_array_mut().unwrap() {
            m.as_object_mut().unwrap().remove("seconds");
        }
        (r["methods"].clone(), r["figures"].clone())
    };
    let args = ["run", "s.toml", "--method", "weak", "--no-validate", "--out", "rep"];
    let o = fpkbench(d, &args);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let (with, shown) = estimates(&d.join("rep/report.json"));
    assert_eq!(shown, serde_json::json!(true));
    assert!(d.join("rep/characteristics.svg").exists());
    let o = fpkbench(d, &[&args[..], &["--no-figures"]].concat());
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let mut files: Vec<String> = std::fs::read_dir(d.join("rep"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.'))
        .collect();
    files.sort();
    assert_eq!(files, ["report.html", "report.json", "report.md", "run.mcap"]);
    let (without, shown) = estimates(&d.join("rep/report.json"));
    assert_eq!(shown, serde_json::json!(false));
    assert_eq!(without, with, "the same estimates, standard errors and curves");
    for page in ["report.md", "report.html"] {
        let text = std::fs::read_to_string(d.join("rep").join(page)).unwrap();
        assert!(
            !text.contains(".svg") && !text.contains("<figure"),
            "{page} shows a figure"
        );
    }
    assert!(partials(d).is_empty());
}

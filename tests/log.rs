//! MCAP log: exact round trip, self-description, truncation, and the CLI around it.

use fpkbench::io::log::{read_info, read_samples, Compression, LogError, LogWriter};
use fpkbench::model::Model;
use fpkbench::sim::{simulate, Collect, SampleBatch, SampleSink};
use fpkbench::Scenario;
use std::path::Path;
use std::process::Command;

/// Temporary (`*.partial`) files left in `dir`.
fn partials(dir: &Path) -> Vec<std::path::PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(".partial"))
        .collect()
}

fn scenario(record_length: f64, trajectories: usize) -> Scenario {
    let src = std::fs::read_to_string("scenarios/duffing2dof.toml").unwrap();
    let mut s = Scenario::parse(&src, "duffing2dof.toml", "duffing2dof").unwrap();
    s.simulation.record_length = record_length;
    s.simulation.trajectories = trajectories;
    s
}

/// Writes to the log and keeps a copy in memory.
struct Tee<'a>(&'a mut LogWriter, &'a mut Collect);
impl SampleSink for Tee<'_> {
    fn write(&mut self, b: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
        self.1.write(b.clone())?;
        self.0.write(b)
    }
}

fn write_log(s: &Scenario, path: &Path) -> Vec<(u32, f64, Vec<f64>)> {
    let m = Model::new(s);
    let mut w = LogWriter::create(path, s, &m).unwrap();
    let mut c = Collect::default();
    simulate(&m, &s.simulation, &mut Tee(&mut w, &mut c), &|_| {}).unwrap();
    w.finish().unwrap();
    let mut samples = Vec::new();
    for b in &c.batches {
        b.for_each_sample(|j, t, row| samples.push((j, t, row.to_vec())));
    }
    samples
}

#[test]
fn a_log_at_a_disturbance_level_describes_the_scenario_at_that_level() {
    // The sweep's logs: the scenario file as written plus the level among the run facts,
    // read back as the rescaled scenario (level 0 removes the disturbance).
    let src = std::fs::read_to_string("scenarios/disturbed2dof.toml").unwrap();
    let mut base = Scenario::parse(&src, "disturbed2dof.toml", "disturbed2dof").unwrap();
    base.simulation.record_length = 20.0;
    base.simulation.trajectories = 2;
    let dir = tempfile::tempdir().unwrap();
    for level in [0.0, 0.25, 2.0] {
        let s = base.with_disturbance_level(level);
        assert_eq!(s.source, base.source, "the text is never rewritten");
        let path = dir.path().join(format!("level-{level}.mcap"));
        write_log(&s, &path);
        let info = read_info(&path).unwrap();
        assert_eq!(info.run["disturbance_level"], format!("{level:?}"));
        assert_eq!(info.scenario, s, "level {level}");
        assert_eq!(info.truth, s.truth());
    }
    let none = base.with_disturbance_level(0.0);
    assert_eq!(none.excitations.len(), base.excitations.len() - 1);
    let measured = none.identify.disturbance.as_ref().unwrap().structure.measured;
    assert!(none.excitations[measured].measured);
}

#[test]
fn every_sample_scenario_and_truth_round_trip_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let s = scenario(200.0, 10);
    let written = write_log(&s, &path);
    assert!(partials(dir.path()).is_empty());
    let info = read_info(&path).unwrap();
    assert_eq!(info.scenario, s, "scenario recovered from the attachment");
    assert_eq!(info.truth, s.truth());
    assert!(info.truth.iter().any(|(k, v)| k == "k3[ground-m1]" && *v == 20.0));
    assert_eq!(info.run["seed"], "2024");
    assert_eq!(info.run["scheme"], "semi-implicit");
    assert_eq!(
        info.columns,
        ["x_m1", "v_m1", "a_m1", "x_m2", "v_m2", "a_m2", "p_m1", "p_m2"]
    );
    assert_eq!(info.channel_metadata["interval_averaged"], "a_m1,a_m2,p_m1,p_m2");
    let mut read = Vec::new();
    let n = read_samples(&info, |traj, t, v| read.push((traj, t, v.to_vec()))).unwrap();
    assert_eq!(n as usize, written.len());
    assert_eq!(n, 10 * 2000);
    for (a, b) in written.iter().zip(&read) {
        assert_eq!(a.0, b.0);
        assert_eq!(a.1.to_bits(), b.1.to_bits());
        assert!(a.2.iter().zip(&b.2).all(|(x, y)| x.to_bits() == y.to_bits()));
    }
}

#[test]
fn zstd_chunks_read_back_the_same_samples() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, packed) = (dir.path().join("plain.mcap"), dir.path().join("zstd.mcap"));
    let s = scenario(200.0, 5);
    write_log(&s, &plain);
    let m = Model::new(&s);
    let mut w = LogWriter::create_with(&packed, &s, &m, Compression::Zstd).unwrap();
    simulate(&m, &s.simulation, &mut w, &|_| {}).unwrap();
    let summary = w.finish().unwrap();
    assert_eq!(summary.samples, 5 * 2000);
    let all = |p: &Path| {
        let mut v = Vec::new();
        read_samples(&read_info(p).unwrap(), |j, t, x| {
            v.push(j as u64);
            v.push(t.to_bits());
            v.extend(x.iter().map(|x| x.to_bits()));
        })
        .unwrap();
        v
    };
    assert_eq!(all(&plain), all(&packed));
    // The chunks really are compressed (the description is the same in both).
    let bytes = std::fs::read(&packed).unwrap();
    assert!(bytes.windows(4).any(|w| w == b"zstd"));
    assert!(!std::fs::read(&plain).unwrap().windows(4).any(|w| w == b"zstd"));
}

#[test]
fn truncated_log_says_how_many_samples_are_readable_and_yields_them() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let s = scenario(2000.0, 8);
    let written = write_log(&s, &path);
    let bytes = std::fs::read(&path).unwrap();
    // Cut the file at 60 %: as if the writer had been killed mid-run.
    let cut = dir.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() * 6 / 10]).unwrap();
    let info = read_info(&cut).expect("the description precedes the samples");
    assert_eq!(info.scenario, s);
    let mut got = Vec::new();
    let err = read_samples(&info, |traj, t, v| got.push((traj, t, v.to_vec()))).unwrap_err();
    match &err {
        LogError::Truncated { readable, expected, .. } => {
            assert_eq!(*readable as usize, got.len());
            assert_eq!(*expected as usize, written.len());
            assert!(
                got.len() > written.len() / 3 && got.len() < written.len(),
                "{} of {}",
                got.len(),
                written.len()
            );
        }
        e => panic!("expected Truncated, got {e}"),
    }
    assert!(err.to_string().contains("samples are still readable"));
    // What was read is exactly the start of what was written.
    for (a, b) in written.iter().zip(&got) {
        assert_eq!((a.0, a.1.to_bits()), (b.0, b.1.to_bits()));
        assert_eq!(a.2, b.2);
    }
    // The CLI says so and exits 2; export leaves no file behind.
    let out = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args(["inspect", cut.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("PROBLEM") && text.contains("truncated"), "{text}");
    let csv = dir.path().join("cut.csv");
    let out = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args([
            "export",
            cut.to_str().unwrap(),
            "--format",
            "csv",
            "-o",
            csv.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(!csv.exists() && partials(dir.path()).is_empty());
    // With --allow-truncated the readable samples are exported and identified, and the
    // report says how many of the promised ones they are.
    let out = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args(["export", cut.to_str().unwrap(), "--format", "csv", "-o"])
        .arg(&csv)
        .arg("--allow-truncated")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(std::fs::read_to_string(&csv).unwrap().lines().count(), got.len() + 1);
    assert!(String::from_utf8_lossy(&out.stderr).contains("the log is truncated"));
    let out = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args([
            "identify",
            cut.to_str().unwrap(),
            "--allow-truncated",
            "--no-validate",
            "--out",
        ])
        .arg(dir.path().join("report"))
        .output()
        .unwrap();
    assert!(
        out.status.code().is_some_and(|c| c < 2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains(&format!("TRUNCATED LOG: identified from the {} samples", got.len())),
        "{text}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report/report.json")).unwrap()).unwrap();
    assert_eq!(json["samples"], got.len() as u64);
    assert_eq!(json["expected_samples"], written.len() as u64);
    // A file that is not MCAP at all.
    std::fs::write(dir.path().join("junk.mcap"), b"not an mcap file").unwrap();
    assert!(read_info(&dir.path().join("junk.mcap")).is_err());
}

#[test]
fn simulate_inspect_export_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let sc = dir.path().join("small.toml");
    let src = std::fs::read_to_string("scenarios/sdof_duffing.toml")
        .unwrap()
        .replace("record_length = 312.5", "record_length = 30.0");
    std::fs::write(&sc, src).unwrap();
    let bin = env!("CARGO_BIN_EXE_fpkbench");
    // Default output: out/<scenario name>/run.mcap relative to the working directory.
    let out = Command::new(bin)
        .current_dir(dir.path())
        .args(["simulate", "small.toml", "--json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["samples"], 32 * 300);
    let log = dir.path().join("out/sdof_duffing/run.mcap");
    assert!(log.exists());
    let out = Command::new(bin)
        .args(["inspect", log.to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["samples"], 9600);
    assert_eq!(v["truth"]["k3[ground-m1]"], 20.0);
    assert_eq!(v["record_length_s"], 30.0);
    let csv = dir.path().join("x.csv");
    let out = Command::new(bin)
        .args([
            "export",
            log.to_str().unwrap(),
            "--format",
            "csv",
            "-o",
            csv.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(text.lines().next().unwrap(), "trajectory,t,x_m1,v_m1,a_m1,p_m1");
    assert_eq!(text.lines().count(), 9601);
    let npy = dir.path().join("x.npy");
    let out = Command::new(bin)
        .args([
            "export",
            log.to_str().unwrap(),
            "--format",
            "npy",
            "-o",
            npy.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    let bytes = std::fs::read(&npy).unwrap();
    assert_eq!(&bytes[..6], b"\x93NUMPY");
    let hlen = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    assert_eq!((10 + hlen) % 64, 0);
    assert!(String::from_utf8_lossy(&bytes[10..10 + hlen]).contains("'shape': (                9600,)"));
    assert_eq!(bytes.len() - 10 - hlen, 9600 * (4 + 8 * 5));
}

#[test]
fn an_abandoned_writer_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let s = scenario(10.0, 2);
    let w = LogWriter::create(&path, &s, &Model::new(&s)).unwrap();
    assert_eq!(partials(dir.path()).len(), 1, "written under a temporary name");
    drop(w);
    assert!(!path.exists() && partials(dir.path()).is_empty());
}

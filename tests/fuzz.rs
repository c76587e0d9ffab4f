//! Bounded fuzzing in the test suite (property tests with fixed seeds; the long runs are the
//! `cargo fuzz` targets in fuzz/, see docs/reliability.md):
//!
//! - the scenario parser on mutated shipped scenarios and fuzz seeds (tests/fuzz_seeds) —
//!   and every mutant it accepts is simulated briefly and identified;
//! - the log reader on mutated logs (bytes flipped, overwritten, deleted, inserted, cut),
//!   plain and zstd, with every allocation bounded by the file's size;
//! - the identifier on arbitrary sample values, finite and not.
//!
//! Each case runs under a watchdog: a case that takes longer than [`HANG`] fails the test
//! as a hang. No case may panic.

use crate::common;

use common::{fresh_log, records, small_scenario, write_records, Layout};
use fpkbench::io::log::{read_info, read_samples};
use fpkbench::pipeline::{identify_log, simulate_log, Options};
use fpkbench::Scenario;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::Duration;

/// Longest a single case may take before it counts as a hang.
const HANG: Duration = Duration::from_secs(60);

/// Run `f` on a thread of its own; fail if it panics or outlives [`HANG`].
fn guarded<T: Send + 'static>(what: String, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = std::sync::mpsc::channel();
    let handle = std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    match rx.recv_timeout(HANG) {
        Ok(v) => {
            handle.join().unwrap();
            v
        }
        Err(std::sync::mpsc::RecvTimeoutError::Timeout) => panic!("hang: {what}"),
        Err(_) => {
            let e = handle.join().unwrap_err();
            let msg = e
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            panic!("panic on {what}: {msg}")
        }
    }
}

fn runner(cases: u32) -> TestRunner {
    TestRunner::new_with_rng(
        Config {
            cases,
            failure_persistence: None,
            ..Config::default()
        },
        TestRng::deterministic_rng(RngAlgorithm::ChaCha),
    )
}

/// One edit of a text or a byte string.
#[derive(Debug, Clone)]
enum Edit {
    Flip(usize, u8),
    Overwrite(usize, Vec<u8>),
    Delete(usize, usize),
    Insert(usize, Vec<u8>),
    Cut(usize),
}

fn apply(mut b: Vec<u8>, edits: &[Edit]) -> Vec<u8> {
    for e in edits {
        let n = b.len().max(1);
        match e {
            Edit::Flip(at, bit) => {
                let at = at % n;
                if at < b.len() {
                    b[at] ^= 1 << (bit % 8);
                }
            }
            Edit::Overwrite(at, bytes) => {
                let at = at % n;
                for (i, &x) in bytes.iter().enumerate() {
                    if at + i < b.len() {
                        b[at + i] = x;
                    }
                }
            }
            Edit::Delete(at, len) => {
                let at = at % n;
                let end = (at + len % 64).min(b.len());
                if at < end {
                    b.drain(at..end);
                }
            }
            Edit::Insert(at, bytes) => {
                let at = (at % n).min(b.len());
                b.splice(at..at, bytes.iter().copied());
            }
            Edit::Cut(at) => b.truncate(at % n),
        }
    }
    b
}

fn edits(alphabet: &'static [u8]) -> impl Strategy<Value = Vec<Edit>> {
    let byte = proptest::sample::select(alphabet);
    let edit = prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(a, b)| Edit::Flip(a, b)),
        (any::<usize>(), proptest::collection::vec(byte.clone(), 1..12)).prop_map(|(a, b)| Edit::Overwrite(a, b)),
        (any::<usize>(), any::<usize>()).prop_map(|(a, n)| Edit::Delete(a, n)),
        (any::<usize>(), proptest::collection::vec(byte, 1..12)).prop_map(|(a, b)| Edit::Insert(a, b)),
        any::<usize>().prop_map(Edit::Cut),
    ];
    proptest::collection::vec(edit, 1..4)
}

/// Bytes a mutated TOML text is made of: TOML syntax, digits, and the scenario's words.
const TOML_BYTES: &[u8] = b"[]{}=,.\"'#\n 0123456789-+eEinfa_xyzmk";
const ANY_BYTES: &[u8] = &{
    let mut a = [0u8; 256];
    let mut i = 0;
    while i < 256 {
        a[i] = i as u8;
        i += 1;
    }
    a
};

/// The shipped scenarios and the fuzz seeds (tests/fuzz_seeds: the keys no shipped
/// scenario holds — `[measurement]` and a rig's sensors, the non-power terms beside a
/// hysteresis, a profile and a comparison, a selection among kinds with a candidate link,
/// a lab multisine with every key and its amplitude shape).
fn shipped_scenarios() -> Vec<(String, String)> {
    let mut v: Vec<_> = ["scenarios", "tests/fuzz_seeds"]
        .iter()
        .flat_map(|d| std::fs::read_dir(d).unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .map(|p| (p.display().to_string(), std::fs::read_to_string(&p).unwrap()))
        .collect();
    v.sort();
    v
}

/// A mutant the parser accepted, made short enough to simulate in a moment.
fn shortened(mut s: Scenario) -> Option<Scenario> {
    let sim = &mut s.simulation;
    sim.trajectories = sim.trajectories.min(2);
    sim.record_length = sim.record_length.min(200.0 * sim.sample_interval);
    sim.burn_in = sim.burn_in.min(5.0);
    (sim.check().is_ok() && sim.total_steps() < 2e7).then_some(s)
}

#[test]
fn the_scenario_parser_survives_mutations_and_accepted_mutants_run() {
    let scenarios = shipped_scenarios();
    let dir = tempfile::tempdir().unwrap();
    let dir_path = dir.path().to_path_buf();
    let accepted = Cell::new(0usize);
    let n = Cell::new(0usize);
    runner(300)
        .run(&(0..scenarios.len(), edits(TOML_BYTES)), |(k, e)| {
            let (name, text) = scenarios[k].clone();
            let mutated = apply(text.into_bytes(), &e);
            let Ok(src) = String::from_utf8(mutated) else {
                return Ok(());
            };
            n.set(n.get() + 1);
            let log = dir_path.join(format!("case{}.mcap", n.get()));
            let ran = guarded(format!("{name} with {e:?}"), move || {
                let Ok(s) = Scenario::parse(&src, "mutant.toml", "mutant") else {
                    return false;
                };
                if let Some(s) = shortened(s) {
                    if simulate_log(&s, &log, Default::default(), &|_| {}).is_ok() {
                        let options = Options {
                            validate: false,
                            ..Options::default()
                        };
                        if let Ok(r) = identify_log(&log, &options) {
                            fpkbench::report::write_all(&r, &log.with_extension("report")).unwrap();
                        }
                        let _ = std::fs::remove_file(&log);
                    }
                }
                true
            });
            accepted.set(accepted.get() + ran as usize);
            Ok(())
        })
        .unwrap();
    eprintln!(
        "scenario parser: {} UTF-8 mutants, {} accepted",
        n.get(),
        accepted.get()
    );
    // The mutations are small: many mutants stay valid and go through the whole pipeline.
    assert!(accepted.get() > 20, "{} mutants accepted", accepted.get());
}

struct Logs {
    _dir: tempfile::TempDir,
    plain: PathBuf,
    zstd: PathBuf,
}

fn logs() -> &'static Logs {
    static LOGS: OnceLock<Logs> = OnceLock::new();
    LOGS.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let plain = dir.path().join("plain.mcap");
        fresh_log(&small_scenario(30.0, 2), &plain);
        let zstd = dir.path().join("zstd.mcap");
        write_records(
            &records(&plain),
            &zstd,
            Layout::new(
                mcap::WriteOptions::new()
                    .compression(Some(mcap::Compression::Zstd))
                    .chunk_size(Some(2048)),
            ),
        );
        Logs { _dir: dir, plain, zstd }
    })
}

/// Read `path` completely; the largest allocation made on the way.
fn read_fully(path: &Path) -> usize {
    common::reset_largest();
    if let Ok(info) = read_info(path) {
        let _ = read_samples(&info, |_, _, _| {});
    }
    common::largest()
}

#[test]
fn the_log_reader_survives_mutations_within_its_allocation_bound() {
    let logs = logs();
    let originals: Vec<Vec<u8>> = [&logs.plain, &logs.zstd]
        .iter()
        .map(|p| std::fs::read(p).unwrap())
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let dir_path = dir.path().to_path_buf();
    let n = Cell::new(0usize);
    runner(1500)
        .run(&(0..2usize, edits(ANY_BYTES)), |(k, e)| {
            let bytes = apply(originals[k].clone(), &e);
            n.set(n.get() + 1);
            let path = dir_path.join(format!("case{}.mcap", n.get()));
            std::fs::write(&path, &bytes).unwrap();
            let p = path.clone();
            let largest = guarded(format!("log {k} with {e:?}"), move || read_fully(&p));
            // The stated bound (docs/reliability.md): the file's size plus the reader's 1 MiB
            // buffer; for a compressed chunk also its declared size (at most MAX_CHUNK) and
            // the zstd window (at most 2^ZSTD_WINDOW_LOG).
            use fpkbench::io::reader::{MAX_CHUNK, ZSTD_WINDOW_LOG};
            let bound = bytes.len() + (1 << 20) + (64 << 10);
            let compressed = (MAX_CHUNK as usize + 1).max(1 << ZSTD_WINDOW_LOG) + (1 << 20);
            prop_assert!(
                largest <= bound.max(compressed),
                "{largest} bytes for a file of {}",
                bytes.len()
            );
            if k == 0 {
                prop_assert!(largest <= bound, "{largest} bytes for a file of {}", bytes.len());
            }
            let _ = std::fs::remove_file(&path);
            Ok(())
        })
        .unwrap();
}

/// A sample value: mostly ordinary, sometimes extreme or not finite.
fn value() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => -3.0..3.0f64,
        1 => prop_oneof![
            Just(0.0),
            Just(1e-300),
            Just(1e150),
            Just(-1e200),
            Just(f64::MAX),
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(f64::NEG_INFINITY),
        ],
    ]
}

#[test]
fn the_identifier_survives_arbitrary_sample_values() {
    let logs = logs();
    let r = records(&logs.plain);
    let dir = tempfile::tempdir().unwrap();
    let dir_path = dir.path().to_path_buf();
    let n = Cell::new(0usize);
    // Per case: a rule for every value of the log (constant, scaled, or overwritten at
    // some instants), so that both whole-log extremes and rare bad values occur.
    let strategy = (
        value(),
        0.0..1.0f64,
        proptest::collection::vec((any::<usize>(), value()), 0..6),
    );
    runner(48)
        .run(&strategy, |(fill, scale, spots)| {
            let mut r = r.clone();
            // 4 columns of 2 trajectories: per column a length, padding and 2 values.
            let cols = 4;
            for (k, m) in r.messages.iter_mut().enumerate() {
                for c in 0..cols {
                    for j in 0..2 {
                        let at = 12 + c * (8 + 16) + 8 + 8 * j;
                        let old = f64::from_le_bytes(m.1[at..at + 8].try_into().unwrap());
                        let v = if fill.is_finite() && fill.abs() < 10.0 {
                            old * (scale * 1e3)
                        } else if k % 3 == 0 {
                            fill
                        } else {
                            old
                        };
                        m.1[at..at + 8].copy_from_slice(&v.to_le_bytes());
                    }
                }
            }
            for (at, v) in &spots {
                let k = at % r.messages.len();
                let off = 12 + (at / 7 % cols) * 24 + 8 + 8 * (at % 2);
                r.messages[k].1[off..off + 8].copy_from_slice(&v.to_le_bytes());
            }
            n.set(n.get() + 1);
            let path = dir_path.join(format!("case{}.mcap", n.get()));
            write_records(&r, &path, Layout::new(mcap::WriteOptions::new()));
            let p = path.clone();
            let out = dir_path.join(format!("report{}", n.get()));
            let report: Option<fpkbench::report::Report> =
                guarded(format!("fill {fill}, scale {scale}, spots {spots:?}"), move || {
                    let options = Options {
                        validate: false,
                        ..Options::default()
                    };
                    let report = identify_log(&p, &options).ok();
                    // The report and its plots too: extreme values must not hang the plotting.
                    if let Some(r) = &report {
                        fpkbench::report::write_all(r, &out).unwrap();
                    }
                    report
                });
            if let Some(report) = report {
                for m in &report.methods {
                    prop_assert!(
                        m.outcome.error().is_some() || m.parameters.iter().all(|p| p.estimate.is_finite()),
                        "{}: a non-finite estimate without an error",
                        m.method
                    );
                }
            }
            let _ = std::fs::remove_file(&path);
            Ok(())
        })
        .unwrap();
}

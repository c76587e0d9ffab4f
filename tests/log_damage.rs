//! Damaged and hostile logs: every one gives an error that says what is wrong and what can
//! still be read — never a panic, an abort, a hang or an allocation beyond the file's size.
//! Each damaged log is made here from a fresh one.

use crate::common;

use common::{fresh_log, records, small_scenario, write_records, Layout};
use fpkbench::io::log::{read_info, read_samples, LogError};
use fpkbench::pipeline::{identify_log, Options, PipelineError};
use std::path::Path;

/// The stated bound for an uncompressed log: no allocation beyond the file's size plus the
/// reader's 1 MiB input buffer and small change.
fn bound(file_len: usize) -> usize {
    file_len + (1 << 20) + (64 << 10)
}

/// One sample as bits: trajectory, time, values.
type Sample = (u32, u64, Vec<u64>);

/// Read a log fully; the samples delivered and the outcome. Checks the allocation bound.
fn read_all(path: &Path) -> (Vec<Sample>, Result<u64, LogError>) {
    let len = std::fs::metadata(path).unwrap().len() as usize;
    common::reset_largest();
    let mut got = Vec::new();
    let outcome = read_info(path).and_then(|info| {
        read_samples(&info, |j, t, x| {
            got.push((j, t.to_bits(), x.iter().map(|v| v.to_bits()).collect()));
        })
    });
    // (The delivered samples are collected by the test itself; leave them out.)
    let largest = common::largest();
    let collected = got.capacity() * std::mem::size_of::<Sample>();
    assert!(
        largest <= bound(len).max(collected),
        "{}: an allocation of {largest} bytes for a file of {len}",
        path.display()
    );
    (got, outcome)
}

fn fresh(dir: &Path) -> (std::path::PathBuf, Vec<u8>) {
    let path = dir.join("run.mcap");
    fresh_log(&small_scenario(2000.0, 8), &path);
    let bytes = std::fs::read(&path).unwrap();
    (path, bytes)
}

/// Byte offsets of the chunk records (opcode 0x06) at the top level of `bytes`.
fn chunk_offsets(bytes: &[u8]) -> Vec<usize> {
    let mut at = 8;
    let mut out = Vec::new();
    while at + 9 <= bytes.len() {
        let op = bytes[at];
        let n = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        if op == 0x06 {
            out.push(at);
        }
        if op == 0x02 {
            break;
        }
        at += 9 + n;
    }
    out
}

#[test]
fn a_flipped_bit_in_a_chunk_is_caught_by_its_crc_and_nothing_of_it_is_delivered() {
    let dir = tempfile::tempdir().unwrap();
    let (path, bytes) = fresh(dir.path());
    let (all, ok) = read_all(&path);
    assert_eq!(ok.unwrap(), 8 * 20000);
    let chunks = chunk_offsets(&bytes);
    assert!(chunks.len() >= 4, "{} chunks", chunks.len());
    // A bit deep inside the third chunk's messages (a sample value; the first chunk holds
    // the schema and channel, the second the first samples).
    let mut bad = bytes.clone();
    let at = chunks[2] + 4000;
    bad[at] ^= 0x10;
    let damaged = dir.path().join("flipped.mcap");
    std::fs::write(&damaged, &bad).unwrap();
    let (got, outcome) = read_all(&damaged);
    match outcome {
        Err(LogError::Corrupt { reason, readable, .. }) => {
            assert!(reason.contains("CRC"), "{reason}");
            assert!(reason.contains(&format!("byte {}: chunk CRC", chunks[2])), "{reason}");
            assert_eq!(readable as usize, got.len());
        }
        other => panic!("expected Corrupt, got {other:?}"),
    }
    // Everything delivered is intact: the samples of the chunks before the damaged one.
    assert!(!got.is_empty() && got.len() < all.len());
    assert_eq!(got[..], all[..got.len()]);
}

#[test]
fn a_flipped_bit_in_a_zstd_chunk_is_caught_too() {
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = fresh(dir.path());
    let zstd = dir.path().join("zstd.mcap");
    write_records(
        &records(&path),
        &zstd,
        Layout::new(mcap::WriteOptions::new().compression(Some(mcap::Compression::Zstd))),
    );
    let mut bad = std::fs::read(&zstd).unwrap();
    let chunks = chunk_offsets(&bad);
    let at = chunks[1] + 3000;
    bad[at] ^= 0x01;
    std::fs::write(&zstd, &bad).unwrap();
    let err = read_all(&zstd).1.unwrap_err().to_string();
    assert!(
        err.contains("damaged") && err.contains(&format!("byte {}: chunk CRC", chunks[1])),
        "{err}"
    );
}

#[test]
fn damaged_lengths_and_headers_give_errors_not_huge_allocations() {
    let dir = tempfile::tempdir().unwrap();
    let (_, bytes) = fresh(dir.path());
    let chunk = chunk_offsets(&bytes)[0];
    let mut cases: Vec<(String, Vec<u8>)> = Vec::new();
    // Every byte of the first chunk's record length and header set to 0xff, then 0x00.
    for i in 1..(9 + 8 + 8 + 8 + 4 + 4 + 8) {
        for v in [0xffu8, 0x00, 0x7f] {
            if bytes[chunk + i] != v {
                let mut b = bytes.clone();
                b[chunk + i] = v;
                cases.push((format!("chunk byte {i} = {v:#x}"), b));
            }
        }
    }
    // 22 bytes deleted in the middle of the data.
    let mut b = bytes.clone();
    b.drain(bytes.len() / 2..bytes.len() / 2 + 22);
    cases.push(("22 bytes deleted".into(), b));
    // Random bytes after the magic.
    let mut b = bytes[..8].to_vec();
    let mut x = 0x9e3779b97f4a7c15u64;
    for _ in 0..100_000 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        b.push(x as u8);
    }
    cases.push(("random bytes after the magic".into(), b));
    // Cut at many places.
    for k in 1..20 {
        cases.push((format!("cut at {k}/20"), bytes[..bytes.len() * k / 20].to_vec()));
    }
    let path = dir.path().join("case.mcap");
    for (name, b) in cases {
        std::fs::write(&path, &b).unwrap();
        let (got, outcome) = read_all(&path);
        let e = outcome.expect_err(&name);
        let text = e.to_string();
        assert!(!text.contains('\u{1b}'), "{name}: escape codes in {text}");
        if let LogError::Truncated { readable, .. } | LogError::Corrupt { readable, .. } = e {
            assert_eq!(readable as usize, got.len(), "{name}");
        }
    }
}

#[test]
fn non_finite_and_malformed_samples_are_refused_saying_where() {
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = fresh(dir.path());
    let r = records(&path);
    let edited = dir.path().join("edited.mcap");
    let write = |edit: &dyn Fn(&mut Vec<u8>)| {
        let mut r = r.clone();
        edit(&mut r.messages[250].1);
        write_records(&r, &edited, Layout::new(mcap::WriteOptions::new()));
        read_all(&edited)
    };
    // Trajectory 2's x_m1 (column 0) at instant 250: offset 4 + 8 + 8 + 8 * 2 (8 trajectories).
    for (v, shown) in [(f64::NAN, "NaN"), (f64::INFINITY, "inf"), (f64::NEG_INFINITY, "-inf")] {
        let (got, outcome) = write(&|m| m[36..44].copy_from_slice(&v.to_le_bytes()));
        let text = outcome.unwrap_err().to_string();
        assert!(
            text.contains(&format!("x_m1 = {shown} at t = 25.1 s, trajectory 2")) && text.contains("instant 250"),
            "{text}"
        );
        assert_eq!(got.len(), 250 * 8);
    }
    // A message of the wrong size, and one whose array lengths disagree.
    let text = write(&|m| m.truncate(m.len() - 8)).1.unwrap_err().to_string();
    assert!(text.contains("instant 250") && text.contains("bytes where"), "{text}");
    let text = write(&|m| m[12] = 9).1.unwrap_err().to_string();
    assert!(text.contains("array x_m1 holds 9 values"), "{text}");
}

#[test]
fn huge_sample_values_give_an_identification_error_not_a_panic_or_a_hang() {
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = fresh(dir.path());
    let mut r = records(&path);
    for m in r.messages.iter_mut().step_by(7) {
        m.1[20..28].copy_from_slice(&1e200f64.to_le_bytes());
    }
    let edited = dir.path().join("huge.mcap");
    write_records(&r, &edited, Layout::new(mcap::WriteOptions::new()));
    let options = Options {
        validate: false,
        ..Options::default()
    };
    match identify_log(&edited, &options) {
        Err(PipelineError::Ident(e)) => assert!(e.to_string().contains("non-finite"), "{e}"),
        Err(e) => panic!("unexpected error {e}"),
        Ok(report) => {
            // The plots of such data are drawn (or said to be undrawable), not hung on.
            let files = fpkbench::report::write_all(&report, &dir.path().join("report")).unwrap();
            assert!(files.len() >= 3);
            let weak = report.methods.iter().find(|m| m.method.name() == "weak").unwrap();
            assert!(
                weak.outcome.error().is_some_and(|e| e.contains("non-finite")),
                "{:?}",
                weak.outcome
            );
            // Methods that survive report their own failure; none may claim an estimate.
            for m in &report.methods {
                assert!(
                    m.outcome.error().is_some() || m.parameters.iter().all(|p| p.estimate.is_finite()),
                    "{}",
                    m.method
                );
            }
        }
    }
}

#[test]
fn impossible_run_facts_are_refused_on_read() {
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = fresh(dir.path());
    let r = records(&path);
    let edited = dir.path().join("facts.mcap");
    for (key, value, says) in [
        ("dt_s", "NaN", "dt must be a finite number > 0"),
        ("substeps", "0", "substeps must be 1..="),
        ("trajectories", "1000000000000", "trajectories must be 1..="),
        ("record_length_s", "1e300", "integration steps"),
        ("sample_interval_s", "0.00015", "whole multiple of dt"),
        ("burn_in_s", "-1", "burn_in must be"),
    ] {
        let mut r = r.clone();
        let run = r.metadata.iter_mut().find(|m| m.0 == "fpkbench.run").unwrap();
        run.1.insert(key.into(), value.into());
        write_records(&r, &edited, Layout::new(mcap::WriteOptions::new()));
        let text = read_info(&edited).unwrap_err().to_string();
        assert!(
            text.contains("run facts") && text.contains(says),
            "{key} = {value}: {text}"
        );
    }
    // A truth value that is not a number, and a channel whose columns are not the scenario's.
    let mut bad = r.clone();
    let truth = bad.metadata.iter_mut().find(|m| m.0 == "fpkbench.truth").unwrap();
    truth.1.insert("k1[ground-m1]".into(), "ten".into());
    write_records(&bad, &edited, Layout::new(mcap::WriteOptions::new()));
    assert!(read_info(&edited).unwrap_err().to_string().contains("is not a number"));
    let mut bad = r.clone();
    bad.channel.2.insert("columns".into(), "x_m1,v_m1".into());
    write_records(&bad, &edited, Layout::new(mcap::WriteOptions::new()));
    assert!(read_info(&edited)
        .unwrap_err()
        .to_string()
        .contains("are not those of its scenario"));
}

#[test]
fn a_damaged_metadata_record_is_called_damaged_not_truncated() {
    let dir = tempfile::tempdir().unwrap();
    let (_, bytes) = fresh(dir.path());
    // The run-facts record: its map's byte length made larger than the record.
    let at = bytes.windows(11).position(|w| w == b"fpkbench.ru").unwrap() - 4 - 9;
    assert_eq!(bytes[at], 0x0c, "a metadata record");
    let name_len = u32::from_le_bytes(bytes[at + 9..at + 13].try_into().unwrap()) as usize;
    let map_len_at = at + 13 + name_len;
    let mut bad = bytes.clone();
    bad[map_len_at..map_len_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    let path = dir.path().join("meta.mcap");
    std::fs::write(&path, &bad).unwrap();
    let text = read_info(&path).unwrap_err().to_string();
    assert!(
        text.contains("corrupt at byte") && text.contains("metadata record"),
        "{text}"
    );
    assert!(!text.contains("truncated"), "{text}");
}

#[test]
fn a_filtered_force_faster_than_the_step_is_refused_and_one_at_the_limit_ends_in_a_report() {
    // B = 1e300 1/s: white noise to the masses, which the step cannot follow; refused from
    // the scenario, naming the key and the white-noise equivalent, before any simulation.
    let src = std::fs::read_to_string("scenarios/filtered2dof.toml").unwrap();
    let e = fpkbench::Scenario::parse(&src.replacen("B = 5.0", "B = 1e300", 1), "b.toml", "b").unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("excitation[0].B") && text.contains("kind = \"white\"") && text.contains("b.toml:"),
        "{text}"
    );
    // B·dt = 1 (dt = 2.5e-4): the fastest filter allowed; simulation, identification and
    // plots end (an extreme corner once hung them).
    let mut s = fpkbench::Scenario::parse(&src.replacen("B = 5.0", "B = 4000.0", 1), "b.toml", "b").unwrap();
    s.simulation.record_length = 100.0;
    s.simulation.trajectories = 4;
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("b.mcap");
    fpkbench::pipeline::simulate_log(&s, &log, Default::default(), &|_| {}).unwrap();
    let options = Options {
        validate: false,
        ..Options::default()
    };
    if let Ok(r) = identify_log(&log, &options) {
        fpkbench::report::write_all(&r, &dir.path().join("report")).unwrap();
    }
}

/// A chunk whose record length claims 7e16 bytes is damage, not a cut-short file: it is
/// never offered `--allow-truncated`.
#[test]
fn an_impossible_chunk_length_is_damage_not_truncation() {
    let dir = tempfile::tempdir().unwrap();
    let (_, bytes) = fresh(dir.path());
    let chunk = chunk_offsets(&bytes)[1];
    let mut b = bytes.clone();
    b[chunk + 1..chunk + 9].copy_from_slice(&70_000_000_000_000_000u64.to_le_bytes());
    let path = dir.path().join("long.mcap");
    std::fs::write(&path, &b).unwrap();
    let (got, outcome) = read_all(&path);
    match outcome {
        Err(LogError::Corrupt { reason, readable, .. }) => {
            assert!(
                reason.contains("70000000000000000") && reason.contains("damaged"),
                "{reason}"
            );
            assert_eq!(readable as usize, got.len());
        }
        other => panic!("expected damage, got {other:?}"),
    }
}

#[test]
fn a_zstd_frame_asking_for_a_huge_window_is_refused_within_the_bound() {
    // Found by the long fuzzing run: a damaged zstd frame header made the decoder allocate
    // a 117 MB window. Here a chunk is recompressed with a 128 MiB window (long-distance
    // matching), as no MCAP writer does; the reader refuses it without allocating it.
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = fresh(dir.path());
    let zstd_log = dir.path().join("zstd.mcap");
    write_records(
        &records(&path),
        &zstd_log,
        Layout::new(mcap::WriteOptions::new().compression(Some(mcap::Compression::Zstd))),
    );
    let bytes = std::fs::read(&zstd_log).unwrap();
    let at = chunk_offsets(&bytes)[1];
    let body = &bytes[at + 9..];
    let header_len = 8 + 8 + 8 + 4 + 4 + 4; // times, size, crc, "zstd" with its length
    assert_eq!(&body[32..36], b"zstd");
    let n = u64::from_le_bytes(body[header_len..header_len + 8].try_into().unwrap()) as usize;
    let old = &body[header_len + 8..header_len + 8 + n];
    let records = zstd::decode_all(old).unwrap();
    let mut enc = zstd::stream::Encoder::new(Vec::new(), 1).unwrap();
    enc.long_distance_matching(true).unwrap();
    enc.window_log(27).unwrap();
    std::io::Write::write_all(&mut enc, &records).unwrap();
    let new = enc.finish().unwrap();
    let mut chunk = body[..header_len].to_vec();
    chunk.extend_from_slice(&(new.len() as u64).to_le_bytes());
    chunk.extend_from_slice(&new);
    let mut out = bytes[..at].to_vec();
    out.push(0x06);
    out.extend_from_slice(&(chunk.len() as u64).to_le_bytes());
    out.extend_from_slice(&chunk);
    out.extend_from_slice(&bytes[at + 9 + header_len + 8 + n..]);
    let damaged = dir.path().join("window.mcap");
    std::fs::write(&damaged, &out).unwrap();
    common::reset_largest();
    let text = read_all(&damaged).1.unwrap_err().to_string();
    assert!(
        text.contains(&format!("corrupt at byte {at}")) && text.contains("zstd"),
        "{text}"
    );
    let largest = common::largest();
    assert!(largest < 64 << 20, "{largest} bytes allocated");
}

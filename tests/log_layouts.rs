//! Every valid MCAP layout reads the same samples, scenario and truth: a fresh fpkbench log
//! re-written by the `mcap` crate's writer with its options varied (chunking, compression,
//! chunk size, summary, indexes, statistics, repeated records, where the description
//! records go, an extra topic), then read by the library and by the command line.

use crate::common;

use common::{fresh_log, relayout, small_scenario, Layout};
use fpkbench::io::log::{read_info, read_samples};
use mcap::{Compression, WriteOptions};
use std::path::Path;
use std::process::Command;

/// Every sample as bits, in file order.
fn samples(path: &Path) -> Vec<u64> {
    let info = read_info(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut v = Vec::new();
    read_samples(&info, |j, t, x| {
        v.push(j as u64);
        v.push(t.to_bits());
        v.extend(x.iter().map(|x| x.to_bits()));
    })
    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    v
}

fn layouts() -> Vec<(&'static str, Layout)> {
    let base = || WriteOptions::new();
    let last = |options: WriteOptions| Layout {
        options,
        description_last: true,
        extra_channel: false,
    };
    vec![
        ("chunked 64 MiB", Layout::new(base().chunk_size(Some(64 << 20)))),
        ("unchunked", last(base().use_chunks(false))),
        (
            "zstd 4 KiB chunks",
            last(base().compression(Some(Compression::Zstd)).chunk_size(Some(4096))),
        ),
        (
            "no statistics, no summary offsets",
            last(base().emit_statistics(false).emit_summary_offsets(false)),
        ),
        (
            "no indexes, no repeated channels/schemas",
            last(
                base()
                    .emit_message_indexes(false)
                    .emit_chunk_indexes(false)
                    .emit_attachment_indexes(false)
                    .emit_metadata_indexes(false)
                    .repeat_channels(false)
                    .repeat_schemas(false),
            ),
        ),
        ("lz4 chunks", last(base().compression(Some(Compression::Lz4)))),
        (
            "lz4 1 KiB chunks, no summary at all",
            last(
                base()
                    .compression(Some(Compression::Lz4))
                    .chunk_size(Some(1024))
                    .emit_summary_records(false)
                    .emit_summary_offsets(false),
            ),
        ),
        (
            "unchunked, no summary, no CRCs",
            last(
                base()
                    .use_chunks(false)
                    .emit_summary_records(false)
                    .calculate_data_section_crc(false)
                    .calculate_summary_section_crc(false)
                    .calculate_attachment_crcs(false),
            ),
        ),
        (
            "an extra topic interleaved",
            Layout {
                options: base().compression(Some(Compression::Zstd)),
                description_last: true,
                extra_channel: true,
            },
        ),
    ]
}

#[test]
fn every_layout_reads_the_same_samples_scenario_and_truth() {
    let dir = tempfile::tempdir().unwrap();
    let original = dir.path().join("run.mcap");
    let s = small_scenario(40.0, 3);
    fresh_log(&s, &original);
    let want = samples(&original);
    assert_eq!(want.len(), 3 * 400 * (2 + 4));
    let info = read_info(&original).unwrap();
    let bin = env!("CARGO_BIN_EXE_fpkbench");
    let csv = |log: &Path| {
        let out = dir.path().join("x.csv");
        let o = Command::new(bin)
            .args([
                "export",
                log.to_str().unwrap(),
                "--format",
                "csv",
                "-o",
                out.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{}: {}",
            log.display(),
            String::from_utf8_lossy(&o.stderr)
        );
        std::fs::read(out).unwrap()
    };
    let want_csv = csv(&original);
    for (i, (name, layout)) in layouts().into_iter().enumerate() {
        let path = dir.path().join(format!("layout{i}.mcap"));
        relayout(&original, &path, layout);
        assert_eq!(samples(&path), want, "{name}: samples");
        let got = read_info(&path).unwrap();
        assert_eq!(got.scenario, info.scenario, "{name}: scenario");
        assert_eq!(got.truth, info.truth, "{name}: truth");
        assert_eq!(got.run, info.run, "{name}: run facts");
        assert_eq!(csv(&path), want_csv, "{name}: export");
        let o = Command::new(bin)
            .args(["inspect", path.to_str().unwrap(), "--json"])
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{name}: inspect: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["samples"], 1200, "{name}");
    }
}

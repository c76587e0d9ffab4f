//! Test helpers shared by the log tests: a small fresh log, and the same log re-written
//! with another MCAP layout (or with edited records) by the `mcap` crate's own writer.
#![allow(dead_code)]

use fpkbench::io::log::LogWriter;
use fpkbench::io::reader::{McapFile, Record, Scan};
use fpkbench::model::Model;
use fpkbench::sim::simulate;
use fpkbench::Scenario;
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::ops::ControlFlow;
use std::path::Path;

/// Records the largest single allocation made by each thread, so that tests can check the
/// reader's allocation bound (docs/reliability.md). Every test binary that uses this module
/// allocates through it.
struct Largest;

thread_local! {
    static LARGEST: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

unsafe impl std::alloc::GlobalAlloc for Largest {
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        let _ = LARGEST.try_with(|c| c.set(c.get().max(layout.size())));
        unsafe { std::alloc::System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: std::alloc::Layout) {
        unsafe { std::alloc::System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: std::alloc::Layout, new_size: usize) -> *mut u8 {
        let _ = LARGEST.try_with(|c| c.set(c.get().max(new_size)));
        unsafe { std::alloc::System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Largest = Largest;

/// Start counting this thread's largest allocation afresh.
pub fn reset_largest() {
    LARGEST.with(|c| c.set(0));
}

/// This thread's largest single allocation since [`reset_largest`].
pub fn largest() -> usize {
    LARGEST.with(|c| c.get())
}

/// The SDOF Duffing scenario shortened to `record_length` s per trajectory.
pub fn small_scenario(record_length: f64, trajectories: usize) -> Scenario {
    let src = std::fs::read_to_string("scenarios/sdof_duffing.toml").unwrap();
    let mut s = Scenario::parse(&src, "sdof_duffing.toml", "sdof_duffing").unwrap();
    s.simulation.record_length = record_length;
    s.simulation.trajectories = trajectories;
    s
}

/// Simulate `s` into a log at `path` (the fpkbench writer, uncompressed).
pub fn fresh_log(s: &Scenario, path: &Path) {
    let m = Model::new(s);
    let mut w = LogWriter::create(path, s, &m).unwrap();
    simulate(&m, &s.simulation, &mut w, &|_| {}).unwrap();
    w.finish().unwrap();
}

/// Every record of a log, owned.
#[derive(Default, Clone)]
pub struct Records {
    pub library: String,
    pub profile: String,
    /// `(name, encoding, data)` of the sample schema.
    pub schema: (String, String, Vec<u8>),
    /// `(topic, message encoding, metadata)` of the sample channel.
    pub channel: (String, String, BTreeMap<String, String>),
    pub attachments: Vec<(String, String, Vec<u8>)>,
    pub metadata: Vec<(String, BTreeMap<String, String>)>,
    /// `(log_time, payload)` per message.
    pub messages: Vec<(u64, Vec<u8>)>,
}

pub fn records(path: &Path) -> Records {
    let mut r = Records::default();
    Scan::new(McapFile::open(path).unwrap())
        .run(|rec, _| {
            match rec {
                Record::Header { profile, library } => (r.profile, r.library) = (profile, library),
                Record::Schema {
                    name, encoding, data, ..
                } => r.schema = (name, encoding, data.to_vec()),
                Record::Channel {
                    topic,
                    message_encoding,
                    metadata,
                    ..
                } => r.channel = (topic, message_encoding, metadata),
                Record::Attachment { name, media_type, data } => r.attachments.push((name, media_type, data.to_vec())),
                Record::Metadata { name, metadata } => r.metadata.push((name, metadata)),
                Record::Message { log_time, data, .. } => r.messages.push((log_time, data.to_vec())),
                Record::Other(_) => {}
            }
            ControlFlow::Continue(())
        })
        .unwrap();
    r
}

/// How to lay a log out again.
pub struct Layout {
    pub options: mcap::WriteOptions,
    /// Attachments and metadata after the messages (as a tool that copies messages first
    /// writes them), not before.
    pub description_last: bool,
    /// A second topic with its own schema, one message of it before each sample message.
    pub extra_channel: bool,
}

impl Layout {
    pub fn new(options: mcap::WriteOptions) -> Layout {
        Layout {
            options,
            description_last: false,
            extra_channel: false,
        }
    }
}

/// Write `r` to `dst` with `layout`.
pub fn write_records(r: &Records, dst: &Path, layout: Layout) {
    let file = std::io::BufWriter::new(std::fs::File::create(dst).unwrap());
    let mut w = layout
        .options
        .profile(r.profile.clone())
        .library(r.library.clone())
        .create(file)
        .unwrap();
    let schema = w.add_schema(&r.schema.0, &r.schema.1, &r.schema.2).unwrap();
    let channel = w.add_channel(schema, &r.channel.0, &r.channel.1, &r.channel.2).unwrap();
    let other = if layout.extra_channel {
        let s = w.add_schema("other/msg/Note", "ros2msg", b"string text\n").unwrap();
        Some(w.add_channel(s, "/other", "cdr", &BTreeMap::new()).unwrap())
    } else {
        None
    };
    let description = |w: &mut mcap::Writer<std::io::BufWriter<std::fs::File>>| {
        for (name, media_type, data) in &r.attachments {
            w.attach(&mcap::Attachment {
                log_time: 0,
                create_time: 0,
                name: name.clone(),
                media_type: media_type.clone(),
                data: Cow::Borrowed(data),
            })
            .unwrap();
        }
        for (name, metadata) in &r.metadata {
            w.write_metadata(&mcap::records::Metadata {
                name: name.clone(),
                metadata: metadata.clone(),
            })
            .unwrap();
        }
    };
    if !layout.description_last {
        description(&mut w);
    }
    for (seq, (time, data)) in r.messages.iter().enumerate() {
        if let Some(other) = other {
            let header = mcap::records::MessageHeader {
                channel_id: other,
                sequence: seq as u32,
                log_time: *time,
                publish_time: *time,
            };
            w.write_to_known_channel(&header, b"\x00\x01\x00\x00\x05\x00\x00\x00note\x00")
                .unwrap();
        }
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: seq as u32,
            log_time: *time,
            publish_time: *time,
        };
        w.write_to_known_channel(&header, data).unwrap();
    }
    if layout.description_last {
        description(&mut w);
    }
    w.finish().unwrap();
}

/// Re-write the log at `src` to `dst` with `layout`.
pub fn relayout(src: &Path, dst: &Path, layout: Layout) {
    write_records(&records(src), dst, layout);
}

/// The files of `dir` whose names end in `ext` (e.g. `".toml"`), sorted by path.
pub fn files_in(dir: &str, ext: &str) -> Vec<std::path::PathBuf> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(ext))
        .collect();
    files.sort();
    files
}

/// `fpkbench export LOG --format FORMAT -o OUT`, through the binary (exit 0 asserted).
pub fn export(log: &Path, format: &str, out: &Path) {
    let st = std::process::Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args([
            "export",
            log.to_str().unwrap(),
            "--format",
            format,
            "-o",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(st.status.success(), "{}", String::from_utf8_lossy(&st.stderr));
}

//! The MCAP run log: layout, writer and streaming reader.
//!
//! Layout (fixed; see docs/log-format.md):
//! - profile `ros2`; one schema `fpkbench/msg/Sample` (encoding `ros2msg`), one channel
//!   [`TOPIC`] with message encoding `cdr`, whose metadata gives units, the column list,
//!   which excitations are unmeasured and how white-noise quantities were averaged;
//! - before any sample: the scenario TOML as attachment [`SCENARIO_ATTACHMENT`], the true
//!   parameters as metadata record [`TRUTH_METADATA`], the run facts as [`RUN_METADATA`] —
//!   so even a truncated log describes itself;
//! - one message per sampling instant carrying every trajectory, `log_time` = time after
//!   burn-in in ns, payload CDR little-endian: 4-byte encapsulation header, `float64 t`,
//!   then per column a `float64[]` with one value per trajectory (`uint32` length, 4 bytes
//!   padding, the values) — element `j` of every array is trajectory `j`;
//! - chunks uncompressed by default (a sample's 8-byte values barely compress, and zstd
//!   would cost several times the simulation itself), or zstd on request.
//!
//! The writer encodes (and compresses) on its own thread, fed whole batches through a
//! bounded channel and handing them back for the simulator to refill; it writes to
//! `<name>.partial` and renames only after `finish()`.

use crate::model::Model;
use crate::model::Quantity;
use crate::scenario::{Scenario, ScenarioError};
use crate::sim::{SampleBatch, SampleSink};
use mcap::records::{MessageHeader, Metadata, Record};
use mcap::sans_io::{LinearReadEvent, LinearReader};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Read};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::thread::JoinHandle;

pub const TOPIC: &str = "/fpkbench/samples";
pub const SCHEMA_NAME: &str = "fpkbench/msg/Sample";
pub const SCENARIO_ATTACHMENT: &str = "scenario.toml";
pub const TRUTH_METADATA: &str = "fpkbench.truth";
pub const RUN_METADATA: &str = "fpkbench.run";
const CDR_HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Chunk compression of a log.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Compression {
    /// Plain chunks: the fastest to write and read.
    #[default]
    None,
    /// zstd level 1, compressed on the writer thread (`compression_threads(0)`).
    Zstd,
}

/// Bytes of one instant's message: header, `t`, then per column a length, padding and
/// one `float64` per trajectory.
fn message_len(columns: usize, trajectories: usize) -> usize {
    4 + 8 + columns * (8 + 8 * trajectories)
}

/// Errors reading or writing a log.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: MCAP error: {source}")]
    Mcap {
        path: String,
        #[source]
        source: mcap::McapError,
    },
    /// The file ends early (e.g. the writer was killed). The samples before the break were
    /// delivered to the caller.
    #[error(
        "{path}: the log is truncated ({reason}); {readable} samples are still readable \
         (of {expected} the run was to write)"
    )]
    Truncated {
        path: String,
        reason: String,
        readable: u64,
        expected: u64,
    },
    /// The file is MCAP but not an fpkbench log, or its description is inconsistent.
    #[error("{path}: not a valid fpkbench log: {reason}")]
    Invalid { path: String, reason: String },
    #[error("{path}: the scenario stored in the log is invalid")]
    Scenario {
        path: String,
        #[source]
        source: ScenarioError,
    },
}

/// Run facts stored in the log's [`RUN_METADATA`] record.
pub fn run_facts(s: &Scenario) -> BTreeMap<String, String> {
    let sim = &s.simulation;
    let mut m = BTreeMap::new();
    m.insert("scenario".into(), s.name.clone());
    m.insert("seed".into(), sim.seed.to_string());
    m.insert("scheme".into(), sim.scheme.name().into());
    m.insert("dt_s".into(), sim.dt.to_string());
    m.insert("substeps".into(), sim.substeps.to_string());
    m.insert("sample_interval_s".into(), sim.sample_interval.to_string());
    m.insert("record_length_s".into(), sim.record_length.to_string());
    m.insert("burn_in_s".into(), sim.burn_in.to_string());
    m.insert("trajectories".into(), sim.trajectories.to_string());
    m.insert(
        "samples_per_trajectory".into(),
        sim.samples_per_trajectory().to_string(),
    );
    if let Some(level) = s.disturbance_level {
        m.insert("disturbance_level".into(), format!("{level:?}"));
    }
    m.insert("tool".into(), format!("fpkbench {}", env!("CARGO_PKG_VERSION")));
    m
}

fn schema_text(cols: &[String]) -> String {
    let mut s = String::from(
        "# One sampling instant of every trajectory of an fpkbench run (SI units; see channel\n\
         # metadata): element j of each array is trajectory j.\n\
         float64 t\n",
    );
    for c in cols {
        s.push_str(&format!("float64[] {c}\n"));
    }
    s
}

fn channel_metadata(s: &Scenario, model: &Model, cols: &[String]) -> BTreeMap<String, String> {
    let mut m = BTreeMap::new();
    m.insert("columns".into(), cols.join(","));
    let mut units = vec!["t:s".to_string()];
    for c in cols {
        let u = Quantity::of_column(c).unwrap_or(Quantity::Force).unit(s.motion);
        units.push(format!("{c}:{u}"));
    }
    m.insert("units".into(), units.join(","));
    let unmeasured: Vec<_> = s
        .excitations
        .iter()
        .filter(|e| !e.measured)
        .map(|e| Quantity::Force.column_name(&e.name))
        .collect();
    m.insert("unmeasured".into(), unmeasured.join(","));
    let mut averaged = Vec::new();
    for (i, name) in model.mass_names.iter().enumerate() {
        if model.white_on(i) {
            averaged.push(Quantity::Acceleration.column_name(name));
        }
    }
    for e in &s.excitations {
        if matches!(e.process, crate::scenario::Process::White { .. }) {
            averaged.push(Quantity::Force.column_name(&e.name));
        }
    }
    m.insert("interval_averaged".into(), averaged.join(","));
    m.insert(
        "note".into(),
        "White noise has no value at an instant: columns in interval_averaged are means over the \
         preceding sample interval (impulse / interval, dv / interval), as a band-limited sensor \
         would give. Other accelerations are the force balance at the sample instant. With the \
         semi-implicit scheme the sample instant is the midpoint of the last integration step \
         (t − dt/2): its velocity is the step's mean, and the displacement is the step's mean too. \
         A filtered force is sampled at that instant as well, drawn from the exact \
         Ornstein-Uhlenbeck bridge between its values at the step's two ends."
            .into(),
    );
    m
}

/// What a finished log holds.
#[derive(Debug, Clone)]
pub struct LogSummary {
    pub path: PathBuf,
    pub samples: u64,
    pub bytes: u64,
}

type WriterResult = Result<u64, LogError>;

/// Writes a run log; a [`SampleSink`] for the simulator.
pub struct LogWriter {
    tx: Option<SyncSender<SampleBatch>>,
    /// Batches the writer thread has finished with.
    spent: Receiver<SampleBatch>,
    thread: Option<JoinHandle<WriterResult>>,
    tmp: PathBuf,
    dest: PathBuf,
}

impl LogWriter {
    /// Start an uncompressed log at `dest` (written as `dest.partial` until
    /// [`finish`](Self::finish)).
    pub fn create(dest: &Path, s: &Scenario, model: &Model) -> Result<LogWriter, LogError> {
        Self::create_with(dest, s, model, Compression::None)
    }

    /// Start a log at `dest` with the given chunk compression.
    pub fn create_with(
        dest: &Path,
        s: &Scenario,
        model: &Model,
        compression: Compression,
    ) -> Result<LogWriter, LogError> {
        let label = dest.display().to_string();
        let io = |source| LogError::Io {
            path: label.clone(),
            source,
        };
        let mc = |source| LogError::Mcap {
            path: label.clone(),
            source,
        };
        if let Some(dir) = dest.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(io)?;
        }
        let tmp = super::partial_path(dest);
        let file = File::create(&tmp).map_err(io)?;
        let mut w = mcap::WriteOptions::new()
            .profile("ros2")
            .library(format!("fpkbench {}", env!("CARGO_PKG_VERSION")))
            .compression(match compression {
                Compression::None => None,
                Compression::Zstd => Some(mcap::Compression::Zstd),
            })
            .compression_threads(0)
            .compression_level(1)
            .chunk_size(Some(1 << 20))
            .create(BufWriter::with_capacity(1 << 20, file))
            .map_err(mc)?;
        let cols = model.column_names();
        let schema = w
            .add_schema(SCHEMA_NAME, "ros2msg", schema_text(&cols).as_bytes())
            .map_err(mc)?;
        let channel = w
            .add_channel(schema, TOPIC, "cdr", &channel_metadata(s, model, &cols))
            .map_err(mc)?;
        w.attach(&mcap::Attachment {
            log_time: 0,
            create_time: 0,
            name: SCENARIO_ATTACHMENT.into(),
            media_type: "application/toml".into(),
            data: std::borrow::Cow::Borrowed(s.source.as_bytes()),
        })
        .map_err(mc)?;
        let truth = s.truth().into_iter().map(|(k, v)| (k, format!("{v:?}"))).collect();
        w.write_metadata(&Metadata {
            name: TRUTH_METADATA.into(),
            metadata: truth,
        })
        .map_err(mc)?;
        w.write_metadata(&Metadata {
            name: RUN_METADATA.into(),
            metadata: run_facts(s),
        })
        .map_err(mc)?;

        let (tx, rx) = sync_channel::<SampleBatch>(2);
        let (spent_tx, spent) = sync_channel::<SampleBatch>(2);
        let path = label.clone();
        let trajectories = s.simulation.trajectories;
        let thread = std::thread::spawn(move || -> WriterResult {
            let mc = |source| LogError::Mcap {
                path: path.clone(),
                source,
            };
            // Fixed layout: header, t, then per column its length, padding and values.
            let stride = 8 + 8 * trajectories;
            let mut payload = vec![0u8; message_len(cols.len(), trajectories)];
            payload[..4].copy_from_slice(&CDR_HEADER);
            for c in 0..cols.len() {
                let at = 12 + c * stride;
                payload[at..at + 4].copy_from_slice(&(trajectories as u32).to_le_bytes());
            }
            let mut seq: u32 = 0;
            for batch in rx {
                if (batch.columns, batch.trajectories) != (cols.len(), trajectories) {
                    return Err(LogError::Invalid {
                        path: path.clone(),
                        reason: format!(
                            "a batch of {} columns x {} trajectories was written to a log of {} x {}",
                            batch.columns,
                            batch.trajectories,
                            cols.len(),
                            trajectories
                        ),
                    });
                }
                for (k, &t) in batch.time.iter().enumerate() {
                    payload[4..12].copy_from_slice(&t.to_le_bytes());
                    let values = batch.instant(k).chunks_exact(trajectories);
                    for (column, v) in payload[12..].chunks_exact_mut(stride).zip(values) {
                        for (out, v) in column[8..].chunks_exact_mut(8).zip(v) {
                            out.copy_from_slice(&v.to_le_bytes());
                        }
                    }
                    let ns = (t * 1e9).round() as u64;
                    let header = MessageHeader {
                        channel_id: channel,
                        sequence: seq,
                        log_time: ns,
                        publish_time: ns,
                    };
                    w.write_to_known_channel(&header, &payload).map_err(mc)?;
                    seq = seq.wrapping_add(1);
                }
                // The simulator refills it, if it wants it before the next one is spent.
                let _ = spent_tx.try_send(batch);
            }
            w.finish().map_err(mc)?;
            let mut inner = w.into_inner();
            std::io::Write::flush(&mut inner).map_err(|source| LogError::Io {
                path: path.clone(),
                source,
            })?;
            Ok(seq as u64 * trajectories as u64)
        });
        Ok(LogWriter {
            tx: Some(tx),
            spent,
            thread: Some(thread),
            tmp,
            dest: dest.to_path_buf(),
        })
    }

    /// Close the log, then move it to its final name.
    pub fn finish(mut self) -> Result<LogSummary, LogError> {
        let label = self.dest.display().to_string();
        drop(self.tx.take());
        let result = self
            .thread
            .take()
            .expect("finish once")
            .join()
            .map_err(|_| LogError::Invalid {
                path: label.clone(),
                reason: "the log writer thread panicked".into(),
            })?;
        let samples = result?;
        std::fs::rename(&self.tmp, &self.dest).map_err(|source| LogError::Io {
            path: label.clone(),
            source,
        })?;
        let bytes = std::fs::metadata(&self.dest).map(|m| m.len()).unwrap_or(0);
        Ok(LogSummary {
            path: self.dest.clone(),
            samples,
            bytes,
        })
    }

    /// The writer thread's error, if it stopped early (called when a send fails).
    fn thread_error(&mut self) -> LogError {
        drop(self.tx.take());
        match self.thread.take().map(|t| t.join()) {
            Some(Ok(Err(e))) => e,
            _ => LogError::Invalid {
                path: self.dest.display().to_string(),
                reason: "the log writer stopped".into(),
            },
        }
    }
}

impl SampleSink for LogWriter {
    fn write(&mut self, batch: SampleBatch) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
        let sent = self.tx.as_ref().map(|tx| tx.send(batch).is_ok()).unwrap_or(false);
        if sent {
            Ok(())
        } else {
            Err(Box::new(self.thread_error()))
        }
    }
    fn recycle(&mut self) -> Option<SampleBatch> {
        self.spent.try_recv().ok()
    }
}

impl Drop for LogWriter {
    /// An unfinished log is removed, never left looking complete.
    fn drop(&mut self) {
        if self.thread.is_some() {
            drop(self.tx.take());
            if let Some(t) = self.thread.take() {
                let _ = t.join();
            }
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

// ---------------------------------------------------------------------------------------
// Reading.

/// The self-description of a log.
#[derive(Debug, Clone)]
pub struct LogInfo {
    pub path: PathBuf,
    pub scenario: Scenario,
    /// True parameters by name, in the writer's order.
    pub truth: Vec<(String, f64)>,
    pub run: BTreeMap<String, String>,
    pub columns: Vec<String>,
    pub channel_metadata: BTreeMap<String, String>,
    pub library: String,
}

impl LogInfo {
    /// Samples the run was to write (trajectories × samples per trajectory).
    pub fn expected_samples(&self) -> u64 {
        let s = &self.scenario.simulation;
        (s.trajectories * s.samples_per_trajectory()) as u64
    }
}

/// Stream every record of an MCAP file through `f`, in constant memory. `f` returns
/// `false` to stop early.
fn stream_records(path: &Path, mut f: impl FnMut(Record<'_>) -> Result<bool, LogError>) -> Result<(), LogError> {
    let label = path.display().to_string();
    let mut file = File::open(path).map_err(|source| LogError::Io {
        path: label.clone(),
        source,
    })?;
    let mut reader = LinearReader::new();
    while let Some(event) = reader.next_event() {
        match event {
            Ok(LinearReadEvent::ReadRequest(n)) => {
                let buf = reader.insert(n);
                let read = file.read(buf).map_err(|source| LogError::Io {
                    path: label.clone(),
                    source,
                })?;
                reader.notify_read(read);
            }
            Ok(LinearReadEvent::Record { data, opcode }) => {
                let rec = mcap::parse_record(opcode, data).map_err(|source| LogError::Mcap {
                    path: label.clone(),
                    source,
                })?;
                if !f(rec)? {
                    return Ok(());
                }
            }
            Err(source) => return Err(LogError::Mcap { path: label, source }),
        }
    }
    Ok(())
}

/// Read a log's self-description: scenario, truth, run facts, columns. Reads only up to
/// the first sample.
pub fn read_info(path: &Path) -> Result<LogInfo, LogError> {
    let label = path.display().to_string();
    let mut scenario_src: Option<String> = None;
    let mut truth = Vec::new();
    let mut run = BTreeMap::new();
    let mut channel: Option<(String, BTreeMap<String, String>)> = None;
    let mut library = String::new();
    let res = stream_records(path, |rec| {
        match rec {
            Record::Header(h) => library = h.library,
            Record::Attachment { header, data, .. } if header.name == SCENARIO_ATTACHMENT => {
                scenario_src = Some(String::from_utf8_lossy(&data).into_owned());
            }
            Record::Metadata(m) if m.name == TRUTH_METADATA => {
                truth = m
                    .metadata
                    .into_iter()
                    .map(|(k, v)| (k, v.parse::<f64>().unwrap_or(f64::NAN)))
                    .collect();
            }
            Record::Metadata(m) if m.name == RUN_METADATA => run = m.metadata,
            Record::Channel(c) if c.topic == TOPIC => channel = Some((c.topic, c.metadata)),
            Record::Message { .. } => return Ok(false),
            _ => {}
        }
        Ok(true)
    });
    // A log cut off after its description still describes itself.
    if let Err(e) = res {
        if scenario_src.is_none() || channel.is_none() {
            return Err(e);
        }
    }
    let invalid = |reason: &str| LogError::Invalid {
        path: label.clone(),
        reason: reason.into(),
    };
    let src = scenario_src.ok_or_else(|| invalid("no scenario attachment (`scenario.toml`)"))?;
    let (_, channel_metadata) = channel.ok_or_else(|| invalid("no sample channel (`/fpkbench/samples`)"))?;
    let name = run.get("scenario").cloned().unwrap_or_else(|| "scenario".into());
    let mut scenario =
        Scenario::parse(&src, &format!("{label}#scenario.toml"), &name).map_err(|source| LogError::Scenario {
            path: label.clone(),
            source,
        })?;
    apply_run_facts(&mut scenario, &run).map_err(|reason| LogError::Invalid {
        path: label.clone(),
        reason,
    })?;
    let columns: Vec<String> = channel_metadata
        .get("columns")
        .map(|c| c.split(',').map(str::to_string).collect())
        .ok_or_else(|| invalid("channel metadata has no `columns`"))?;
    // Truth is keyed by name; keep the scenario's order.
    let order: Vec<String> = scenario.truth().into_iter().map(|t| t.0).collect();
    truth.sort_by_key(|(k, _)| order.iter().position(|o| o == k).unwrap_or(usize::MAX));
    Ok(LogInfo {
        path: path.to_path_buf(),
        scenario,
        truth,
        run,
        columns,
        channel_metadata,
        library,
    })
}

/// The run facts describe what was simulated; they override the attached scenario's
/// `[simulation]` (a run may have been made with settings changed from the file's).
fn apply_run_facts(s: &mut Scenario, run: &BTreeMap<String, String>) -> Result<(), String> {
    fn get<T: std::str::FromStr>(run: &BTreeMap<String, String>, key: &str) -> Result<Option<T>, String> {
        run.get(key)
            .map(|v| {
                v.parse::<T>()
                    .map_err(|_| format!("run fact {key} = {v:?} is not a valid value"))
            })
            .transpose()
    }
    let sim = &mut s.simulation;
    if let Some(v) = get(run, "seed")? {
        sim.seed = v;
    }
    if let Some(v) = get(run, "dt_s")? {
        sim.dt = v;
    }
    if let Some(v) = get(run, "substeps")? {
        sim.substeps = v;
    }
    if let Some(v) = get(run, "sample_interval_s")? {
        sim.sample_interval = v;
    }
    if let Some(v) = get(run, "record_length_s")? {
        sim.record_length = v;
    }
    if let Some(v) = get(run, "burn_in_s")? {
        sim.burn_in = v;
    }
    if let Some(v) = get(run, "trajectories")? {
        sim.trajectories = v;
    }
    match run.get("scheme").map(String::as_str) {
        Some("semi-implicit") => sim.scheme = crate::scenario::Scheme::SemiImplicit,
        Some("euler-maruyama") => sim.scheme = crate::scenario::Scheme::EulerMaruyama,
        Some(other) => return Err(format!("run fact scheme = {other:?} is not a known scheme")),
        None => {}
    }
    // After the simulation facts: the level is relative to the measured force at the run's
    // sample interval.
    if let Some(level) = get::<f64>(run, "disturbance_level")? {
        if !(level.is_finite() && level >= 0.0) {
            return Err(format!("run fact disturbance_level = {level} is not a level >= 0"));
        }
        *s = s.with_disturbance_level(level);
    }
    Ok(())
}

/// Stream every sample to `f(trajectory, t, values)` in file order, in constant memory.
/// Returns the number of samples. A truncated file gives [`LogError::Truncated`] after
/// delivering every sample that could be read.
pub fn read_samples(info: &LogInfo, mut f: impl FnMut(u32, f64, &[f64])) -> Result<u64, LogError> {
    let label = info.path.display().to_string();
    let cols = info.columns.len();
    let trajectories = info.scenario.simulation.trajectories;
    let size = message_len(cols, trajectories);
    let stride = 8 + 8 * trajectories;
    let mut values = vec![0.0; cols];
    let mut count = 0u64;
    let mut bad: Option<String> = None;
    let res = stream_records(&info.path, |rec| {
        if let Record::Message { data, .. } = rec {
            let instant = count / trajectories.max(1) as u64;
            if data.len() != size || data[..4] != CDR_HEADER {
                bad = Some(format!(
                    "instant {instant} has {} bytes, expected {size} (CDR little-endian, {cols} arrays of \
                     {trajectories} trajectories)",
                    data.len()
                ));
                return Ok(false);
            }
            let f64_at = |at: usize| f64::from_le_bytes(data[at..at + 8].try_into().unwrap());
            if let Some(c) = (0..cols).find(|c| {
                let at = 12 + c * stride;
                u32::from_le_bytes(data[at..at + 4].try_into().unwrap()) as usize != trajectories
            }) {
                bad = Some(format!(
                    "instant {instant}: array {} does not hold {trajectories} values",
                    info.columns[c]
                ));
                return Ok(false);
            }
            let t = f64_at(4);
            for j in 0..trajectories {
                for (c, v) in values.iter_mut().enumerate() {
                    *v = f64_at(20 + c * stride + 8 * j);
                }
                f(j as u32, t, &values);
            }
            count += trajectories as u64;
        }
        Ok(true)
    });
    if let Some(reason) = bad {
        return Err(LogError::Invalid { path: label, reason });
    }
    let expected = info.expected_samples();
    match res {
        Ok(()) if count == expected => Ok(count),
        Ok(()) => Err(LogError::Truncated {
            path: label,
            reason: "it holds fewer samples than its run facts promise".to_string(),
            readable: count,
            expected,
        }),
        Err(LogError::Mcap { source, .. }) => Err(LogError::Truncated {
            path: label,
            reason: format!("{source}"),
            readable: count,
            expected,
        }),
        Err(e) => Err(e),
    }
}

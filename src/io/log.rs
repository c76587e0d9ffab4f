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
//! bounded channel and handing them back for the simulator to refill; it writes to a
//! temporary name ([`Pending`]) and renames only after `finish()`, once the free disk was
//! found to hold the log's [`estimated_size`].

use super::output::{check_free_space, Pending};
use super::reader::{McapFile, ReadError, Record, Scan};
use crate::model::Quantity;
use crate::model::{Characteristic, Model, ParameterName};
use crate::scenario::{Scenario, ScenarioError};
use crate::sim::{SampleBatch, SampleSink};
use mcap::records::{MessageHeader, Metadata};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::ops::ControlFlow;
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
         (of {expected} the run was to write; `--allow-truncated` uses them)"
    )]
    Truncated {
        path: String,
        reason: String,
        readable: u64,
        expected: u64,
    },
    /// Bytes of the file are damaged (a CRC mismatch, an impossible length or value). The
    /// samples before the damage were delivered to the caller and are intact.
    #[error("{path}: the log is damaged: {reason}; the {readable} samples before the damage are intact")]
    Corrupt {
        path: String,
        reason: String,
        readable: u64,
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
    let layout = model.columns();
    for (k, c) in cols.iter().enumerate() {
        let u = layout.at(k).0.unit(s.motion);
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
    file: Option<Pending>,
    dest: PathBuf,
}

/// Bytes a log of `s` will take: every instant's message with its record, index and
/// chunk overhead, plus the description (the estimate checked against the free disk).
pub fn estimated_size(s: &Scenario, model: &Model) -> u64 {
    let sim = &s.simulation;
    let per_message = message_len(model.column_names().len(), sim.trajectories) as u64 + 9 + 22 + 16;
    (sim.samples_per_trajectory() as u64).saturating_mul(per_message) + s.source.len() as u64 + 65536
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
        let pending = Pending::new(dest).map_err(io)?;
        let dir = dest
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        check_free_space(dir, estimated_size(s, model), "the log").map_err(io)?;
        let file = File::create(pending.path()).map_err(io)?;
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
            file: Some(pending),
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
        let pending = self.file.take().expect("finish once");
        pending.commit().map_err(|source| LogError::Io {
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
        }
        // An uncommitted `Pending` removes its temporary file.
        drop(self.file.take());
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
    /// Use the readable samples of a truncated log instead of refusing it
    /// (`--allow-truncated`); see [`read_samples`].
    pub accept_truncated: bool,
}

impl LogInfo {
    /// Samples the run was to write (trajectories × samples per trajectory).
    pub fn expected_samples(&self) -> u64 {
        let s = &self.scenario.simulation;
        (s.trajectories as u64).saturating_mul(s.samples_per_trajectory() as u64)
    }

    /// The description of a run that is not written anywhere (its samples come from the
    /// simulation: `pipeline::Input::simulation`).
    pub fn of_simulation(scenario: Scenario) -> LogInfo {
        let m = crate::model::Model::new(&scenario);
        LogInfo {
            path: PathBuf::from(format!("<{} simulated in memory>", scenario.name)),
            truth: scenario.truth(),
            run: BTreeMap::new(),
            columns: m.column_names(),
            channel_metadata: BTreeMap::new(),
            library: String::new(),
            accept_truncated: false,
            scenario,
        }
    }

    /// The description of measured data on a model file: the model's `[simulation]` taken
    /// from the data (records as trajectories, their sample interval and longest length;
    /// steps of a tenth of the interval for the validation's re-simulation) and its truth
    /// only where the model gives values.
    pub fn of_measured(mut model: Scenario, data: &super::table::Measured) -> LogInfo {
        let sim = &mut model.simulation;
        sim.sample_interval = data.sample_interval;
        sim.dt = data.sample_interval / data.steps_per_sample() as f64;
        // The validation's re-simulation: `ω·dt` = 0.01 (`STEP_OMEGA`), a step chosen for
        // the semi-implicit scheme's first-order bias, whatever the default scheme.
        sim.scheme = crate::scenario::Scheme::SemiImplicit;
        sim.record_length = data.record_length();
        sim.trajectories = data.lengths.len();
        sim.burn_in = 0.0;
        let m = crate::model::Model::new(&model);
        // The coefficients to identify that the model gives no value for have no truth.
        let mut truth: Vec<(String, f64)> = model.truth();
        for il in &model.identify.links {
            let link = &model.links[il.link];
            for (terms, values, kind) in [
                (&il.stiffness, &link.stiffness, Characteristic::Stiffness),
                (&il.damping, &link.damping, Characteristic::Damping),
            ] {
                if values.is_empty() {
                    for &term in terms.iter().flatten() {
                        let name = ParameterName::Coefficient {
                            kind,
                            term,
                            link: link.name.clone(),
                        };
                        truth.push((name.to_string(), f64::NAN));
                    }
                }
            }
        }
        LogInfo {
            path: data.files.first().cloned().unwrap_or_default(),
            truth,
            run: BTreeMap::new(),
            columns: m.column_names(),
            channel_metadata: BTreeMap::new(),
            library: String::new(),
            accept_truncated: false,
            scenario: model,
        }
    }
}

fn open(path: &Path) -> Result<McapFile, LogError> {
    McapFile::open(path).map_err(|e| LogError::Io {
        path: path.display().to_string(),
        source: std::io::Error::other(e.to_string()),
    })
}

/// What the description records of a log hold, gathered wherever they are.
#[derive(Default)]
struct Description {
    scenario: Option<String>,
    truth: Option<BTreeMap<String, String>>,
    run: Option<BTreeMap<String, String>>,
    channel: Option<BTreeMap<String, String>>,
    library: String,
}

impl Description {
    fn take(&mut self, rec: Record<'_>) {
        match rec {
            Record::Header { library, .. } => self.library = library,
            Record::Attachment { name, data, .. } if name == SCENARIO_ATTACHMENT && self.scenario.is_none() => {
                self.scenario = Some(String::from_utf8_lossy(data).into_owned());
            }
            Record::Metadata { name, metadata } if name == TRUTH_METADATA => self.truth = Some(metadata),
            Record::Metadata { name, metadata } if name == RUN_METADATA => self.run = Some(metadata),
            Record::Channel { topic, metadata, .. } if topic == TOPIC && self.channel.is_none() => {
                self.channel = Some(metadata)
            }
            _ => {}
        }
    }
    fn complete(&self) -> bool {
        self.scenario.is_some() && self.truth.is_some() && self.run.is_some() && self.channel.is_some()
    }
}

/// Read a log's self-description: scenario, truth, run facts, columns.
///
/// The records are found wherever the writer put them: fpkbench puts them before the first
/// sample (so a truncated log still describes itself) and the reader stops there; other
/// writers may put them after the messages, where the summary's indexes point at them or,
/// without a summary, a scan to the end finds them.
pub fn read_info(path: &Path) -> Result<LogInfo, LogError> {
    let label = path.display().to_string();
    let invalid = |reason: String| LogError::Invalid {
        path: label.clone(),
        reason,
    };
    let mut file = open(path)?;
    // The summary's view, if the file has a sound one (a damaged summary is not fatal:
    // the linear scan below reads the same records and says what is wrong if it must).
    let mut indexed = Description::default();
    if let Ok(Some(summary)) = file.summary() {
        for (id_at, len) in summary.attachments().chain(summary.metadata()).collect::<Vec<_>>() {
            let _ = file.indexed_record(id_at, len, |rec| indexed.take(rec));
        }
        for (_, topic, _, metadata) in summary.channels {
            if topic == TOPIC && indexed.channel.is_none() {
                indexed.channel = Some(metadata);
            }
        }
    }
    let mut found = Description::default();
    let mut seen_message = false;
    let res = Scan::new(file).run(|rec, _| {
        if matches!(rec, Record::Message { .. }) {
            seen_message = true;
        }
        found.take(rec);
        if found.complete() || (seen_message && fill(&mut found, &indexed)) {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    fill(&mut found, &indexed);
    if let Err(e) = res {
        // A log cut off or damaged after its description still describes itself.
        if !found.complete() {
            return Err(match e {
                ReadError::Io(m) => LogError::Io {
                    path: label.clone(),
                    source: std::io::Error::other(m),
                },
                ReadError::Truncated { .. } => invalid(format!(
                    "{e}, before the log's description (scenario, truth, run facts, sample channel) \
                     was complete: nothing can be read"
                )),
                ReadError::Corrupt { .. } => invalid(format!(
                    "{e}; the log's description (scenario, truth, run facts, sample channel) is \
                     not readable"
                )),
            });
        }
    }
    let src = found
        .scenario
        .ok_or_else(|| invalid(format!("no scenario attachment (`{SCENARIO_ATTACHMENT}`)")))?;
    let channel_metadata = found
        .channel
        .ok_or_else(|| invalid(format!("no sample channel (`{TOPIC}`)")))?;
    let run = found
        .run
        .ok_or_else(|| invalid(format!("no run facts (metadata `{RUN_METADATA}`)")))?;
    let truth_map = found
        .truth
        .ok_or_else(|| invalid(format!("no truth (metadata `{TRUTH_METADATA}`)")))?;
    let name = run.get("scenario").cloned().unwrap_or_else(|| "scenario".into());
    let mut scenario =
        Scenario::parse(&src, &format!("{label}#scenario.toml"), &name).map_err(|source| LogError::Scenario {
            path: label.clone(),
            source,
        })?;
    apply_run_facts(&mut scenario, &run).map_err(&invalid)?;
    let columns: Vec<String> = channel_metadata
        .get("columns")
        .map(|c| c.split(',').map(str::to_string).collect())
        .ok_or_else(|| invalid("channel metadata has no `columns`".into()))?;
    let expected = model_columns(&scenario);
    if columns != expected {
        return Err(invalid(format!(
            "the channel's columns ({}) are not those of its scenario ({})",
            columns.join(","),
            expected.join(",")
        )));
    }
    let mut truth = Vec::new();
    for (k, v) in truth_map {
        let x = v
            .parse::<f64>()
            .map_err(|_| invalid(format!("truth {k} = {v:?} is not a number")))?;
        truth.push((k, x));
    }
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
        library: found.library,
        accept_truncated: false,
    })
}

/// Complete `found` from the summary's records; whether it is then complete.
fn fill(found: &mut Description, indexed: &Description) -> bool {
    macro_rules! or {
        ($f:ident) => {
            if found.$f.is_none() {
                found.$f = indexed.$f.clone();
            }
        };
    }
    or!(scenario);
    or!(truth);
    or!(run);
    or!(channel);
    found.complete()
}

/// The sample columns a log of scenario `s` has (its model's).
fn model_columns(s: &Scenario) -> Vec<String> {
    Model::new(s).column_names()
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
        Some("heun") => sim.scheme = crate::scenario::Scheme::Heun,
        Some(other) => return Err(format!("run fact scheme = {other:?} is not a known scheme")),
        None => {}
    }
    sim.check()
        .map_err(|e| format!("the run facts give an invalid [simulation]: {e}"))?;
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
/// Returns the number of samples.
///
/// Only messages on [`TOPIC`] are read (a log may carry other topics too). Every value is
/// checked finite. A chunk is checked against its CRC before any of its samples is
/// delivered, so a damaged chunk gives [`LogError::Corrupt`] with the count of samples
/// before it, all intact. A file that ends early gives [`LogError::Truncated`] after
/// delivering every sample that could be read — or, when the caller asked for it with
/// [`LogInfo::accept_truncated`], the count of those samples.
pub fn read_samples(info: &LogInfo, f: impl FnMut(u32, f64, &[f64])) -> Result<u64, LogError> {
    let all: Vec<usize> = (0..info.columns.len()).collect();
    read_columns(info, &all, f)
}

/// [`read_samples`] of some columns: `values` holds the log's columns `columns` (indices
/// into [`LogInfo::columns`]), in that order; the others are not decoded.
pub fn read_columns(info: &LogInfo, columns: &[usize], mut f: impl FnMut(u32, f64, &[f64])) -> Result<u64, LogError> {
    let label = info.path.display().to_string();
    let cols = info.columns.len();
    let trajectories = info.scenario.simulation.trajectories;
    let size = message_len(cols, trajectories);
    let stride = 8 + 8 * trajectories;
    let mut values = vec![0.0; columns.len()];
    let mut instant = 0u64;
    let mut ours: Vec<u16> = Vec::new();
    let mut bad: Option<String> = None;
    let mut scan = Scan::new(open(&info.path)?);
    let res = scan.run(|rec, offset| {
        match rec {
            Record::Channel { id, topic, .. } if topic == TOPIC => ours.push(id),
            Record::Message { channel_id, data, .. } if ours.contains(&channel_id) => {
                // A stop requested: the caller (`pipeline::Input`) reports it.
                if crate::interrupt::requested() {
                    return ControlFlow::Break(());
                }
                match check_message(data, info, size, stride) {
                    Ok(()) => {}
                    Err(e) => {
                        bad = Some(format!("message at byte {offset} (instant {instant}): {e}"));
                        return ControlFlow::Break(());
                    }
                }
                let f64_at = |at: usize| f64::from_le_bytes(data[at..at + 8].try_into().unwrap());
                let t = f64_at(4);
                for j in 0..trajectories {
                    for (v, &c) in values.iter_mut().zip(columns) {
                        *v = f64_at(20 + c * stride + 8 * j);
                    }
                    f(j as u32, t, &values);
                }
                instant += 1;
            }
            _ => {}
        }
        ControlFlow::Continue(())
    });
    let count = instant * trajectories as u64;
    let expected = info.expected_samples();
    if let Some(reason) = bad {
        return Err(LogError::Corrupt {
            path: label,
            reason,
            readable: count,
        });
    }
    let truncated = |reason: String| {
        if info.accept_truncated {
            Ok(count)
        } else {
            Err(LogError::Truncated {
                path: label.clone(),
                reason,
                readable: count,
                expected,
            })
        }
    };
    match res {
        Ok(()) if count == expected => Ok(count),
        Ok(()) if count > expected => Err(LogError::Invalid {
            path: label,
            reason: format!("it holds {count} samples, more than the {expected} its run facts promise"),
        }),
        Ok(()) => truncated("it holds fewer samples than its run facts promise".into()),
        Err(e @ ReadError::Truncated { .. }) => truncated(e.to_string()),
        Err(ReadError::Io(m)) => Err(LogError::Io {
            path: label,
            source: std::io::Error::other(m),
        }),
        Err(e @ ReadError::Corrupt { .. }) => Err(LogError::Corrupt {
            path: label,
            reason: e.to_string(),
            readable: count,
        }),
    }
}

/// Whether one instant's message has the log's layout and finite values; what is wrong if not.
fn check_message(data: &[u8], info: &LogInfo, size: usize, stride: usize) -> Result<(), String> {
    let trajectories = info.scenario.simulation.trajectories;
    if data.len() != size {
        return Err(format!(
            "{} bytes where {size} were expected ({} arrays of {trajectories} trajectories)",
            data.len(),
            info.columns.len()
        ));
    }
    if data[..4] != CDR_HEADER {
        return Err(format!(
            "encapsulation header {:02x?} is not CDR little-endian {CDR_HEADER:02x?}",
            &data[..4]
        ));
    }
    let f64_at = |at: usize| f64::from_le_bytes(data[at..at + 8].try_into().unwrap());
    let t = f64_at(4);
    if !t.is_finite() {
        return Err(format!("time t = {t}"));
    }
    for (c, name) in info.columns.iter().enumerate() {
        let at = 12 + c * stride;
        let n = u32::from_le_bytes(data[at..at + 4].try_into().unwrap()) as usize;
        if n != trajectories {
            return Err(format!(
                "array {name} holds {n} values, not one per trajectory ({trajectories})"
            ));
        }
        for j in 0..trajectories {
            let v = f64_at(at + 8 + 8 * j);
            if !v.is_finite() {
                return Err(format!(
                    "{name} = {v} at t = {t} s, trajectory {j}, channel {TOPIC} (every value must be finite)"
                ));
            }
        }
    }
    Ok(())
}

//! Measured data as tables: CSV (a header row of column names), `.npy` (fpkbench's own
//! export, a structured array, or a plain 2-D float array whose column names the model
//! file gives), mapped by a model file's `[data]` section onto the model's quantities and
//! split into records (independent trajectories). Every error names the file, and where
//! it applies the row and the column.
//!
//! A CSV file is a [`Source`] read again on every pass (`super::measured`), in bounded
//! memory whatever its size; `.npy` files, MCAP topics and tables handed over from Python
//! are held in memory (8 bytes per value).

pub use super::delimited::{CsvFile, CsvOptions, Labels, RowFn};
pub use super::measured::differentiate;
pub use super::measured::{
    measured, measured_with, DifferencedNoise, IntegratedNoise, Measured, DERIVE_LIMIT, GAP, OUTLIER, STEP_OMEGA,
};
use crate::scenario::DataMapping;
use std::path::{Path, PathBuf};
use std::sync::{mpsc, Arc};

/// Rows a file is decoded ahead of the pass that reads them, per block
/// ([`Source::for_each_row_ahead`]): 8192 rows of a few columns stay within the cache.
const AHEAD_ROWS: usize = 8192;

/// An error in measured data: the file, and where the message names them, the column and
/// the row (1-based, counting the table's rows, not the file's lines) it is about, for a
/// program to point at them (the Python package's `DataError.column`).
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct DataError {
    pub path: String,
    pub message: String,
    pub column: Option<String>,
    pub row: Option<usize>,
}

pub(super) fn err(path: &Path, message: impl Into<String>) -> DataError {
    DataError {
        path: path.display().to_string(),
        message: message.into(),
        column: None,
        row: None,
    }
}

impl DataError {
    /// The error is about `column`.
    pub(super) fn in_column(mut self, column: &str) -> DataError {
        self.column = Some(column.to_string());
        self
    }

    /// The error is about the table's `row` (1-based).
    pub(super) fn at_row(mut self, row: usize) -> DataError {
        self.row = Some(row);
        self
    }
}

/// A table: named columns of numbers.
#[derive(Debug, Clone)]
pub struct Table {
    pub path: PathBuf,
    pub names: Vec<String>,
    pub columns: Vec<Vec<f64>>,
    /// Where the record column held text: the ids in order, the column holding each row's
    /// index into them.
    pub record_labels: Option<Vec<String>>,
}

impl Table {
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, Vec::len)
    }
}

/// Where measured rows come from: a table in memory, a CSV file read on every pass, or
/// some columns of an fpkbench log read on every pass.
#[derive(Debug, Clone)]
pub enum Source {
    Memory(Table),
    Csv(CsvFile),
    Log(Arc<LogColumns>),
}

/// Some columns of an fpkbench log as a table, read from the file on every pass (a
/// simulated rig's sensor channels: docs/measurement.md, "A rig's sensors"): the columns
/// `trajectory` and `t`, then the log's columns `columns` (indices into its layout), under
/// `names`.
#[derive(Debug)]
pub struct LogColumns {
    pub info: super::log::LogInfo,
    pub columns: Vec<usize>,
    pub names: Vec<String>,
}

impl LogColumns {
    /// One pass: `f(row, values)` for each sample in the log's order, `values` the
    /// `wanted` columns of this table; `f` returns whether to go on (the rest of the file is
    /// then read without calling it).
    fn for_each_row(&self, wanted: &[usize], f: &mut RowFn) -> Result<(), DataError> {
        let mut values = vec![0.0; wanted.len()];
        let (mut row, mut stop) = (0, None);
        // Only the log's columns wanted are decoded; `r` holds them in `logged`'s order.
        let logged: Vec<usize> = wanted
            .iter()
            .filter(|&&k| k >= 2)
            .map(|&k| self.columns[k - 2])
            .collect();
        super::log::read_columns(&self.info, &logged, |trajectory, t, r| {
            if stop.is_some() {
                return;
            }
            let mut r = r.iter();
            for (v, &k) in values.iter_mut().zip(wanted) {
                *v = match k {
                    0 => trajectory as f64,
                    1 => t,
                    _ => *r.next().expect("a wanted column"),
                };
            }
            match f(row, &values) {
                Ok(true) => row += 1,
                Ok(false) => stop = Some(Ok(())),
                Err(e) => stop = Some(Err(e)),
            }
        })
        .map_err(|e| err(&self.info.path, e.to_string()))?;
        stop.unwrap_or(Ok(()))
    }
}

impl From<Table> for Source {
    fn from(t: Table) -> Source {
        Source::Memory(t)
    }
}

impl Source {
    pub fn path(&self) -> &Path {
        match self {
            Source::Memory(t) => &t.path,
            Source::Csv(c) => &c.path,
            Source::Log(l) => &l.info.path,
        }
    }

    pub fn names(&self) -> &[String] {
        match self {
            Source::Memory(t) => &t.names,
            Source::Csv(c) => &c.names,
            Source::Log(l) => &l.names,
        }
    }

    /// Read the rows once: `f(row, values)` for each (`row` from 0), `values` the `wanted`
    /// columns' numbers, a text record id as its number in `labels`; `f` returns whether to
    /// go on.
    pub fn for_each_row(&self, wanted: &[usize], labels: &mut Labels, f: &mut RowFn) -> Result<(), DataError> {
        match self {
            Source::Csv(c) => c.for_each_row(wanted, labels, f),
            Source::Log(l) => l.for_each_row(wanted, f),
            Source::Memory(t) => {
                if let Some(l) = &t.record_labels {
                    labels.names.clone_from(l);
                }
                let mut values = vec![0.0; wanted.len()];
                for r in 0..t.rows() {
                    for (v, &k) in values.iter_mut().zip(wanted) {
                        *v = t.columns[k][r];
                    }
                    if !f(r, &values)? {
                        break;
                    }
                }
                Ok(())
            }
        }
    }

    /// [`Source::for_each_row`] with a file decoded on a thread of its own, [`AHEAD_ROWS`]
    /// rows at a time, while `f` works on the rows before on the calling thread: parsing a
    /// CSV file or decoding a log overlaps the checks, the integration and the sums of the
    /// passes that look at measured data before the identification's own (whose pass driver
    /// has a read-ahead of its own: `pipeline::pass`; a third thread there only competes
    /// with the accumulators for two cores). `f` sees the same rows in the same order, and an
    /// error of the file comes after every row before it, as when read in turn.
    pub(crate) fn for_each_row_ahead(
        &self,
        wanted: &[usize],
        labels: &mut Labels,
        f: &mut RowFn,
    ) -> Result<(), DataError> {
        if matches!(self, Source::Memory(_)) || wanted.is_empty() {
            return self.for_each_row(wanted, labels, f);
        }
        // Blocks in flight: one being decoded, one waiting, one being read by `f`.
        const IN_FLIGHT: usize = 3;
        let width = wanted.len();
        let (full_tx, full_rx) = mpsc::sync_channel::<Result<Vec<f64>, DataError>>(IN_FLIGHT);
        let (empty_tx, empty_rx) = mpsc::channel::<Vec<f64>>();
        for _ in 0..IN_FLIGHT {
            empty_tx
                .send(Vec::with_capacity(AHEAD_ROWS * width))
                .expect("the receiver is here");
        }
        std::thread::scope(|scope| {
            scope.spawn(move || {
                let mut block = empty_rx.recv().expect("a block to start with");
                // A failed send: `f` stopped the pass (or panicked), so the decoding stops.
                let mut gone = false;
                let read = self.for_each_row(wanted, labels, &mut |_, v| {
                    block.extend_from_slice(v);
                    if block.len() == AHEAD_ROWS * width {
                        let next = empty_rx.recv().unwrap_or_default();
                        gone = full_tx.send(Ok(std::mem::replace(&mut block, next))).is_err();
                    }
                    Ok(!gone)
                });
                if !gone && !block.is_empty() {
                    gone = full_tx.send(Ok(block)).is_err();
                }
                if let (false, Err(e)) = (gone, read) {
                    let _ = full_tx.send(Err(e));
                }
            });
            // Owned here, so that returning early drops them: the decoding thread then
            // sees its sends fail and stops, and the scope can end.
            let (full_rx, empty_tx) = (full_rx, empty_tx);
            let mut row = 0;
            for block in full_rx.iter() {
                let mut block = block?;
                for v in block.chunks_exact(width) {
                    if !f(row, v)? {
                        return Ok(());
                    }
                    row += 1;
                }
                block.clear();
                let _ = empty_tx.send(block);
            }
            Ok(())
        })
    }

    /// The index of the column named `name`, or an error listing the columns there are.
    pub fn column(&self, name: &str, role: &str) -> Result<usize, DataError> {
        let names = self.names();
        match names.iter().position(|n| n == name) {
            Some(k) => Ok(k),
            None => {
                let close: Vec<&String> = names
                    .iter()
                    .filter(|n| n.eq_ignore_ascii_case(name) || n.contains(name) || name.contains(n.as_str()))
                    .collect();
                Err(err(
                    self.path(),
                    format!(
                        "no column {name:?} ({role}); the table has {}{}",
                        names.join(", "),
                        if close.is_empty() {
                            String::new()
                        } else {
                            format!(
                                " — did you mean {}?",
                                close.iter().map(|c| format!("{c:?}")).collect::<Vec<_>>().join(" or ")
                            )
                        }
                    ),
                )
                .in_column(name))
            }
        }
    }
}

/// The table `path` holds, as the model's `[data]` section `d` says to read it: CSV (its
/// header now, its rows on every pass), npy, or — for `.mcap` — the messages of its
/// `topic` (JSON, ROS 2 CDR or protobuf).
pub fn read_for(path: &Path, d: &DataMapping) -> Result<Source, DataError> {
    if path.extension().and_then(|e| e.to_str()) == Some("mcap") {
        let Some(topic) = &d.topic else {
            return Err(err(path, "an MCAP file needs the topic to read: [data] topic = \"/…\""));
        };
        let mut fields: Vec<String> = d.columns.iter().map(|c| c.1.clone()).collect();
        fields.extend(d.time.iter().chain(&d.record).cloned());
        fields.dedup();
        return read_mcap_topic(path, topic, &fields).map(Source::Memory);
    }
    if path.extension().and_then(|e| e.to_str()) == Some("npy") {
        return read_table(path, &d.npy_columns).map(Source::Memory);
    }
    CsvFile::open(path, &CsvOptions::of(d)).map(Source::Csv)
}

/// The messages of `topic` in an MCAP file written by any tool (JSON, ROS 2 CDR or
/// protobuf; [`super::decode`]): per message its `log_time` (s) and the numeric fields named
/// in `fields` (a dotted path reaches into nested records and lists: `pose.angle`,
/// `position.0`).
pub fn read_mcap_topic(path: &Path, topic: &str, fields: &[String]) -> Result<Table, DataError> {
    use super::decode::Decoder;
    use super::reader::{McapFile, Record, Scan};
    use std::ops::ControlFlow;
    let file = McapFile::open(path).map_err(|e| err(path, e.to_string()))?;
    let mut schemas: Vec<(u16, String, String, Vec<u8>)> = Vec::new();
    // Per channel: id, topic, and its decoder (or why there is none).
    let mut channels: Vec<(u16, String, Result<Decoder, String>)> = Vec::new();
    let wanted: Vec<String> = fields.iter().filter(|f| f.as_str() != "log_time").cloned().collect();
    let mut names = vec!["log_time".to_string()];
    names.extend(wanted.iter().cloned());
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    let mut failure: Option<String> = None;
    let mut count = 0usize;
    Scan::new(file)
        .run(|rec, offset| {
            match rec {
                Record::Schema {
                    id,
                    name,
                    encoding,
                    data,
                } => schemas.push((id, name, encoding, data.to_vec())),
                Record::Channel {
                    id,
                    schema_id,
                    topic: t,
                    message_encoding,
                    ..
                } => {
                    let schema = schemas
                        .iter()
                        .rev()
                        .find(|s| s.0 == schema_id && schema_id != 0)
                        .map(|s| (s.1.as_str(), s.2.as_str(), s.3.as_slice()));
                    let decoder = if t == topic {
                        Decoder::new(&message_encoding, schema)
                    } else {
                        Err(String::new())
                    };
                    channels.push((id, t, decoder));
                }
                Record::Message {
                    channel_id,
                    log_time,
                    data,
                } => {
                    let Some((_, _, decoder)) = channels.iter().find(|c| c.0 == channel_id && c.1 == topic) else {
                        return ControlFlow::Continue(());
                    };
                    count += 1;
                    let decoder = match decoder {
                        Ok(d) => d,
                        Err(why) => {
                            failure = Some(format!("topic {topic:?}: {why}"));
                            return ControlFlow::Break(());
                        }
                    };
                    let v = match decoder.decode(data) {
                        Ok(v) => v,
                        Err(e) => {
                            failure = Some(format!("message {count} (byte {offset}) on {topic:?}: {e}"));
                            return ControlFlow::Break(());
                        }
                    };
                    columns[0].push(log_time as f64 * 1e-9);
                    for (k, f) in wanted.iter().enumerate() {
                        match v.at(f) {
                            Some(x) => columns[k + 1].push(x),
                            None => {
                                let has = v.numeric_paths();
                                failure = Some(format!(
                                    "message {count} (byte {offset}) on {topic:?}: no numeric field {f:?}; its numeric \
                                     fields are {}",
                                    if has.is_empty() { "none".into() } else { has.join(", ") }
                                ));
                                return ControlFlow::Break(());
                            }
                        }
                    }
                }
                _ => {}
            }
            ControlFlow::Continue(())
        })
        .map_err(|e| err(path, e.to_string()))?;
    if let Some(f) = failure {
        return Err(err(path, f));
    }
    if count == 0 {
        // A channel can be written twice (the data section and the summary): each topic once.
        let mut topics: Vec<&str> = Vec::new();
        for c in &channels {
            if !topics.contains(&c.1.as_str()) {
                topics.push(&c.1);
            }
        }
        return Err(err(
            path,
            format!(
                "no messages on topic {topic:?}; the file has {}",
                if topics.is_empty() {
                    "no topics".to_string()
                } else {
                    topics.join(", ")
                }
            ),
        ));
    }
    Ok(Table {
        path: path.to_path_buf(),
        names,
        columns,
        record_labels: None,
    })
}

/// Read a CSV (numbers only, delimiter from its header) or `.npy` table (by extension);
/// `npy_columns` names a plain 2-D array's columns.
pub fn read_table(path: &Path, npy_columns: &[String]) -> Result<Table, DataError> {
    read_table_with(path, npy_columns, &CsvOptions::default())
}

/// [`read_table`] with a CSV file read as `csv` says.
pub fn read_table_with(path: &Path, npy_columns: &[String], csv: &CsvOptions) -> Result<Table, DataError> {
    match path.extension().and_then(|e| e.to_str()) {
        Some("npy") => {
            let bytes = std::fs::read(path).map_err(|e| err(path, format!("cannot read: {e}")))?;
            read_npy(path, &bytes, npy_columns)
        }
        _ => CsvFile::open(path, csv)?.read_all(),
    }
}

/// `.npy` version 1–3 with a little-endian float64 (or, in a structured array, uint32)
/// layout in C order.
fn read_npy(path: &Path, b: &[u8], npy_columns: &[String]) -> Result<Table, DataError> {
    if b.len() < 10 || &b[..6] != b"\x93NUMPY" {
        return Err(err(path, "not a .npy file (no \\x93NUMPY magic)"));
    }
    let (len, start) = match b[6] {
        1 => (u16::from_le_bytes([b[8], b[9]]) as usize, 10),
        2 | 3 if b.len() >= 12 => (u32::from_le_bytes([b[8], b[9], b[10], b[11]]) as usize, 12),
        v => return Err(err(path, format!("unsupported .npy version {v}"))),
    };
    let header = b
        .get(start..start + len)
        .and_then(|h| std::str::from_utf8(h).ok())
        .ok_or_else(|| err(path, "truncated or non-text .npy header"))?;
    let body = &b[start + len..];
    if header.contains("'fortran_order': True") {
        return Err(err(
            path,
            "Fortran-order arrays are not supported: save with numpy's default C order",
        ));
    }
    let shape: Vec<usize> = header
        .split("'shape':")
        .nth(1)
        .and_then(|s| s.split(['(', ')']).nth(1))
        .map(|s| s.split(',').filter_map(|x| x.trim().parse().ok()).collect())
        .ok_or_else(|| err(path, "the .npy header has no shape"))?;
    let descr = header
        .split("'descr':")
        .nth(1)
        .ok_or_else(|| err(path, "the .npy header has no descr"))?;
    if descr.trim_start().starts_with('[') {
        // A structured array: fields (name, type).
        let fields: Vec<(String, String)> = descr
            .split(']')
            .next()
            .unwrap_or("")
            .split('(')
            .skip(1)
            .filter_map(|f| {
                let mut parts = f.split('\'').filter(|s| !s.trim().is_empty() && s.trim() != ",");
                Some((parts.next()?.to_string(), parts.next()?.to_string()))
            })
            .collect();
        let widths: Vec<usize> = fields
            .iter()
            .map(|(n, t)| match t.as_str() {
                "<f8" => Ok(8),
                "<u4" | "<i4" | "<f4" => Ok(4),
                _ => Err(err(
                    path,
                    format!("field {n:?} has type {t}: float64, float32 or (u)int32 expected"),
                )),
            })
            .collect::<Result<_, _>>()?;
        let rec: usize = widths.iter().sum();
        let n = *shape.first().unwrap_or(&0);
        if body.len() < n * rec {
            return Err(err(
                path,
                format!(
                    "truncated: {n} records of {rec} bytes need {} bytes, found {}",
                    n * rec,
                    body.len()
                ),
            ));
        }
        let mut columns = vec![Vec::with_capacity(n); fields.len()];
        for r in 0..n {
            let mut at = r * rec;
            for (k, ((_, t), w)) in fields.iter().zip(&widths).enumerate() {
                let x = &body[at..at + w];
                columns[k].push(match t.as_str() {
                    "<f8" => f64::from_le_bytes(x.try_into().expect("8 bytes")),
                    "<f4" => f32::from_le_bytes(x.try_into().expect("4 bytes")) as f64,
                    "<u4" => u32::from_le_bytes(x.try_into().expect("4 bytes")) as f64,
                    _ => i32::from_le_bytes(x.try_into().expect("4 bytes")) as f64,
                });
                at += w;
            }
        }
        return Ok(Table {
            path: path.to_path_buf(),
            names: fields.into_iter().map(|f| f.0).collect(),
            columns,
            record_labels: None,
        });
    }
    if !descr.contains("'<f8'") {
        return Err(err(path, "a plain .npy array must be float64 ('<f8')"));
    }
    let (rows, cols) = match shape.as_slice() {
        [r, c] => (*r, *c),
        _ => {
            return Err(err(
                path,
                format!("a plain .npy array must be 2-D (rows × columns), got shape {shape:?}"),
            ))
        }
    };
    if npy_columns.len() != cols {
        return Err(err(
            path,
            format!(
                "a plain 2-D array has no column names: save a structured array (a dtype of named fields) \
                 or a CSV with a header, or name its {cols} columns in a model file's [data] npy_columns \
                 (got {} names)",
                npy_columns.len()
            ),
        ));
    }
    if body.len() < rows * cols * 8 {
        return Err(err(path, "truncated .npy data"));
    }
    let mut columns = vec![Vec::with_capacity(rows); cols];
    for r in 0..rows {
        for (c, col) in columns.iter_mut().enumerate() {
            let at = (r * cols + c) * 8;
            col.push(f64::from_le_bytes(body[at..at + 8].try_into().expect("8 bytes")));
        }
    }
    Ok(Table {
        path: path.to_path_buf(),
        names: npy_columns.to_vec(),
        columns,
        record_labels: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A CSV file of `rows` rows (text record ids, a time, a value) with a value that is
    /// not a number at row `bad_at`, and the rows it hands over read in turn and read
    /// ahead: `(row, values)` until `stop_at` (`f` returns false there), then the result and
    /// the labels.
    #[allow(clippy::type_complexity)]
    fn both_ways(
        rows: usize,
        bad_at: usize,
        stop_at: usize,
    ) -> [(Vec<(usize, Vec<f64>)>, Result<(), String>, Vec<String>); 2] {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        let mut text = String::from("run,time,x\n");
        for r in 0..rows {
            let x = if r == bad_at {
                "oops".to_string()
            } else {
                format!("{}", (r as f64 * 0.37).sin())
            };
            text += &format!("{},{},{x}\n", ["b", "a", "c"][r % 3], r / 3);
        }
        std::fs::write(&path, text).unwrap();
        let o = CsvOptions {
            record: Some("run"),
            time: Some("time"),
            ..Default::default()
        };
        let source = Source::Csv(CsvFile::open(&path, &o).unwrap());
        [false, true].map(|ahead| {
            let (mut seen, mut labels) = (Vec::new(), Labels::default());
            let mut f = |r: usize, v: &[f64]| {
                seen.push((r, v.to_vec()));
                Ok(r != stop_at)
            };
            let res = match ahead {
                false => source.for_each_row(&[2, 0, 1], &mut labels, &mut f),
                true => source.for_each_row_ahead(&[2, 0, 1], &mut labels, &mut f),
            };
            (seen, res.map_err(|e| e.to_string()), labels.names)
        })
    }

    /// A file read ahead on a thread of its own hands over the same rows in the same order
    /// as read in turn, over several blocks and a part-filled last one: a bad value's error
    /// comes after every row before it, a stop ends the pass at once (the decoding thread
    /// then stops too), and text record ids get the same numbers.
    #[test]
    fn a_file_read_ahead_gives_the_rows_read_in_turn() {
        let n = 2 * AHEAD_ROWS + 1234;
        // Every row; a bad value in the last block; one in the second block; a stop in the
        // second block.
        for (bad_at, stop_at) in [
            (usize::MAX, usize::MAX),
            (n - 5, usize::MAX),
            (AHEAD_ROWS + 7, usize::MAX),
            (n, 9000),
        ] {
            let [turn, ahead] = both_ways(n, bad_at, stop_at);
            assert_eq!(turn, ahead, "bad value at {bad_at}, stop at {stop_at}");
            let handed = turn.0.len();
            match (bad_at < n, stop_at < n) {
                (true, _) => {
                    assert_eq!(handed, bad_at);
                    assert!(turn.1.as_ref().unwrap_err().contains("\"oops\" is not a number"));
                }
                (false, true) => assert_eq!(handed, stop_at + 1),
                (false, false) => assert_eq!(handed, n),
            }
            assert_eq!(turn.2, ["b", "a", "c"]);
        }
    }
}

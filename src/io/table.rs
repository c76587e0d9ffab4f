//! Measured data as tables: CSV (a header row of column names), `.npy` (fpkbench's own
//! export, a structured array, or a plain 2-D float array whose column names the model
//! file gives), mapped by a model file's `[data]` section onto the model's quantities and
//! split into records (independent trajectories). Every error names the file, and where
//! it applies the row and the column.
//!
//! The tables are read into memory (8 bytes per value); the identification over them then
//! runs as over a log (see [`super::log::read_samples`]).

pub use super::delimited::CsvOptions;
use crate::scenario::{DataMapping, Scenario};
use std::path::{Path, PathBuf};

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

    /// The column named `name`, or an error listing the columns there are.
    fn column(&self, name: &str, role: &str) -> Result<&[f64], DataError> {
        match self.names.iter().position(|n| n == name) {
            Some(k) => Ok(&self.columns[k]),
            None => {
                let close: Vec<&String> = self
                    .names
                    .iter()
                    .filter(|n| n.eq_ignore_ascii_case(name) || n.contains(name) || name.contains(n.as_str()))
                    .collect();
                Err(err(
                    &self.path,
                    format!(
                        "no column {name:?} ({role}); the table has {}{}",
                        self.names.join(", "),
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

/// Read the table `path` holds for a model's `[data]`: CSV, npy, or — for `.mcap` — the
/// messages of its `topic` (JSON, ROS 2 CDR or protobuf).
/// The table `path` as the model's `[data]` section `d` says to read it.
pub fn read_for(path: &Path, d: &DataMapping) -> Result<Table, DataError> {
    if path.extension().and_then(|e| e.to_str()) == Some("mcap") {
        let Some(topic) = &d.topic else {
            return Err(err(path, "an MCAP file needs the topic to read: [data] topic = \"/…\""));
        };
        let mut fields: Vec<String> = d.columns.iter().map(|c| c.1.clone()).collect();
        fields.extend(d.time.iter().chain(&d.record).cloned());
        fields.dedup();
        return read_mcap_topic(path, topic, &fields);
    }
    read_table_with(path, &d.npy_columns, &CsvOptions::of(d))
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
    let bytes = std::fs::read(path).map_err(|e| err(path, format!("cannot read: {e}")))?;
    match path.extension().and_then(|e| e.to_str()) {
        Some("npy") => read_npy(path, &bytes, npy_columns),
        _ => super::delimited::read_csv(path, &bytes, csv),
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
                "a plain 2-D array has no column names: give its {cols} columns in the model file's \
                 [data] npy_columns (got {} names)",
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

/// `ω·h` above which differentiating displacements is too coarse (a 0.17 % smoothing of
/// the velocity's amplitude; the weak form's moments amplify it).
pub const DERIVE_LIMIT: f64 = 0.1;

/// Measured data mapped onto a model: per record, its start time and its samples in the
/// log's column layout (`model::Columns`; unmapped columns NaN).
#[derive(Debug, Clone)]
pub struct Measured {
    pub files: Vec<PathBuf>,
    pub width: usize,
    pub sample_interval: f64,
    /// Per record: the sample times from its start and the row-major samples.
    pub records: Vec<(Vec<f64>, Vec<f64>)>,
    /// What the reading did that a user should know (e.g. derived velocities).
    pub notes: Vec<String>,
    /// The highest RMS frequency of the measured motion (rad/s): over the masses, of each
    /// velocity's spectrum (else the displacement's) up to the Nyquist frequency, in the
    /// longest record. A re-simulation of the data's model steps finely enough for it.
    pub motion_frequency: f64,
}

/// `ω·dt` of a re-simulation of measured data at the motion's RMS frequency: the bias of
/// the scheme's stationary variances is then far below the validation's sampling spread
/// (the shipped scenarios step at 0.003–0.015).
pub const STEP_OMEGA: f64 = 0.01;

impl Measured {
    /// Integration steps per sample interval for re-simulating the data's model: `ω·dt ≤`
    /// [`STEP_OMEGA`] at [`Measured::motion_frequency`], and at least 10. (A fixed 10 made
    /// the bushing's validation step at `ω·dt ≈ 0.12`, and its standard deviations differ
    /// from the data's by up to 0.8 % where the log path's differ by 0.2 %.)
    pub fn steps_per_sample(&self) -> usize {
        let wh = self.motion_frequency * self.sample_interval;
        if wh.is_finite() {
            ((wh / STEP_OMEGA).ceil() as usize).clamp(10, 100_000)
        } else {
            10
        }
    }

    pub fn samples(&self) -> u64 {
        self.records.iter().map(|r| r.0.len() as u64).sum()
    }
    /// The longest record (s).
    pub fn record_length(&self) -> f64 {
        self.records
            .iter()
            .map(|r| r.0.len() as f64 * self.sample_interval)
            .fold(0.0, f64::max)
    }
}

/// Map the tables onto `model`'s quantities by its `[data]`: scale, split into records
/// (files, or the record column), check the time base and every value.
pub fn measured(model: &Scenario, tables: &[Table]) -> Result<Measured, DataError> {
    let d: &DataMapping = model.data.as_ref().expect("a model file");
    let m = crate::model::Model::new(model);
    let layout = m.columns();
    let names = m.column_names();
    let width = layout.len();
    let mut records = Vec::new();
    let mut interval: Option<f64> = d.sample_interval;
    let mut notes = Vec::new();
    for t in tables {
        let scale = |c: &str| d.scale.get(c).copied().unwrap_or(1.0);
        let mapped: Vec<(usize, &str, &[f64])> = d
            .columns
            .iter()
            .map(|(q, c)| {
                let k = names.iter().position(|n| n == q).expect("checked by the model file");
                t.column(c, &format!("mapped to {q} in [data.columns]"))
                    .map(|v| (k, c.as_str(), v))
            })
            .collect::<Result<_, _>>()?;
        let time = d
            .time
            .as_ref()
            .map(|c| t.column(c, "the time column, [data] time"))
            .transpose()?;
        let record = d
            .record
            .as_ref()
            .map(|c| t.column(c, "the record column, [data] record"))
            .transpose()?;
        check_values(t, &mapped, d, time, record)?;
        let (ids, rows_of) = records_by_id(t.rows(), record);
        for (rk, all_rows) in rows_of.iter().enumerate() {
            let id = record.is_some().then(|| match &t.record_labels {
                Some(labels) => format!("{:?}", labels[ids[rk] as usize]),
                None => ids[rk].to_string(),
            });
            let pieces = match (time, d.time.as_deref()) {
                (Some(time), Some(c)) => {
                    let p = pieces(t, (c, time), all_rows, id.as_deref(), &mut interval, d.split_gaps)?;
                    if p.len() > 1 {
                        notes.push(split_note(id.as_deref(), time, all_rows, &p));
                    }
                    p
                }
                _ => std::iter::once(0..all_rows.len()).collect(),
            };
            for piece in pieces {
                let rows = &all_rows[piece];
                let first = records.is_empty();
                let h = interval.ok_or_else(|| err(&t.path, "one sample per record and no sample interval"))?;
                let mut samples = vec![f64::NAN; rows.len() * width];
                for (s, &r) in rows.iter().enumerate() {
                    for (k, c, v) in &mapped {
                        samples[s * width + k] = v[r] * scale(c);
                    }
                }
                if d.derive {
                    let present: Vec<usize> = mapped.iter().map(|x| x.0).collect();
                    let derived = derive_missing(&mut samples, width, h, &m, &present);
                    // The notes once, from the first record, each judged on the signal its
                    // column was derived from (itself derived, for an acceleration from a
                    // derived velocity).
                    if first {
                        let n = rows.len();
                        for (fk, dk) in derived {
                            let r = Resolution::of((0..n).map(|s| samples[s * width + fk]), n, h);
                            notes.extend(derive_notes(&names[fk], &names[dk], h, r));
                        }
                    }
                }
                let times = (0..rows.len()).map(|s| (s + 1) as f64 * h).collect();
                records.push((times, samples));
            }
        }
    }
    let sample_interval = interval.ok_or_else(|| err(&tables[0].path, "no sample interval"))?;
    let given: Vec<(usize, String)> = d
        .columns
        .iter()
        .map(|(q, c)| (names.iter().position(|n| n == q).expect("a quantity"), c.clone()))
        .collect();
    let mapped = super::units::Mapped {
        records: &records,
        width,
        h: sample_interval,
        columns: &given,
        names: &names,
    };
    let masses: Vec<_> = (0..m.masses())
        .map(|i| (layout.x(i), layout.v(i), layout.a(i)))
        .collect();
    super::units::check_units(&mapped, &masses).map_err(|(k, e)| {
        let column = given.iter().find(|g| g.0 == k).map_or("?", |g| g.1.as_str());
        err(&tables[0].path, e).in_column(column)
    })?;
    let motion_frequency = motion_frequency(&records, width, sample_interval, &masses);
    Ok(Measured {
        motion_frequency,
        files: tables.iter().map(|t| t.path.clone()).collect(),
        width,
        sample_interval,
        records,
        notes,
    })
}

/// [`Measured::motion_frequency`]: the highest RMS frequency over the masses' velocities
/// (else displacements) that the records hold, NaN if none.
fn motion_frequency(records: &[(Vec<f64>, Vec<f64>)], width: usize, h: f64, masses: &[(usize, usize, usize)]) -> f64 {
    let Some((_, longest)) = records.iter().max_by_key(|r| r.0.len()) else {
        return f64::NAN;
    };
    let n = longest.len() / width;
    // Mapped or derived: unmapped columns are NaN.
    let has = |k: usize| longest.get(k).is_some_and(|v| v.is_finite());
    masses
        .iter()
        .filter_map(|&(x, v, _)| [v, x].into_iter().find(|&k| has(k)))
        .map(|k| Resolution::of((0..n).map(|s| longest[s * width + k]), n, h).wh / h)
        .fold(f64::NAN, f64::max)
}

/// Every value of the mapped, time and record columns finite, and no mapped column constant.
fn check_values(
    t: &Table,
    mapped: &[(usize, &str, &[f64])],
    d: &DataMapping,
    time: Option<&[f64]>,
    record: Option<&[f64]>,
) -> Result<(), DataError> {
    for (_, c, v) in mapped
        .iter()
        .copied()
        .chain(time.map(|v| (0, d.time.as_deref().unwrap_or(""), v)))
        .chain(record.map(|v| (0, d.record.as_deref().unwrap_or(""), v)))
    {
        if let Some(r) = v.iter().position(|x| !x.is_finite()) {
            return Err(err(
                &t.path,
                format!("row {}, column {c:?}: {} (every value must be finite)", r + 1, v[r]),
            )
            .in_column(c)
            .at_row(r + 1));
        }
    }
    for (_, c, v) in mapped {
        if v.len() > 1 && v.iter().all(|x| *x == v[0]) {
            return Err(err(
                &t.path,
                format!("column {c:?} is constant ({}): a measured response varies", v[0]),
            )
            .in_column(c));
        }
        if let Some(o) = Outlier::find(v) {
            return Err(err(
                &t.path,
                format!(
                    "row {}, column {c:?}: {} lies {} interquartile ranges from the column's median ({}; the middle \
                     half within [{}, {}]): a lost decimal point, a logger glitch? {} value(s) lie over {OUTLIER} \
                     interquartile ranges out, which a stationary response does not reach; correct or remove them \
                     (with `split_gaps = true` the rows around a removed one become records of their own)",
                    o.row + 1,
                    v[o.row],
                    if o.distance < 1e4 {
                        format!("{:.0}", o.distance)
                    } else {
                        format!("{:.1e}", o.distance)
                    },
                    sig6(o.median),
                    sig6(o.quartiles[0]),
                    sig6(o.quartiles[1]),
                    o.count
                ),
            )
            .in_column(c)
            .at_row(o.row + 1));
        }
    }
    Ok(())
}

/// How many interquartile ranges from its column's median a value may lie: 40 standard
/// deviations of a normal variable (a chance below 10^-300), far beyond any stationary
/// response's tail, while a lost decimal point or a logger's glitch lands further out.
pub const OUTLIER: f64 = 30.0;

/// The first value of a column over [`OUTLIER`] interquartile ranges from its median.
struct Outlier {
    row: usize,
    distance: f64,
    median: f64,
    quartiles: [f64; 2],
    count: usize,
}

impl Outlier {
    fn find(v: &[f64]) -> Option<Outlier> {
        let mut sorted = v.to_vec();
        let n = sorted.len();
        let mut at = |q: f64| {
            *sorted
                .select_nth_unstable_by(((n - 1) as f64 * q) as usize, f64::total_cmp)
                .1
        };
        let (q1, median, q3) = (at(0.25), at(0.5), at(0.75));
        let iqr = q3 - q1;
        if iqr <= 0.0 {
            return None;
        }
        let distance = |x: f64| (x - median).abs() / iqr;
        let count = v.iter().filter(|&&x| distance(x) > OUTLIER).count();
        let row = v.iter().position(|&x| distance(x) > OUTLIER)?;
        Some(Outlier {
            row,
            distance: distance(v[row]),
            median,
            quartiles: [q1, q3],
            count,
        })
    }
}

/// The rows of each record (all rows one record without a record column), the records in
/// the order of their ids, not of their first rows: the jackknife's groups follow the
/// records, so a logger's interleaved rows and a sorted table give the same estimates.
fn records_by_id(rows: usize, record: Option<&[f64]>) -> (Vec<f64>, Vec<Vec<usize>>) {
    let mut ids: Vec<f64> = Vec::new();
    let mut rows_of: Vec<Vec<usize>> = Vec::new();
    for r in 0..rows {
        let id = record.map_or(0.0, |c| c[r]);
        let k = match ids.iter().position(|&x| x == id) {
            Some(k) => k,
            None => {
                ids.push(id);
                rows_of.push(Vec::new());
                ids.len() - 1
            }
        };
        rows_of[k].push(r);
    }
    let mut order: Vec<usize> = (0..ids.len()).collect();
    order.sort_by(|&a, &b| ids[a].total_cmp(&ids[b]));
    let ids = order.iter().map(|&k| ids[k]).collect();
    let rows_of = order.iter().map(|&k| std::mem::take(&mut rows_of[k])).collect();
    (ids, rows_of)
}

/// A step of at least this many sample intervals is a gap in the record (lost samples, a
/// paused logger), not uneven sampling.
pub const GAP: f64 = 1.5;

/// The pieces of one record's `rows` (ranges of `rows`): the whole record, or with `split`
/// the runs between its time gaps (steps of [`GAP`] sample intervals or more). The times,
/// the `time` column's (name, values), must increase by one even step, `interval` (when
/// not given, the median of the first record's first thousand steps, to nine digits). Refused, naming the
/// record `id`, the row and the time: a time that does not increase, an uneven step, a
/// gap when not splitting.
fn pieces(
    t: &Table,
    (column, time): (&str, &[f64]),
    rows: &[usize],
    id: Option<&str>,
    interval: &mut Option<f64>,
    split: bool,
) -> Result<Vec<std::ops::Range<usize>>, DataError> {
    if interval.is_none() && rows.len() > 1 {
        let mut steps: Vec<f64> = rows.windows(2).take(1000).map(|w| time[w[1]] - time[w[0]]).collect();
        steps.sort_by(f64::total_cmp);
        // To nine significant digits: a difference of two printed times carries their
        // rounding (0.10000000000000142 for 0.1).
        let h = steps[steps.len() / 2];
        let h = format!("{h:.8e}").parse::<f64>().unwrap_or(h);
        if h > 0.0 {
            *interval = Some(h);
        }
    }
    let in_record = id.map_or(String::new(), |id| format!("record {id}, "));
    let mut pieces = Vec::new();
    let mut start = 0;
    for (s, w) in rows.windows(2).enumerate() {
        let dt = time[w[1]] - time[w[0]];
        let at = |what: String| {
            err(
                &t.path,
                format!("{in_record}row {}, t = {} s: {what}", w[1] + 1, time[w[1]]),
            )
            .in_column(column)
            .at_row(w[1] + 1)
        };
        if dt <= 0.0 {
            return Err(at(format!("the time does not increase (previous {} s)", time[w[0]])));
        }
        let h = interval.expect("set from the steps");
        if (dt - h).abs() <= 1e-6 * h {
            continue;
        }
        let (dt, h) = (sig6(dt), sig6(h));
        if dt < GAP * h {
            return Err(at(format!(
                "time step {dt} s where the sampling is every {h} s: the samples must be evenly spaced"
            )));
        }
        if !split {
            return Err(at(format!(
                "a gap of {dt} s where the sampling is every {h} s; set `split_gaps = true` in [data] to make \
                 each piece between gaps a record of its own (or split it with the record column)"
            )));
        }
        pieces.push(start..s + 1);
        start = s + 1;
    }
    pieces.push(start..rows.len());
    Ok(pieces)
}

/// `x` to six significant digits: a time difference's rounding in the last bits is no
/// news to a reader.
fn sig6(x: f64) -> f64 {
    format!("{x:.5e}").parse::<f64>().unwrap_or(x)
}

/// The report's note on a record split at its gaps: each piece by its start time and
/// length.
fn split_note(id: Option<&str>, time: &[f64], rows: &[usize], pieces: &[std::ops::Range<usize>]) -> String {
    let shown: Vec<String> = pieces
        .iter()
        .take(6)
        .enumerate()
        .map(|(k, p)| {
            let (a, b) = (time[rows[p.start]], time[rows[p.end - 1]]);
            format!(
                "piece {} from t = {} s, {} samples ({} s)",
                k + 1,
                sig6(a),
                p.len(),
                sig6(b - a)
            )
        })
        .collect();
    format!(
        "{} split at {} time gap(s) into {} records: {}{}",
        id.map_or("the record".to_string(), |id| format!("record {id}")),
        pieces.len() - 1,
        pieces.len(),
        shown.join("; "),
        if pieces.len() > 6 { "; …" } else { "" }
    )
}

/// Derivatives a record lacks, by central differences (one-sided at the ends): velocities
/// from displacements, then accelerations from velocities. `samples` holds the record's rows
/// of `width` columns, `present` the columns it has. Returns the (from, derived) columns.
fn derive_missing(
    samples: &mut [f64],
    width: usize,
    h: f64,
    m: &crate::model::Model,
    present: &[usize],
) -> Vec<(usize, usize)> {
    let layout = m.columns();
    let n = samples.len() / width;
    let mut present = present.to_vec();
    let mut derived = Vec::new();
    for i in 0..m.masses() {
        for (fk, dk) in [(layout.x(i), layout.v(i)), (layout.v(i), layout.a(i))] {
            if present.contains(&dk) || !present.contains(&fk) {
                continue;
            }
            for s in 0..n {
                let (a, b) = (s.saturating_sub(1), (s + 1).min(n - 1));
                samples[s * width + dk] = (samples[b * width + fk] - samples[a * width + fk]) / ((b - a) as f64 * h);
            }
            present.push(dk);
            derived.push((fk, dk));
        }
    }
    derived
}

/// How well central differences at the sampling `h` resolve a signal, from the signal's own
/// spectrum (Welch, up to the Nyquist frequency): its RMS frequency `ω = √(∫ω²S / ∫S)`
/// (what the derivative's std over the signal's would be), and the share of the
/// derivative's amplitude the differences lose (they pass `sin(ωh)/(ωh)` at each `ω`).
#[derive(Debug, Clone, Copy)]
struct Resolution {
    /// `ω·h`.
    wh: f64,
    /// `1 − std(central difference) / std(derivative)`.
    loss: f64,
}

impl Resolution {
    fn of(signal: impl Iterator<Item = f64>, n: usize, h: f64) -> Resolution {
        let len = (n / 4).next_power_of_two().clamp(16, 4096);
        let mut welch = crate::ident::spectrum::Welch::new(len, h, 1);
        for x in signal {
            welch.push(0, x);
        }
        let sp = welch.spectrum();
        let (mut m0, mut m2, mut kept) = (0.0, 0.0, 0.0);
        for (&w, &s) in sp.omega.iter().zip(&sp.density) {
            let sinc = (w * h).sin() / (w * h);
            m0 += s;
            m2 += w * w * s;
            kept += w * w * s * sinc * sinc;
        }
        Resolution {
            wh: (m2 / m0).sqrt() * h,
            loss: 1.0 - (kept / m2).sqrt(),
        }
    }
}

/// What the report says of a derived column: the rule, and a warning where the sampling is
/// too coarse for it.
fn derive_notes(from: &str, derived: &str, h: f64, r: Resolution) -> Vec<String> {
    let mut notes = vec![format!(
        "{derived} derived from {from} by central differences over 2 × {h} s (docs/data.md)"
    )];
    if r.wh > DERIVE_LIMIT {
        notes.push(format!(
            "WARNING: the sampling is too coarse to differentiate {from}: ω·h = {:.2} (ω the RMS frequency of \
             {from}'s spectrum), so the derived {derived} lacks about {:.0} % of the motion's derivative (central \
             differences pass sin(ωh)/(ωh)) and the estimates are biased (on sdof_duffing at ω·h = 0.33, k3 by \
             −24 %); sample at least {:.0}× faster or measure it",
            r.wh,
            100.0 * r.loss,
            (r.wh / DERIVE_LIMIT).ceil()
        ));
    }
    notes
}

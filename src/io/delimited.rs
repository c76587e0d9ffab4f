//! CSV tables as spreadsheets and loggers write them: quoted fields, a byte-order mark, `#`
//! comments, the delimiter from the header or the model's `[data] delimiter`, a decimal
//! comma, text record ids and ISO 8601 date-times in the time column (docs/data.md,
//! "Formats"). A [`CsvFile`] reads its header once and its rows on every pass, so a table
//! of any size streams in bounded memory; [`CsvFile::read_all`] reads a whole table into memory.

use super::table::{err, DataError, Table};
use crate::scenario::DataMapping;
use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

/// How a CSV file is written and which of its columns may hold text: the record column's
/// ids (records are then ordered by their text) and the time column's ISO 8601 date-times
/// (seconds since the table's first).
#[derive(Debug, Clone, Copy, Default)]
pub struct CsvOptions<'a> {
    /// The field delimiter; `None`: the header's own (`,`, `;` or tab).
    pub delimiter: Option<u8>,
    /// Numbers with a decimal comma.
    pub decimal_comma: bool,
    pub record: Option<&'a str>,
    pub time: Option<&'a str>,
}

impl<'a> CsvOptions<'a> {
    /// The options of a model's `[data]` section.
    pub fn of(d: &'a DataMapping) -> CsvOptions<'a> {
        CsvOptions {
            delimiter: d.delimiter,
            decimal_comma: d.decimal_comma,
            record: d.record.as_deref(),
            time: d.time.as_deref(),
        }
    }
}

/// Text record ids met while reading rows, numbered in the order they first appear (the
/// same numbers on every pass over the same file).
#[derive(Debug, Default)]
pub struct Labels {
    pub names: Vec<String>,
    index: HashMap<String, u32>,
}

impl Labels {
    /// The number of `text`, given it one if it is new.
    fn number(&mut self, text: &str) -> f64 {
        if let Some(&k) = self.index.get(text) {
            return k as f64;
        }
        let k = self.names.len() as u32;
        self.names.push(text.to_string());
        self.index.insert(text.to_string(), k);
        k as f64
    }
}

/// What a pass over a table's rows calls for each row: `(row, values)`, returning whether
/// to go on.
pub type RowFn<'a> = dyn FnMut(usize, &[f64]) -> Result<bool, DataError> + 'a;

/// A CSV file's header, read once; its rows are read on each [`CsvFile::for_each_row`].
#[derive(Debug, Clone)]
pub struct CsvFile {
    pub path: PathBuf,
    pub names: Vec<String>,
    delimiter: u8,
    decimal_comma: bool,
    /// Which text each column may hold instead of numbers.
    roles: Vec<Text>,
}

/// Which text a CSV column may hold instead of numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Text {
    None,
    Record,
    Time,
}

impl CsvFile {
    /// The header of the CSV file `path` (the first line that is not blank or a `#`
    /// comment): the column names, and the delimiter when `o` does not give it.
    pub fn open(path: &Path, o: &CsvOptions) -> Result<CsvFile, DataError> {
        let file = std::fs::File::open(path).map_err(|e| err(path, format!("cannot read: {e}")))?;
        CsvFile::header(path, BufReader::new(file), o)
    }

    /// [`CsvFile::open`] on the start of the file's text.
    fn header(path: &Path, mut start: impl BufRead, o: &CsvOptions) -> Result<CsvFile, DataError> {
        let mut line = Vec::new();
        loop {
            line.clear();
            let n = start
                .read_until(b'\n', &mut line)
                .map_err(|e| err(path, format!("cannot read: {e}")))?;
            if n == 0 {
                return Err(err(path, "empty: a header row of column names is expected"));
            }
            let l = line.strip_prefix(b"\xef\xbb\xbf").unwrap_or(&line);
            if !l.iter().all(u8::is_ascii_whitespace) && !l.starts_with(b"#") {
                break;
            }
        }
        let header = line.strip_prefix(b"\xef\xbb\xbf").unwrap_or(&line);
        if let Err(e) = std::str::from_utf8(header) {
            return Err(err(
                path,
                format!(
                    "header, byte {}: not UTF-8 text (a CSV file is expected; .npy by its extension)",
                    e.valid_up_to() + 1
                ),
            ));
        }
        // The header's own delimiter: the most frequent of `,` `;` tab.
        let delimiter = o.delimiter.unwrap_or_else(|| {
            let count = |d: u8| header.iter().filter(|&&b| b == d).count();
            [b',', b';', b'\t']
                .into_iter()
                .max_by_key(|&d| count(d))
                .filter(|&d| count(d) > 0)
                .unwrap_or(b',')
        });
        let mut reader = builder(delimiter, csv::Trim::All).from_reader(header);
        let names: Vec<String> = reader
            .headers()
            .map_err(|e| err(path, csv_error(&e)))?
            .iter()
            .map(str::to_string)
            .collect();
        for (k, n) in names.iter().enumerate() {
            if n.is_empty() {
                return Err(err(path, format!("line 1, column {}: empty column name", k + 1)));
            }
            if names[..k].contains(n) {
                return Err(err(path, format!("line 1: column name {n:?} given twice")));
            }
        }
        let roles = names
            .iter()
            .map(|n| {
                if Some(n.as_str()) == o.record {
                    Text::Record
                } else if Some(n.as_str()) == o.time {
                    Text::Time
                } else {
                    Text::None
                }
            })
            .collect();
        Ok(CsvFile {
            path: path.to_path_buf(),
            names,
            delimiter,
            decimal_comma: o.decimal_comma,
            roles,
        })
    }

    /// Read the file's rows once: `f(row, values)` for each, `row` counted from 0 over the
    /// table's rows (not the file's lines), `values` the `wanted` columns' numbers — text
    /// record ids as their number in `labels`, date-times as seconds since the first row's.
    /// `f` returns whether to go on. Only the wanted columns are parsed.
    pub fn for_each_row(&self, wanted: &[usize], labels: &mut Labels, f: &mut RowFn) -> Result<(), DataError> {
        let file = std::fs::File::open(&self.path).map_err(|e| err(&self.path, format!("cannot read: {e}")))?;
        self.rows_of(BufReader::with_capacity(1 << 20, file), wanted, labels, f)
    }

    fn rows_of(
        &self,
        mut input: impl BufRead,
        wanted: &[usize],
        labels: &mut Labels,
        f: &mut RowFn,
    ) -> Result<(), DataError> {
        let path = &self.path;
        let bom = input.fill_buf().is_ok_and(|b| b.starts_with(b"\xef\xbb\xbf"));
        if bom {
            input.consume(3);
        }
        let mut reader = builder(self.delimiter, csv::Trim::Headers).from_reader(input);
        let headers = reader.byte_headers().map_err(|e| err(path, csv_error(&e)))?.len();
        let mut record = csv::ByteRecord::new();
        let mut values = vec![0.0; wanted.len()];
        let mut comma: Vec<u8> = Vec::new();
        // Record ids: numbers (true) or text (false), as the first row says.
        let mut numeric_ids: Option<bool> = None;
        let mut first_time: Option<i64> = None;
        let mut row = 0usize;
        loop {
            match reader.read_byte_record(&mut record) {
                Ok(false) => break,
                Ok(true) => {}
                Err(e) => return Err(err(path, csv_error(&e))),
            }
            let line = record.position().map_or(0, |p| p.line());
            if record.len() != headers {
                return Err(err(
                    path,
                    format!("line {line}: {} fields where the header has {headers}", record.len()),
                ));
            }
            for (v, &k) in values.iter_mut().zip(wanted) {
                let name = &self.names[k];
                let bytes = record[k].trim_ascii();
                // Numbers parsed from the bytes (ASCII); text looked at only where a
                // number is not found.
                let number = if self.decimal_comma {
                    comma.clear();
                    comma.extend(bytes.iter().map(|&b| if b == b',' { b'.' } else { b }));
                    fast_float2::parse::<f64, _>(&comma)
                } else {
                    fast_float2::parse::<f64, _>(bytes)
                };
                let field = match number {
                    Ok(_) => "",
                    Err(_) => std::str::from_utf8(bytes).map_err(|_| {
                        err(path, format!("line {line}, column {name:?}: not UTF-8 text")).in_column(name)
                    })?,
                };
                let role = self.roles[k];
                if role == Text::Record && *numeric_ids.get_or_insert(number.is_ok()) != number.is_ok() {
                    return Err(err(
                        path,
                        format!(
                            "line {line}, column {name:?}: record ids are numbers in some rows and text in others; \
                             give every record the same kind of id"
                        ),
                    )
                    .in_column(name));
                }
                *v = match (number, role) {
                    (Ok(v), _) => v,
                    (Err(_), Text::Record) => labels.number(field),
                    (Err(_), Text::Time) => match date_time_ns(field) {
                        Some(ns) => (ns - *first_time.get_or_insert(ns)) as f64 * 1e-9,
                        None => {
                            return Err(err(
                                path,
                                format!(
                                    "line {line}, column {name:?}: {field:?} is neither a number of seconds nor an \
                                     ISO 8601 date-time (2026-01-31T12:00:00.125, with an optional zone)"
                                ),
                            )
                            .in_column(name))
                        }
                    },
                    (Err(_), Text::None) => {
                        let hint = if !self.decimal_comma && field.contains(',') && !field.contains('.') {
                            " (a decimal comma? set [data] decimal = \",\")"
                        } else {
                            ""
                        };
                        return Err(err(
                            path,
                            format!("line {line}, column {name:?}: {field:?} is not a number{hint}"),
                        )
                        .in_column(name));
                    }
                };
            }
            if !f(row, &values)? {
                break;
            }
            row += 1;
        }
        Ok(())
    }
}

/// A CSV reader of the file's dialect; `trim`: which of its fields to trim (rows are
/// trimmed field by field, only the fields read).
fn builder(delimiter: u8, trim: csv::Trim) -> csv::ReaderBuilder {
    let mut b = csv::ReaderBuilder::new();
    b.delimiter(delimiter).comment(Some(b'#')).trim(trim);
    b
}

impl CsvFile {
    /// The whole table in memory: every column a number, text record ids numbered in the
    /// order of their text.
    pub fn read_all(&self) -> Result<Table, DataError> {
        let file = std::fs::File::open(&self.path).map_err(|e| err(&self.path, format!("cannot read: {e}")))?;
        self.table(BufReader::with_capacity(1 << 20, file))
    }

    fn table(&self, input: impl BufRead) -> Result<Table, DataError> {
        let all: Vec<usize> = (0..self.names.len()).collect();
        let mut columns: Vec<Vec<f64>> = vec![Vec::new(); all.len()];
        let mut labels = Labels::default();
        self.rows_of(input, &all, &mut labels, &mut |_, v| {
            for (c, x) in columns.iter_mut().zip(v) {
                c.push(*x);
            }
            Ok(true)
        })?;
        let mut record_labels = None;
        if let Some(k) = self.roles.iter().position(|r| *r == Text::Record) {
            if !labels.names.is_empty() {
                let mut sorted = labels.names.clone();
                sorted.sort();
                for v in columns[k].iter_mut() {
                    *v = sorted.binary_search(&labels.names[*v as usize]).expect("a label") as f64;
                }
                record_labels = Some(sorted);
            }
        }
        Ok(Table {
            path: self.path.clone(),
            names: self.names.clone(),
            columns,
            record_labels,
        })
    }
}

/// An ISO 8601 date-time in nanoseconds since 1970 (UTC where a zone is given, the clock's
/// own time where not): `2026-01-31T12:00:00.125`, `… 12:00:00`, `…Z`, `…+01:00`.
fn date_time_ns(s: &str) -> Option<i64> {
    if let Ok(t) = chrono::DateTime::parse_from_rfc3339(s) {
        return t.timestamp_nanos_opt();
    }
    [
        "%Y-%m-%dT%H:%M:%S%.f",
        "%Y-%m-%d %H:%M:%S%.f",
        "%Y-%m-%d %H:%M:%S%.f%:z",
        "%Y-%m-%d %H:%M:%S%.f%z",
    ]
    .iter()
    .find_map(|f| {
        chrono::NaiveDateTime::parse_from_str(s, f)
            .ok()
            .and_then(|t| t.and_utc().timestamp_nanos_opt())
            .or_else(|| {
                chrono::DateTime::parse_from_str(s, f)
                    .ok()
                    .and_then(|t| t.timestamp_nanos_opt())
            })
    })
}

/// A CSV reading error as a line and what is wrong, without the parser's internals.
fn csv_error(e: &csv::Error) -> String {
    let line = e.position().map_or(String::new(), |p| format!("line {}: ", p.line()));
    match e.kind() {
        csv::ErrorKind::UnequalLengths { expected_len, len, .. } => {
            format!("{line}{len} fields where the header has {expected_len}")
        }
        csv::ErrorKind::Utf8 { .. } => format!("{line}not UTF-8 text"),
        _ => format!("{line}{e}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str, o: &CsvOptions) -> Result<Table, DataError> {
        CsvFile::header(Path::new("t.csv"), text.as_bytes(), o)?.table(text.as_bytes())
    }

    #[test]
    fn csv_as_spreadsheets_and_loggers_write_it() {
        let o = CsvOptions {
            decimal_comma: true,
            record: Some("run"),
            time: Some("time"),
            ..Default::default()
        };
        // A byte-order mark, `;` found from the header, quoted fields, a comment and a blank
        // line, text run ids (ordered by their text) and zoned date-times.
        let text = "\u{feff}\"run\";time;\"x; in m\"\n# rig 3\nb;2026-03-01T08:00:00.25+01:00;\"1,5\"\n\n\
                    a;2026-03-01 07:00:00.50Z;-2,25e-3\nb;2026-03-01 08:00:00.5+01:00;3\n";
        let t = read(text, &o).unwrap();
        assert_eq!(t.names, ["run", "time", "x; in m"]);
        assert_eq!(t.columns[0], [1.0, 0.0, 1.0]);
        assert_eq!(
            t.record_labels.as_deref(),
            Some(&["a".to_string(), "b".to_string()][..])
        );
        assert_eq!(t.columns[1], [0.0, 0.25, 0.25]);
        assert_eq!(t.columns[2], [1.5, -2.25e-3, 3.0]);
        // Tabs, and plain numbers.
        let t = read("a\tb\n1.5\t2\n", &CsvOptions::default()).unwrap();
        assert_eq!(t.columns, [vec![1.5], vec![2.0]]);
    }

    #[test]
    fn csv_mistakes_are_named_by_line_and_column() {
        let o = CsvOptions {
            record: Some("run"),
            time: Some("time"),
            ..Default::default()
        };
        let e = |text: &str| read(text, &o).unwrap_err().to_string();
        assert!(e("run;x\n1;0,5\n")
            .contains("line 2, column \"x\": \"0,5\" is not a number (a decimal comma? set [data] decimal = \",\")"));
        assert!(
            e("run,time,x\n1,yesterday,0.5\n").contains("line 2, column \"time\": \"yesterday\" is neither a number")
        );
        assert!(e("run,x\n1,0.5\nb,0.5\n").contains("numbers in some rows and text in others"));
        assert!(e("run,x\n1,0.5,7\n").contains("line 2: 3 fields where the header has 2"));
        assert!(e("run,x\n1,abc\n").contains("line 2, column \"x\": \"abc\" is not a number"));
        assert!(e("").contains("empty"));
    }

    proptest::proptest! {
        /// Any text under a header naming the record and time columns is read or refused
        /// with a message, never a panic.
        #[test]
        fn any_csv_text_is_read_or_refused(
            body in "[ab,;\t\"\n#0-9.eE+:TZ -]{0,300}",
            header in "(a;b|a,b|b\ta|\"a\";b;c)\n",
            decimal_comma in proptest::prelude::any::<bool>(),
        ) {
            let o = CsvOptions { decimal_comma, record: Some("a"), time: Some("b"), ..Default::default() };
            let _ = read(&(header + &body), &o);
        }
    }
}

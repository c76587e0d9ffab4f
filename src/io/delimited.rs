//! CSV tables as spreadsheets and loggers write them, read into a [`Table`] of numbers:
//! quoted fields, a byte-order mark, `#` comments, the delimiter from the header or the
//! model's `[data] delimiter`, a decimal comma, text record ids and ISO 8601 date-times in
//! the time column (docs/data.md, "Formats").

use super::table::{err, DataError, Table};
use crate::scenario::DataMapping;
use std::path::Path;

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

/// A CSV file's columns as numbers: quoted fields, a UTF-8 byte-order mark, `#` comment
/// lines and blank lines are understood.
pub(super) fn read_csv(path: &Path, bytes: &[u8], o: &CsvOptions) -> Result<Table, DataError> {
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    if let Err(e) = std::str::from_utf8(bytes) {
        let line = 1 + bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count();
        return Err(err(
            path,
            format!("line {line}: not UTF-8 text (a CSV file is expected; .npy by its extension)"),
        ));
    }
    let header_line = bytes
        .split(|&b| b == b'\n')
        .find(|l| !l.iter().all(u8::is_ascii_whitespace) && !l.starts_with(b"#"))
        .ok_or_else(|| err(path, "empty: a header row of column names is expected"))?;
    // The header's own delimiter: the most frequent of `,` `;` tab outside quotes.
    let delimiter = o.delimiter.unwrap_or_else(|| {
        let count = |d: u8| header_line.iter().filter(|&&b| b == d).count();
        [b',', b';', b'\t']
            .into_iter()
            .max_by_key(|&d| count(d))
            .filter(|&d| count(d) > 0)
            .unwrap_or(b',')
    });
    let mut reader = csv::ReaderBuilder::new()
        .delimiter(delimiter)
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(bytes);
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
    let role = |k: usize| {
        if Some(names[k].as_str()) == o.record {
            Text::Record
        } else if Some(names[k].as_str()) == o.time {
            Text::Time
        } else {
            Text::None
        }
    };
    let roles: Vec<Text> = (0..names.len()).map(role).collect();
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    // Text record ids (numbered once all are known) and date-times (ns since the first).
    let mut record_text: Vec<String> = Vec::new();
    let mut first_time: Option<i64> = None;
    let mut row = csv::StringRecord::new();
    loop {
        match reader.read_record(&mut row) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => return Err(err(path, csv_error(&e))),
        }
        let line = row.position().map_or(0, |p| p.line());
        if row.len() != names.len() {
            return Err(err(
                path,
                format!("line {line}: {} fields where the header has {}", row.len(), names.len()),
            ));
        }
        for (k, f) in row.iter().enumerate() {
            let number = if o.decimal_comma {
                f.replace(',', ".").parse()
            } else {
                f.parse()
            };
            let v = match (number, roles[k]) {
                (Ok(v), _) => v,
                (Err(_), Text::Record) => {
                    record_text.push(f.to_string());
                    // Placeholder: the text's rank, filled in below.
                    f64::NAN
                }
                (Err(_), Text::Time) => match date_time_ns(f) {
                    Some(ns) => (ns - *first_time.get_or_insert(ns)) as f64 * 1e-9,
                    None => {
                        return Err(err(
                            path,
                            format!(
                                "line {line}, column {:?}: {f:?} is neither a number of seconds nor an ISO 8601 \
                                 date-time (2026-01-31T12:00:00.125, with an optional zone)",
                                names[k]
                            ),
                        ))
                    }
                },
                (Err(_), Text::None) => {
                    let hint = if !o.decimal_comma && f.contains(',') && !f.contains('.') {
                        " (a decimal comma? set [data] decimal = \",\")"
                    } else {
                        ""
                    };
                    return Err(err(
                        path,
                        format!("line {line}, column {:?}: {f:?} is not a number{hint}", names[k]),
                    ));
                }
            };
            columns[k].push(v);
        }
    }
    let mut record_labels = None;
    if let Some(k) = roles.iter().position(|r| *r == Text::Record) {
        if !record_text.is_empty() {
            if record_text.len() != columns[k].len() {
                return Err(err(
                    path,
                    format!(
                        "column {:?}: record ids are numbers in some rows and text in others; give every record \
                         the same kind of id",
                        names[k]
                    ),
                ));
            }
            let mut labels = record_text.clone();
            labels.sort();
            labels.dedup();
            for (v, t) in columns[k].iter_mut().zip(&record_text) {
                *v = labels.binary_search(t).expect("a label") as f64;
            }
            record_labels = Some(labels);
        }
    }
    Ok(Table {
        path: path.to_path_buf(),
        names,
        columns,
        record_labels,
    })
}

/// Which text a CSV column may hold instead of numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Text {
    None,
    Record,
    Time,
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
        read_csv(Path::new("t.csv"), text.as_bytes(), o)
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

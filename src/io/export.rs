//! Export a run log to CSV (spreadsheets) or NPY (numpy), streaming in constant memory.
//!
//! Both start with the columns `trajectory, t`, then the log's columns. The NPY file is a
//! one-dimensional structured array whose field names are the column names
//! (`np.load(path)["x_m1"]`). Output is written to a temporary name and renamed when done.

use super::log::{read_samples, LogError, LogInfo};
use super::output::Pending;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::Path;

/// Export format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Comma-separated text with a header line; numbers round-trip exactly.
    Csv,
    /// numpy structured array (`trajectory` uint32, every other column float64).
    Npy,
}

impl Format {
    pub fn extension(self) -> &'static str {
        match self {
            Format::Csv => "csv",
            Format::Npy => "npy",
        }
    }
}

/// Write the samples of the log described by `info` to `dest`. Returns the sample count.
/// A truncated log is exported up to the break, then its error is returned and nothing is
/// left at `dest`.
pub fn export(info: &LogInfo, format: Format, dest: &Path) -> Result<u64, LogError> {
    let label = dest.display().to_string();
    let io = |source| LogError::Io {
        path: label.clone(),
        source,
    };
    let pending = Pending::new(dest).map_err(io)?;
    let mut out = BufWriter::with_capacity(1 << 20, File::create(pending.path()).map_err(io)?);
    let mut failed: Option<std::io::Error> = None;
    let result = match format {
        Format::Csv => {
            let header = format!("trajectory,t,{}\n", info.columns.join(","));
            out.write_all(header.as_bytes()).map_err(io)?;
            let mut line = String::new();
            read_samples(info, |traj, t, values| {
                if failed.is_some() {
                    return;
                }
                use std::fmt::Write as _;
                line.clear();
                let _ = write!(line, "{traj},{t:?}");
                for v in values {
                    let _ = write!(line, ",{v:?}");
                }
                line.push('\n');
                if let Err(e) = out.write_all(line.as_bytes()) {
                    failed = Some(e);
                }
            })
        }
        Format::Npy => {
            // Header written twice: a placeholder with room for any shape, then the real one.
            let write_header = |out: &mut BufWriter<File>, n: u64| -> std::io::Result<()> {
                let mut descr = String::from("[('trajectory', '<u4'), ('t', '<f8')");
                for c in &info.columns {
                    descr.push_str(&format!(", ('{c}', '<f8')"));
                }
                descr.push(']');
                let mut dict = format!("{{'descr': {descr}, 'fortran_order': False, 'shape': ({n:>20},), }}");
                let total = 10 + dict.len() + 1;
                let pad = (64 - total % 64) % 64;
                dict.push_str(&" ".repeat(pad));
                dict.push('\n');
                out.write_all(b"\x93NUMPY\x01\x00")?;
                out.write_all(&(dict.len() as u16).to_le_bytes())?;
                out.write_all(dict.as_bytes())
            };
            write_header(&mut out, 0).map_err(io)?;
            let mut rec = Vec::new();
            let r = read_samples(info, |traj, t, values| {
                if failed.is_some() {
                    return;
                }
                rec.clear();
                rec.extend_from_slice(&traj.to_le_bytes());
                rec.extend_from_slice(&t.to_le_bytes());
                for v in values {
                    rec.extend_from_slice(&v.to_le_bytes());
                }
                if let Err(e) = out.write_all(&rec) {
                    failed = Some(e);
                }
            });
            if let Ok(n) = r {
                out.seek(SeekFrom::Start(0)).map_err(io)?;
                write_header(&mut out, n).map_err(io)?;
            }
            r
        }
    };
    // On every error path `pending` is dropped, which removes the temporary file.
    if let Some(e) = failed {
        return Err(io(e));
    }
    let n = result?;
    out.flush().map_err(io)?;
    drop(out);
    pending.commit().map_err(io)?;
    Ok(n)
}

//! A reader of MCAP files that follows the specification and trusts nothing in the file.
//!
//! It reads any valid layout — chunked or not, zstd, lz4 or plain chunks of any size, with
//! or without summary, indexes, statistics and repeated schemas or channels — and reports
//! a damaged file instead of crashing on it:
//!
//! - every length is checked against the bytes that remain before anything is allocated,
//!   so no buffer is larger than the file itself, except a decompressed chunk, which grows
//!   only with the bytes the decompressor actually produces and never beyond the size its
//!   header declares or [`MAX_CHUNK`], and the zstd decoder's window (at most
//!   2^[`ZSTD_WINDOW_LOG`] bytes, whatever a frame header asks for);
//! - chunk CRCs are checked before any record of the chunk is handed out, and the data
//!   section's, the summary's and every attachment's CRC are checked where the writer
//!   stored one (a stored 0 means "not computed", as the specification says);
//! - errors say where (byte offset, record) and what, with no parser internals.
//!
//! It knows only MCAP; what the records mean for fpkbench is [`super::log`]'s business.
//! See docs/log-format.md, "What you can do to a log".

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::ops::ControlFlow;
use std::path::Path;

/// The 8 bytes at both ends of an MCAP file.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";
/// Largest decompressed chunk accepted (writers use 1–64 MiB).
pub const MAX_CHUNK: u64 = 256 << 20;
/// Largest zstd window accepted (32 MiB): zstd's levels 1–19 use at most 8 MiB; only
/// long-distance matching asks for more, and a damaged frame header may ask for anything.
pub const ZSTD_WINDOW_LOG: u32 = 25;

mod op {
    pub const HEADER: u8 = 0x01;
    pub const FOOTER: u8 = 0x02;
    pub const SCHEMA: u8 = 0x03;
    pub const CHANNEL: u8 = 0x04;
    pub const MESSAGE: u8 = 0x05;
    pub const CHUNK: u8 = 0x06;
    pub const ATTACHMENT: u8 = 0x09;
    pub const ATTACHMENT_INDEX: u8 = 0x0A;
    pub const METADATA: u8 = 0x0C;
    pub const METADATA_INDEX: u8 = 0x0D;
    pub const DATA_END: u8 = 0x0F;
}

/// Footer record plus end magic: opcode, length, three fields, magic.
const FOOTER_LEN: u64 = 1 + 8 + 20 + 8;

/// What went wrong reading an MCAP file.
#[derive(Debug, Clone, PartialEq)]
pub enum ReadError {
    /// The file ends inside a record or before its end magic.
    Truncated { offset: u64, what: String },
    /// Bytes that cannot be what the specification says is there.
    Corrupt { offset: u64, what: String },
    /// The operating system refused a read.
    Io(String),
}

impl std::fmt::Display for ReadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReadError::Truncated { offset, what } => write!(f, "the file ends at byte {offset}: {what}"),
            ReadError::Corrupt { offset, what } => write!(f, "corrupt at byte {offset}: {what}"),
            ReadError::Io(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for ReadError {}

/// One record, borrowed from the reader's buffers. Records fpkbench has no use for
/// (indexes, statistics, private opcodes) come as [`Record::Other`].
#[derive(Debug)]
pub enum Record<'a> {
    Header {
        profile: String,
        library: String,
    },
    Schema {
        id: u16,
        name: String,
        encoding: String,
        data: &'a [u8],
    },
    Channel {
        id: u16,
        schema_id: u16,
        topic: String,
        message_encoding: String,
        metadata: BTreeMap<String, String>,
    },
    Message {
        channel_id: u16,
        log_time: u64,
        data: &'a [u8],
    },
    Attachment {
        name: String,
        media_type: String,
        data: &'a [u8],
    },
    Metadata {
        name: String,
        metadata: BTreeMap<String, String>,
    },
    Other(u8),
}

/// A bounds-checked little-endian cursor over one record's body.
struct Fields<'a> {
    data: &'a [u8],
    at: usize,
    /// File offset of `data[0]`, for messages.
    offset: u64,
    record: &'static str,
}

impl<'a> Fields<'a> {
    fn new(data: &'a [u8], offset: u64, record: &'static str) -> Self {
        Fields {
            data,
            at: 0,
            offset,
            record,
        }
    }
    fn corrupt(&self, what: &str) -> ReadError {
        ReadError::Corrupt {
            offset: self.offset + self.at as u64,
            what: format!("{} record: {what}", self.record),
        }
    }
    fn take(&mut self, n: u64, field: &str) -> Result<&'a [u8], ReadError> {
        let left = (self.data.len() - self.at) as u64;
        if n > left {
            return Err(self.corrupt(&format!(
                "field `{field}` needs {n} bytes but the record has {left} left"
            )));
        }
        let s = &self.data[self.at..self.at + n as usize];
        self.at += n as usize;
        Ok(s)
    }
    fn u16(&mut self, field: &str) -> Result<u16, ReadError> {
        Ok(u16::from_le_bytes(self.take(2, field)?.try_into().unwrap()))
    }
    fn u32(&mut self, field: &str) -> Result<u32, ReadError> {
        Ok(u32::from_le_bytes(self.take(4, field)?.try_into().unwrap()))
    }
    fn u64(&mut self, field: &str) -> Result<u64, ReadError> {
        Ok(u64::from_le_bytes(self.take(8, field)?.try_into().unwrap()))
    }
    fn bytes32(&mut self, field: &str) -> Result<&'a [u8], ReadError> {
        let n = self.u32(field)?;
        self.take(n as u64, field)
    }
    fn string(&mut self, field: &str) -> Result<String, ReadError> {
        let at = self.at;
        let b = self.bytes32(field)?;
        String::from_utf8(b.to_vec()).map_err(|_| {
            self.at = at;
            self.corrupt(&format!("field `{field}` is not UTF-8"))
        })
    }
    fn map(&mut self, field: &str) -> Result<BTreeMap<String, String>, ReadError> {
        let body = self.bytes32(field)?;
        let mut inner = Fields::new(body, self.offset + (self.at - body.len()) as u64, self.record);
        let mut m = BTreeMap::new();
        while inner.at < body.len() {
            let k = inner.string(field)?;
            let v = inner.string(field)?;
            m.insert(k, v);
        }
        Ok(m)
    }
    fn rest(&mut self) -> &'a [u8] {
        let s = &self.data[self.at..];
        self.at = self.data.len();
        s
    }
}

/// Parse the body of one record (not a chunk: see [`Scan`]).
fn parse(opcode: u8, body: &[u8], offset: u64) -> Result<Record<'_>, ReadError> {
    Ok(match opcode {
        op::HEADER => {
            let mut f = Fields::new(body, offset, "header");
            Record::Header {
                profile: f.string("profile")?,
                library: f.string("library")?,
            }
        }
        op::SCHEMA => {
            let mut f = Fields::new(body, offset, "schema");
            Record::Schema {
                id: f.u16("id")?,
                name: f.string("name")?,
                encoding: f.string("encoding")?,
                data: f.bytes32("data")?,
            }
        }
        op::CHANNEL => {
            let mut f = Fields::new(body, offset, "channel");
            Record::Channel {
                id: f.u16("id")?,
                schema_id: f.u16("schema_id")?,
                topic: f.string("topic")?,
                message_encoding: f.string("message_encoding")?,
                metadata: f.map("metadata")?,
            }
        }
        op::MESSAGE => {
            let mut f = Fields::new(body, offset, "message");
            let channel_id = f.u16("channel_id")?;
            f.u32("sequence")?;
            let log_time = f.u64("log_time")?;
            f.u64("publish_time")?;
            Record::Message {
                channel_id,
                log_time,
                data: f.rest(),
            }
        }
        op::ATTACHMENT => {
            let mut f = Fields::new(body, offset, "attachment");
            f.u64("log_time")?;
            f.u64("create_time")?;
            let name = f.string("name")?;
            let media_type = f.string("media_type")?;
            let n = f.u64("data_len")?;
            let data = f.take(n, "data")?;
            let covered = f.at;
            let crc = f.u32("crc")?;
            if crc != 0 && crc != crc32fast::hash(&body[..covered]) {
                return Err(ReadError::Corrupt {
                    offset,
                    what: format!("attachment `{name}`: its CRC does not match its bytes"),
                });
            }
            Record::Attachment { name, media_type, data }
        }
        op::METADATA => {
            let mut f = Fields::new(body, offset, "metadata");
            Record::Metadata {
                name: f.string("name")?,
                metadata: f.map("metadata")?,
            }
        }
        other => Record::Other(other),
    })
}

/// A file being read: its handle, length and name for messages.
pub struct McapFile {
    file: BufReader<File>,
    len: u64,
}

impl McapFile {
    pub fn open(path: &Path) -> Result<McapFile, ReadError> {
        let file = File::open(path).map_err(|e| ReadError::Io(e.to_string()))?;
        let meta = file.metadata().map_err(|e| ReadError::Io(e.to_string()))?;
        if meta.is_dir() {
            return Err(ReadError::Io("is a directory".into()));
        }
        Ok(McapFile {
            file: BufReader::with_capacity(1 << 20, file),
            len: meta.len(),
        })
    }

    pub fn len(&self) -> u64 {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn read_at(&mut self, offset: u64, buf: &mut Vec<u8>, n: u64) -> Result<(), ReadError> {
        if offset.checked_add(n).is_none_or(|end| end > self.len) {
            return Err(ReadError::Corrupt {
                offset,
                what: format!("an index points at {n} bytes beyond the end of the file"),
            });
        }
        self.file
            .seek(SeekFrom::Start(offset))
            .map_err(|e| ReadError::Io(e.to_string()))?;
        buf.clear();
        buf.resize(n as usize, 0);
        self.file.read_exact(buf).map_err(|e| ReadError::Io(e.to_string()))
    }

    /// The summary section's records fpkbench uses, through the footer: channels, and the
    /// attachment and metadata records its indexes point at (read and CRC-checked).
    /// `None` when the file has no usable footer or summary (then read it linearly).
    pub fn summary(&mut self) -> Result<Option<Summary>, ReadError> {
        if self.len < 8 + FOOTER_LEN {
            return Ok(None);
        }
        let mut tail = Vec::new();
        let footer_at = self.len - FOOTER_LEN;
        self.read_at(footer_at, &mut tail, FOOTER_LEN)?;
        if &tail[29..] != MAGIC || tail[0] != op::FOOTER || tail[1..9] != 20u64.to_le_bytes() {
            return Ok(None);
        }
        let field = |at: usize| u64::from_le_bytes(tail[at..at + 8].try_into().unwrap());
        let (start, crc) = (field(9), u32::from_le_bytes(tail[25..29].try_into().unwrap()));
        if start == 0 {
            return Ok(None);
        }
        if start < 8 || start > footer_at {
            return Err(ReadError::Corrupt {
                offset: footer_at,
                what: format!("the footer puts the summary at byte {start}, outside the file"),
            });
        }
        let mut body = Vec::new();
        self.read_at(start, &mut body, footer_at - start)?;
        if crc != 0 {
            let mut h = crc32fast::Hasher::new();
            h.update(&body);
            h.update(&tail[..25]);
            if h.finalize() != crc {
                return Err(ReadError::Corrupt {
                    offset: start,
                    what: "the summary section's CRC does not match its bytes".into(),
                });
            }
        }
        let mut summary = Summary::default();
        let mut at = 0usize;
        while at < body.len() {
            let offset = start + at as u64;
            let (opcode, n) = record_head(&body[at..], offset, "summary section")?;
            let rec = &body[at + 9..at + 9 + n];
            at += 9 + n;
            match opcode {
                op::ATTACHMENT_INDEX | op::METADATA_INDEX => {
                    let mut f = Fields::new(rec, offset + 9, "index");
                    let (at, len) = (f.u64("offset")?, f.u64("length")?);
                    summary.indexed.push((opcode, at, len));
                }
                _ => {
                    if let Record::Channel {
                        id,
                        topic,
                        message_encoding,
                        metadata,
                        ..
                    } = parse(opcode, rec, offset + 9)?
                    {
                        summary.channels.push((id, topic, message_encoding, metadata));
                    }
                }
            }
        }
        Ok(Some(summary))
    }

    /// Read the record an index points at; `f` gets it parsed.
    pub fn indexed_record<T>(
        &mut self,
        offset: u64,
        length: u64,
        f: impl FnOnce(Record<'_>) -> T,
    ) -> Result<T, ReadError> {
        let mut buf = Vec::new();
        self.read_at(offset, &mut buf, length)?;
        let (opcode, n) = record_head(&buf, offset, "indexed record")?;
        if 9 + n != buf.len() {
            return Err(ReadError::Corrupt {
                offset,
                what: format!("an index gives {length} bytes for a record of {}", 9 + n),
            });
        }
        Ok(f(parse(opcode, &buf[9..], offset + 9)?))
    }
}

/// What the summary section offers.
#[derive(Debug, Default)]
pub struct Summary {
    /// `(id, topic, message encoding, metadata)`.
    pub channels: Vec<(u16, String, String, BTreeMap<String, String>)>,
    /// Attachment and metadata indexes: `(index opcode, offset, length)`.
    indexed: Vec<(u8, u64, u64)>,
}

impl Summary {
    /// `(offset, length)` of every indexed attachment.
    pub fn attachments(&self) -> impl Iterator<Item = (u64, u64)> + '_ {
        self.indexed
            .iter()
            .filter(|i| i.0 == op::ATTACHMENT_INDEX)
            .map(|i| (i.1, i.2))
    }
    /// `(offset, length)` of every indexed metadata record.
    pub fn metadata(&self) -> impl Iterator<Item = (u64, u64)> + '_ {
        self.indexed
            .iter()
            .filter(|i| i.0 == op::METADATA_INDEX)
            .map(|i| (i.1, i.2))
    }
}

/// Read `r` to its end into `buf`, but no more than `limit` bytes; `buf` grows by doubling
/// as bytes arrive and never past `limit` (not even its capacity).
fn read_at_most(mut r: impl Read, limit: u64, buf: &mut Vec<u8>) -> std::io::Result<usize> {
    let limit = limit as usize;
    let mut len = 0;
    loop {
        if len == buf.len() {
            if len == limit {
                break;
            }
            let grow = (2 * len).max(64 << 10).min(limit) - len;
            buf.reserve_exact(grow);
            buf.resize(len + grow, 0);
        }
        match r.read(&mut buf[len..]) {
            Ok(0) => break,
            Ok(n) => len += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    buf.truncate(len);
    Ok(len)
}

/// Opcode and body length of the record starting `buf`, checked against `buf`.
fn record_head(buf: &[u8], offset: u64, within: &str) -> Result<(u8, usize), ReadError> {
    if buf.len() < 9 {
        return Err(ReadError::Corrupt {
            offset,
            what: format!("{within}: {} bytes left, too few for a record", buf.len()),
        });
    }
    let n = u64::from_le_bytes(buf[1..9].try_into().unwrap());
    if n > (buf.len() - 9) as u64 {
        return Err(ReadError::Corrupt {
            offset,
            what: format!(
                "{within}: record (opcode 0x{:02x}) claims {n} bytes but {} remain",
                buf[0],
                buf.len() - 9
            ),
        });
    }
    Ok((buf[0], n as usize))
}

/// The longest record a length may claim before it counts as damaged rather than cut
/// short (1 TiB: far beyond any chunk or message a writer makes).
pub const MAX_RECORD: u64 = 1 << 40;

/// Reads every record of a file from the start, in file order, including the records
/// inside chunks (a chunk is checked whole before its first record is handed out).
pub struct Scan {
    file: McapFile,
    /// Reused buffers: the current top-level record, a chunk's compressed bytes and a
    /// chunk's decompressed records.
    record: Vec<u8>,
    chunk: Vec<u8>,
    hasher: crc32fast::Hasher,
}

impl Scan {
    pub fn new(file: McapFile) -> Scan {
        Scan {
            file,
            record: Vec::new(),
            chunk: Vec::new(),
            hasher: crc32fast::Hasher::new(),
        }
    }

    fn read(&mut self, n: u64, offset: u64, what: &str) -> Result<(), ReadError> {
        let left = self.file.len - offset;
        if n > left && n > MAX_RECORD {
            // No writer makes a record this long: the length itself is damaged, whatever
            // follows it (docs/reliability.md: an impossible length is damage).
            return Err(ReadError::Corrupt {
                offset,
                what: format!(
                    "{what} at byte {offset} claims {n} bytes, more than any record can hold ({MAX_RECORD}): \
                     its length is damaged"
                ),
            });
        }
        if n > left {
            return Err(ReadError::Truncated {
                offset: self.file.len,
                what: format!(
                    "{what} at byte {offset} claims {n} bytes but {left} remain (the file was cut \
                     short, or this length is damaged)"
                ),
            });
        }
        self.record.clear();
        self.record.resize(n as usize, 0);
        self.file
            .file
            .read_exact(&mut self.record)
            .map_err(|e| ReadError::Io(e.to_string()))?;
        Ok(())
    }

    /// Feed every record to `f` (with the file offset of its body; inside a chunk, the
    /// offset of the chunk record) until
    /// `f` breaks or the file ends. Ends `Ok` only after a complete file: end magic read
    /// and, where stored, the data section CRC matched.
    pub fn run(&mut self, mut f: impl FnMut(Record<'_>, u64) -> ControlFlow<()>) -> Result<(), ReadError> {
        self.file
            .file
            .seek(SeekFrom::Start(0))
            .map_err(|e| ReadError::Io(e.to_string()))?;
        self.read(8, 0, "the start magic")?;
        if self.record[..] != MAGIC[..] {
            return Err(ReadError::Corrupt {
                offset: 0,
                what: "not an MCAP file (no MCAP magic at the start)".into(),
            });
        }
        self.hasher = crc32fast::Hasher::new();
        self.hasher.update(MAGIC);
        let mut offset = 8u64;
        let mut in_data = true;
        loop {
            self.read(9, offset, "a record")?;
            let opcode = self.record[0];
            let n = u64::from_le_bytes(self.record[1..9].try_into().unwrap());
            let head: [u8; 9] = self.record[..9].try_into().unwrap();
            self.read(n, offset, &format!("record (opcode 0x{opcode:02x})"))?;
            let body_at = offset + 9;
            if opcode == op::DATA_END && in_data {
                in_data = false;
                let stored = Fields::new(&self.record, body_at, "data end").u32("data_section_crc")?;
                let computed = std::mem::take(&mut self.hasher).finalize();
                if stored != 0 && stored != computed {
                    return Err(ReadError::Corrupt {
                        offset,
                        what: "the data section's CRC does not match its bytes (a byte changed)".into(),
                    });
                }
            } else if in_data {
                self.hasher.update(&head);
                self.hasher.update(&self.record);
            }
            offset = body_at + n;
            if opcode == op::FOOTER {
                self.read(8, offset, "the end magic")?;
                if self.record[..] != MAGIC[..] {
                    return Err(ReadError::Corrupt {
                        offset,
                        what: "the footer is not followed by the MCAP magic".into(),
                    });
                }
                return Ok(());
            }
            if opcode == op::CHUNK {
                if self.chunk_records(body_at - 9, &mut f)?.is_break() {
                    return Ok(());
                }
            } else if f(parse(opcode, &self.record, body_at)?, body_at).is_break() {
                return Ok(());
            }
        }
    }

    /// Check and decompress the chunk (record at byte `at`, body in `self.record`), then
    /// feed its records to `f`.
    fn chunk_records(
        &mut self,
        at: u64,
        f: &mut impl FnMut(Record<'_>, u64) -> ControlFlow<()>,
    ) -> Result<ControlFlow<()>, ReadError> {
        let mut h = Fields::new(&self.record, at + 9, "chunk");
        h.u64("message_start_time")?;
        h.u64("message_end_time")?;
        let size = h.u64("uncompressed_size")?;
        let crc = h.u32("uncompressed_crc")?;
        let compression = h.string("compression")?;
        let n = h.u64("records_len")?;
        let compressed = h.take(n, "records")?;
        let corrupt = |what: String| ReadError::Corrupt { offset: at, what };
        if size > MAX_CHUNK {
            return Err(corrupt(format!(
                "chunk declares {size} uncompressed bytes (more than the {MAX_CHUNK} accepted)"
            )));
        }
        let records: &[u8] = match compression.as_str() {
            "" => {
                if n != size {
                    return Err(corrupt(format!(
                        "uncompressed chunk holds {n} bytes but declares {size}"
                    )));
                }
                compressed
            }
            "zstd" | "lz4" => {
                self.chunk.clear();
                let got = if compression == "zstd" {
                    let mut d = zstd::stream::read::Decoder::with_buffer(compressed)
                        .map_err(|e| corrupt(format!("zstd chunk: {e}")))?;
                    d.window_log_max(ZSTD_WINDOW_LOG)
                        .map_err(|e| corrupt(format!("zstd chunk: {e}")))?;
                    read_at_most(d, size + 1, &mut self.chunk)
                } else {
                    read_at_most(
                        lz4_flex::frame::FrameDecoder::new(compressed),
                        size + 1,
                        &mut self.chunk,
                    )
                };
                let got = got.map_err(|e| corrupt(format!("{compression} chunk does not decompress: {e}")))?;
                if got as u64 != size {
                    return Err(corrupt(format!(
                        "{compression} chunk decompresses to {}{got} bytes but declares {size}",
                        if got as u64 > size { "more than " } else { "" }
                    )));
                }
                &self.chunk
            }
            other => {
                return Err(corrupt(format!(
                    "chunk compression `{other}` is not one of zstd, lz4 or none"
                )))
            }
        };
        if crc != 0 && crc32fast::hash(records) != crc {
            return Err(corrupt(format!(
                "chunk CRC mismatch: its {size} bytes of records changed since they were written"
            )));
        }
        let mut i = 0usize;
        while i < records.len() {
            let (opcode, len) = record_head(&records[i..], at, "chunk")?;
            let rec = parse(opcode, &records[i + 9..i + 9 + len], at)?;
            i += 9 + len;
            if f(rec, at).is_break() {
                return Ok(ControlFlow::Break(()));
            }
        }
        Ok(ControlFlow::Continue(()))
    }
}

//! Messages of MCAP topics written by other tools, decoded into a tree of values whose
//! numeric leaves a model's `[data]` section names by dotted paths (`pose.angle`,
//! `position.0` for an array's first element). Three encodings, the ones a rig's logger
//! writes into MCAP (docs/data.md):
//!
//! - `json` (Foxglove's JSON channels);
//! - `cdr` with a `ros2msg` schema (ROS 2): the message definition text with its
//!   dependencies after `====` / `MSG: pkg/Type` lines, classic little- or big-endian CDR;
//! - `protobuf` with a `protobuf` schema: a serialized `FileDescriptorSet` and the message's
//!   full name (proto2 and proto3, packed or not; absent proto3 scalars are 0).

use std::collections::BTreeMap;

/// A decoded message: numbers (every numeric and boolean field), text, lists and records.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Number(f64),
    Text,
    List(Vec<Value>),
    Record(Vec<(String, Value)>),
}

impl Value {
    /// The number at a dotted path (record keys, list indices).
    pub fn at(&self, path: &str) -> Option<f64> {
        let mut v = self;
        for key in path.split('.') {
            v = match v {
                Value::Record(fields) => &fields.iter().find(|f| f.0 == key)?.1,
                Value::List(items) => items.get(key.parse::<usize>().ok()?)?,
                _ => return None,
            };
        }
        match v {
            Value::Number(x) => Some(*x),
            _ => None,
        }
    }

    fn of_json(v: &serde_json::Value) -> Value {
        match v {
            serde_json::Value::Number(n) => Value::Number(n.as_f64().unwrap_or(f64::NAN)),
            serde_json::Value::Bool(b) => Value::Number(f64::from(u8::from(*b))),
            serde_json::Value::Array(a) => Value::List(a.iter().map(Value::of_json).collect()),
            serde_json::Value::Object(o) => {
                Value::Record(o.iter().map(|(k, v)| (k.clone(), Value::of_json(v))).collect())
            }
            _ => Value::Text,
        }
    }
}

/// How one channel's messages are decoded.
#[derive(Debug, Clone)]
pub enum Decoder {
    Json,
    Ros2(Ros2Schema),
    Protobuf(ProtoSchema),
}

impl Decoder {
    /// The decoder for a channel's message encoding and its schema (`name`, `encoding`,
    /// `data`), or why there is none.
    pub fn new(message_encoding: &str, schema: Option<(&str, &str, &[u8])>) -> Result<Decoder, String> {
        match (message_encoding, schema) {
            ("json", _) => Ok(Decoder::Json),
            ("cdr", Some((name, "ros2msg", data))) => {
                let text = std::str::from_utf8(data).map_err(|_| "the ros2msg schema is not UTF-8 text".to_string())?;
                Ros2Schema::parse(name, text).map(Decoder::Ros2)
            }
            ("protobuf", Some((name, "protobuf", data))) => ProtoSchema::parse(name, data).map(Decoder::Protobuf),
            (enc, schema) => Err(format!(
                "{enc:?} messages{}: the encodings read here are JSON, ROS 2 CDR (ros2msg schema) and protobuf \
                 (export other encodings to CSV)",
                schema.map_or(String::new(), |s| format!(" with a {:?} schema", s.1))
            )),
        }
    }

    pub fn decode(&self, data: &[u8]) -> Result<Value, String> {
        match self {
            Decoder::Json => serde_json::from_slice::<serde_json::Value>(data)
                .map(|v| Value::of_json(&v))
                .map_err(|e| format!("not JSON: {e}")),
            Decoder::Ros2(s) => s.decode(data),
            Decoder::Protobuf(s) => s.decode(data),
        }
    }
}

// ---------------------------------------------------------------------------------------
// ROS 2: message definitions and CDR.

#[derive(Debug, Clone, PartialEq)]
enum Ros2Type {
    Primitive(&'static str, usize),
    Text,
    Nested(String),
}

#[derive(Debug, Clone, PartialEq)]
enum Arity {
    One,
    Fixed(usize),
    Sequence,
}

#[derive(Debug, Clone)]
struct Ros2Field {
    name: String,
    ty: Ros2Type,
    arity: Arity,
}

/// A ROS 2 message definition with its dependencies, by full name (`pkg/msg/Type` is
/// stored as `pkg/Type`).
#[derive(Debug, Clone)]
pub struct Ros2Schema {
    root: String,
    types: BTreeMap<String, Vec<Ros2Field>>,
}

fn primitive(ty: &str) -> Option<Ros2Type> {
    let (name, size) = match ty {
        "bool" => ("bool", 1),
        "byte" | "uint8" | "char" => ("uint8", 1),
        "int8" => ("int8", 1),
        "int16" => ("int16", 2),
        "uint16" => ("uint16", 2),
        "int32" => ("int32", 4),
        "uint32" => ("uint32", 4),
        "int64" => ("int64", 8),
        "uint64" => ("uint64", 8),
        "float32" => ("float32", 4),
        "float64" => ("float64", 8),
        _ => return None,
    };
    Some(Ros2Type::Primitive(name, size))
}

/// `pkg/msg/Type` and `pkg/Type` as `pkg/Type`.
fn ros2_name(name: &str) -> String {
    let parts: Vec<&str> = name.split('/').collect();
    match parts.as_slice() {
        [pkg, _, ty] => format!("{pkg}/{ty}"),
        _ => name.to_string(),
    }
}

impl Ros2Schema {
    pub fn parse(name: &str, text: &str) -> Result<Ros2Schema, String> {
        let root = ros2_name(name);
        let root_pkg = root.split('/').next().unwrap_or("").to_string();
        let mut types = BTreeMap::new();
        let mut current = root.clone();
        let mut pkg = root_pkg;
        let mut fields = Vec::new();
        for (n, raw) in text.lines().enumerate() {
            let line = raw.split('#').next().unwrap_or("").trim();
            if line.starts_with("====") {
                types.insert(std::mem::take(&mut current), std::mem::take(&mut fields));
                continue;
            }
            if let Some(t) = line.strip_prefix("MSG:") {
                current = ros2_name(t.trim());
                pkg = current.split('/').next().unwrap_or("").to_string();
                continue;
            }
            if line.is_empty() {
                continue;
            }
            let mut words = line.split_whitespace();
            let (Some(ty), Some(fname)) = (words.next(), words.next()) else {
                return Err(format!("ros2msg schema line {}: {raw:?} is not `type name`", n + 1));
            };
            // Constants (`int32 MODE=1`) are not in the message.
            if fname.contains('=') || words.next().is_some_and(|w| w.starts_with('=')) {
                continue;
            }
            let (base, arity) = match ty.find('[') {
                Some(i) => {
                    let inner = ty[i + 1..].trim_end_matches(']');
                    let arity = if inner.is_empty() || inner.starts_with("<=") {
                        Arity::Sequence
                    } else {
                        Arity::Fixed(
                            inner
                                .parse()
                                .map_err(|_| format!("ros2msg schema line {}: array size {inner:?}", n + 1))?,
                        )
                    };
                    (&ty[..i], arity)
                }
                None => (ty, Arity::One),
            };
            let base = base.split("<=").next().unwrap_or(base);
            let ty = match base {
                "string" | "wstring" => Ros2Type::Text,
                "Header" => Ros2Type::Nested("std_msgs/Header".into()),
                b => match primitive(b) {
                    Some(p) => p,
                    None if b.contains('/') => Ros2Type::Nested(ros2_name(b)),
                    None => Ros2Type::Nested(format!("{pkg}/{b}")),
                },
            };
            fields.push(Ros2Field {
                name: fname.to_string(),
                ty,
                arity,
            });
        }
        types.insert(current, fields);
        // The builtin types a definition may use without including them.
        for t in ["builtin_interfaces/Time", "builtin_interfaces/Duration"] {
            types.entry(t.to_string()).or_insert_with(|| {
                vec![
                    Ros2Field {
                        name: "sec".into(),
                        ty: Ros2Type::Primitive("int32", 4),
                        arity: Arity::One,
                    },
                    Ros2Field {
                        name: "nanosec".into(),
                        ty: Ros2Type::Primitive("uint32", 4),
                        arity: Arity::One,
                    },
                ]
            });
        }
        let schema = Ros2Schema { root, types };
        for fields in schema.types.values() {
            for f in fields {
                if let Ros2Type::Nested(t) = &f.ty {
                    if !schema.types.contains_key(t) {
                        return Err(format!(
                            "ros2msg schema: field {:?} has type {t:?}, whose definition the schema lacks",
                            f.name
                        ));
                    }
                }
            }
        }
        Ok(schema)
    }

    pub fn decode(&self, data: &[u8]) -> Result<Value, String> {
        if data.len() < 4 {
            return Err("shorter than the CDR encapsulation header".into());
        }
        let little = match (data[0], data[1]) {
            (0, 0) => false,
            (0, 1) => true,
            (a, b) => {
                return Err(format!(
                    "CDR encapsulation {a:#04x}{b:02x}: only classic CDR (0x0000, 0x0001) is read"
                ))
            }
        };
        let mut c = Cdr {
            data: &data[4..],
            at: 0,
            little,
        };
        self.record(&self.root, &mut c, 0)
    }

    fn record(&self, ty: &str, c: &mut Cdr, depth: usize) -> Result<Value, String> {
        if depth > 32 {
            return Err("message types nested more than 32 deep".into());
        }
        let fields = &self.types[ty];
        let mut out = Vec::with_capacity(fields.len());
        for f in fields {
            let v = match f.arity {
                Arity::One => self.value(&f.ty, c, depth)?,
                Arity::Fixed(n) => Value::List((0..n).map(|_| self.value(&f.ty, c, depth)).collect::<Result<_, _>>()?),
                Arity::Sequence => {
                    let n = c.u32()? as usize;
                    if n > c.data.len() {
                        return Err(format!(
                            "field {:?}: a sequence of {n} elements in a shorter message",
                            f.name
                        ));
                    }
                    Value::List((0..n).map(|_| self.value(&f.ty, c, depth)).collect::<Result<_, _>>()?)
                }
            };
            out.push((f.name.clone(), v));
        }
        Ok(Value::Record(out))
    }

    fn value(&self, ty: &Ros2Type, c: &mut Cdr, depth: usize) -> Result<Value, String> {
        match ty {
            Ros2Type::Primitive(name, size) => c.primitive(name, *size).map(Value::Number),
            Ros2Type::Text => {
                let n = c.u32()? as usize;
                c.take(n)?;
                Ok(Value::Text)
            }
            Ros2Type::Nested(t) => self.record(t, c, depth + 1),
        }
    }
}

/// A CDR cursor; alignment counts from the end of the encapsulation header.
struct Cdr<'a> {
    data: &'a [u8],
    at: usize,
    little: bool,
}

impl Cdr<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.data.len());
        let Some(end) = end else {
            return Err(format!(
                "truncated CDR message: {n} bytes wanted at byte {}",
                self.at + 4
            ));
        };
        let s = &self.data[self.at..end];
        self.at = end;
        Ok(s)
    }
    fn aligned(&mut self, size: usize) -> Result<[u8; 8], String> {
        self.at = self.at.div_ceil(size) * size;
        let little = self.little;
        let b = self.take(size)?;
        let mut out = [0u8; 8];
        if little {
            out[..size].copy_from_slice(b);
        } else {
            for (k, x) in b.iter().rev().enumerate() {
                out[k] = *x;
            }
        }
        Ok(out)
    }
    fn u32(&mut self) -> Result<u32, String> {
        let b = self.aligned(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn primitive(&mut self, name: &str, size: usize) -> Result<f64, String> {
        let b = self.aligned(size)?;
        Ok(match name {
            "bool" | "uint8" => b[0] as f64,
            "int8" => b[0] as i8 as f64,
            "int16" => i16::from_le_bytes([b[0], b[1]]) as f64,
            "uint16" => u16::from_le_bytes([b[0], b[1]]) as f64,
            "int32" => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            "uint32" => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            "int64" => i64::from_le_bytes(b) as f64,
            "uint64" => u64::from_le_bytes(b) as f64,
            "float32" => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            _ => f64::from_le_bytes(b),
        })
    }
}

// ---------------------------------------------------------------------------------------
// Protobuf: a FileDescriptorSet and the wire format.

#[derive(Debug, Clone)]
struct ProtoField {
    name: String,
    number: u64,
    /// FieldDescriptorProto.Type: 1 double … 18 sint64.
    ty: u64,
    repeated: bool,
    /// Full name of a message field's type (without the leading dot).
    type_name: String,
}

/// The message types of a `FileDescriptorSet` by full name, and the one to decode.
#[derive(Debug, Clone)]
pub struct ProtoSchema {
    root: String,
    types: BTreeMap<String, Vec<ProtoField>>,
}

/// A protobuf wire cursor.
struct Wire<'a> {
    data: &'a [u8],
    at: usize,
}

impl<'a> Wire<'a> {
    fn varint(&mut self) -> Result<u64, String> {
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let Some(&b) = self.data.get(self.at) else {
                return Err("truncated protobuf varint".into());
            };
            self.at += 1;
            v |= ((b & 0x7f) as u64) << shift;
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err("protobuf varint longer than 10 bytes".into())
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.data.len());
        let end = end.ok_or_else(|| format!("truncated protobuf message: {n} bytes wanted at byte {}", self.at))?;
        let s = &self.data[self.at..end];
        self.at = end;
        Ok(s)
    }
    /// The next field: (number, wire type, varint or fixed value, or length-delimited bytes).
    fn field(&mut self) -> Result<(u64, u8, u64, &'a [u8]), String> {
        let key = self.varint()?;
        let (number, wt) = (key >> 3, (key & 7) as u8);
        match wt {
            0 => Ok((number, 0, self.varint()?, &[])),
            1 => Ok((number, 1, u64::from_le_bytes(self.take(8)?.try_into().expect("8")), &[])),
            2 => {
                let n = self.varint()? as usize;
                Ok((number, 2, 0, self.take(n)?))
            }
            5 => Ok((
                number,
                5,
                u32::from_le_bytes(self.take(4)?.try_into().expect("4")) as u64,
                &[],
            )),
            _ => Err(format!("protobuf wire type {wt} (field {number}) is not read")),
        }
    }
    fn done(&self) -> bool {
        self.at >= self.data.len()
    }
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

impl ProtoSchema {
    pub fn parse(name: &str, set: &[u8]) -> Result<ProtoSchema, String> {
        let mut types = BTreeMap::new();
        let mut files = Wire { data: set, at: 0 };
        while !files.done() {
            let (n, _, _, file) = files.field()?;
            if n != 1 {
                continue;
            }
            let (mut package, mut messages) = (String::new(), Vec::new());
            let mut w = Wire { data: file, at: 0 };
            while !w.done() {
                match w.field()? {
                    (2, 2, _, b) => package = text(b),
                    (4, 2, _, b) => messages.push(b),
                    _ => {}
                }
            }
            for m in messages {
                Self::message(&package, m, &mut types)?;
            }
        }
        let root = name.trim_start_matches('.').to_string();
        if !types.contains_key(&root) {
            return Err(format!(
                "the protobuf schema has no message {root:?}; it has {}",
                types.keys().cloned().collect::<Vec<_>>().join(", ")
            ));
        }
        Ok(ProtoSchema { root, types })
    }

    fn message(scope: &str, b: &[u8], types: &mut BTreeMap<String, Vec<ProtoField>>) -> Result<(), String> {
        let (mut name, mut fields, mut nested) = (String::new(), Vec::new(), Vec::new());
        let mut w = Wire { data: b, at: 0 };
        while !w.done() {
            match w.field()? {
                (1, 2, _, b) => name = text(b),
                (2, 2, _, b) => fields.push(b),
                (3, 2, _, b) => nested.push(b),
                _ => {}
            }
        }
        let full = if scope.is_empty() {
            name
        } else {
            format!("{scope}.{name}")
        };
        let mut out = Vec::new();
        for f in fields {
            let mut field = ProtoField {
                name: String::new(),
                number: 0,
                ty: 0,
                repeated: false,
                type_name: String::new(),
            };
            let mut w = Wire { data: f, at: 0 };
            while !w.done() {
                match w.field()? {
                    (1, 2, _, b) => field.name = text(b),
                    (3, 0, v, _) => field.number = v,
                    (4, 0, v, _) => field.repeated = v == 3,
                    (5, 0, v, _) => field.ty = v,
                    (6, 2, _, b) => field.type_name = text(b).trim_start_matches('.').to_string(),
                    _ => {}
                }
            }
            out.push(field);
        }
        for n in nested {
            Self::message(&full, n, types)?;
        }
        types.insert(full, out);
        Ok(())
    }

    pub fn decode(&self, data: &[u8]) -> Result<Value, String> {
        self.record(&self.root, data, 0)
    }

    fn record(&self, ty: &str, data: &[u8], depth: usize) -> Result<Value, String> {
        if depth > 32 {
            return Err("message types nested more than 32 deep".into());
        }
        let Some(fields) = self.types.get(ty) else {
            return Err(format!("the protobuf schema lacks message type {ty:?}"));
        };
        let mut values: Vec<Vec<Value>> = vec![Vec::new(); fields.len()];
        let mut w = Wire { data, at: 0 };
        while !w.done() {
            let (number, wt, v, bytes) = w.field()?;
            let Some(k) = fields.iter().position(|f| f.number == number) else {
                continue;
            };
            let f = &fields[k];
            match (f.ty, wt) {
                (11, 2) => values[k].push(self.record(&f.type_name, bytes, depth + 1)?),
                (9 | 12, 2) => values[k].push(Value::Text),
                // A packed repeated scalar.
                (_, 2) => {
                    let mut p = Wire { data: bytes, at: 0 };
                    while !p.done() {
                        let raw = match f.ty {
                            1 | 6 | 16 => u64::from_le_bytes(p.take(8)?.try_into().expect("8")),
                            2 | 7 | 15 => u32::from_le_bytes(p.take(4)?.try_into().expect("4")) as u64,
                            _ => p.varint()?,
                        };
                        values[k].push(Value::Number(scalar(f.ty, raw)));
                    }
                }
                _ => values[k].push(Value::Number(scalar(f.ty, v))),
            }
        }
        let out = fields
            .iter()
            .zip(values)
            .filter_map(|(f, mut v)| {
                let value = if f.repeated {
                    Value::List(v)
                } else if let Some(last) = v.pop() {
                    last
                } else if f.ty == 11 || f.ty == 9 || f.ty == 12 {
                    return None;
                } else {
                    // proto3 leaves zeros out.
                    Value::Number(0.0)
                };
                Some((f.name.clone(), value))
            })
            .collect();
        Ok(Value::Record(out))
    }
}

/// A scalar field's value from its raw varint or fixed bits.
fn scalar(ty: u64, raw: u64) -> f64 {
    match ty {
        1 => f64::from_bits(raw),
        2 => f32::from_bits(raw as u32) as f64,
        3 | 16 => raw as i64 as f64,
        5 | 14 => raw as u32 as i32 as f64,
        15 => raw as u32 as i32 as f64,
        17 => {
            let v = raw as u32;
            ((v >> 1) as i32 ^ -((v & 1) as i32)) as f64
        }
        18 => ((raw >> 1) as i64 ^ -((raw & 1) as i64)) as f64,
        _ => raw as f64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ros2_cdr_with_a_header_arrays_and_alignment() {
        let def = "std_msgs/Header header\nfloat64[] position\nfloat32 gain  # comment\nint32 MODE=3\nuint8 flag\nfloat64 angle\n\
                   ================================================================================\n\
                   MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n";
        let s = Ros2Schema::parse("rig_msgs/msg/State", def).unwrap();
        let mut b = vec![0u8, 1, 0, 0];
        let mut body: Vec<u8> = Vec::new();
        let pad = |body: &mut Vec<u8>, a: usize| {
            while !body.len().is_multiple_of(a) {
                body.push(0)
            }
        };
        body.extend(7i32.to_le_bytes()); // stamp.sec
        body.extend(500u32.to_le_bytes()); // stamp.nanosec
        body.extend(4u32.to_le_bytes()); // frame_id length with its NUL
        body.extend(b"rig\0");
        body.extend(2u32.to_le_bytes()); // position: 2 elements
        pad(&mut body, 8);
        body.extend(1.5f64.to_le_bytes());
        body.extend((-2.25f64).to_le_bytes());
        body.extend(0.5f32.to_le_bytes());
        body.push(1);
        pad(&mut body, 8);
        body.extend(3.75f64.to_le_bytes());
        b.extend(body);
        let v = s.decode(&b).unwrap();
        assert_eq!(v.at("header.stamp.sec"), Some(7.0));
        assert_eq!(v.at("header.stamp.nanosec"), Some(500.0));
        assert_eq!(v.at("position.0"), Some(1.5));
        assert_eq!(v.at("position.1"), Some(-2.25));
        assert_eq!(v.at("position.2"), None);
        assert_eq!(v.at("gain"), Some(0.5));
        assert_eq!(v.at("flag"), Some(1.0));
        assert_eq!(v.at("angle"), Some(3.75));
        assert_eq!(v.at("header.frame_id"), None);
        // Cut short: an error, not a panic.
        assert!(s.decode(&b[..b.len() - 3]).unwrap_err().contains("truncated"));
        // A type the schema does not define.
        assert!(Ros2Schema::parse("a/B", "c/D d\n").unwrap_err().contains("lacks"));
    }

    fn key(n: u64, wt: u64) -> Vec<u8> {
        varint((n << 3) | wt)
    }
    fn varint(mut v: u64) -> Vec<u8> {
        let mut out = Vec::new();
        loop {
            let b = (v & 0x7f) as u8;
            v >>= 7;
            if v == 0 {
                out.push(b);
                return out;
            }
            out.push(b | 0x80);
        }
    }
    fn len(n: u64, b: &[u8]) -> Vec<u8> {
        let mut out = key(n, 2);
        out.extend(varint(b.len() as u64));
        out.extend(b);
        out
    }
    fn field(name: &str, number: u64, ty: u64, repeated: bool, type_name: &str) -> Vec<u8> {
        let mut f = len(1, name.as_bytes());
        f.extend(key(3, 0));
        f.extend(varint(number));
        f.extend(key(4, 0));
        f.extend(varint(if repeated { 3 } else { 1 }));
        f.extend(key(5, 0));
        f.extend(varint(ty));
        if !type_name.is_empty() {
            f.extend(len(6, type_name.as_bytes()));
        }
        f
    }

    #[test]
    fn protobuf_scalars_packed_nested_and_proto3_zeros() {
        // message Pose { double angle = 1; sint32 turns = 2; }
        // message State { Pose pose = 1; repeated double q = 2; float gain = 3; int64 count = 4; }
        let mut pose = len(1, b"Pose");
        pose.extend(len(2, &field("angle", 1, 1, false, "")));
        pose.extend(len(2, &field("turns", 2, 17, false, "")));
        let mut state = len(1, b"State");
        state.extend(len(2, &field("pose", 1, 11, false, ".rig.Pose")));
        state.extend(len(2, &field("q", 2, 1, true, "")));
        state.extend(len(2, &field("gain", 3, 2, false, "")));
        state.extend(len(2, &field("count", 4, 3, false, "")));
        let mut file = len(2, b"rig");
        file.extend(len(4, &pose));
        file.extend(len(4, &state));
        let set = len(1, &file);
        let s = ProtoSchema::parse("rig.State", &set).unwrap();
        let mut pose_msg = key(1, 1);
        pose_msg.extend(0.125f64.to_le_bytes());
        pose_msg.extend(key(2, 0));
        pose_msg.extend(varint(5)); // zigzag −3
        let mut msg = len(1, &pose_msg);
        let packed: Vec<u8> = [1.0f64, -4.5].iter().flat_map(|x| x.to_le_bytes()).collect();
        msg.extend(len(2, &packed));
        msg.extend(key(4, 0));
        msg.extend(varint((-2i64) as u64));
        let v = s.decode(&msg).unwrap();
        assert_eq!(v.at("pose.angle"), Some(0.125));
        assert_eq!(v.at("pose.turns"), Some(-3.0));
        assert_eq!(v.at("q.1"), Some(-4.5));
        assert_eq!(v.at("gain"), Some(0.0), "proto3 leaves zeros out");
        assert_eq!(v.at("count"), Some(-2.0));
        assert!(s.decode(&msg[..msg.len() - 1]).is_err());
        assert!(ProtoSchema::parse("rig.Other", &set).unwrap_err().contains("rig.State"));
    }
}

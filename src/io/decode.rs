//! Messages of MCAP topics written by other tools, decoded into a tree of values whose
//! numeric leaves a model's `[data]` section names by dotted paths (`pose.angle`,
//! `position.0` for an array's first element). Three encodings, the ones a rig's logger
//! writes into MCAP (docs/data.md):
//!
//! - `json` (Foxglove's JSON channels);
//! - `cdr` with a `ros2msg` schema (ROS 2): the message definition text with its
//!   dependencies after `====` / `MSG: pkg/Type` lines, classic little- or big-endian CDR;
//! - `protobuf` with a `protobuf` schema: a serialized `FileDescriptorSet` and the message's
//!   full name, decoded by `prost-reflect` (proto2 and proto3, packed or not; absent scalars
//!   at their default, maps as records keyed by the map's keys: `gains.k1`).

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

    /// The dotted paths of its numeric leaves, in order, for messages that name what a
    /// message has: a list of numbers as one entry, `q.0 … q.5`.
    pub fn numeric_paths(&self) -> Vec<String> {
        fn collect(v: &Value, prefix: &str, out: &mut Vec<String>) {
            let join = |k: &str| {
                if prefix.is_empty() {
                    k.to_string()
                } else {
                    format!("{prefix}.{k}")
                }
            };
            match v {
                Value::Number(_) => out.push(prefix.to_string()),
                Value::Text => {}
                Value::Record(fields) => {
                    for (k, x) in fields {
                        collect(x, &join(k), out);
                    }
                }
                Value::List(items) if !items.is_empty() && items.iter().all(|x| matches!(x, Value::Number(_))) => out
                    .push(match items.len() {
                        1 => join("0"),
                        n => format!("{} … {}", join("0"), join(&(n - 1).to_string())),
                    }),
                Value::List(items) => {
                    for (i, x) in items.iter().enumerate() {
                        collect(x, &join(&i.to_string()), out);
                    }
                }
            }
        }
        let mut out = Vec::new();
        collect(self, "", &mut out);
        out
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
// Protobuf: the schema's FileDescriptorSet and dynamic messages, by prost-reflect.

/// The message type to decode, from the schema's `FileDescriptorSet`.
#[derive(Debug, Clone)]
pub struct ProtoSchema {
    message: prost_reflect::MessageDescriptor,
}

impl ProtoSchema {
    /// The message `name` (its full name, `package.Type`) of the serialized
    /// `FileDescriptorSet` `set`.
    pub fn parse(name: &str, set: &[u8]) -> Result<ProtoSchema, String> {
        let pool = prost_reflect::DescriptorPool::decode(set)
            .map_err(|e| format!("the protobuf schema is not a valid FileDescriptorSet: {e}"))?;
        let root = name.trim_start_matches('.');
        match pool.get_message_by_name(root) {
            Some(message) => Ok(ProtoSchema { message }),
            None => Err(format!(
                "the protobuf schema has no message {root:?}; it has {}",
                pool.all_messages()
                    .map(|m| m.full_name().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
        }
    }

    pub fn decode(&self, data: &[u8]) -> Result<Value, String> {
        let msg = prost_reflect::DynamicMessage::decode(self.message.clone(), data)
            .map_err(|e| format!("protobuf message of {}: {e}", self.message.full_name()))?;
        Ok(Self::record(&msg))
    }

    /// Every field of `msg` by name: absent scalars at their default (proto3 leaves zeros
    /// out), absent sub-messages left out, maps as records keyed by the map's keys.
    fn record(msg: &prost_reflect::DynamicMessage) -> Value {
        use prost_reflect::ReflectMessage;
        let fields = msg
            .descriptor()
            .fields()
            .filter(|f| f.is_list() || f.is_map() || f.kind().as_message().is_none() || msg.has_field(f))
            .map(|f| (f.name().to_string(), Self::value(&msg.get_field(&f))))
            .collect();
        Value::Record(fields)
    }

    fn value(v: &prost_reflect::Value) -> Value {
        use prost_reflect::Value as P;
        match v {
            P::Bool(b) => Value::Number(f64::from(u8::from(*b))),
            P::I32(x) | P::EnumNumber(x) => Value::Number(f64::from(*x)),
            P::I64(x) => Value::Number(*x as f64),
            P::U32(x) => Value::Number(f64::from(*x)),
            P::U64(x) => Value::Number(*x as f64),
            P::F32(x) => Value::Number(f64::from(*x)),
            P::F64(x) => Value::Number(*x),
            P::String(_) | P::Bytes(_) => Value::Text,
            P::Message(m) => Self::record(m),
            P::List(items) => Value::List(items.iter().map(Self::value).collect()),
            P::Map(map) => {
                let mut entries: Vec<_> = map.iter().collect();
                entries.sort_by(|a, b| a.0.cmp(b.0));
                Value::Record(entries.into_iter().map(|(k, v)| (map_key(k), Self::value(v))).collect())
            }
        }
    }
}

/// A map key as a path component.
fn map_key(k: &prost_reflect::MapKey) -> String {
    use prost_reflect::MapKey as K;
    match k {
        K::Bool(b) => b.to_string(),
        K::I32(x) => x.to_string(),
        K::I64(x) => x.to_string(),
        K::U32(x) => x.to_string(),
        K::U64(x) => x.to_string(),
        K::String(s) => s.clone(),
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

    /// The `FileDescriptorSet` of package `rig`:
    /// `message Pose { double angle = 1; sint32 turns = 2; }`,
    /// `message State { Pose pose = 1; repeated double q = 2; float gain = 3; int64 count = 4;
    /// map<string, double> gains = 5; string frame = 6; }` (proto3).
    fn rig_schema() -> Vec<u8> {
        use prost::Message;
        use prost_types::field_descriptor_proto::{Label, Type};
        use prost_types::{DescriptorProto, FieldDescriptorProto, FileDescriptorProto, FileDescriptorSet};
        let field = |name: &str, number: i32, ty: Type, label: Label, type_name: &str| FieldDescriptorProto {
            name: Some(name.into()),
            number: Some(number),
            r#type: Some(ty as i32),
            label: Some(label as i32),
            type_name: (!type_name.is_empty()).then(|| type_name.into()),
            ..Default::default()
        };
        let one = Label::Optional;
        let pose = DescriptorProto {
            name: Some("Pose".into()),
            field: vec![
                field("angle", 1, Type::Double, one, ""),
                field("turns", 2, Type::Sint32, one, ""),
            ],
            ..Default::default()
        };
        let entry = DescriptorProto {
            name: Some("GainsEntry".into()),
            field: vec![
                field("key", 1, Type::String, one, ""),
                field("value", 2, Type::Double, one, ""),
            ],
            options: Some(prost_types::MessageOptions {
                map_entry: Some(true),
                ..Default::default()
            }),
            ..Default::default()
        };
        let state = DescriptorProto {
            name: Some("State".into()),
            field: vec![
                field("pose", 1, Type::Message, one, ".rig.Pose"),
                field("q", 2, Type::Double, Label::Repeated, ""),
                field("gain", 3, Type::Float, one, ""),
                field("count", 4, Type::Int64, one, ""),
                field("gains", 5, Type::Message, Label::Repeated, ".rig.State.GainsEntry"),
                field("frame", 6, Type::String, one, ""),
            ],
            nested_type: vec![entry],
            ..Default::default()
        };
        FileDescriptorSet {
            file: vec![FileDescriptorProto {
                name: Some("rig.proto".into()),
                package: Some("rig".into()),
                message_type: vec![pose, state],
                syntax: Some("proto3".into()),
                ..Default::default()
            }],
        }
        .encode_to_vec()
    }

    #[test]
    fn protobuf_scalars_packed_nested_maps_and_proto3_zeros() {
        let set = rig_schema();
        let s = ProtoSchema::parse("rig.State", &set).unwrap();
        // The wire bytes written by hand, as another tool's encoder would.
        let mut pose_msg = key(1, 1);
        pose_msg.extend(0.125f64.to_le_bytes());
        pose_msg.extend(key(2, 0));
        pose_msg.extend(varint(5)); // zigzag −3
        let mut msg = len(1, &pose_msg);
        let packed: Vec<u8> = [1.0f64, -4.5].iter().flat_map(|x| x.to_le_bytes()).collect();
        msg.extend(len(2, &packed));
        msg.extend(key(4, 0));
        msg.extend(varint((-2i64) as u64));
        let mut entry = len(1, b"k1");
        entry.extend(key(2, 1));
        entry.extend(7.5f64.to_le_bytes());
        msg.extend(len(5, &entry));
        msg.extend(len(6, b"base"));
        let v = s.decode(&msg).unwrap();
        assert_eq!(v.at("pose.angle"), Some(0.125));
        assert_eq!(v.at("pose.turns"), Some(-3.0));
        assert_eq!(v.at("q.1"), Some(-4.5));
        assert_eq!(v.at("gain"), Some(0.0), "proto3 leaves zeros out");
        assert_eq!(v.at("count"), Some(-2.0));
        assert_eq!(v.at("gains.k1"), Some(7.5));
        assert_eq!(v.at("frame"), None, "text is not a number");
        assert_eq!(
            v.numeric_paths(),
            ["pose.angle", "pose.turns", "q.0 … q.1", "gain", "count", "gains.k1"]
        );
        // An absent sub-message is absent, not a record of zeros.
        let only_q = len(2, &packed);
        assert_eq!(s.decode(&only_q).unwrap().at("pose.angle"), None);
        // Cut short: an error, not a panic.
        assert!(s.decode(&msg[..msg.len() - 1]).is_err());
        assert!(ProtoSchema::parse("rig.Other", &set).unwrap_err().contains("rig.State"));
        assert!(ProtoSchema::parse("rig.State", &set[..set.len() - 3]).is_err());
    }
}

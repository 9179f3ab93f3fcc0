//! The protobuf envelope of a record's raw payloads: each payload is stored as a
//! protobuf message with one field, `bytes data = 1`, so Foxglove and Lichtblick (which
//! parse every channel of a file on open and flag any encoding but `json`, `protobuf`,
//! `flatbuffer`, `ros1` and `cdr`) list the raw channels as ordinary topics instead of
//! "Unsupported encoding" problems. The payload bytes inside are unchanged; the reader
//! takes them out again, so what replay, inspect, diff, profile and export see is
//! byte-identical to shared memory.
//!
//! The schema of a raw channel is a protobuf `FileDescriptorSet` declaring the message
//! named exactly as the aisle type (`aisle.PointCloud.v1`: package `aisle.PointCloud`,
//! message `v1`), so the schema name stays the type name. Written by hand: three nested
//! descriptors are all it takes, and no protobuf code generator is needed for them.
//!
//! Knows the protobuf wire format of one bytes field and of the descriptors; nothing of
//! the file or of what the payloads mean.

/// Tag of field 1 with wire type 2 (length-delimited).
const DATA_TAG: u8 = 0x0a;

fn varint(mut v: u64, out: &mut Vec<u8>) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// Appends the envelope of `payload` to `out` (cleared first).
pub fn wrap(payload: &[u8], out: &mut Vec<u8>) {
    out.clear();
    out.reserve(payload.len() + 11);
    out.push(DATA_TAG);
    varint(payload.len() as u64, out);
    out.extend_from_slice(payload);
}

/// The payload inside an envelope, or why `data` is not one.
pub fn unwrap(data: &[u8]) -> Result<&[u8], String> {
    let Some((&DATA_TAG, rest)) = data.split_first() else {
        return Err("a raw message does not start with its envelope's field tag".into());
    };
    let mut len: u64 = 0;
    for (i, &b) in rest.iter().enumerate().take(10) {
        len |= u64::from(b & 0x7f) << (7 * i);
        if b & 0x80 == 0 {
            let body = &rest[i + 1..];
            return if body.len() as u64 == len {
                Ok(body)
            } else {
                Err(format!(
                    "a raw message's envelope says {len} bytes, {} follow",
                    body.len()
                ))
            };
        }
    }
    Err("a raw message's envelope has no valid length".into())
}

/// True when `name` is a protobuf identifier.
fn identifier(name: &str) -> bool {
    let mut chars = name.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// The protobuf package and message name of the envelope of `type_name`: the type name
/// itself when it is a valid full name (every aisle type is), else one made valid.
pub fn message_name(type_name: &str) -> (String, String) {
    if let Some((package, name)) = type_name.rsplit_once('.')
        && package.split('.').all(identifier)
        && identifier(name)
    {
        return (package.to_string(), name.to_string());
    }
    let mut name: String = type_name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if !identifier(&name) {
        name.insert(0, '_');
    }
    ("aisle.raw".to_string(), name)
}

fn field(number: u8, bytes: &[u8], out: &mut Vec<u8>) {
    out.push(number << 3 | 2);
    varint(bytes.len() as u64, out);
    out.extend_from_slice(bytes);
}

fn number(field_number: u8, v: u64, out: &mut Vec<u8>) {
    out.push(field_number << 3);
    varint(v, out);
}

/// The full name of the envelope message of `type_name` and its `FileDescriptorSet`.
pub fn schema(type_name: &str) -> (String, Vec<u8>) {
    let (package, name) = message_name(type_name);
    // FieldDescriptorProto: name 1, number 3, label 4 (optional = 1), type 5 (bytes =
    // 12), json_name 10.
    let mut data_field = Vec::new();
    field(1, b"data", &mut data_field);
    number(3, 1, &mut data_field);
    number(4, 1, &mut data_field);
    number(5, 12, &mut data_field);
    field(10, b"data", &mut data_field);
    // DescriptorProto: name 1, field 2.
    let mut message = Vec::new();
    field(1, name.as_bytes(), &mut message);
    field(2, &data_field, &mut message);
    // FileDescriptorProto: name 1, package 2, message_type 4, syntax 12.
    let mut file = Vec::new();
    let file_name = format!("{}/{name}.proto", package.replace('.', "/"));
    field(1, file_name.as_bytes(), &mut file);
    field(2, package.as_bytes(), &mut file);
    field(4, &message, &mut file);
    field(12, b"proto3", &mut file);
    // FileDescriptorSet: file 1.
    let mut set = Vec::new();
    field(1, &file, &mut set);
    (format!("{package}.{name}"), set)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_and_unwrap_give_the_payload_back() {
        let mut out = Vec::new();
        for n in [0usize, 1, 127, 128, 300, 1 << 20] {
            let payload: Vec<u8> = (0..n).map(|i| i as u8).collect();
            wrap(&payload, &mut out);
            assert_eq!(unwrap(&out).unwrap(), payload.as_slice(), "{n}");
        }
        // 300 = 0b10_0101100: two length bytes.
        wrap(&[7; 300], &mut out);
        assert_eq!(&out[..3], &[0x0a, 0xac, 0x02]);
        assert!(unwrap(&out[..out.len() - 1]).is_err());
        assert!(unwrap(&[0x12, 0]).is_err());
        assert!(unwrap(&[]).is_err());
        assert!(unwrap(&[0x0a, 0xff, 0xff]).is_err());
    }

    #[test]
    fn the_schema_is_named_as_the_type() {
        let (name, set) = schema("aisle.PointCloud.v1");
        assert_eq!(name, "aisle.PointCloud.v1");
        let text = String::from_utf8_lossy(&set);
        assert!(text.contains("aisle/PointCloud/v1.proto") && text.contains("proto3"));
        assert_eq!(
            message_name("9 bad.name"),
            ("aisle.raw".into(), "_9_bad_name".into())
        );
    }
}

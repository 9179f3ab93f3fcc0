//! A payload as text, field by field (like `ros2 topic echo`): one `name: value` line
//! per field in declaration order, nested structs indented, arrays of numbers on one
//! line, long arrays cut after a few elements with their length said, padding left out.
//! An array the message uses in part (`Message::used_len`: a cloud's `rows x cols`
//! points, a grid's cells) shows its used elements, then `(capacity N)`.
//!
//! Works from the layout descriptions of the catalogue (`FieldLayout`), so it knows every
//! message type without a line per type. Knows nothing of the bus or of files.

use crate::diff::{array_parts, nested, primitive, primitive_size, type_size};
use aisle_messages::{FieldLayout, all_layouts, read_name};
use std::fmt::Write;

/// How much of a long array is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TextOptions {
    /// Elements of an array of numbers.
    pub numbers: usize,
    /// Elements of an array of structs.
    pub structs: usize,
}

impl Default for TextOptions {
    fn default() -> Self {
        TextOptions {
            numbers: 8,
            structs: 3,
        }
    }
}

/// The text of one payload of the message type `type_name`; `None` when the type is
/// not in the catalogue. A short payload reads as zeros past its end.
pub fn payload_text(type_name: &str, bytes: &[u8], opts: &TextOptions) -> Option<String> {
    let layouts = all_layouts();
    let (_, size, _, fields) = layouts.iter().find(|l| l.0 == type_name)?;
    let mut padded;
    let bytes = if bytes.len() < *size {
        padded = bytes.to_vec();
        padded.resize(*size, 0);
        &padded[..]
    } else {
        bytes
    };
    // The bytes the message says it uses (a cloud's rows x cols points, a grid's
    // cells): an array past them shows its used elements, and its capacity as such.
    let used = crate::catalog::used_len(type_name, bytes).unwrap_or(*size);
    let mut out = String::new();
    write_fields(&mut out, fields, &bytes[..*size], 0, opts, used);
    Some(out)
}

/// The fields of `b` at `indent`; an array reaching past `used` bytes is cut there.
fn write_fields(
    out: &mut String,
    fields: &[FieldLayout],
    b: &[u8],
    indent: usize,
    o: &TextOptions,
    used: usize,
) {
    for f in fields {
        if f.name.starts_with('_') {
            continue; // padding
        }
        let ty = f.ty.trim();
        let end = f.offset + f.size;
        let field = Field {
            name: f.name,
            ty,
            capacity: (end > used)
                .then(|| array_parts(ty).and_then(|(e, _)| type_size(e)))
                .flatten()
                .filter(|&es| es > 0)
                .map(|es| f.size / es),
        };
        let end = if field.capacity.is_some() {
            used.max(f.offset)
        } else {
            end
        };
        write_field(out, &field, &b[f.offset..end], indent, o);
    }
}

/// One field: its name, type and, for an array the message uses only in part, its
/// capacity in elements.
struct Field<'a> {
    name: &'a str,
    ty: &'a str,
    capacity: Option<usize>,
}

fn write_field(out: &mut String, f: &Field, b: &[u8], indent: usize, o: &TextOptions) {
    let (name, ty) = (f.name, f.ty);
    let pad = "  ".repeat(indent);
    let cap = |n: usize| match f.capacity {
        Some(c) if c != n => format!(" (capacity {c})"),
        _ => String::new(),
    };
    if let Some(elem) = array_parts(ty).map(|(e, _)| e) {
        if elem == "u8" && (name == "name" || name == "text") {
            let _ = writeln!(out, "{pad}{name}: {:?}", read_name(b));
            return;
        }
        let es = type_size(elem).filter(|&s| s > 0).unwrap_or(b.len().max(1));
        let n = b.len() / es;
        if let Some(line) = inline(ty, b, o) {
            let _ = writeln!(out, "{pad}{name}: {line}{}", cap(n));
            return;
        }
        let shown = n.min(o.structs);
        if shown < n {
            let _ = writeln!(
                out,
                "{pad}{name}: # {n} elements, the first {shown}{}",
                cap(n)
            );
        } else if f.capacity.is_some() {
            let _ = writeln!(out, "{pad}{name}: # {n} elements{}", cap(n));
        } else {
            let _ = writeln!(out, "{pad}{name}:");
        }
        for i in 0..shown {
            let mut item = String::new();
            write_value(&mut item, elem, &b[i * es..(i + 1) * es], indent + 2, o);
            // YAML list item: the first line's indentation ends in "- ".
            let cut = (indent + 1) * 2;
            if item.len() >= cut + 2 {
                let _ = write!(out, "{}- {}", "  ".repeat(indent + 1), &item[cut + 2..]);
            }
        }
        return;
    }
    if let Some(v) = primitive(ty, b) {
        let _ = writeln!(out, "{pad}{name}: {v}");
        return;
    }
    let _ = writeln!(out, "{pad}{name}:");
    write_value(out, ty, b, indent + 1, o);
}

/// A struct's fields at `indent` (an element of an array of structs).
fn write_value(out: &mut String, ty: &str, b: &[u8], indent: usize, o: &TextOptions) {
    match nested(ty) {
        Some(fields) => write_fields(out, fields, b, indent, o, b.len()),
        None => {
            let _ = writeln!(out, "{}{:02x?}", "  ".repeat(indent), b);
        }
    }
}

/// An array of numbers (or of arrays of numbers) on one line, cut after
/// `o.numbers` elements; `None` for an array of structs.
fn inline(ty: &str, b: &[u8], o: &TextOptions) -> Option<String> {
    if let Some(v) = primitive(ty, b) {
        return Some(v);
    }
    let (elem, _) = array_parts(ty)?;
    let numeric = |t: &str| {
        let mut t = t;
        while let Some((e, _)) = array_parts(t) {
            t = e;
        }
        primitive_size(t).is_some()
    };
    if !numeric(elem) {
        return None;
    }
    let es = type_size(elem).filter(|&s| s > 0)?;
    let n = b.len() / es;
    let shown = n.min(o.numbers);
    let mut parts = Vec::with_capacity(shown + 1);
    for i in 0..shown {
        parts.push(inline(elem, &b[i * es..(i + 1) * es], o)?);
    }
    if shown < n {
        parts.push(format!("... ({n} values)"));
    }
    Some(format!("[{}]", parts.join(", ")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aligned::{message_bytes, zeroed_box};
    use aisle_messages::{
        Heartbeat, OccupancyGrid, PointCloud, RobotState, Trajectory, write_name,
    };

    #[test]
    fn header_first_then_fields_nested_and_inline() {
        let mut m = zeroed_box::<RobotState>();
        m.header.seq = 12;
        m.header.stamp_ns = 1_500_000_000;
        m.pose.x = 1.25;
        m.twist = [0.5, -0.25];
        let t = payload_text(
            RobotState::TYPE_NAME,
            message_bytes(&*m),
            &TextOptions::default(),
        )
        .unwrap();
        assert!(
            t.starts_with("header:\n  seq: 12\n  stamp_ns: 1500000000\n"),
            "{t}"
        );
        assert!(t.contains("pose:\n  x: 1.25\n"), "{t}");
        assert!(t.contains("twist: [0.5, -0.25]\n"), "{t}");
        assert!(!t.contains("_pad"), "{t}");
    }

    #[test]
    fn long_arrays_are_cut_with_their_length_and_names_read_as_text() {
        let mut g = zeroed_box::<OccupancyGrid>();
        (g.width, g.height) = (40, 25);
        g.cells[1] = 100;
        let t = payload_text(
            OccupancyGrid::TYPE_NAME,
            message_bytes(&*g),
            &TextOptions::default(),
        )
        .unwrap();
        let c = aisle_messages::MAX_GRID_CELLS;
        assert!(
            t.contains(&format!(
                "cells: [0, 100, 0, 0, 0, 0, 0, 0, ... (1000 values)] (capacity {c})"
            )),
            "{t}"
        );
        let mut tr = zeroed_box::<Trajectory>();
        tr.commands[1].v = 0.75;
        let t = payload_text(
            Trajectory::TYPE_NAME,
            message_bytes(&*tr),
            &TextOptions::default(),
        )
        .unwrap();
        let n = aisle_messages::MAX_COMMANDS;
        assert!(
            t.contains(&format!("commands: # {n} elements, the first 3\n")),
            "{t}"
        );
        assert!(t.contains("\n  - "), "{t}");
        assert!(t.contains("v: 0.75"), "{t}");
        let mut h = zeroed_box::<Heartbeat>();
        write_name(&mut h.text, "planning");
        let t = payload_text(
            Heartbeat::TYPE_NAME,
            message_bytes(&*h),
            &TextOptions::default(),
        )
        .unwrap();
        assert!(t.contains("text: \"planning\"\n"), "{t}");
        assert_eq!(
            payload_text("aisle.Nope.v1", &[], &TextOptions::default()),
            None
        );
    }

    #[test]
    fn a_cloud_shows_the_points_its_rows_and_cols_use_and_its_capacity_as_such() {
        let mut c = zeroed_box::<PointCloud>();
        (c.rows, c.cols) = (2, 3);
        c.points[0] = [1.5, 0.0, 0.25];
        c.points[9] = [9.0, 9.0, 9.0]; // past the used points: not shown
        let t = payload_text(
            PointCloud::TYPE_NAME,
            message_bytes(&*c),
            &TextOptions::default(),
        )
        .unwrap();
        let cap = aisle_messages::MAX_CLOUD_POINTS;
        let line = t.lines().find(|l| l.starts_with("points:")).unwrap();
        assert_eq!(
            line,
            format!(
                "points: [[1.5, 0.0, 0.25], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], \
[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]] (capacity {cap})"
            ),
            "{t}"
        );
        (c.rows, c.cols) = (31, 1201);
        let t = payload_text(
            PointCloud::TYPE_NAME,
            message_bytes(&*c),
            &TextOptions::default(),
        )
        .unwrap();
        assert!(
            t.contains(&format!("... (37231 values)] (capacity {cap})\n")),
            "{t}"
        );
        assert!(!t.contains(&format!("({cap} values)")), "{t}");
    }

    #[test]
    fn every_catalogue_type_prints_and_a_short_payload_reads_as_zeros() {
        for (name, size, _, _) in all_layouts() {
            let t = payload_text(name, &vec![0u8; size], &TextOptions::default()).unwrap();
            assert!(
                !t.is_empty() && t.lines().count() < 400,
                "{name}: {} lines",
                t.lines().count()
            );
            assert_eq!(
                payload_text(name, &[], &TextOptions::default()).unwrap(),
                t,
                "{name}"
            );
        }
    }
}

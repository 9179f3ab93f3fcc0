//! Field-level comparison of two payloads of the same message type: the first field that
//! differs, named by its path (`commands[3].v`, `header.stamp_ns`, `cells[5120]`) with
//! both values decoded.
//!
//! Works from the layout descriptions every message carries (`FIELDS`), so it knows
//! every type of the catalogue without a line per type. Knows nothing of files or the
//! bus; the caller says which field paths to leave out (wall-clock times).

use aisle_messages::{FieldLayout, all_layouts};

/// The first difference between two payloads.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldDiff {
    /// Path of the field, e.g. `commands[3].v`.
    pub field: String,
    /// Value in the first payload (the recorded one), decoded.
    pub recorded: String,
    /// Value in the second payload (the live one), decoded.
    pub live: String,
}

impl std::fmt::Display for FieldDiff {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: recorded {}, live {}",
            self.field, self.recorded, self.live
        )
    }
}

/// Fields measured on the wall clock, which differ between any two runs.
pub const WALL_CLOCK_FIELDS: [&str; 6] = [
    "header.seq",
    "header.tick_wall_ns",
    "header.publish_wall_ns",
    "solve_ns",
    "compute_ns",
    "cpu_ns",
];

/// The first field (in declaration order, depth first) whose bytes differ between `a`
/// and `b`, both payloads of the message type `type_name`, skipping the field paths in
/// `ignore` (an ignored struct skips everything in it). `None` when they are equal. A
/// payload of the wrong size is reported as a difference of `<size>`.
pub fn first_difference(type_name: &str, a: &[u8], b: &[u8], ignore: &[&str]) -> Option<FieldDiff> {
    let layouts = all_layouts();
    let Some((_, size, _, fields)) = layouts.iter().find(|l| l.0 == type_name) else {
        return (a != b).then(|| FieldDiff {
            field: "<unknown type>".into(),
            recorded: format!("{} bytes", a.len()),
            live: format!("{} bytes", b.len()),
        });
    };
    if a.len() > *size || b.len() > *size {
        return Some(FieldDiff {
            field: "<size>".into(),
            recorded: format!("{} bytes", a.len()),
            live: format!("{} bytes", b.len()),
        });
    }
    walk(fields, &padded(a, *size), &padded(b, *size), "", ignore)
}

/// `x` as a message of `size` bytes: a payload as a bus port hands it out (its used
/// part) reads as zeros past its end.
fn padded(x: &[u8], size: usize) -> std::borrow::Cow<'_, [u8]> {
    if x.len() == size {
        x.into()
    } else {
        let mut whole = x.to_vec();
        whole.resize(size, 0);
        whole.into()
    }
}

/// Depth-first search over `fields` laid out from byte 0 of `a` and `b`.
fn walk(
    fields: &[FieldLayout],
    a: &[u8],
    b: &[u8],
    prefix: &str,
    ignore: &[&str],
) -> Option<FieldDiff> {
    for f in fields {
        let path = if prefix.is_empty() {
            f.name.to_string()
        } else {
            format!("{prefix}.{}", f.name)
        };
        if ignore.contains(&path.as_str()) {
            continue;
        }
        let range = f.offset..f.offset + f.size;
        let (fa, fb) = (&a[range.clone()], &b[range]);
        if fa == fb {
            continue;
        }
        if let Some(d) = value_diff(f.ty, fa, fb, &path, ignore) {
            return Some(d);
        }
    }
    None
}

/// The difference inside one field of type `ty` (as written in the source).
fn value_diff(ty: &str, a: &[u8], b: &[u8], path: &str, ignore: &[&str]) -> Option<FieldDiff> {
    let ty = ty.trim();
    if let Some((elem, _)) = array_parts(ty) {
        let elem_size = type_size(elem).filter(|&s| s > 0 && a.len().is_multiple_of(s))?;
        let i = (0..a.len() / elem_size).find(|i| {
            a[i * elem_size..(i + 1) * elem_size] != b[i * elem_size..(i + 1) * elem_size]
        })?;
        let range = i * elem_size..(i + 1) * elem_size;
        return value_diff(
            elem,
            &a[range.clone()],
            &b[range],
            &format!("{path}[{i}]"),
            ignore,
        );
    }
    if let Some(v) = primitive(ty, a) {
        return Some(FieldDiff {
            field: path.to_string(),
            recorded: v,
            live: primitive(ty, b).unwrap_or_default(),
        });
    }
    match nested(ty) {
        Some(fields) => walk(fields, a, b, path, ignore),
        None => Some(FieldDiff {
            field: path.to_string(),
            recorded: format!("{a:02x?}"),
            live: format!("{b:02x?}"),
        }),
    }
}

/// A number decoded from its little-endian bytes; `None` when `ty` is not a number type.
pub(crate) fn primitive(ty: &str, bytes: &[u8]) -> Option<String> {
    macro_rules! num {
        ($($t:ty),*) => {
            $(if ty == stringify!($t) {
                let arr: [u8; std::mem::size_of::<$t>()] = bytes.try_into().ok()?;
                return Some(format!("{:?}", <$t>::from_le_bytes(arr)));
            })*
        };
    }
    num!(u8, i8, u16, i16, u32, i32, u64, i64, f32, f64);
    None
}

pub(crate) fn primitive_size(ty: &str) -> Option<usize> {
    Some(match ty {
        "u8" | "i8" => 1,
        "u16" | "i16" => 2,
        "u32" | "i32" | "f32" => 4,
        "u64" | "i64" | "f64" => 8,
        _ => return None,
    })
}

/// `[T; N]` as (`T`, `N`), both trimmed; `T` may itself be an array.
pub(crate) fn array_parts(ty: &str) -> Option<(&str, &str)> {
    let inner = ty.trim().strip_prefix('[')?.strip_suffix(']')?;
    let (elem, len) = inner.rsplit_once(';')?;
    Some((elem.trim(), len.trim()))
}

pub(crate) fn type_size(ty: &str) -> Option<usize> {
    if let Some((elem, len)) = array_parts(ty) {
        return type_size(elem)?.checked_mul(len.parse().ok()?);
    }
    primitive_size(ty).or_else(|| {
        let name = ty.trim();
        all_layouts()
            .into_iter()
            .find(|l| ident_matches(name, l.0))
            .map(|l| l.1)
    })
}

/// The fields of the nested struct written `ident` in a field type.
pub(crate) fn nested(ident: &str) -> Option<&'static [FieldLayout]> {
    all_layouts()
        .into_iter()
        .find(|l| ident_matches(ident, l.0))
        .map(|l| l.3)
}

/// Field types name nested structs by Rust identifier (`TimedCommandMsg`), layouts by
/// versioned type name (`aisle.TimedCommand.v1`).
fn ident_matches(ident: &str, type_name: &str) -> bool {
    let mut parts = type_name.split('.');
    let (Some("aisle"), Some(base)) = (parts.next(), parts.next()) else {
        return false;
    };
    ident == base || ident.strip_suffix("Msg") == Some(base)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aligned::{message_bytes, zeroed_box};
    use aisle_messages::{OccupancyGrid, TickDone, Trajectory};

    #[test]
    fn every_field_type_of_every_layout_resolves() {
        for (name, size, _, fields) in all_layouts() {
            let mut end = 0;
            for f in fields {
                let ty = f.ty.trim();
                let resolved = match array_parts(ty) {
                    Some((elem, _)) => type_size(elem).map(|s| s > 0 && f.size.is_multiple_of(s)),
                    None => type_size(ty).map(|s| s == f.size),
                };
                assert_eq!(resolved, Some(true), "{name}.{}: {}", f.name, f.ty);
                end = end.max(f.offset + f.size);
            }
            assert!(end <= size, "{name}");
        }
    }

    #[test]
    fn equal_payloads_have_no_difference() {
        let t = zeroed_box::<Trajectory>();
        let b = message_bytes(&*t);
        assert_eq!(first_difference(Trajectory::TYPE_NAME, b, b, &[]), None);
    }

    #[test]
    fn names_the_nested_array_element_and_both_values() {
        let a = zeroed_box::<Trajectory>();
        let mut b = a.clone();
        b.commands[3].v = 0.5;
        b.commands[7].w = -1.0;
        let d = first_difference(
            Trajectory::TYPE_NAME,
            message_bytes(&*a),
            message_bytes(&*b),
            &[],
        )
        .unwrap();
        assert_eq!(d.field, "commands[3].v");
        assert_eq!((d.recorded.as_str(), d.live.as_str()), ("0.0", "0.5"));
    }

    #[test]
    fn ignored_wall_clock_fields_are_skipped_but_the_rest_is_not() {
        let a = zeroed_box::<Trajectory>();
        let mut b = a.clone();
        b.header.publish_wall_ns = 123;
        b.header.seq = 9;
        b.solve_ns = 77;
        let (ra, rb) = (message_bytes(&*a).to_vec(), message_bytes(&*b).to_vec());
        assert_eq!(
            first_difference(Trajectory::TYPE_NAME, &ra, &rb, &WALL_CLOCK_FIELDS),
            None
        );
        let d = first_difference(Trajectory::TYPE_NAME, &ra, &rb, &[]).unwrap();
        assert_eq!(d.field, "header.seq");
        b.header.stamp_ns = 5;
        let d = first_difference(
            Trajectory::TYPE_NAME,
            &ra,
            message_bytes(&*b),
            &WALL_CLOCK_FIELDS,
        )
        .unwrap();
        assert_eq!(d.to_string(), "header.stamp_ns: recorded 0, live 5");
    }

    #[test]
    fn grid_cells_and_sizes() {
        let a = zeroed_box::<OccupancyGrid>();
        let mut b = a.clone();
        b.cells[5120] = 2;
        let d = first_difference(
            OccupancyGrid::TYPE_NAME,
            message_bytes(&*a),
            message_bytes(&*b),
            &[],
        )
        .unwrap();
        assert_eq!(d.field, "cells[5120]");
        assert_eq!(d.live, "2");
        // The used part a port hands out reads as zeros past its end.
        let short = &message_bytes(&*a)[..100];
        let d = first_difference(OccupancyGrid::TYPE_NAME, short, message_bytes(&*b), &[]);
        assert_eq!(d.unwrap().field, "cells[5120]");
        assert!(
            first_difference(OccupancyGrid::TYPE_NAME, short, message_bytes(&*a), &[]).is_none()
        );
        let long = [message_bytes(&*a), &[0u8; 8]].concat();
        let d = first_difference(OccupancyGrid::TYPE_NAME, &long, message_bytes(&*b), &[]);
        assert_eq!(d.unwrap().field, "<size>");
        let t = zeroed_box::<TickDone>();
        assert!(first_difference("aisle.Nope.v1", message_bytes(&*t), &[], &[]).is_some());
    }
}

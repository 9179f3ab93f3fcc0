//! A message field's Rust type (as `FieldLayout::ty` writes it) as a ctypes expression:
//! numbers, catalogue structs and fixed-size arrays of them. Knows the catalogue's
//! layouts and constants; nothing of files or the CLI.

use anyhow::{Context, bail};
use std::collections::HashMap;

/// A field type the generator can express.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Ty {
    /// A number: its ctypes name and size.
    Prim(&'static str, usize),
    /// A catalogue struct: its Rust (and Python) name and size.
    Struct(String, usize),
    /// `[T; N]`.
    Array(Box<Ty>, usize),
}

impl Ty {
    pub fn size(&self) -> usize {
        match self {
            Ty::Prim(_, s) | Ty::Struct(_, s) => *s,
            Ty::Array(t, n) => t.size() * n,
        }
    }

    /// The ctypes expression of the type, e.g. `(ctypes.c_float * 3) * 131072`.
    pub fn ctypes(&self) -> String {
        match self {
            Ty::Prim(name, _) => format!("ctypes.{name}"),
            Ty::Struct(name, _) => name.clone(),
            Ty::Array(t, n) => match **t {
                Ty::Array(..) => format!("({}) * {n}", t.ctypes()),
                _ => format!("{} * {n}", t.ctypes()),
            },
        }
    }
}

/// What a type refers to: constants (array lengths) and struct sizes by Rust name.
pub struct Names<'a> {
    pub constants: &'a HashMap<&'static str, u64>,
    pub structs: &'a HashMap<String, usize>,
}

fn prim(name: &str) -> Option<Ty> {
    let (c, s) = match name {
        "u8" => ("c_uint8", 1),
        "i8" => ("c_int8", 1),
        "u16" => ("c_uint16", 2),
        "i16" => ("c_int16", 2),
        "u32" => ("c_uint32", 4),
        "i32" => ("c_int32", 4),
        "u64" => ("c_uint64", 8),
        "i64" => ("c_int64", 8),
        "f32" => ("c_float", 4),
        "f64" => ("c_double", 8),
        _ => return None,
    };
    Some(Ty::Prim(c, s))
}

/// Parses `ty` (whitespace ignored). An unknown name or array length is an error naming it.
pub fn parse(ty: &str, names: &Names) -> anyhow::Result<Ty> {
    let compact: String = ty.chars().filter(|c| !c.is_whitespace()).collect();
    parse_compact(&compact, names).with_context(|| format!("field type `{ty}`"))
}

fn parse_compact(s: &str, names: &Names) -> anyhow::Result<Ty> {
    if let Some(inner) = s.strip_prefix('[').and_then(|r| r.strip_suffix(']')) {
        let split = top_level_semicolon(inner)
            .with_context(|| format!("`{s}` is not an array `[T; N]`"))?;
        let (elem, len) = (&inner[..split], &inner[split + 1..]);
        let n = match len.parse::<u64>() {
            Ok(n) => n,
            Err(_) => *names
                .constants
                .get(len)
                .with_context(|| format!("unknown array length `{len}`"))?,
        };
        return Ok(Ty::Array(Box::new(parse_compact(elem, names)?), n as usize));
    }
    if let Some(p) = prim(s) {
        return Ok(p);
    }
    match names.structs.get(s) {
        Some(size) => Ok(Ty::Struct(s.to_string(), *size)),
        None => bail!("unknown type `{s}` (not a number nor a catalogue struct)"),
    }
}

/// The `;` of `T; N` outside any nested brackets.
fn top_level_semicolon(s: &str) -> Option<usize> {
    let mut depth = 0i32;
    for (i, c) in s.char_indices() {
        match c {
            '[' => depth += 1,
            ']' => depth -= 1,
            ';' if depth == 0 => return Some(i),
            _ => {}
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_structs_and_nested_arrays_parse_to_ctypes() {
        let constants = HashMap::from([("MAX", 16u64)]);
        let structs = HashMap::from([("Pose2Msg".to_string(), 24usize)]);
        let n = Names {
            constants: &constants,
            structs: &structs,
        };
        assert_eq!(parse("f64", &n).unwrap().ctypes(), "ctypes.c_double");
        let t = parse("[[f32; 3]; MAX]", &n).unwrap();
        assert_eq!(t.ctypes(), "(ctypes.c_float * 3) * 16");
        assert_eq!(t.size(), 192);
        let t = parse("[Pose2Msg; 4]", &n).unwrap();
        assert_eq!((t.ctypes(), t.size()), ("Pose2Msg * 4".to_string(), 96));
        let e = format!("{:#}", parse("[u8; NOPE]", &n).unwrap_err());
        assert!(e.contains("NOPE"), "{e}");
        let e = format!("{:#}", parse("bool", &n).unwrap_err());
        assert!(e.contains("`bool`"), "{e}");
    }
}

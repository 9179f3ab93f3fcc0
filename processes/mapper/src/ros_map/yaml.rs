//! The map_server YAML: a flat `key: value` file, parsed by hand (no YAML crate is in
//! the workspace and the format needs none).
//!
//! Keys: `image`, `resolution`, `origin: [x, y, yaw]` (required); `negate` (0),
//! `occupied_thresh` (0.65), `free_thresh` (0.196), `mode` (trinary | scale | raw,
//! default trinary). Unknown or repeated keys, nested YAML and a non-zero yaw (the grid
//! is axis-aligned) are errors naming the file, the line and the key. Knows nothing of
//! the image.

use crate::error::MapError;
use std::path::{Path, PathBuf};

/// How pixel values become occupancy (map_server's `mode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapMode {
    Trinary,
    Scale,
    Raw,
}

impl MapMode {
    pub fn as_str(&self) -> &'static str {
        match self {
            MapMode::Trinary => "trinary",
            MapMode::Scale => "scale",
            MapMode::Raw => "raw",
        }
    }
}

/// The content of a map YAML.
#[derive(Debug, Clone, PartialEq)]
pub struct MapYaml {
    /// The image path as written (relative paths are relative to the YAML's directory).
    pub image: PathBuf,
    /// Metres per pixel.
    pub resolution: f64,
    /// Pose of the lower-left corner of the lower-left pixel: x, y, yaw.
    pub origin: [f64; 3],
    pub negate: bool,
    pub occupied_thresh: f64,
    pub free_thresh: f64,
    pub mode: MapMode,
}

/// ROS 1 map_server's default thresholds.
pub const DEFAULT_OCCUPIED_THRESH: f64 = 0.65;
pub const DEFAULT_FREE_THRESH: f64 = 0.196;

const KEYS: [&str; 7] = [
    "image",
    "resolution",
    "origin",
    "negate",
    "occupied_thresh",
    "free_thresh",
    "mode",
];

/// Removes a trailing ` # comment` and surrounding quotes; errors on an unclosed quote.
fn scalar(raw: &str) -> Result<&str, String> {
    let raw = raw.trim();
    if let Some(q) = raw.chars().next().filter(|c| *c == '"' || *c == '\'') {
        let rest = &raw[1..];
        let end = rest.find(q).ok_or_else(|| format!("unclosed quote {q}"))?;
        let after = rest[end + 1..].trim();
        if !(after.is_empty() || after.starts_with('#')) {
            return Err(format!("unexpected text after the quoted value: `{after}`"));
        }
        return Ok(&rest[..end]);
    }
    let v = match raw.find(" #").or_else(|| raw.find("\t#")) {
        Some(i) => &raw[..i],
        None => raw,
    };
    Ok(v.trim())
}

fn number(v: &str) -> Result<f64, String> {
    match v.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("`{v}` is not a finite number")),
    }
}

fn fraction(v: &str) -> Result<f64, String> {
    let x = number(v)?;
    if (0.0..=1.0).contains(&x) {
        Ok(x)
    } else {
        Err(format!("{x} is not within [0, 1]"))
    }
}

pub fn parse_map_yaml(file: &Path, text: &str) -> Result<MapYaml, MapError> {
    let err = |line: Option<usize>, key: Option<&str>, reason: String| {
        MapError::ros(file, line, key, reason)
    };
    let mut fields = Fields::default();
    let mut seen: [usize; KEYS.len()] = [0; KEYS.len()];
    for (i, line) in text.lines().enumerate() {
        let n = i + 1;
        let Some((key, raw)) = key_value(line).map_err(|e| err(Some(n), None, e))? else {
            continue;
        };
        let Some(k) = KEYS.iter().position(|k| *k == key) else {
            return Err(err(
                Some(n),
                Some(key),
                format!("unknown key (expected one of {})", KEYS.join(", ")),
            ));
        };
        if seen[k] != 0 {
            return Err(err(
                Some(n),
                Some(key),
                format!("repeated (first on line {})", seen[k]),
            ));
        }
        seen[k] = n;
        (scalar(raw).and_then(|v| fields.set(key, v, n)))
            .map_err(|e| err(Some(n), Some(key), e))?;
    }
    fields.finish(file)
}

/// The key and the raw value of a `key: value` line, `None` for a blank, comment or
/// document-marker line.
fn key_value(line: &str) -> Result<Option<(&str, &str)>, String> {
    let t = line.trim();
    if t.is_empty() || t.starts_with('#') || t == "---" || t == "..." {
        return Ok(None);
    }
    if line.starts_with(char::is_whitespace) {
        return Err("nested YAML is not supported: the map file is flat `key: value` lines".into());
    }
    let Some((key, raw)) = t.split_once(':') else {
        return Err(format!("expected `key: value`, got `{t}`"));
    };
    Ok(Some((key.trim(), raw)))
}

/// The values read so far; thresholds keep the line they were set on (0: default).
struct Fields {
    image: Option<PathBuf>,
    resolution: Option<f64>,
    origin: Option<[f64; 3]>,
    negate: (bool, usize),
    occupied: (f64, usize),
    free: (f64, usize),
    mode: MapMode,
}

impl Default for Fields {
    fn default() -> Fields {
        Fields {
            image: None,
            resolution: None,
            origin: None,
            negate: (false, 0),
            occupied: (DEFAULT_OCCUPIED_THRESH, 0),
            free: (DEFAULT_FREE_THRESH, 0),
            mode: MapMode::Trinary,
        }
    }
}

impl Fields {
    /// Sets `key` (one of [`KEYS`]) from the scalar `v` on line `n`.
    fn set(&mut self, key: &str, v: &str, n: usize) -> Result<(), String> {
        match key {
            "image" => {
                if v.is_empty() {
                    return Err("empty image path".into());
                }
                self.image = Some(PathBuf::from(v));
            }
            "resolution" => {
                let r = number(v)?;
                if r <= 0.0 {
                    return Err(format!("must be positive, got {r}"));
                }
                self.resolution = Some(r);
            }
            "origin" => self.origin = Some(origin(v)?),
            "negate" => {
                self.negate.0 = match v {
                    "0" | "false" | "False" => false,
                    "1" | "true" | "True" => true,
                    _ => return Err(format!("expected 0 or 1, got `{v}`")),
                };
                self.negate.1 = n;
            }
            "occupied_thresh" => self.occupied = (fraction(v)?, n),
            "free_thresh" => self.free = (fraction(v)?, n),
            "mode" => {
                self.mode = match v {
                    "trinary" => MapMode::Trinary,
                    "scale" => MapMode::Scale,
                    "raw" => MapMode::Raw,
                    _ => return Err(format!("expected trinary, scale or raw, got `{v}`")),
                }
            }
            _ => unreachable!("key checked against KEYS"),
        }
        Ok(())
    }

    /// The map description, once the thresholds agree and every required key is set.
    fn finish(self, file: &Path) -> Result<MapYaml, MapError> {
        let err = |line: Option<usize>, key: Option<&str>, reason: String| {
            MapError::ros(file, line, key, reason)
        };
        let missing = |k: &str| err(None, Some(k), "missing".into());
        let (free, occupied) = (self.free, self.occupied);
        if free.0 >= occupied.0 {
            return Err(err(
                Some(free.1.max(occupied.1)).filter(|&l| l > 0),
                Some("free_thresh"),
                format!(
                    "free_thresh {} must be below occupied_thresh {}",
                    free.0, occupied.0
                ),
            ));
        }
        Ok(MapYaml {
            image: self.image.ok_or_else(|| missing("image"))?,
            resolution: self.resolution.ok_or_else(|| missing("resolution"))?,
            origin: self.origin.ok_or_else(|| missing("origin"))?,
            negate: self.negate.0,
            occupied_thresh: occupied.0,
            free_thresh: free.0,
            mode: self.mode,
        })
    }
}

/// `[x, y, yaw]` with a zero yaw (grids are axis-aligned).
fn origin(v: &str) -> Result<[f64; 3], String> {
    let inner = v
        .strip_prefix('[')
        .and_then(|s| s.strip_suffix(']'))
        .ok_or_else(|| format!("expected `[x, y, yaw]`, got `{v}`"))?;
    let parts: Vec<&str> = inner.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!("expected 3 numbers, got {}", parts.len()));
    }
    let mut o = [0.0; 3];
    for (slot, p) in o.iter_mut().zip(&parts) {
        *slot = number(p)?;
    }
    if o[2].abs() > 1e-9 {
        return Err(format!(
            "yaw {} is not supported: grids are axis-aligned",
            o[2]
        ));
    }
    Ok(o)
}

/// The YAML text of `y` (numbers in Rust's shortest round-trip form).
pub fn format_map_yaml(y: &MapYaml) -> String {
    format!(
        "image: {}\nmode: {}\nresolution: {}\norigin: [{}, {}, {}]\nnegate: {}\noccupied_thresh: {}\nfree_thresh: {}\n",
        y.image.display(),
        y.mode.as_str(),
        y.resolution,
        y.origin[0],
        y.origin[1],
        y.origin[2],
        u8::from(y.negate),
        y.occupied_thresh,
        y.free_thresh
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "# saved by map_saver\nimage: \"map.pgm\"  # the picture\nresolution: 0.050000\norigin: [-10.000000, -10.000000, 0.000000]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";

    #[test]
    fn map_saver_output_parses() {
        let y = parse_map_yaml(Path::new("m.yaml"), GOOD).unwrap();
        assert_eq!(y.image, PathBuf::from("map.pgm"));
        assert_eq!(y.resolution, 0.05);
        assert_eq!(y.origin, [-10.0, -10.0, 0.0]);
        assert!(!y.negate);
        assert_eq!(y.mode, MapMode::Trinary);
        let again = parse_map_yaml(Path::new("m.yaml"), &format_map_yaml(&y)).unwrap();
        assert_eq!(again, y);
    }

    fn error_of(text: &str) -> String {
        parse_map_yaml(Path::new("bad.yaml"), text)
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn malformed_files_name_file_line_and_key() {
        let e = error_of(&GOOD.replace("resolution: 0.050000", "resolution: fine"));
        assert!(e.starts_with("bad.yaml:3: key `resolution`"), "{e}");
        let e = error_of(&GOOD.replace("negate: 0", "negate: 0\ncolour: red"));
        assert!(
            e.starts_with("bad.yaml:6: key `colour`: unknown key"),
            "{e}"
        );
        let e = error_of(&GOOD.replace("image: \"map.pgm\"  # the picture\n", ""));
        assert!(e.starts_with("bad.yaml: key `image`: missing"), "{e}");
        let e = error_of(&GOOD.replace("0.000000]", "0.5]"));
        assert!(e.contains("key `origin`") && e.contains("yaw"), "{e}");
        let e = error_of(&GOOD.replace("[-10.000000, -10.000000, 0.000000]", "[1, 2"));
        assert!(e.starts_with("bad.yaml:4: key `origin`"), "{e}");
        let e = error_of(&GOOD.replace("free_thresh: 0.196", "free_thresh: 0.9"));
        assert!(e.starts_with("bad.yaml:7: key `free_thresh`"), "{e}");
        let e = error_of(&format!("{GOOD}resolution: 0.1\n"));
        assert!(e.contains("repeated (first on line 3)"), "{e}");
        let e = error_of("image: a.pgm\n  nested: 1\n");
        assert!(e.starts_with("bad.yaml:2:"), "{e}");
        let e = error_of("just some text\n");
        assert!(e.starts_with("bad.yaml:1:"), "{e}");
        let e = error_of("image: \"a.pgm\n");
        assert!(e.contains("unclosed quote"), "{e}");
        let e = error_of(&GOOD.replace("resolution: 0.050000", "resolution: -1"));
        assert!(e.contains("positive"), "{e}");
        let e = error_of(&GOOD.replace("resolution: 0.050000", "resolution: NaN"));
        assert!(e.contains("finite"), "{e}");
    }
}

//! [`load`]: read a file, deserialize it strictly, validate it ([`Validate`]) and locate
//! every error by file, line and key.

use crate::InvalidKey;
use serde::de::DeserializeOwned;
use std::path::{Path, PathBuf};

/// A configuration problem, always with the file it came from.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("{}: cannot read: {source}", file.display())]
    Read {
        file: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}:{line}: {message}", file.display())]
    Parse {
        file: PathBuf,
        line: usize,
        message: String,
    },
    #[error("{}:{}: key `{key}`: {reason}", file.display(), line.map_or_else(|| "?".to_string(), |l| l.to_string()))]
    Invalid {
        file: PathBuf,
        key: String,
        line: Option<usize>,
        reason: String,
    },
}

impl ConfigError {
    /// A value that parsed but makes no sense. `text` is the file's content, used to
    /// find the line where the key's last segment is assigned or its table starts.
    pub fn invalid(file: &Path, text: &str, key: &str, reason: impl Into<String>) -> Self {
        ConfigError::Invalid {
            file: file.to_path_buf(),
            key: key.to_string(),
            line: locate_key(text, key),
            reason: reason.into(),
        }
    }

    pub fn file(&self) -> &Path {
        match self {
            ConfigError::Read { file, .. }
            | ConfigError::Parse { file, .. }
            | ConfigError::Invalid { file, .. } => file,
        }
    }
}

/// A config type's own check of its values: the first bad one, by dotted key.
pub trait Validate {
    fn validate(&self) -> Result<(), InvalidKey>;

    /// Called by [`load`] after validation with the directory holding the file, so that
    /// paths written in it can be taken relative to it. Most configs hold no paths.
    fn relative_to(&mut self, _dir: &Path) {}
}

/// Reads, deserializes and validates `path`: the one way a config file is loaded.
pub fn load<T: DeserializeOwned + Validate>(path: &Path) -> Result<T, ConfigError> {
    let (mut value, text) = load_toml::<T>(path)?;
    checked(&value, path, &text)?;
    value.relative_to(path.parent().unwrap_or_else(|| Path::new(".")));
    Ok(value)
}

/// As [`load`], from text already in memory (`path` names it in errors; relative paths
/// in it are left as written).
pub fn parse<T: DeserializeOwned + Validate>(path: &Path, text: &str) -> Result<T, ConfigError> {
    let value = parse_toml::<T>(path, text)?;
    checked(&value, path, text)?;
    Ok(value)
}

fn checked<T: Validate>(value: &T, path: &Path, text: &str) -> Result<(), ConfigError> {
    value
        .validate()
        .map_err(|e| ConfigError::invalid(path, text, &e.key, e.reason))
}

/// Reads and deserializes `path` without validating it. Unknown keys are refused by the target types
/// (`deny_unknown_fields`), so a typo is an error, not a silent default.
pub fn load_toml<T: DeserializeOwned>(path: &Path) -> Result<(T, String), ConfigError> {
    let text = crate::read_capped(path).map_err(|source| ConfigError::Read {
        file: path.to_path_buf(),
        source,
    })?;
    let value = parse_toml(path, &text)?;
    Ok((value, text))
}

/// Deserializes `text` as if read from `path` (for tests and embedded defaults).
pub fn parse_toml<T: DeserializeOwned>(path: &Path, text: &str) -> Result<T, ConfigError> {
    toml::from_str::<T>(text).map_err(|e| {
        let line = e.span().map_or(0, |s| line_of_offset(text, s.start));
        ConfigError::Parse {
            file: path.to_path_buf(),
            line,
            message: e.message().trim().to_string(),
        }
    })
}

fn line_of_offset(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Best-effort line of a dotted key such as `body[3].size` or `kinematics.track_width`:
/// the first assignment of its last plain segment, else the first table header naming it.
fn locate_key(text: &str, key: &str) -> Option<usize> {
    let last = key
        .rsplit('.')
        .next()
        .map(|s| s.split('[').next().unwrap_or(s))
        .filter(|s| !s.is_empty())?;
    let mut index_wanted: Option<usize> = None;
    let mut array_name: Option<&str> = None;
    // `body[3].size`: find the 4th `[[body]]` header, then `size` after it.
    if let Some(seg) = key.split('.').find(|s| s.contains('[')) {
        let name = seg.split('[').next().unwrap_or("");
        let idx = seg
            .split('[')
            .nth(1)
            .and_then(|r| r.trim_end_matches(']').parse().ok());
        array_name = Some(name);
        index_wanted = idx;
    }
    let mut start_line = 0;
    if let (Some(name), Some(idx)) = (array_name, index_wanted) {
        let header = format!("[[{name}]]");
        let mut seen = 0;
        for (i, l) in text.lines().enumerate() {
            if l.trim() == header {
                if seen == idx {
                    start_line = i;
                    if last == name {
                        return Some(i + 1);
                    }
                    break;
                }
                seen += 1;
            }
        }
    }
    for (i, l) in text.lines().enumerate().skip(start_line) {
        let t = l.trim_start();
        if let Some(rest) = t.strip_prefix(last)
            && rest.trim_start().starts_with('=')
        {
            return Some(i + 1);
        }
        if t.starts_with('[')
            && t.trim_matches(|c| c == '[' || c == ']').rsplit('.').next() == Some(last)
        {
            return Some(i + 1);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Small {
        rate: f64,
    }

    #[test]
    fn unknown_key_names_file_line_and_key() {
        let text = "rate = 10.0\nrat = 3\n";
        let err = parse_toml::<Small>(Path::new("x.toml"), text)
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("x.toml:2:"), "{err}");
        assert!(err.contains("rat"), "{err}");
    }

    #[test]
    fn wrong_type_is_located() {
        let err = parse_toml::<Small>(Path::new("y.toml"), "\n\nrate = \"fast\"\n")
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("y.toml:3:"), "{err}");
    }

    #[test]
    fn invalid_value_finds_the_line_of_an_array_entry() {
        let text =
            "[[body]]\nname = \"a\"\nsize = [1, 1, 1]\n[[body]]\nname = \"b\"\nsize = [-1, 1, 1]\n";
        let e = ConfigError::invalid(Path::new("w.toml"), text, "body[1].size", "negative");
        assert_eq!(e.to_string(), "w.toml:6: key `body[1].size`: negative");
    }

    impl Validate for Small {
        fn validate(&self) -> Result<(), InvalidKey> {
            crate::checks::positive("rate", self.rate)
        }
    }

    #[test]
    fn load_validates_and_locates_the_key() {
        let e = parse::<Small>(Path::new("z.toml"), "# rate\n\nrate = -1.0\n")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "z.toml:3: key `rate`: must be positive and finite, got -1"
        );
        assert!(parse::<Small>(Path::new("z.toml"), "rate = 1.0\n").is_ok());
    }

    #[test]
    fn missing_file_is_an_error_naming_it() {
        let e = load_toml::<Small>(Path::new("/nonexistent/aisle.toml")).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/aisle.toml"));
    }
}

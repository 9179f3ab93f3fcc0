//! The one "value parsed but makes no sense" error, [`InvalidKey`], and the checks every
//! config type uses to produce it.
//!
//! Knows nothing of files or lines: a check names the dotted key it looked at; the
//! loader ([`crate::load`]) adds the file and finds the line.

use std::fmt::Display;

/// A value that parsed but cannot be used, with the dotted TOML key that holds it
/// (`kinematics.track_width`, `body[3].size`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("key `{key}`: {reason}")]
pub struct InvalidKey {
    pub key: String,
    pub reason: String,
}

impl InvalidKey {
    pub fn new(key: impl Into<String>, reason: impl Into<String>) -> InvalidKey {
        InvalidKey {
            key: key.into(),
            reason: reason.into(),
        }
    }
}

/// `v` as a message shows it: in exponent form when plain digits would run long (an
/// absurd `1e300` is one word, not 301 digits).
pub fn shown(v: f64) -> String {
    let a = v.abs();
    if a.is_finite() && (a >= 1e6 || (a > 0.0 && a < 1e-4)) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// `v` is finite and > 0.
pub fn positive(key: &str, v: f64) -> Result<(), InvalidKey> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(InvalidKey::new(
            key,
            format!("must be positive and finite, got {}", shown(v)),
        ))
    }
}

/// `v` is finite and <= `max` (`unit` follows the numbers in the message): a number that
/// parses but no robot or sensor has, refused before it reaches the code.
pub fn at_most(key: &str, v: f64, max: f64, unit: &str) -> Result<(), InvalidKey> {
    if v.is_finite() && v <= max {
        Ok(())
    } else {
        Err(InvalidKey::new(
            key,
            format!(
                "must be at most {}{unit}, got {}{unit}",
                shown(max),
                shown(v)
            ),
        ))
    }
}

/// `v` is finite and >= 0.
pub fn non_negative(key: &str, v: f64) -> Result<(), InvalidKey> {
    at_least(key, v, 0.0)
}

/// `v` is finite and >= `min`.
pub fn at_least(key: &str, v: f64, min: f64) -> Result<(), InvalidKey> {
    if v.is_finite() && v >= min {
        Ok(())
    } else {
        Err(InvalidKey::new(
            key,
            format!("must be >= {min} and finite, got {}", shown(v)),
        ))
    }
}

/// Every entry of `v` is finite.
pub fn finite(key: &str, v: &[f64]) -> Result<(), InvalidKey> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(InvalidKey::new(key, format!("must be finite, got {v:?}")))
    }
}

/// `[low, high]`, both finite, low < high.
pub fn interval(key: &str, v: [f64; 2]) -> Result<(), InvalidKey> {
    if v.iter().all(|x| x.is_finite()) && v[0] < v[1] {
        Ok(())
    } else {
        Err(InvalidKey::new(
            key,
            format!("must be finite [low, high] with low < high, got {v:?}"),
        ))
    }
}

/// `lo <= v <= hi` for integers.
pub fn in_range<T: PartialOrd + Display>(key: &str, v: T, lo: T, hi: T) -> Result<(), InvalidKey> {
    if lo <= v && v <= hi {
        Ok(())
    } else {
        Err(InvalidKey::new(
            key,
            format!("must be in {lo}..={hi}, got {v}"),
        ))
    }
}

/// A name that is not blank.
pub fn non_empty(key: &str, s: &str) -> Result<(), InvalidKey> {
    if s.trim().is_empty() {
        Err(InvalidKey::new(key, "must not be empty"))
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks_name_the_key_and_the_value() {
        assert!(positive("a", 1.0).is_ok());
        let e = positive("a.b", f64::NAN).unwrap_err();
        assert_eq!(e.key, "a.b");
        assert_eq!(
            e.to_string(),
            "key `a.b`: must be positive and finite, got NaN"
        );
        assert!(non_negative("x", 0.0).is_ok() && non_negative("x", -1e-9).is_err());
        assert!(at_least("x", 1.0, 1.0).is_ok() && at_least("x", 0.5, 1.0).is_err());
        assert!(finite("x", &[1.0, f64::INFINITY]).is_err());
        assert!(interval("x", [0.0, 1.0]).is_ok() && interval("x", [1.0, 1.0]).is_err());
        assert!(in_range("x", 3u32, 1, 3).is_ok() && in_range("x", 4u32, 1, 3).is_err());
        assert!(non_empty("x", " ").is_err() && non_empty("x", "l").is_ok());
        assert!(at_most("x", 5.0, 5.0, " m").is_ok());
        assert_eq!(
            at_most("x", 1e300, 5.0, " m").unwrap_err().to_string(),
            "key `x`: must be at most 5 m, got 1e300 m"
        );
        assert_eq!(
            positive("x", -1e-300).unwrap_err().reason,
            "must be positive and finite, got -1e-300"
        );
        assert_eq!(
            (shown(0.25), shown(2e6), shown(0.0)),
            ("0.25".into(), "2e6".into(), "0".into())
        );
    }
}

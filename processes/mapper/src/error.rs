//! The mapper's error type: every failure of the library is one of these variants.
//!
//! File problems always name the file, and where it makes sense the line and the key.
//! This module only describes errors; it does not decide what the node does with them.

use aisle_config::ConfigError;
use aisle_geometry::GridError;
use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum MapError {
    /// The scene or `mapper.toml` could not be read or made no sense.
    #[error(transparent)]
    Config(#[from] ConfigError),

    /// A `MapConfig` value makes no sense (the key is named).
    #[error("mapper config: {0}")]
    InvalidConfig(#[from] aisle_config::InvalidKey),

    #[error("grid: {0}")]
    Grid(#[from] GridError),

    /// A file of a ROS map (the YAML or the image) is malformed.
    #[error("{}{}: {}{reason}",
        file.display(),
        line.map_or_else(String::new, |l| format!(":{l}")),
        key.as_ref().map_or_else(String::new, |k| format!("key `{k}`: ")))]
    RosMap {
        file: PathBuf,
        line: Option<usize>,
        key: Option<String>,
        reason: String,
    },

    #[error("{}: {source}", file.display())]
    Io {
        file: PathBuf,
        #[source]
        source: std::io::Error,
    },

    /// The point cloud does not have the shape the beam geometry describes.
    #[error("point cloud is {rows} x {cols} with {len} points; expected {exp_rows} x {exp_cols}")]
    CloudShape {
        rows: usize,
        cols: usize,
        len: usize,
        exp_rows: usize,
        exp_cols: usize,
    },

    #[error("{what} is not finite")]
    NotFinite { what: &'static str },

    #[error("{what}: {got} given, at most {max} supported")]
    TooMany {
        what: &'static str,
        got: usize,
        max: usize,
    },

    /// A caller buffer has the wrong length.
    #[error("{what} buffer holds {got} cells, {expected} needed")]
    BufferSize {
        what: &'static str,
        expected: usize,
        got: usize,
    },

    /// A grid handed back (restored state) does not match the map's geometry.
    #[error("grid geometry mismatch: {0}")]
    GeometryMismatch(String),
}

impl MapError {
    pub(crate) fn ros(
        file: impl Into<PathBuf>,
        line: Option<usize>,
        key: Option<&str>,
        reason: impl Into<String>,
    ) -> Self {
        MapError::RosMap {
            file: file.into(),
            line,
            key: key.map(str::to_string),
            reason: reason.into(),
        }
    }
}

//! Paths of the shipped configuration (`config/` at the workspace root), for tests,
//! benches and examples. Knows only where the directory is, not what the files hold.

use std::path::{Path, PathBuf};

/// The workspace's `config/` directory.
pub fn shipped_dir() -> PathBuf {
    // This crate sits at interfaces/config, two levels below the workspace root.
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config")
}

/// A shipped config file, e.g. `shipped("lidar.toml")`.
pub fn shipped(name: &str) -> PathBuf {
    shipped_dir().join(name)
}

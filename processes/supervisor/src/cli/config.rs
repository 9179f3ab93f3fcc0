//! Where the config directory comes from.

use std::path::{Path, PathBuf};

/// The config directory: explicit, else `./config`, else the one this binary was built
/// from (so `cargo run` works from any directory of the checkout).
pub fn config_dir(explicit: Option<&Path>) -> PathBuf {
    if let Some(p) = explicit {
        return p.to_path_buf();
    }
    let local = PathBuf::from("config");
    if local.join("warehouse.toml").is_file() {
        return local;
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config")
}

//! A config directory that holds only what differs from another: its `overlay.toml`
//! names the base (`"built-in"`, the config embedded in the binary, or a directory
//! relative to the overlay), and a command given such a directory runs on a private copy
//! (0700) of the base with the overlay's files laid over it. `config/large/` and
//! `config/growth/*/` are overlays of `config/`. Knows nothing of what the files mean.
//!
//! Overlays do not nest: a base that is an overlay itself is refused, so one file says
//! where every other comes from.

use crate::scenario::write::is_record;
use anyhow::{Context, bail};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The file that makes a directory an overlay.
pub const OVERLAY_FILE: &str = "overlay.toml";

/// The base the built-in config stands for in `overlay.toml`.
const BUILT_IN: &str = "built-in";

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct OverlayFile {
    /// `"built-in"`, or a config directory relative to the overlay.
    base: String,
}

/// Where an overlay's base comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum Base {
    BuiltIn,
    Dir(PathBuf),
}

/// The base `dir` lays its files over, or `None` when `dir` is a whole config
/// directory (it has no `overlay.toml`).
pub fn base_of(dir: &Path) -> anyhow::Result<Option<Base>> {
    let file = dir.join(OVERLAY_FILE);
    if !file.exists() {
        return Ok(None);
    }
    let text = aisle_config::read_capped(&file)
        .with_context(|| format!("{}: cannot read", file.display()))?;
    let parsed: OverlayFile =
        toml::from_str(&text).with_context(|| format!("{}: invalid", file.display()))?;
    if parsed.base == BUILT_IN {
        return Ok(Some(Base::BuiltIn));
    }
    let base = dir.join(&parsed.base);
    if !base.is_dir() {
        bail!(
            "{}: key `base`: {} is not a directory (a config directory, or \"{BUILT_IN}\")",
            file.display(),
            base.display()
        );
    }
    if base.join(OVERLAY_FILE).exists() {
        bail!(
            "{}: key `base`: {} is an overlay itself; overlays do not nest",
            file.display(),
            base.display()
        );
    }
    // Looked at before anything is copied: a base is copied whole, recursively, so a
    // directory that is not a config (`/`, a home directory) would be copied whole.
    let files = crate::check::ConfigFiles::in_dir(&base);
    let missing: Vec<String> = files
        .all()
        .iter()
        .filter(|p| !p.is_file())
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    if !missing.is_empty() {
        bail!(
            "{}: key `base`: {} (\"{}\") is not a config directory: it has no {} (a base \
             holds every file a config needs; or \"{BUILT_IN}\")",
            file.display(),
            base.display(),
            parsed.base,
            missing.join(", ")
        );
    }
    Ok(Some(Base::Dir(base)))
}

/// Copies the files of `from` (recursively, `overlay.toml` and records left out) into
/// `into`, replacing what is there; returns each copy with its source.
pub fn copy_files(from: &Path, into: &Path) -> anyhow::Result<Vec<(PathBuf, PathBuf)>> {
    let mut copied = Vec::new();
    let entries = std::fs::read_dir(from).with_context(|| format!("reading {}", from.display()))?;
    for entry in entries {
        let path = entry
            .with_context(|| format!("reading {}", from.display()))?
            .path();
        let name = path.file_name().unwrap_or_default();
        let target = into.join(name);
        if path.is_dir() {
            // A config directory of its own (`config/large/`) is not part of this one.
            if path.join("warehouse.toml").exists() || path.join(OVERLAY_FILE).exists() {
                continue;
            }
            std::fs::create_dir_all(&target)
                .with_context(|| format!("creating {}", target.display()))?;
            copied.extend(copy_files(&path, &target)?);
        } else if path.is_file() && name != OVERLAY_FILE && !is_record(&path) {
            std::fs::copy(&path, &target)
                .with_context(|| format!("copying {} to {}", path.display(), target.display()))?;
            copied.push((target, path));
        }
    }
    Ok(copied)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_overlay_names_its_base_and_a_wrong_one_is_refused_naming_the_file() {
        let root = tempfile::tempdir().unwrap();
        let whole = root.path().join("whole");
        let over = root.path().join("over");
        std::fs::create_dir_all(&whole).unwrap();
        std::fs::create_dir_all(&over).unwrap();
        for f in crate::check::ConfigFiles::in_dir(&whole).all() {
            std::fs::write(f, "").unwrap();
        }
        assert_eq!(base_of(&whole).unwrap(), None);
        std::fs::write(over.join(OVERLAY_FILE), "base = \"../whole\"\n").unwrap();
        assert_eq!(
            base_of(&over).unwrap(),
            Some(Base::Dir(over.join("../whole")))
        );
        std::fs::write(over.join(OVERLAY_FILE), "base = \"built-in\"\n").unwrap();
        assert_eq!(base_of(&over).unwrap(), Some(Base::BuiltIn));
        for (text, says) in [
            ("base = \"../missing\"\n", "not a directory"),
            ("base = \"../over\"\n", "do not nest"),
            ("bas = \"built-in\"\n", "invalid"),
            (
                "base = \"/\"\n",
                "is not a config directory: it has no warehouse.toml",
            ),
            ("base = \"..\"\n", "is not a config directory"),
        ] {
            std::fs::write(over.join(OVERLAY_FILE), text).unwrap();
            let e = format!("{:#}", base_of(&over).unwrap_err());
            assert!(e.contains("overlay.toml") && e.contains(says), "{e}");
        }
    }

    #[test]
    fn records_and_the_overlay_file_are_not_copied() {
        let root = tempfile::tempdir().unwrap();
        let (from, into) = (root.path().join("from"), root.path().join("into"));
        std::fs::create_dir_all(from.join("nodes")).unwrap();
        std::fs::create_dir_all(&into).unwrap();
        for f in [
            "mission.toml",
            "nodes/watch.py",
            OVERLAY_FILE,
            "run.mcap",
            "old.MCAP",
        ] {
            std::fs::write(from.join(f), "x").unwrap();
        }
        let mut copied: Vec<PathBuf> = copy_files(&from, &into)
            .unwrap()
            .into_iter()
            .map(|(to, _)| to.strip_prefix(&into).unwrap().to_path_buf())
            .collect();
        copied.sort();
        assert_eq!(
            copied,
            [PathBuf::from("mission.toml"), "nodes/watch.py".into()]
        );
    }
}

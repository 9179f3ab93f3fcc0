//! Where the config directory comes from: `--config-dir`, else the default config
//! embedded in the binary (every file of the workspace's `config/` at build time,
//! `build.rs`), written to a private temporary directory (0700) for the command's
//! lifetime, since nodes, URDF, mission and graph are all read by path. So an installed
//! binary needs no source tree, and the current directory never changes which config
//! a command uses. A `--config-dir` that is an overlay (`overlay.rs`) is assembled in
//! such a directory too: its base, then its own files. Knows nothing of what the files
//! mean.

use super::overlay::{self, Base};
use anyhow::{Context, bail};
use std::path::{Path, PathBuf};

mod embedded {
    include!(concat!(env!("OUT_DIR"), "/embedded_config.rs"));
}

/// Every embedded file: its path relative to the config directory, its contents.
pub fn embedded_files() -> &'static [(&'static str, &'static [u8])] {
    embedded::FILES
}

/// How the private config directories of commands are named in the temporary directory.
pub const CONFIG_DIR_PREFIX: &str = "aisle-config-";

/// A config directory a command uses; an embedded one is removed when this is dropped.
pub struct ConfigDir {
    path: PathBuf,
    _temp: Option<tempfile::TempDir>,
}

impl ConfigDir {
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// `explicit` (assembled in a fresh private directory when it is an overlay), else the
/// embedded config written to one.
pub fn resolve(explicit: Option<&Path>) -> anyhow::Result<ConfigDir> {
    let base = match explicit {
        None => Base::BuiltIn,
        Some(p) => match overlay::base_of(p)? {
            None => {
                return Ok(ConfigDir {
                    path: p.to_path_buf(),
                    _temp: None,
                });
            }
            Some(base) => base,
        },
    };
    // 0700 (created so, not changed after): other users cannot read or swap the files.
    use std::os::unix::fs::PermissionsExt;
    // Named after this process (pid and start time), so `aisle clean` can tell a
    // directory a killed command left from one in use.
    let prefix = match aisle_bus::owner::Owner::current() {
        Some(o) => format!("{CONFIG_DIR_PREFIX}{}-{}-", o.pid, o.start),
        None => CONFIG_DIR_PREFIX.to_string(),
    };
    let temp = tempfile::Builder::new()
        .prefix(&prefix)
        .permissions(std::fs::Permissions::from_mode(0o700))
        .tempdir()
        .context("creating a directory for the config (is TMPDIR writable?)")?;
    let mut sources = match &base {
        Base::BuiltIn => {
            let written = write_embedded(temp.path(), true)?;
            let from = |p: &Path| {
                let rel = p.strip_prefix(temp.path()).unwrap_or(p);
                PathBuf::from(format!("(built-in) {}", rel.display()))
            };
            written
                .into_iter()
                .map(|p| {
                    let source = from(&p);
                    (p, source)
                })
                .collect()
        }
        Base::Dir(dir) => overlay::copy_files(dir, temp.path())?,
    };
    if let Some(over) = explicit {
        let own = overlay::copy_files(over, temp.path())?;
        let n = own.len();
        sources.extend(own);
        sources.push((temp.path().to_path_buf(), over.to_path_buf()));
        note_sources(sources);
        // Said on every command; errors name the files it was assembled from.
        eprintln!(
            "config: {} is an overlay: its {n} files over {}, assembled in {}",
            over.display(),
            match &base {
                Base::BuiltIn => "the built-in config".to_string(),
                Base::Dir(d) => d.display().to_string(),
            },
            temp.path().display()
        );
    }
    Ok(ConfigDir {
        path: temp.path().to_path_buf(),
        _temp: Some(temp),
    })
}

/// Each file of an assembled config directory (and the directory itself) with where it
/// came from, the overlay's copy last: what the messages of this command name instead.
static SOURCES: std::sync::Mutex<Vec<(PathBuf, PathBuf)>> = std::sync::Mutex::new(Vec::new());

fn note_sources(mut sources: Vec<(PathBuf, PathBuf)>) {
    // A file the overlay replaced is named after the overlay's: its copy came later.
    let mut seen = std::collections::HashSet::new();
    sources.reverse();
    sources.retain(|(copy, _)| seen.insert(copy.clone()));
    // Longest first, so a file is replaced before the directory that holds it.
    sources.sort_by_key(|(copy, _)| std::cmp::Reverse(copy.as_os_str().len()));
    if let Ok(mut s) = SOURCES.lock() {
        *s = sources;
    }
}

/// The file `path` (in an assembled config directory) was copied from; `path` itself
/// when it is no copy.
pub fn source_of(path: &Path) -> PathBuf {
    SOURCES
        .lock()
        .ok()
        .and_then(|s| {
            s.iter()
                .find(|(copy, _)| copy == path)
                .map(|(_, source)| source.clone())
        })
        .unwrap_or_else(|| path.to_path_buf())
}

/// `text` with every path of an assembled config directory replaced by the file it
/// was copied from: a user edits the overlay's file or the base's, never the private
/// copy (removed when the command ends).
pub fn name_sources(text: &str) -> String {
    let Ok(sources) = SOURCES.lock() else {
        return text.to_string();
    };
    let mut out = text.to_string();
    for (copy, source) in sources.iter() {
        let copy = copy.display().to_string();
        if out.contains(&copy) {
            out = out.replace(&copy, &source.display().to_string());
        }
    }
    out
}

/// Writes every embedded file under `dir` (created if missing) and returns their paths.
/// Without `force` nothing is written when any of them exists already (the error names
/// it).
pub fn write_embedded(dir: &Path, force: bool) -> anyhow::Result<Vec<PathBuf>> {
    let targets: Vec<(PathBuf, &[u8])> = embedded_files()
        .iter()
        .map(|(rel, data)| (dir.join(rel), *data))
        .collect();
    if !force && let Some((p, _)) = targets.iter().find(|(p, _)| p.symlink_metadata().is_ok()) {
        bail!(
            "{} exists; nothing written (--force overwrites the config files)",
            p.display()
        );
    }
    for (path, data) in &targets {
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("creating {}", parent.display()))?;
        }
        std::fs::write(path, data).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(targets.into_iter().map(|(p, _)| p).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                // Config directories of their own (`config/large/`) are not built in, nor
                // folders of them (`config/growth/`).
                let config_dir = |d: &Path| d.join("warehouse.toml").exists();
                let holds_config_dirs = std::fs::read_dir(&p)
                    .unwrap()
                    .flatten()
                    .any(|e| e.path().is_dir() && config_dir(&e.path()));
                if !config_dir(&p) && !holds_config_dirs {
                    walk(root, &p, out);
                }
            } else {
                let rel = p.strip_prefix(root).unwrap().to_str().unwrap().to_string();
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }

    /// Every file of `config/` (but `large/` and `growth/`: config directories of their
    /// own) is in the binary, byte for byte, and nothing else is.
    #[test]
    fn every_config_file_is_embedded() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config");
        let mut on_disk = BTreeMap::new();
        walk(&root, &root, &mut on_disk);
        let embedded: BTreeMap<String, Vec<u8>> = embedded_files()
            .iter()
            .map(|(r, d)| (r.to_string(), d.to_vec()))
            .collect();
        assert_eq!(
            on_disk.keys().collect::<Vec<_>>(),
            embedded.keys().collect::<Vec<_>>()
        );
        for (rel, data) in &on_disk {
            assert!(
                embedded[rel] == *data,
                "{rel} differs from its embedded copy"
            );
        }
        assert!(embedded.contains_key("graph.toml") && embedded.contains_key("jackal.urdf"));
        assert!(
            !embedded
                .keys()
                .any(|k| k.starts_with("large/") || k.starts_with("growth/"))
        );
    }

    #[test]
    fn the_built_in_config_is_a_private_copy_removed_on_drop() {
        let dir = resolve(None).unwrap();
        let path = dir.path().to_path_buf();
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&path).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o700);
        assert!(path.join("warehouse.toml").is_file());
        crate::check::check_dir(&path).unwrap();
        drop(dir);
        assert!(!path.exists());
    }

    /// `config/large` names `config/` as its base: the command sees the base's files
    /// with the overlay's over them, in a private copy removed on drop.
    #[test]
    fn an_overlay_is_assembled_over_its_base() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config");
        let over = root.join("large");
        let dir = resolve(Some(&over)).unwrap();
        let path = dir.path().to_path_buf();
        assert_ne!(path, over);
        let read = |p: &Path| std::fs::read(p).unwrap();
        assert_eq!(
            read(&path.join("mapper.toml")),
            read(&over.join("mapper.toml"))
        );
        assert_eq!(read(&path.join("teb.toml")), read(&root.join("teb.toml")));
        assert!(!path.join(super::overlay::OVERLAY_FILE).exists());
        assert!(!path.join("large").exists() && !path.join("growth/x4").exists());
        crate::check::check_dir(&path).unwrap();
        // Messages name the files the copy was assembled from.
        let said = format!(
            "{}: bad; {}",
            path.join("mapper.toml").display(),
            path.join("teb.toml").display()
        );
        assert_eq!(
            name_sources(&said),
            format!(
                "{}: bad; {}",
                over.join("mapper.toml").display(),
                over.join("../teb.toml").display()
            )
        );
        assert_eq!(
            name_sources(&path.display().to_string()),
            over.display().to_string()
        );
        // A whole config directory is used where it is.
        assert_eq!(resolve(Some(&root)).unwrap().path(), root.as_path());
        drop(dir);
        assert!(!path.exists());
    }

    #[test]
    fn writing_refuses_to_overwrite_without_force() {
        let dir = tempfile::tempdir().unwrap();
        let written = write_embedded(dir.path(), false).unwrap();
        assert_eq!(written.len(), embedded_files().len());
        std::fs::write(dir.path().join("teb.toml"), "edited").unwrap();
        let e = write_embedded(dir.path(), false).unwrap_err().to_string();
        assert!(e.contains("exists"), "{e}");
        assert_eq!(
            std::fs::read_to_string(dir.path().join("teb.toml")).unwrap(),
            "edited"
        );
        write_embedded(dir.path(), true).unwrap();
        assert_ne!(
            std::fs::read_to_string(dir.path().join("teb.toml")).unwrap(),
            "edited"
        );
    }
}

//! Build script of `aisle`: embeds every file under the workspace's `config/` but the
//! config directories of their own inside it (so an
//! installed binary carries its default config, and a file added there cannot be
//! forgotten) and records the git commit the binary was built from ("unknown" outside a
//! git checkout, e.g. a source tarball: that never fails the build).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

fn main() {
    let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("set by cargo"));
    let config = manifest.join("../../config");
    // A directory: cargo looks at every file under it.
    println!("cargo:rerun-if-changed={}", config.display());
    let mut files = Vec::new();
    collect(&config, &config, &mut files);
    files.sort();
    let mut code = String::from("/// Every file of `config/`: path relative to it, contents.\n");
    code.push_str("pub static FILES: &[(&str, &[u8])] = &[\n");
    for rel in &files {
        let abs = config.join(rel).canonicalize().expect("a config file");
        // Debug formatting quotes and escapes both strings for Rust source.
        writeln!(code, "    ({rel:?}, include_bytes!({:?})),", abs.display()).unwrap();
    }
    code.push_str("];\n");
    std::fs::write(out.join("embedded_config.rs"), code).expect("OUT_DIR is writable");

    println!("cargo:rustc-env=AISLE_GIT_COMMIT={}", git_commit(&manifest));
}

/// Relative paths (with `/`) of the regular files under `dir`; panics (failing the build
/// with the path) when `config/` cannot be read, since the binary would have no config.
fn collect(root: &Path, dir: &Path, files: &mut Vec<String>) {
    let entries = std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    for entry in entries {
        let path = entry.expect("a directory entry").path();
        if path.is_dir() {
            // A directory with a scene of its own (`config/large/`) is another config
            // directory, run with `--config-dir`, not part of the built-in one; so is a
            // folder of such directories (`config/growth/`), README included: `aisle
            // init` would write the README without the directories it describes.
            if !is_config_dir(&path) && !holds_config_dirs(&path) {
                collect(root, &path, files);
            }
        } else if path.is_file() {
            let rel = path.strip_prefix(root).expect("under the root");
            let parts: Vec<String> = rel
                .components()
                .map(|c| {
                    c.as_os_str()
                        .to_str()
                        .expect("UTF-8 file names")
                        .to_string()
                })
                .collect();
            files.push(parts.join("/"));
        }
    }
}

/// The short hash of the commit checked out, or "unknown" (uncommitted changes are not
/// told apart: that would rebuild on every edit).
fn git_commit(manifest: &Path) -> String {
    let git = |args: &[&str]| -> Option<String> {
        let out = Command::new("git")
            .args(args)
            .current_dir(manifest)
            .output()
            .ok()?;
        out.status
            .success()
            .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
    };
    let Some(commit) = git(&["rev-parse", "--short=12", "HEAD"]) else {
        return "unknown".to_string();
    };
    // Rebuild when HEAD moves: HEAD itself, the branch it names, packed refs.
    for p in ["HEAD", "packed-refs"] {
        if let Some(path) = git(&["rev-parse", "--git-path", p]) {
            println!("cargo:rerun-if-changed={}", manifest.join(path).display());
        }
    }
    if let Some(branch) = git(&["symbolic-ref", "-q", "HEAD"])
        && let Some(path) = git(&["rev-parse", "--git-path", &branch])
    {
        println!("cargo:rerun-if-changed={}", manifest.join(path).display());
    }
    commit
}

fn is_config_dir(dir: &Path) -> bool {
    dir.join("warehouse.toml").exists()
}

fn holds_config_dirs(dir: &Path) -> bool {
    std::fs::read_dir(dir).is_ok_and(|entries| {
        entries
            .flatten()
            .any(|e| e.path().is_dir() && is_config_dir(&e.path()))
    })
}

//! The crate graph's one rule: a process crate (processes/*) depends only on interface
//! crates (interfaces/*) and outside libraries, never on another process crate. The
//! supervisor, which launches every process, is the exception.
//!
//! Reads `cargo metadata --no-deps`, so it checks what Cargo.toml files say, normal,
//! build and dev dependencies alike.

use std::path::{Path, PathBuf};
use std::process::Command;

fn under_processes(p: &Path) -> bool {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let processes = std::fs::canonicalize(root.join("processes")).unwrap();
    std::fs::canonicalize(p).is_ok_and(|p| p.starts_with(processes))
}

#[test]
fn no_process_crate_depends_on_another() {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../Cargo.toml");
    let out = Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .arg("--manifest-path")
        .arg(&manifest)
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let mut checked = 0;
    let mut wrong = Vec::new();
    for pkg in meta["packages"].as_array().unwrap() {
        let name = pkg["name"].as_str().unwrap();
        let dir = PathBuf::from(pkg["manifest_path"].as_str().unwrap())
            .parent()
            .unwrap()
            .to_path_buf();
        if !under_processes(&dir) || name == "aisle-supervisor" {
            continue;
        }
        checked += 1;
        for dep in pkg["dependencies"].as_array().unwrap() {
            if let Some(path) = dep["path"].as_str()
                && under_processes(Path::new(path))
            {
                wrong.push(format!("{name} -> {}", dep["name"].as_str().unwrap()));
            }
        }
    }
    assert!(checked >= 5, "found only {checked} process crates");
    assert!(
        wrong.is_empty(),
        "process crates depend on each other: {wrong:?}"
    );
}

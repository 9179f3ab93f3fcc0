//! The binary as `cargo install` leaves it: copied out of the build tree and run from an
//! empty directory, it runs the seed mission on its built-in config (nothing written to
//! the current directory, its private copy removed); `init`, `--version`, `completions`;
//! log lines without colour codes when stderr is not a terminal.

mod support;

use std::path::Path;
use std::process::{Command, Output, Stdio};
use support::TestDir;

/// `bin <args>` in `cwd`, with the test's run and temporary directories.
fn run_in(bin: &Path, cwd: &Path, dir: &TestDir, args: &[&str]) -> Output {
    Command::new(bin)
        .args(args)
        .current_dir(cwd)
        .env("AISLE_RUN_DIR", dir.run_dir())
        .env("TMPDIR", dir.path("tmp"))
        .env("AISLE_LOG", "info")
        .env_remove("NO_COLOR")
        .stdin(Stdio::null())
        .output()
        .expect("aisle runs")
}

fn entries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect()
}

#[test]
fn a_copied_binary_runs_the_seed_mission_from_an_empty_directory() {
    let dir = TestDir::new("install-run");
    for d in ["bin", "empty", "tmp"] {
        std::fs::create_dir_all(dir.path(d)).unwrap();
    }
    let bin = dir.path("bin/aisle");
    std::fs::copy(support::aisle(), &bin).unwrap();
    let cwd = dir.path("empty");
    let out = run_in(&bin, &cwd, &dir, &["run", "--quiet"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("mission succeeded"), "{stdout}");
    assert!(entries(&cwd).is_empty(), "wrote to the current directory");
    assert!(
        entries(&dir.path("tmp")).is_empty(),
        "the built-in config's copy was not removed"
    );
    assert!(support::run_dir_leftovers(&dir.run_dir()).is_empty());
    // stderr is a pipe: log lines without ANSI colour codes.
    assert!(stderr.contains("instance --prefix"), "{stderr}");
    assert!(!stderr.contains('\u{1b}'), "colour codes in {stderr}");
}

#[test]
fn init_writes_the_built_in_config_once_and_version_and_completions_print() {
    let dir = TestDir::new("install-init");
    std::fs::create_dir_all(dir.path("tmp")).unwrap();
    let bin = Path::new(support::aisle());
    let target = dir.path("cfg");
    let t = target.to_str().unwrap();
    let out = run_in(bin, &dir.0, &dir, &["init", t]);
    assert!(out.status.success(), "{out:?}");
    assert!(target.join("graph.toml").is_file() && target.join("jackal.urdf").is_file());
    // Only the config itself: no README of config directories that are not written.
    assert!(!target.join("growth").exists(), "init wrote config/growth/");
    let check = run_in(bin, &dir.0, &dir, &["check", "--config-dir", t]);
    assert!(check.status.success(), "{check:?}");

    // A second init refuses, names a file, and leaves an edited one alone.
    std::fs::write(target.join("teb.toml"), "# edited\n").unwrap();
    let again = run_in(bin, &dir.0, &dir, &["init", t]);
    assert_eq!(again.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&again.stderr);
    assert!(
        stderr.contains(&format!("{t}/")) && stderr.contains("exists"),
        "{stderr}"
    );
    assert_eq!(
        std::fs::read_to_string(target.join("teb.toml")).unwrap(),
        "# edited\n"
    );
    let forced = run_in(bin, &dir.0, &dir, &["init", "--force", t]);
    assert!(forced.status.success(), "{forced:?}");
    assert_ne!(
        std::fs::read_to_string(target.join("teb.toml")).unwrap(),
        "# edited\n"
    );

    let version = run_in(bin, &dir.0, &dir, &["--version"]);
    let v = String::from_utf8_lossy(&version.stdout);
    assert!(version.status.success(), "{version:?}");
    assert!(
        v.starts_with("aisle ") && v.contains("commit ") && v.contains("message schema "),
        "{v}"
    );

    let bash = run_in(bin, &dir.0, &dir, &["completions", "bash"]);
    let script = String::from_utf8_lossy(&bash.stdout);
    assert!(bash.status.success(), "{bash:?}");
    assert!(
        script.contains("complete -F") && script.contains("--config-dir"),
        "{script}"
    );
    let unknown = run_in(bin, &dir.0, &dir, &["completions", "tcsh"]);
    assert_eq!(unknown.status.code(), Some(2));
}

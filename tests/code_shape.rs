//! The shape of the code, checked: no source file over 500 lines and no function over
//! 100 lines outside tests (ARCHITECTURE.md's rule: small modules with one job).
//!
//! Test code is left out: files named `tests.rs` or under a `tests/` directory, and
//! everything from a file's `#[cfg(test)]` on (the project keeps unit tests at the end).
//! Function length is counted from the `fn` line to the closing brace at the same
//! indentation, which is how rustfmt lays every function out.

use std::path::{Path, PathBuf};

const MAX_FILE_LINES: usize = 500;
const MAX_FN_LINES: usize = 100;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        let name = e.file_name().to_string_lossy().to_string();
        if p.is_dir() {
            if !["tests", "target", "benches", "examples"].contains(&name.as_str()) {
                sources(&p, out);
            }
        } else if name.ends_with(".rs") && name != "tests.rs" {
            out.push(p);
        }
    }
}

/// The lines of `text` before its tests.
fn non_test_lines(text: &str) -> Vec<&str> {
    text.lines()
        .take_while(|l| l.trim() != "#[cfg(test)]")
        .collect()
}

/// (first line, length, signature) of every function longer than the limit.
fn long_functions(lines: &[&str]) -> Vec<(usize, usize, String)> {
    let mut found = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let t = line.trim_start();
        let is_fn = [
            "fn ",
            "pub fn ",
            "pub(crate) fn ",
            "const fn ",
            "pub const fn ",
            "unsafe fn ",
        ]
        .iter()
        .any(|p| t.starts_with(p));
        if !is_fn || t.ends_with(';') {
            continue;
        }
        let indent = line.len() - t.len();
        let close = format!("{}}}", " ".repeat(indent));
        if let Some(end) = lines[i + 1..].iter().position(|l| *l == close) {
            let len = end + 2;
            if len > MAX_FN_LINES {
                found.push((i + 1, len, t.chars().take(60).collect()));
            }
        }
    }
    found
}

#[test]
fn no_file_or_function_is_too_long() {
    let root = workspace();
    let mut files = Vec::new();
    for dir in ["interfaces", "processes", "tools/src"] {
        sources(&root.join(dir), &mut files);
    }
    assert!(files.len() > 50, "found only {} files", files.len());
    let mut problems = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        let lines = non_test_lines(&text);
        let shown = f.strip_prefix(&root).unwrap_or(f).display().to_string();
        if lines.len() > MAX_FILE_LINES {
            problems.push(format!("{shown}: {} lines", lines.len()));
        }
        for (at, len, sig) in long_functions(&lines) {
            problems.push(format!("{shown}:{at}: `{sig}` is {len} lines"));
        }
    }
    assert!(problems.is_empty(), "too long:\n{}", problems.join("\n"));
}

#[test]
fn the_checks_see_what_they_should() {
    let body = "    x();\n".repeat(MAX_FN_LINES);
    let text = format!(
        "fn long() {{\n{body}}}\n\nfn short() {{\n}}\n#[cfg(test)]\nfn hidden() {{\n{body}}}\n"
    );
    let lines = non_test_lines(&text);
    let found = long_functions(&lines);
    assert_eq!(found.len(), 1, "{found:?}");
    assert_eq!((found[0].0, found[0].1), (1, MAX_FN_LINES + 2));
}

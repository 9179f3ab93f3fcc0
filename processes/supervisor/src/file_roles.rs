//! Which files a command reads and which it writes must differ: an output that names an
//! input (a render over its record, a report over the mission file) or another output
//! (a record and a report in one file) destroys data and still "succeeds". Checked
//! before anything is read or written; names compare as files (device and inode when
//! both exist, so links and other spellings count), else as absolute paths. Knows paths,
//! not what is in them.

use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

/// Whether `a` and `b` name the same file.
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
        _ => absolute(a) == absolute(b),
    }
}

/// `p` with its directory resolved (symlinks and `..` included) when it exists.
fn absolute(p: &Path) -> PathBuf {
    let name = p.file_name().map(PathBuf::from).unwrap_or_default();
    let parent = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    match parent.canonicalize() {
        Ok(d) => d.join(name),
        Err(_) => p.to_path_buf(),
    }
}

/// Refuses an output (flag, path) that names an input or another output.
pub fn distinct(inputs: &[(&str, &Path)], outputs: &[(&str, &Path)]) -> Result<(), String> {
    for (i, (flag, out)) in outputs.iter().enumerate() {
        for (other, input) in inputs {
            if same_file(out, input) {
                return Err(format!(
                    "{flag} {} is {other} {}, which the command reads: choose another file",
                    out.display(),
                    input.display()
                ));
            }
        }
        for (other, earlier) in &outputs[..i] {
            if same_file(out, earlier) {
                return Err(format!(
                    "{flag} {} is also {other}: each output needs a file of its own",
                    out.display()
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_over_an_input_or_another_output_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let record = dir.path().join("r.mcap");
        std::fs::write(&record, b"x").unwrap();
        let link = dir.path().join("link.mcap");
        std::os::unix::fs::symlink(&record, &link).unwrap();
        let other = dir.path().join("sub/../r.mcap");
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        for out in [&record, &link, &other] {
            let e = distinct(&[("the record", &record)], &[("-o", out)]).unwrap_err();
            assert!(e.contains("which the command reads"), "{e}");
        }
        // Outputs that do not exist yet compare by path.
        let a = dir.path().join("new.json");
        let b = dir.path().join("sub/../new.json");
        let e = distinct(&[], &[("--report", &a), ("--samples", &b)]).unwrap_err();
        assert!(
            e.contains("--samples") && e.contains("also --report"),
            "{e}"
        );
        distinct(&[("the record", &record)], &[("--report", &a)]).unwrap();
    }
}

//! Which files a command reads and which it writes must differ: an output that names an
//! input (a render over its record, a report over the mission file) or another output
//! (a record and a report in one file) destroys data and still "succeeds". Checked
//! before anything is read or written, with `aisle_tools::paths::same_file` (the ROS 2
//! export's rule too). And an output must be one the command can write
//! ([`writable_output`]), found out before the work that produces it (a mission, a
//! record's profile), not after. Knows paths, not what is in them.

use aisle_tools::output_lock::OutputLock;
use aisle_tools::paths::same_file;
use std::path::Path;

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

/// An output file the command will write at its end, locked for it until the returned
/// lock drops: refused now when the path is empty or a directory, its directory is
/// missing, the file cannot be opened for writing there, or another command writes it.
/// The lock's open is the writability probe (the open the write at the end does;
/// `access(2)` says yes to root everywhere, also where the file system takes no new
/// file, such as `/proc`). Names the flag, the path and the OS error.
pub fn writable_output(flag: &str, path: &Path) -> Result<OutputLock, String> {
    output_shape(flag, path)?;
    OutputLock::acquire(flag, path).map_err(|e| e.to_string())
}

/// The path can name an output file: not empty, not a directory, in a directory that
/// exists.
pub fn output_shape(flag: &str, path: &Path) -> Result<(), String> {
    if path.as_os_str().is_empty() {
        return Err(format!("{flag}: the path is empty"));
    }
    if path.is_dir() {
        return Err(format!("{flag} {}: is a directory", path.display()));
    }
    let parent = parent_of(path);
    let meta = std::fs::metadata(parent).map_err(|e| {
        format!(
            "{flag} {}: directory {}: {e}",
            path.display(),
            parent.display()
        )
    })?;
    if !meta.is_dir() {
        return Err(format!(
            "{flag} {}: {} is not a directory",
            path.display(),
            parent.display()
        ));
    }
    Ok(())
}

fn parent_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_the_command_cannot_write_is_refused_before_it_runs() {
        let dir = tempfile::tempdir().unwrap();
        let new = dir.path().join("samples.csv");
        drop(writable_output("--samples", &new).unwrap());
        assert!(!new.exists(), "the probe leaves no file behind");
        std::fs::write(&new, b"kept").unwrap();
        let held = writable_output("--samples", &new).unwrap();
        let e = writable_output("--json", &new).unwrap_err();
        assert!(e.contains("another command"), "{e}");
        drop(held);
        assert_eq!(std::fs::read(&new).unwrap(), b"kept", "never truncated");
        // Refused whoever runs it, root included (access(2) says yes to root): /proc
        // takes no new files.
        let e = writable_output("--samples", Path::new("/proc/x.csv")).unwrap_err();
        assert!(
            e.contains("--samples /proc/x.csv") && e.contains("cannot write"),
            "{e}"
        );
        // A FIFO nobody reads is refused at once, not waited on.
        let fifo = dir.path().join("fifo");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let e = writable_output("--report", &fifo).unwrap_err();
        assert!(e.contains("cannot write"), "{e}");
        let e = writable_output("--svg", dir.path()).unwrap_err();
        assert!(e.contains("is a directory"), "{e}");
        let e = writable_output("--json", &dir.path().join("no/such/x.json")).unwrap_err();
        assert!(e.contains("No such file"), "{e}");
        let e = writable_output("--json", Path::new("")).unwrap_err();
        assert!(e.contains("empty"), "{e}");
    }

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

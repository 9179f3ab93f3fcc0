//! Which files a command reads and which it writes must differ: an output that names an
//! input (a render over its record, a report over the mission file) or another output
//! (a record and a report in one file) destroys data and still "succeeds". Checked
//! before anything is read or written, with `aisle_tools::paths::same_file` (the ROS 2
//! export's rule too). Knows paths, not what is in them.

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

//! Whether two paths name one file: by device and inode when both exist (so links and
//! other spellings count), else by their resolved directories and names. For commands
//! that must not write over what they read.

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

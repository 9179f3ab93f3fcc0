//! [`read_capped`]: the one way a config or mission file's bytes are read. Refuses what
//! is not a plain file (a FIFO, a device such as `/dev/zero`) before opening it, and
//! never reads more than [`MAX_CONFIG_BYTES`] + 1 bytes, so a hostile path fails at once
//! naming the file instead of blocking or filling memory. Knows nothing of TOML.

use std::io::Read;
use std::path::Path;

/// Largest config or mission file accepted (16 MiB). The shipped files are a few KiB;
/// the largest, `config/large`'s scene of 9,972 bodies, is 1.2 MB: a warehouse ten
/// times that still fits.
pub const MAX_CONFIG_BYTES: u64 = 16 << 20;

/// Reads `path` as UTF-8 text, refusing anything but a regular file of at most
/// [`MAX_CONFIG_BYTES`]. The error says why (the caller names the file).
pub fn read_capped(path: &Path) -> std::io::Result<String> {
    read_capped_with(path, MAX_CONFIG_BYTES)
}

/// As [`read_capped`] with another limit (tests).
pub fn read_capped_with(path: &Path, limit: u64) -> std::io::Result<String> {
    // Look before opening: opening a FIFO for reading blocks until a writer comes.
    plain_file(&std::fs::metadata(path)?)?;
    let file = std::fs::File::open(path)?;
    // The path may have been swapped between the look and the open: look again.
    plain_file(&file.metadata()?)?;
    let mut bytes = Vec::new();
    file.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(std::io::Error::new(
            std::io::ErrorKind::FileTooLarge,
            format!(
                "larger than {} KiB, the limit for a config or mission file",
                limit / 1024
            ),
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
        )
    })
}

fn plain_file(meta: &std::fs::Metadata) -> std::io::Result<()> {
    use std::os::unix::fs::FileTypeExt;
    let t = meta.file_type();
    if t.is_file() {
        return Ok(());
    }
    let what = if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a FIFO"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else {
        "not a regular file"
    };
    Err(std::io::Error::new(
        std::io::ErrorKind::InvalidInput,
        format!("{what}, not a regular file"),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A path named `name` in a private directory removed with the returned guard.
    fn scratch(name: &str) -> (tempfile::TempDir, std::path::PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(name);
        (dir, path)
    }

    #[test]
    fn a_small_file_is_read_whole() {
        let (_dir, p) = scratch("small.toml");
        std::fs::write(&p, "rate = 1.0\n").unwrap();
        assert_eq!(read_capped(&p).unwrap(), "rate = 1.0\n");
    }

    #[test]
    fn a_file_over_the_limit_is_refused() {
        let (_dir, p) = scratch("big.toml");
        std::fs::write(&p, vec![b'#'; 101]).unwrap();
        let e = read_capped_with(&p, 100).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::FileTooLarge);
        assert!(read_capped_with(&p, 101).is_ok());
    }

    #[test]
    fn devices_directories_and_fifos_are_refused_without_reading() {
        let e = read_capped(Path::new("/dev/zero")).unwrap_err();
        assert!(e.to_string().contains("character device"), "{e}");
        let e = read_capped(&std::env::temp_dir()).unwrap_err();
        assert!(e.to_string().contains("directory"), "{e}");
        let (_dir, fifo) = scratch("fifo.toml");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .is_ok_and(|s| s.success());
        if made {
            // Would block forever if opened: refused by the look before the open.
            let e = read_capped(&fifo).unwrap_err();
            assert!(e.to_string().contains("FIFO"), "{e}");
        }
    }

    #[test]
    fn binary_content_is_refused() {
        let (_dir, p) = scratch("bin.toml");
        std::fs::write(&p, [b'a', 0xff, 0xfe]).unwrap();
        assert!(read_capped(&p).unwrap_err().to_string().contains("UTF-8"));
    }
}

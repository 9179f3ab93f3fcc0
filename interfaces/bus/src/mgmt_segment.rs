//! iceoryx2's per-instance management segment, created private before iceoryx2 would
//! create it open to everyone.
//!
//! iceoryx2 0.10 (`node/global_management_segment.rs`) opens or creates one shared
//! memory object per instance, `<prefix><sha1 of the state's type name>_node.0_10_0.global_mgmt`,
//! with `enable_global_access(true)`: `posix_shared_memory.rs` creates it 0200 and, once
//! initialised, `fchmod`s it to 0666, so no umask helps. Every other file iceoryx2
//! creates ends 0600 or narrower (their directories are under our 0700 root).
//!
//! So the creator of an instance makes that object itself, exclusively, 0200 while it
//! writes the same bytes iceoryx2's initialiser writes (the package version, then a zero
//! node counter), then 0600; iceoryx2's `open_or_create` finds it initialised and only
//! opens it. `tests` below create a real iceoryx2 node to prove the name, layout and
//! mode match this iceoryx2 version.

use crate::BusError;
use std::ffi::CString;
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::PathBuf;

/// The file name after the prefix: the SHA-1 (hex) of
/// `iceoryx2::node::global_management_segment::State`, the segment's name and the
/// package-version suffix.
const NAME_AFTER_PREFIX: &str = "9204dd183d1c4d8e1ff592a30766ffa6765aa8b5_node.0_10_0.global_mgmt";
/// `PackageVersion::get().to_u64()` of iceoryx2 0.10.0: major << 32 | minor << 16 | patch.
const PACKAGE_VERSION: u64 = 10 << 16;
/// `Data<State>`: an `AtomicU64` version, then the `AtomicU32` node counter, padded to 8.
const SIZE: usize = 16;

/// The segment's path in /dev/shm.
pub fn path(prefix: &str) -> PathBuf {
    PathBuf::from(format!("/dev/shm/{prefix}{NAME_AFTER_PREFIX}"))
}

fn err(prefix: &str, what: String) -> BusError {
    BusError::Instance {
        prefix: prefix.to_string(),
        what,
    }
}

/// Creates the segment private to this user; an existing one must already be (this
/// user's, no group or other bits), else it is refused: someone else made it.
pub fn create_private(prefix: &str) -> Result<(), BusError> {
    let name = CString::new(format!("/{prefix}{NAME_AFTER_PREFIX}"))
        .map_err(|e| err(prefix, format!("segment name: {e}")))?;
    // SAFETY: a valid C string; the mode is applied to a new object only.
    let fd = unsafe {
        libc::shm_open(
            name.as_ptr(),
            libc::O_RDWR | libc::O_CREAT | libc::O_EXCL | libc::O_CLOEXEC,
            0o200 as libc::mode_t,
        )
    };
    if fd < 0 {
        let e = std::io::Error::last_os_error();
        if e.kind() == std::io::ErrorKind::AlreadyExists {
            return check_private(prefix);
        }
        return Err(err(
            prefix,
            format!("cannot create {}: {e}", path(prefix).display()),
        ));
    }
    let result = initialise(fd);
    // SAFETY: fd is ours and closed once.
    unsafe { libc::close(fd) };
    result.map_err(|e| {
        let _ = std::fs::remove_file(path(prefix));
        err(
            prefix,
            format!("cannot initialise {}: {e}", path(prefix).display()),
        )
    })
}

/// Writes the initialised state, then opens the object to its owner (iceoryx2 waits
/// for the owner-read bit before it reads the version).
fn initialise(fd: libc::c_int) -> std::io::Result<()> {
    let os = |r: libc::c_int| {
        if r < 0 {
            Err(std::io::Error::last_os_error())
        } else {
            Ok(())
        }
    };
    // SAFETY: fd is an open shared-memory object of this process.
    os(unsafe { libc::ftruncate(fd, SIZE as libc::off_t) })?;
    let mut bytes = [0u8; SIZE];
    bytes[..8].copy_from_slice(&PACKAGE_VERSION.to_ne_bytes());
    // SAFETY: writes SIZE bytes from a live buffer.
    let n = unsafe { libc::pwrite(fd, bytes.as_ptr().cast(), SIZE, 0) };
    if n != SIZE as isize {
        return Err(std::io::Error::last_os_error());
    }
    // SAFETY: as above.
    os(unsafe { libc::fchmod(fd, 0o600) })
}

/// The segment exists, belongs to this user and is closed to everyone else.
pub fn check_private(prefix: &str) -> Result<(), BusError> {
    let p = path(prefix);
    let meta =
        std::fs::symlink_metadata(&p).map_err(|e| err(prefix, format!("{}: {e}", p.display())))?;
    let mode = meta.permissions().mode() & 0o7777;
    if !meta.is_file() || meta.uid() != crate::run_dir::euid() || mode & 0o077 != 0 {
        return Err(err(
            prefix,
            format!(
                "{} (owner uid {}, mode {mode:04o}) is not private to this user: refused",
                p.display(),
                meta.uid()
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Instance;
    use iceoryx2::prelude::*;
    use std::path::Path;

    fn mgmt_files(prefix: &str) -> Vec<(String, u32, u64)> {
        let mut v: Vec<_> = std::fs::read_dir("/dev/shm")
            .unwrap()
            .flatten()
            .filter_map(|e| {
                let n = e.file_name().into_string().ok()?;
                let m = e.metadata().ok()?;
                (n.starts_with(prefix) && n.ends_with(".global_mgmt"))
                    .then(|| (n, m.permissions().mode() & 0o777, m.len()))
            })
            .collect();
        v.sort();
        v
    }

    fn node(inst: &Instance) -> Node<ipc::Service> {
        NodeBuilder::new()
            .config(&inst.iceoryx_config().unwrap())
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc::Service>()
            .unwrap()
    }

    #[test]
    fn iceoryx2_alone_makes_this_segment_open_to_everyone() {
        let inst = Instance::unique(Path::new("/tmp/aisle-bus-tests"));
        inst.create_root().unwrap();
        let n = node(&inst);
        let files = mgmt_files(&inst.prefix);
        drop(n);
        inst.remove().unwrap();
        let name = path(&inst.prefix)
            .file_name()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        assert_eq!(files, vec![(name, 0o666, SIZE as u64)], "name, mode, size");
    }

    #[test]
    fn iceoryx2_opens_the_private_segment_and_leaves_it_private() {
        let inst = Instance::unique(Path::new("/tmp/aisle-bus-tests"));
        inst.create_root().unwrap();
        create_private(&inst.prefix).unwrap();
        let nodes = [node(&inst), node(&inst)];
        let files = mgmt_files(&inst.prefix);
        let counter = std::fs::read(path(&inst.prefix)).unwrap();
        drop(nodes);
        inst.remove().unwrap();
        let name = path(&inst.prefix)
            .file_name()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        assert_eq!(files, vec![(name, 0o600, SIZE as u64)]);
        assert_eq!(counter[..8], PACKAGE_VERSION.to_ne_bytes());
        assert_eq!(
            counter[8..12],
            2u32.to_ne_bytes(),
            "both nodes counted in it"
        );
    }

    #[test]
    fn a_segment_someone_else_opened_up_is_refused() {
        let inst = Instance::unique(Path::new("/tmp/aisle-bus-tests"));
        std::fs::write(path(&inst.prefix), [0u8; SIZE]).unwrap();
        std::fs::set_permissions(path(&inst.prefix), std::fs::Permissions::from_mode(0o666))
            .unwrap();
        let e = create_private(&inst.prefix).unwrap_err().to_string();
        std::fs::remove_file(path(&inst.prefix)).unwrap();
        assert!(e.contains("mode 0666") && e.contains("not private"), "{e}");
    }
}

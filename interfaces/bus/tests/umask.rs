//! Directories the bus makes are 0700 whatever the umask is when they are made.
//!
//! iceoryx2 narrows the process-wide umask to 0177 while it binds a socket, so a
//! directory made by another thread at that instant would come out 0600: its owner
//! could not enter it. This binary holds one test because it changes the process-wide
//! umask, which would disturb tests running beside it.

use aisle_bus::Instance;
use std::os::unix::fs::PermissionsExt;
use std::path::Path;

fn mode(p: &Path) -> u32 {
    std::fs::metadata(p).unwrap().permissions().mode() & 0o777
}

#[test]
fn roots_and_run_directories_are_0700_under_iceoryx2s_socket_umask() {
    let base = std::env::temp_dir().join(format!("aisle-umask-{}", std::process::id()));
    // SAFETY: umask only swaps the process's mask; no other test runs in this binary.
    let old = unsafe { libc::umask(0o177) };
    let inst = Instance::unique(&base.join("nested"));
    let created = inst.create_root();
    let run = base.join("run");
    let prepared = aisle_bus::run_dir::prepare(&run);
    // SAFETY: as above.
    unsafe { libc::umask(old) };
    created.unwrap();
    prepared.unwrap();
    let modes: Vec<u32> = [&base, &base.join("nested"), &inst.root, &run]
        .iter()
        .map(|p| mode(p))
        .collect();
    std::fs::remove_dir_all(&base).unwrap();
    assert_eq!(modes, vec![0o700; 4], "base, nested, root, run directory");
}

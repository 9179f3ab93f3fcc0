//! The monitor's binary started by hand, outside a group: it refuses with exit 2 and
//! names the variable the supervisor would have set. (This test also makes `cargo test`
//! build the binary the system tests in `tests/external_nodes.rs` launch.)

use std::process::Command;

#[test]
fn started_without_a_group_it_names_what_is_missing() {
    let out = Command::new(env!("CARGO_BIN_EXE_safety_monitor"))
        .env_remove("AISLE_PREFIX")
        .env_remove("AISLE_ROOT")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("AISLE_PREFIX is not set"), "{err}");
}

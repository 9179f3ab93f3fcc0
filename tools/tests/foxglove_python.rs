//! An independent reader decodes the Foxglove channels: runs `read_foxglove.py` (Python
//! `mcap` + `mcap-protobuf-support`) on a synthetic recording: every channel, raw ones
//! included, has an encoding Foxglove decodes; viewer, plot and raw channels decode. Skipped, with a note, when
//! python3 or those packages are not installed (`pip install mcap mcap-protobuf-support`).

use aisle_tools::WriterOptions;
use aisle_tools::synthetic::write_synthetic;
use std::path::Path;
use std::process::Command;

fn python_has_mcap() -> bool {
    Command::new("python3")
        .args(["-c", "import mcap, mcap_protobuf"])
        .output()
        .is_ok_and(|o| o.status.success())
}

#[test]
fn python_mcap_decodes_every_viewer_channel() {
    if !python_has_mcap() {
        eprintln!(
            "note: skipped: python3 with the `mcap` and `mcap-protobuf-support` packages is \
             not available (pip install mcap mcap-protobuf-support)"
        );
        return;
    }
    let path = std::env::temp_dir().join(format!("aisle-fox-{}.mcap", std::process::id()));
    for compression in [
        aisle_tools::Compression::Lz4,
        aisle_tools::Compression::Zstd,
    ] {
        let opts = WriterOptions {
            compression,
            ..WriterOptions::default()
        };
        write_synthetic(std::fs::File::create(&path).unwrap(), 30, opts).unwrap();
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/read_foxglove.py");
        let out = Command::new("python3")
            .arg(&script)
            .arg(&path)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{compression:?}: {stdout}\n{stderr}");
        assert!(stdout.contains("\"problems\": []"), "{stdout}");
        assert!(stdout.contains("mission.toml"), "{stdout}");
    }
    std::fs::remove_file(&path).unwrap();
}

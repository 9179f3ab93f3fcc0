//! Records a running instance until Ctrl-C, for trying the recorder before the CLI has
//! `aisle run --record`:
//! `cargo run -p aisle-tools --release --example record_instance -- PREFIX ROOT CONFIG_DIR OUT.mcap`
//! (PREFIX and ROOT are the instance's, as the supervisor passes them to its children).

use aisle_bus::{Instance, NodeArgs};
use aisle_tools::{RecorderOptions, run_recorder_with};
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(
        a.len() == 4,
        "usage: record_instance PREFIX ROOT CONFIG_DIR OUT.mcap"
    );
    let args = NodeArgs {
        instance: Instance::new(a[0].clone(), PathBuf::from(&a[1]))?,
        config_dir: PathBuf::from(&a[2]),
        dt_ns: 100_000_000,
        controller_every: 5,
        start: [0.0, 0.0, 0.0],
        lidar_off: false,
        restarted: false,
        recorded: false,
    };
    let summary = run_recorder_with(&args, &PathBuf::from(&a[3]), &RecorderOptions::default())?;
    println!(
        "written {:?}\nviewer {} attachments {} lost {} (bus {:?}, queue {:?})",
        summary.written,
        summary.viewer_messages,
        summary.attachments,
        summary.lost(),
        summary.lost_in_bus,
        summary.lost_in_queue
    );
    Ok(())
}

//! `aisle export`: a recorded run converted for other tools (`--ros2`: a ROS 2 bag, see
//! `aisle_tools::ros2` for its topics and conventions), and its exit codes. The
//! conversion itself is the tools crate's.

use crate::exit;
use aisle_tools::output_lock::{LockError, OutputLock};
use clap::{Args, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

/// Subcommands flattened into `aisle`'s own.
#[derive(Debug, Subcommand)]
pub enum ExportCommand {
    /// Convert a recorded run for other tools (`--ros2`: a ROS 2 bag).
    ///
    /// `--ros2` writes a ROS 2 bag (MCAP, profile ros2, CDR) of a record made by `aisle
    /// run --record`, with /aisle/points (PointCloud2), /map and
    /// /aisle/local_map (OccupancyGrid: 0 free, 100 occupied, -1 unknown), /plan,
    /// /aisle/band and /aisle/driven_path (Path), /odom (Odometry), /cmd_vel (Twist),
    /// /tf and /tf_static (frames map, odom, base_link, sensor).
    #[command(
        after_help = "Exit: 0 written, 2 could not (missing or unreadable file, not an \
aisle record, a damaged or truncated record, output not writable or written by another \
command now, output is the record itself). Of a damaged record the readable part is still written, and the error says so."
    )]
    Export(ExportArgs),
}

#[derive(Debug, Args)]
pub struct ExportArgs {
    /// Write a ROS 2 bag (the one format so far; required).
    #[arg(long, required = true)]
    pub ros2: bool,
    /// The record to convert (an MCAP file written by `aisle run --record` or `aisle
    /// record`).
    pub record: PathBuf,
    /// The bag to write (an `.mcap` file, replaced if it exists; `ros2 bag play`,
    /// rosbags and Foxglove open it directly, no metadata.yaml needed).
    pub output: PathBuf,
}

pub fn main(cmd: ExportCommand) -> ExitCode {
    let ExportCommand::Export(a) = cmd;
    // Held until the bag is in place: a second command writing it now is refused.
    let _lock = match lock_output(&a) {
        Ok(l) => l,
        Err(e) => return exit::fail(e),
    };
    match aisle_tools::ros2::export_ros2(&a.record, &a.output) {
        Ok(summary) => {
            if summary.skipped > 0 {
                eprintln!(
                    "warning: {} messages could not be converted (wrong size, counts out of \
                     range or non-finite values) and were left out",
                    summary.skipped
                );
            }
            let total: u64 = summary.written.values().sum();
            println!("wrote {} ({total} messages)", a.output.display());
            for (topic, n) in &summary.written {
                println!("  {topic:<20} {n}");
            }
            // A damaged record is bad input (exit 2), though its readable part was written.
            match &summary.damaged {
                Some(d) => exit::fail(format_args!(
                    "{d} ({} holds the part before the damage only)",
                    a.output.display()
                )),
                None => ExitCode::SUCCESS,
            }
        }
        Err(e) => exit::fail(e),
    }
}

/// The lock on the bag, or `None` where the export refuses the output itself, naming it
/// (the record itself, a directory, a file it cannot open): only another command
/// writing it now is refused here.
fn lock_output(a: &ExportArgs) -> Result<Option<OutputLock>, LockError> {
    if aisle_tools::paths::same_file(&a.record, &a.output) || a.output.is_dir() {
        return Ok(None);
    }
    match OutputLock::acquire("the bag", &a.output) {
        Ok(l) => Ok(Some(l)),
        Err(LockError::Open { .. }) => Ok(None),
        Err(e) => Err(e),
    }
}

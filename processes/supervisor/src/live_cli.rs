//! The command-line options of the live view: `aisle run --foxglove [ADDR]`, and the
//! recorder node's options (`aisle node recorder --out FILE --foxglove ADDR`), which
//! the supervisor passes when a run records or is watched live.
//!
//! Knows only the options; the serving itself is `aisle_tools::live`.

use clap::Args;
use std::net::SocketAddr;
use std::path::PathBuf;

/// `aisle run --foxglove [ADDR]`.
#[derive(Debug, Clone, Args)]
pub struct LiveArgs {
    /// Serve the run live over the Foxglove WebSocket protocol at ADDR (default
    /// 127.0.0.1:8765): open `ws://ADDR` in Foxglove or Lichtblick to watch the scene,
    /// lidar, maps, paths, band, transforms and log (the channels of `--record`).
    /// Serving never holds the group up: messages a slow viewer cannot take are dropped
    /// and counted.
    #[arg(
        long,
        value_name = "ADDR",
        num_args = 0..=1,
        default_missing_value = aisle_tools::live::DEFAULT_ADDR
    )]
    pub foxglove: Option<SocketAddr>,
}

/// The recorder node's outputs (`aisle node recorder`).
#[derive(Debug, Clone, Args)]
pub struct RecorderArgs {
    /// The recorder's output file.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// The recorder serves the live view at this address.
    #[arg(long, value_name = "ADDR")]
    pub foxglove: Option<SocketAddr>,
}

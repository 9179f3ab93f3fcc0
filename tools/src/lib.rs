//! aisle-tools: recording, replay, profiling and pictures of aisle runs.
//!
//! - [`record`]: the recorder node (`run_recorder`) writing one MCAP file per run;
//! - [`replay`]: publishes a recorded file back into a live instance, or (`replay_own`)
//!   into one it creates itself, for consumers without a supervisor;
//! - [`trust`]: which topics a tool may publish into a live instance (none its group
//!   publishes);
//! - [`lockstep`]: replays a lockstep recording tick by tick into live consumers and
//!   compares their outputs with the recorded ones ([`tick_batches`] regroups the file,
//!   [`diff`] names the first differing field, [`ack_rules`] says which recorded
//!   acknowledgements it waits for);
//! - [`reader`]: reads a recorded file (raw payloads, attachments, damage reports);
//! - [`latency`]: the latency figures of a run (quantiles, budgets, tick release), one
//!   definition for `aisle run` and `aisle profile`;
//! - [`profile`]: those figures (and output latencies) from a recorded file;
//! - [`inspect`]: a running instance seen from outside, topic by topic (`aisle topics`,
//!   `echo`, `hz`): services, samples as text, rates;
//! - [`live`]: the live view, the viewer channels served over the Foxglove WebSocket
//!   protocol while a group runs;
//! - [`ros2`]: a record as a ROS 2 bag (`aisle export --ros2`);
//! - [`render`]: a top-view PNG of a run, drawn with `plotters` ([`fonts`]: the embedded
//!   font); [`animate`]: a self-contained HTML page that plays the run back.
//!
//! Lower layers: [`catalog`] (service -> message type), [`writer`] (the MCAP layout),
//! [`viewer`] (Foxglove protobuf conversion), [`aligned`] (viewing bytes as messages),
//! `raw_ports` (type-erased publishers and
//! subscribers opened by topic name, for the recorder and both replays),
//! [`output_lock`] (one command at a time writes an output file),
//! `payload_fields` (header fields read from raw payload bytes). [`synthetic`] makes a
//! deterministic fake run for tests, benchmarks and examples.

pub mod ack_rules;
pub mod aligned;
pub mod animate;
pub mod catalog;
pub mod diff;
pub mod envelope;
pub mod fonts;
pub mod inspect;
pub mod latency;
pub mod live;
pub mod lockstep;
pub mod output_lock;
pub mod paths;
mod payload_fields;
pub mod profile;
mod raw_ports;
pub mod reader;
pub mod record;
pub mod render;
pub mod replay;
mod replay_own;
pub mod ros2;
pub mod tick_batches;
pub mod trust;
pub mod viewer;
pub mod writer;

pub use profile::{ProfileError, ProfileOptions, ProfileReport, profile, profile_with};
pub use reader::{ChannelInfo, FileAttachment, FileMessage, ReadError, RecordFile};
pub use record::{
    RecordSummary, RecorderOptions, run_recorder, run_recorder_live, run_recorder_with,
};
pub use render::{RenderError, RenderOptions, RenderSummary, render, render_file};
pub use replay::{ReplayError, ReplayOptions, ReplaySummary, replay};
pub use writer::{Compression, RecordWriter, WriteError, WriterOptions};
pub mod synthetic;

#[cfg(test)]
mod tests;

//! A thin typed layer over iceoryx2 for the aisle processes.
//!
//! - [`Instance`]: one isolated iceoryx2 instance per launch (unique prefix and root),
//!   handed to every child, private to its user, and removed without a trace when the
//!   launch ends; [`run_dir`] is where roots live and whether that place is trusted;
//!   [`sweep`] removes what dead instances left; [`discovery`] writes and finds the
//!   `aisle-instance.toml` by which processes not launched by a supervisor join;
//!   [`OwnerWatch`] tells such an observer when the instance's owner has ended it.
//! - [`Bus`]: a process's membership: its iceoryx2 node, the schema-hash check on join,
//!   heartbeats, and cleanup of resources left by dead nodes.
//! - [`Publisher`] / [`Subscriber`]: typed pub/sub ports, each paired with an event
//!   service of the same name so a process sleeps until data arrives or a deadline passes.
//!   Large messages are zero-filled and written in place in the loaned sample.
//! - [`Bus::services`]: the instance's publish/subscribe services with their port counts.
//! - [`Bus::hold_service`]: a topic's service held open without ports, with the agreed
//!   settings (what a host's link bridges must exist so).
//! - [`signals`]: SIGINT/SIGTERM become a stop request that every wait loop checks.
//!
//! Ports are opened with the typed topics of `aisle_messages::topics` (name, type and
//! QoS in one table). Knows the message types, not what any process computes nor who
//! publishes what (the graph and the tick protocol are `aisle-node`'s). Request/response
//! is built from two pub/sub services (`request.rs`) so that a recorder sees both
//! directions.

mod args;
mod bus;
pub mod clock;
pub mod discovery;
mod error;
mod extent;
mod hold;
mod instance;
mod mgmt_segment;
mod node;
pub mod owner;
mod owner_watch;
mod port;
mod raw;
mod request;
pub mod run_dir;
mod services;
pub mod signals;
pub mod sweep;

pub use aisle_messages::{Qos, Topic};
pub use args::{NodeArgs, StageTimer};
pub use bus::{Bus, HeartbeatSender};
pub use error::BusError;
pub use hold::HeldService;
pub use instance::{Instance, MAX_ROOT_AND_PREFIX};
pub use node::NodeError;
pub use owner_watch::OwnerWatch;
pub use port::{
    Publisher, Received, SERVICE_SETTINGS, ServiceSettings, Stamp, Subscriber, WaitOutcome,
    message_bytes, used_bytes,
};
pub use raw::{RawPublisher, RawSubscriber};
pub use request::{Client, Correlated};
pub use services::ServiceSummary;

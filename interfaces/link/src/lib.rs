//! The process group spread over hosts.
//!
//! - [`hosts`]: `config/hosts.toml`, which host runs which node and its Zenoh endpoints,
//!   checked against the graph ([`Placement`]). Without that file every node runs on the
//!   supervisor's host, exactly as a single-host run, and no Zenoh session is opened.
//! - [`crossing`]: the topics a placement makes cross hosts (published on one host and
//!   subscribed on another), and which of them each host must bridge.
//!
//! - [`beat`]: the hosts' beats, by which each tells a link that is down.
//! - [`control`]: the supervisor's requests to a host daemon (start, spawn, kill, stop)
//!   and the ends of a host's nodes, over Zenoh queryables.
//! - [`bridge`]: the iceoryx2 Zenoh link of one host, bridging exactly those topics.
//! - [`trimmed`]: the link's carrier, sending each message as the part of it in use.
//! - [`probe`]: the one-way latency of the samples that cross to a host.
//! - [`testing`]: two hosts in one process on the loopback interface (tests, benches).
//!
//! Knows the graph's names, the hosts and the link; it does not launch nodes.

pub mod beat;
pub mod bridge;
pub mod control;
pub mod crossing;
pub mod hosts;
mod ordered;
pub mod probe;
pub mod testing;
pub mod trimmed;

pub use beat::{BEAT, Beating, Beats};
pub use bridge::{Bridge, LinkError, zenoh_config};
pub use control::{
    ControlClient, ControlServer, HostReply, HostRequest, NodeExit, StartGroup, open_session,
};
pub use crossing::{Crossing, crossing_topics};
pub use hosts::{HostDecl, HostsFile, Placement};
pub use probe::LinkSample;
/// The Zenoh session a host's link and control share.
pub use zenoh::Session;

/// Version of what the link puts on the wire: 2 since a catalogue message crosses as its
/// used part ([`trimmed`]), 1 before (whole samples, which a host of version 2 reads but
/// one of version 1 refuses as malformed, silently).
pub const WIRE_VERSION: u64 = 2;

/// The hash the hosts of one group must share: the message schema's
/// ([`aisle_messages::schema_hash`]) with [`WIRE_VERSION`] folded in, so a host whose
/// link reads another wire format is refused at the start, naming both hashes, rather
/// than dropping what crosses.
pub fn group_hash() -> u64 {
    aisle_messages::schema_hash() ^ WIRE_VERSION.wrapping_mul(0x9e37_79b9_7f4a_7c15)
}

//! Every message the aisle processes exchange, as fixed-layout `#[repr(C)]` types that
//! live directly in iceoryx2 shared memory.
//!
//! Rules: no pointers, no heap, no `Option` of pointers; variable-length data is a
//! fixed-capacity array plus a `len`. Every type has a versioned type name
//! (`aisle.PointCloud.v1`), a compile-time size assertion, and a field-by-field layout
//! that feeds the [`schema_hash`]. All-zero bytes are a valid value of every message
//! ([`ZeroedValid`]), so large messages are zero-filled and then written in place in the
//! loaned sample, never built on the stack.
//!
//! This crate knows the shapes of messages and the topic table (name, type, QoS); it does not know
//! how they are sent (see `aisle-bus`) or what the algorithms do with them.

mod catalog;
mod catalog_maps;
mod common;
mod global_map;
mod grid;
mod layout;
mod node_kind;
pub mod topics;
pub mod user_topics;
pub mod wire;

pub use catalog::*;
pub use catalog_maps::{CellChangeMsg, GlobalGrid, MapChanges, OccupancyGrid};
pub use common::*;
pub use global_map::{GlobalMapCopy, MapChangesError, MapUpdate};
pub use grid::{GridCopy, GridMessage, GridTooLarge};
pub use layout::{
    FieldLayout, Message, MessageTypeVisitor, ZeroedValid, all_layouts, message_type_names,
    schema_hash, schema_hash_hex, visit_message_type, zeroed_box,
};
pub use node_kind::{
    EXTERNAL_CODE_BIT, ExternalNode, MAX_EXTERNAL_NAME, NodeKind, check_external_name,
    external_code,
};
pub use topics::{Qos, Topic, TopicInfo, TopicVisitor};

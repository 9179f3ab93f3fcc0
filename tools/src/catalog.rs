//! The recorded services: the topic table (`aisle_messages::topics`) with the per-type
//! layout hash written into channel metadata, and who produces each (the graph).
//!
//! Knows what travels where; it does not know how messages are stored in a file or
//! published on the bus.

use aisle_messages::NodeKind;
use aisle_messages::topics::{self, TopicInfo};
use aisle_node::Graph;
use std::sync::LazyLock;

/// One service and the layout of the message it carries.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServiceInfo {
    pub service: &'static str,
    pub type_name: &'static str,
    pub size: usize,
    pub align: usize,
    /// FNV-1a over this type's layout and every nested (non-message) struct layout.
    pub layout_hash: u64,
}

impl ServiceInfo {
    fn of(topic: &TopicInfo) -> ServiceInfo {
        ServiceInfo {
            service: topic.name,
            type_name: topic.type_name,
            size: topic.size,
            align: topic.align,
            layout_hash: layout_hash(topic.type_name),
        }
    }

    pub fn layout_hash_hex(&self) -> String {
        format!("{:016x}", self.layout_hash)
    }
}

/// Every service, in the order of `aisle_messages::topics::all()` (the table, then the
/// user topics the graph declared).
pub fn services() -> Vec<ServiceInfo> {
    topics::all().iter().map(ServiceInfo::of).collect()
}

/// The catalogue entry of `service`, if it is one of ours.
pub fn service_info(service: &str) -> Option<ServiceInfo> {
    topics::info(service).map(|t| ServiceInfo::of(&t))
}

/// The process that publishes `service` in a run, from the shipped graph (`TickDone`
/// and heartbeats come from every process: `None`). The supervisor also republishes
/// some state after a restart.
pub fn producer(service: &str) -> Option<NodeKind> {
    static GRAPH: LazyLock<Graph> = LazyLock::new(Graph::shipped);
    GRAPH.producer(service)
}

/// How many leading bytes of a `type_name` payload its fields use
/// ([`Message::used_len`](aisle_messages::Message::used_len): a cloud's points or a
/// grid's cells in use, not the capacity); `None` when `type_name` is not a message of
/// the catalogue. A short payload reads as zeros past its end.
pub fn used_len(type_name: &str, bytes: &[u8]) -> Option<usize> {
    aisle_messages::visit_message_type(type_name, UsedLen(bytes))
}

/// [`used_len`] for the message type the catalogue dispatches to.
struct UsedLen<'a>(&'a [u8]);

impl aisle_messages::MessageTypeVisitor for UsedLen<'_> {
    type Output = usize;
    fn visit<M: aisle_messages::Message>(self) -> usize {
        let size = std::mem::size_of::<M>();
        let mut buf = crate::aligned::AlignedBuf::new();
        buf.set_padded(&self.0[..self.0.len().min(size)], size);
        buf.view::<M>().map_or(size, |m| m.used_len().min(size))
    }
}

fn fnv1a(hash: &mut u64, bytes: &[u8]) {
    for b in bytes {
        *hash ^= u64::from(*b);
        *hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
    }
}

/// Layout hash of one message type. Nested structs are named in the field types only by
/// their Rust identifier, so the hash covers every nested (non-message) layout too: a
/// change in `Header` changes every type's hash, a change in `Trajectory` only its own.
pub fn layout_hash(type_name: &str) -> u64 {
    let layouts = aisle_messages::all_layouts();
    let messages = aisle_messages::message_type_names();
    let is_message = |name: &str| messages.contains(&name);
    let mut h = 0xcbf2_9ce4_8422_2325_u64;
    for (name, size, align, fields) in &layouts {
        if *name != type_name && is_message(name) {
            continue;
        }
        fnv1a(&mut h, name.as_bytes());
        fnv1a(&mut h, &(*size as u64).to_le_bytes());
        fnv1a(&mut h, &(*align as u64).to_le_bytes());
        for f in fields.iter() {
            fnv1a(&mut h, f.name.as_bytes());
            fnv1a(&mut h, f.ty.as_bytes());
            fnv1a(&mut h, &(f.offset as u64).to_le_bytes());
            fnv1a(&mut h, &(f.size as u64).to_le_bytes());
        }
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_service_is_listed_once_and_hashes_differ_by_type() {
        let all = services();
        assert_eq!(all.len(), topics::ALL.len());
        let mut names: Vec<_> = all.iter().map(|i| i.service).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), all.len());
        // The global map's grid holds 2^24 cells, the local map's 2^21: two layouts.
        let g = service_info(topics::GLOBAL_MAP.name).unwrap();
        let l = service_info(topics::LOCAL_MAP.name).unwrap();
        assert_ne!(g.layout_hash, l.layout_hash);
        let p = service_info(topics::ROBOT_STATE.name).unwrap();
        assert_ne!(g.layout_hash, p.layout_hash);
        for i in &all {
            let kind = producer(i.service);
            assert_eq!(
                kind.is_none(),
                i.service == topics::TICK_DONE.name || i.service == topics::HEARTBEAT.name,
                "{}",
                i.service
            );
        }
        let t = service_info(topics::TICK.name).unwrap();
        assert_ne!(t.layout_hash, g.layout_hash);
        assert_eq!(t.size, 72);
        assert!(all.iter().all(|i| i.align <= 8));
    }

    #[test]
    fn every_catalogue_message_is_a_service_type() {
        let listed: Vec<&str> = services().iter().map(|i| i.type_name).collect();
        for name in aisle_messages::message_type_names() {
            assert!(listed.contains(&name), "{name}");
        }
    }
}

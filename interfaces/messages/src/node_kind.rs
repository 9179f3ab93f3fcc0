//! Who a message comes from: the built-in processes, and the external nodes a graph
//! declares (a user's Rust or Python process), each with the `u32` code that messages
//! carry (`TickDone.node`, `Heartbeat.node`, `Header`-less ids in `GroupMembers`).
//!
//! A built-in's code is fixed (0..=7). An external node's code is derived from its name
//! alone (FNV-1a, high bit set), so every process of a group, in any language and on any
//! host, computes the same code without asking anyone; a graph refuses two names with
//! the same code. Knows names and codes, not the graph.

use std::sync::{Mutex, PoisonError};

/// A node of the group.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum NodeKind {
    Supervisor,
    Simulator,
    Lidar,
    Mapper,
    GlobalPlanner,
    TebController,
    Recorder,
    Replay,
    /// A process the graph declares with its own command.
    External(ExternalNode),
}

/// An external node: its name and the code derived from it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ExternalNode {
    code: u32,
    name: &'static str,
}

/// The bit every external code has set (built-in codes are small).
pub const EXTERNAL_CODE_BIT: u32 = 0x8000_0000;

/// Longest external node name (it is also a log tag and an environment value).
pub const MAX_EXTERNAL_NAME: usize = 48;

/// External nodes seen by this process (from its graph), so a code read from a message
/// can be named. Interned once per distinct name: a process loads a handful.
static KNOWN_EXTERNAL: Mutex<Vec<ExternalNode>> = Mutex::new(Vec::new());

impl ExternalNode {
    /// The node called `name`. `const`, so a Rust stage can declare its `KIND`.
    pub const fn new(name: &'static str) -> ExternalNode {
        ExternalNode {
            code: external_code(name),
            name,
        }
    }

    pub fn code(self) -> u32 {
        self.code
    }

    pub fn name(self) -> &'static str {
        self.name
    }
}

/// FNV-1a (32 bit) of the UTF-8 name with [`EXTERNAL_CODE_BIT`] set: the wire code of
/// the external node `name`.
pub const fn external_code(name: &str) -> u32 {
    let bytes = name.as_bytes();
    let mut hash: u32 = 0x811c_9dc5;
    let mut i = 0;
    while i < bytes.len() {
        hash ^= bytes[i] as u32;
        hash = hash.wrapping_mul(0x0100_0193);
        i += 1;
    }
    EXTERNAL_CODE_BIT | (hash & !EXTERNAL_CODE_BIT)
}

/// Why a name cannot be an external node's.
pub fn check_external_name(name: &str) -> Result<(), String> {
    let well_formed = !name.is_empty()
        && name.len() <= MAX_EXTERNAL_NAME
        && name.starts_with(|c: char| c.is_ascii_lowercase())
        && name
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_');
    if !well_formed {
        return Err(format!(
            "`{name}` is not a node name: 1 to {MAX_EXTERNAL_NAME} characters a-z, 0-9 and _, \
             starting with a letter"
        ));
    }
    if NodeKind::BUILT_IN.iter().any(|k| k.name() == name) {
        return Err(format!("`{name}` is a built-in node"));
    }
    Ok(())
}

impl NodeKind {
    pub const BUILT_IN: [NodeKind; 8] = [
        NodeKind::Supervisor,
        NodeKind::Simulator,
        NodeKind::Lidar,
        NodeKind::Mapper,
        NodeKind::GlobalPlanner,
        NodeKind::TebController,
        NodeKind::Recorder,
        NodeKind::Replay,
    ];
    /// The five built-in processes the supervisor launches, in start order.
    pub const LAUNCHED: [NodeKind; 5] = [
        NodeKind::Simulator,
        NodeKind::Lidar,
        NodeKind::Mapper,
        NodeKind::GlobalPlanner,
        NodeKind::TebController,
    ];

    /// The external node `name`, known from now on to [`NodeKind::from_u32`] and
    /// [`NodeKind::from_name`] in this process. The name must pass
    /// [`check_external_name`] (a graph checks it when it is loaded).
    pub fn external(name: &str) -> NodeKind {
        let mut known = KNOWN_EXTERNAL
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        if let Some(e) = known.iter().find(|e| e.name == name) {
            return NodeKind::External(*e);
        }
        // Leaked once per distinct name, so names stay `&'static` like the built-ins'.
        let e = ExternalNode::new(Box::leak(name.to_owned().into_boxed_str()));
        known.push(e);
        NodeKind::External(e)
    }

    /// The code messages carry.
    pub fn code(self) -> u32 {
        match self {
            NodeKind::Supervisor => 0,
            NodeKind::Simulator => 1,
            NodeKind::Lidar => 2,
            NodeKind::Mapper => 3,
            NodeKind::GlobalPlanner => 4,
            NodeKind::TebController => 5,
            NodeKind::Recorder => 6,
            NodeKind::Replay => 7,
            NodeKind::External(e) => e.code,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            NodeKind::Supervisor => "supervisor",
            NodeKind::Simulator => "simulator",
            NodeKind::Lidar => "lidar",
            NodeKind::Mapper => "mapper",
            NodeKind::GlobalPlanner => "global_planner",
            NodeKind::TebController => "teb_controller",
            NodeKind::Recorder => "recorder",
            NodeKind::Replay => "replay",
            NodeKind::External(e) => e.name,
        }
    }

    pub fn is_external(self) -> bool {
        matches!(self, NodeKind::External(_))
    }

    /// A built-in node, or an external one this process has met.
    pub fn from_name(name: &str) -> Option<NodeKind> {
        Self::BUILT_IN
            .into_iter()
            .find(|k| k.name() == name)
            .or_else(|| Self::known_external(|e| e.name == name))
    }

    /// The node of a wire code: a built-in, or an external one this process has met.
    pub fn from_u32(code: u32) -> Option<NodeKind> {
        Self::BUILT_IN
            .into_iter()
            .find(|k| k.code() == code)
            .or_else(|| Self::known_external(|e| e.code == code))
    }

    fn known_external(pred: impl Fn(&ExternalNode) -> bool) -> Option<NodeKind> {
        let known = KNOWN_EXTERNAL
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        known
            .iter()
            .find(|e| pred(e))
            .map(|e| NodeKind::External(*e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip_and_externals_are_named_by_their_hash() {
        for k in NodeKind::BUILT_IN {
            assert_eq!(NodeKind::from_u32(k.code()), Some(k));
            assert_eq!(NodeKind::from_name(k.name()), Some(k));
        }
        // FNV-1a of "a" is 0xe40c292c (published test vector), high bit already set.
        assert_eq!(external_code("a"), 0xe40c_292c);
        assert_eq!(external_code(""), EXTERNAL_CODE_BIT | 0x011c_9dc5);
        assert_eq!(NodeKind::from_name("safety_monitor_x"), None);
        let k = NodeKind::external("safety_monitor_x");
        assert_eq!(k.code(), external_code("safety_monitor_x"));
        assert_eq!(NodeKind::from_u32(k.code()), Some(k));
        assert_eq!(NodeKind::from_name("safety_monitor_x"), Some(k));
        assert_eq!(NodeKind::External(ExternalNode::new("safety_monitor_x")), k);
        assert!(k.code() & EXTERNAL_CODE_BIT != 0 && k.is_external());
    }

    #[test]
    fn external_names_are_checked() {
        assert!(check_external_name("safety_monitor").is_ok());
        for bad in ["", "Lidar", "1x", "a-b", "lidar", &"x".repeat(49)] {
            assert!(check_external_name(bad).is_err(), "{bad}");
        }
    }
}

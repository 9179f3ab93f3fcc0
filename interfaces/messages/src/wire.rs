//! Read-only tables of what message fields carry as codes (wire enums, flag bits, node
//! codes), the capacities that size message arrays, and the Rust names of the catalogue's
//! types: what generated bindings for other languages (`aisle gen python`) are made
//! from. Nothing here changes a layout or the schema hash.

use crate::catalog::{
    DockMove, GoalMode, GridKind, MissionState, NodeState, PlanStatus, SimCommandKind, StageStatus,
    TickMode,
};

/// A `u32` wire enum: its Rust name and (variant, code) pairs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WireEnum {
    pub name: &'static str,
    pub variants: &'static [(&'static str, u32)],
}

macro_rules! enums {
    ($($e:ident),* $(,)?) => {
        /// Every wire enum of the catalogue.
        pub const ENUMS: &[WireEnum] = &[$(WireEnum { name: stringify!($e), variants: $e::VARIANTS }),*];
    };
}

enums!(
    TickMode,
    StageStatus,
    PlanStatus,
    DockMove,
    GoalMode,
    SimCommandKind,
    NodeState,
    GridKind,
    MissionState,
);

macro_rules! constants {
    ($($c:ident),* $(,)?) => {
        /// Capacities and flag bits, by their Rust names (array lengths in `FieldLayout::ty`
        /// name these).
        pub const CONSTANTS: &[(&str, u64)] = &[$((stringify!($c), crate::catalog::$c as u64)),*];
    };
}

constants!(
    STAGE_CONTROLLER,
    MAX_CLOUD_ROWS,
    MAX_CLOUD_COLS,
    MAX_CLOUD_POINTS,
    MAX_GRID_SIDE,
    MAX_GRID_CELLS,
    MAX_GLOBAL_GRID_SIDE,
    MAX_GLOBAL_GRID_CELLS,
    MAX_MAP_CHANGES,
    MAX_DOCK_PARTS,
    MAX_PLACED_PARTS,
    MAX_PATH_POSES,
    MAX_COMMANDS,
    MAX_BODIES,
    MAX_CONTACTS,
    MAX_GROUP_MEMBERS,
    NAME_LEN,
    TEXT_LEN,
);

/// The built-in nodes' names and codes (`Header::source`, `TickDone::node`, ...).
pub fn node_codes() -> Vec<(&'static str, u32)> {
    crate::NodeKind::BUILT_IN
        .iter()
        .map(|k| (k.name(), k.code()))
        .collect()
}

/// (Rust type name, versioned type name) of every message and part, in the order of
/// [`crate::all_layouts`].
pub fn rust_names() -> Vec<(&'static str, &'static str)> {
    crate::layout::rust_names()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_follow_the_catalogue() {
        let names = rust_names();
        let layouts = crate::all_layouts();
        assert_eq!(names.len(), layouts.len());
        for ((_, tn), (ln, ..)) in names.iter().zip(&layouts) {
            assert_eq!(tn, ln);
        }
        assert!(
            ENUMS.iter().any(|e| e.name == "StageStatus"
                && e.variants.contains(&("Done", StageStatus::Done as u32)))
        );
        assert_eq!(crate::topics::CONST_NAMES.len(), crate::topics::ALL.len());
        assert!(node_codes().contains(&("lidar", 2)));
    }
}

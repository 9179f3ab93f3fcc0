//! Layout descriptions and the schema hash over all of them.

use crate::catalog::*;
use crate::catalog_maps::*;
use crate::common::*;
use std::sync::LazyLock;

/// One field of a message: its name, Rust type (as written), offset and size in bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FieldLayout {
    pub name: &'static str,
    pub ty: &'static str,
    pub offset: usize,
    pub size: usize,
}

/// Marker for types whose every field is a number or an array of numbers, so that
/// all-zero bytes are a valid value.
///
/// # Safety
/// Implement only for `#[repr(C)]` types without references, pointers, `bool`, enums
/// or `NonZero*` fields (the `message!` macro does this for the types it declares).
pub unsafe trait ZeroedValid: Sized {}

/// A message type: shared-memory safe, versioned, with a describable layout.
pub trait Message:
    iceoryx2::prelude::ZeroCopySend + ZeroedValid + core::fmt::Debug + 'static
{
    /// The versioned type name iceoryx2 compares when a service is opened.
    const TYPE_NAME: &'static str;
    /// Field layout, in declaration order.
    const FIELDS: &'static [FieldLayout];

    fn header(&self) -> &crate::Header;
    fn header_mut(&mut self) -> &mut crate::Header;

    /// How many leading bytes of this value its fields use (at least the header): a
    /// publisher keeps every byte after them zero, so it clears only what an earlier
    /// message left in a sample instead of the whole capacity. The whole value unless
    /// the type says less (a grid's or a cloud's unused capacity).
    fn used_len(&self) -> usize {
        core::mem::size_of::<Self>()
    }
}

/// (type name, size, align, fields) for every message, in catalogue order.
pub fn all_layouts() -> Vec<(&'static str, usize, usize, &'static [FieldLayout])> {
    layouts()
}

/// Something done with one message type chosen at run time by its type name (a
/// tool reading raw payloads): `visit` runs with that type as `M`.
pub trait MessageTypeVisitor {
    type Output;
    fn visit<M: Message>(self) -> Self::Output;
}

/// Runs `visitor` with the message type whose versioned name is `type_name`; `None`
/// when no message of the catalogue has that name (nested layouts such as `Header` are
/// not messages).
pub fn visit_message_type<V: MessageTypeVisitor>(type_name: &str, visitor: V) -> Option<V::Output> {
    visit_message(type_name, visitor)
}

/// The versioned names of the message types (not the nested layouts), in catalogue
/// order.
pub fn message_type_names() -> Vec<&'static str> {
    message_names()
}

/// Lists every layout once, each marked `message` (a type sent on its own, with a
/// header) or `nested` (a part of messages): `layouts()` (what the schema hash
/// covers), `rust_names()` (what generated bindings call them), and the message
/// dispatch all follow this one list.
macro_rules! catalogue {
    ($($kind:ident $t:ident),* $(,)?) => {
        fn layouts() -> Vec<(&'static str, usize, usize, &'static [FieldLayout])> {
            vec![$((<$t>::TYPE_NAME, core::mem::size_of::<$t>(), core::mem::align_of::<$t>(), <$t>::FIELDS)),*]
        }
        /// (Rust type name, versioned type name), in the order of `layouts()`.
        pub(crate) fn rust_names() -> Vec<(&'static str, &'static str)> {
            vec![$((stringify!($t), <$t>::TYPE_NAME)),*]
        }
        fn visit_message<V: MessageTypeVisitor>(type_name: &str, visitor: V) -> Option<V::Output> {
            $(if_message!($kind {
                if type_name == <$t>::TYPE_NAME {
                    return Some(visitor.visit::<$t>());
                }
            });)*
            None
        }
        fn message_names() -> Vec<&'static str> {
            let mut names = Vec::new();
            $(if_message!($kind { names.push(<$t>::TYPE_NAME); });)*
            names
        }
    };
}

/// The block for a `message` entry of the catalogue, nothing for a `nested` one.
macro_rules! if_message {
    (message $body:block) => {
        $body
    };
    (nested $body:block) => {};
}

catalogue!(
    nested Header,
    nested Pose2Msg,
    nested Pose3Msg,
    nested PathPoseMsg,
    nested TimedCommandMsg,
    nested TimedPoseMsg,
    nested RectMsg,
    nested BodyTruth,
    message Tick,
    message TickDone,
    message RobotState,
    message WorldTruth,
    message PointCloud,
    message OccupancyGrid,
    message GlobalGrid,
    nested CellChangeMsg,
    message MapChanges,
    message MapperControl,
    message PlanRequest,
    message PlanResponse,
    message ControllerGoal,
    message Trajectory,
    message ControllerBand,
    nested TimedTwistMsg,
    message SimState,
    message SimCommand,
    message Heartbeat,
    message MissionStatus,
    message InstanceInfo,
    message GroupMembers,
);

fn fnv1a(hash: &mut u64, bytes: &[u8]) {
    for b in bytes {
        *hash ^= u64::from(*b);
        *hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
    }
}

static SCHEMA_HASH: LazyLock<u64> = LazyLock::new(|| {
    let mut h = 0xcbf2_9ce4_8422_2325_u64;
    for (name, size, align, fields) in all_layouts() {
        fnv1a(&mut h, name.as_bytes());
        fnv1a(&mut h, &(size as u64).to_le_bytes());
        fnv1a(&mut h, &(align as u64).to_le_bytes());
        for f in fields {
            fnv1a(&mut h, f.name.as_bytes());
            fnv1a(&mut h, f.ty.as_bytes());
            fnv1a(&mut h, &(f.offset as u64).to_le_bytes());
            fnv1a(&mut h, &(f.size as u64).to_le_bytes());
        }
    }
    h
});

/// A 64-bit FNV-1a hash over every message's name, size, alignment and fields. Two
/// builds that disagree on any layout disagree on this hash; a process whose hash differs
/// from the supervisor's is refused when it joins.
pub fn schema_hash() -> u64 {
    *SCHEMA_HASH
}

pub fn schema_hash_hex() -> String {
    format!("{:016x}", schema_hash())
}

/// A zero-filled message on the heap (a valid value, see [`ZeroedValid`]): for tests and
/// in-memory stand-ins of the bus; large messages never go on the stack.
pub fn zeroed_box<M: ZeroedValid>() -> Box<M> {
    let layout = std::alloc::Layout::new::<M>();
    if layout.size() == 0 {
        // SAFETY: a zero-sized ZeroedValid type has exactly one value.
        return unsafe { Box::from_raw(std::ptr::NonNull::<M>::dangling().as_ptr()) };
    }
    // SAFETY: the layout is M's and non-zero; all-zero bytes are a valid M.
    unsafe {
        let p = std::alloc::alloc_zeroed(layout) as *mut M;
        if p.is_null() {
            std::alloc::handle_alloc_error(layout);
        }
        Box::from_raw(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct SizeOf;
    impl MessageTypeVisitor for SizeOf {
        type Output = usize;
        fn visit<M: Message>(self) -> usize {
            core::mem::size_of::<M>()
        }
    }

    #[test]
    fn the_messages_are_the_layouts_with_a_header_and_each_dispatches_to_its_type() {
        let names = message_type_names();
        for (name, size, _, fields) in all_layouts() {
            let top = fields.first().is_some_and(|f| f.name == "header");
            assert_eq!(top, names.contains(&name), "{name}");
            assert_eq!(
                visit_message_type(name, SizeOf),
                top.then_some(size),
                "{name}"
            );
        }
        assert_eq!(visit_message_type("aisle/NoSuchType_v1", SizeOf), None);
    }
}

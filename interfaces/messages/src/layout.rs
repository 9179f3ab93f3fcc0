//! Layout descriptions and the schema hash over all of them.

use crate::catalog::*;
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

/// Lists every message type once: `layouts()` (what the schema hash covers) and
/// `rust_names()` (what generated bindings call them) follow the same order.
macro_rules! catalogue {
    ($($t:ident),* $(,)?) => {
        fn layouts() -> Vec<(&'static str, usize, usize, &'static [FieldLayout])> {
            vec![$((<$t>::TYPE_NAME, core::mem::size_of::<$t>(), core::mem::align_of::<$t>(), <$t>::FIELDS)),*]
        }
        /// (Rust type name, versioned type name), in the order of `layouts()`.
        pub(crate) fn rust_names() -> Vec<(&'static str, &'static str)> {
            vec![$((stringify!($t), <$t>::TYPE_NAME)),*]
        }
    };
}

catalogue!(
    Header,
    Pose2Msg,
    Pose3Msg,
    PathPoseMsg,
    TimedCommandMsg,
    TimedPoseMsg,
    RectMsg,
    BodyTruth,
    Tick,
    TickDone,
    RobotState,
    WorldTruth,
    PointCloud,
    OccupancyGrid,
    MapperControl,
    PlanRequest,
    PlanResponse,
    ControllerGoal,
    Trajectory,
    ControllerBand,
    TimedTwistMsg,
    SimState,
    SimCommand,
    Heartbeat,
    MissionStatus,
    InstanceInfo,
    GroupMembers,
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

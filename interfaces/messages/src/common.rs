//! The header every message starts with, the small structs messages are built from, and
//! the macros that declare a fixed-layout type together with its layout description.

use iceoryx2::prelude::ZeroCopySend;

/// Declares a `#[repr(C)]` struct that is `ZeroCopySend`, all-numeric (`ZeroedValid`)
/// and describes its own layout (`FIELDS`).
#[macro_export]
#[doc(hidden)]
macro_rules! layout_struct {
    ($(#[$m:meta])* $name:ident = $tn:tt { $($(#[$fm:meta])* $f:ident : $t:ty),* $(,)? }) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
        #[repr(C)]
        #[type_name($tn)]
        pub struct $name { $($(#[$fm])* pub $f: $t),* }

        // SAFETY: every field is a number, an array of numbers or another
        // `layout_struct!` type (checked by `assert_zeroed_valid` below).
        unsafe impl $crate::ZeroedValid for $name {}
        impl $name {
            pub const TYPE_NAME: &'static str = $tn;
            pub const FIELDS: &'static [$crate::FieldLayout] = &[$(
                $crate::FieldLayout {
                    name: stringify!($f),
                    ty: stringify!($t),
                    offset: core::mem::offset_of!($name, $f),
                    size: core::mem::size_of::<$t>(),
                }
            ),*];
            #[allow(dead_code)]
            fn assert_zeroed_valid() { $( $crate::common::zeroed_valid_field::<$t>(); )* }
        }
        const _: () = assert!(core::mem::size_of::<$name>() % core::mem::align_of::<$name>() == 0);
    };
}

/// Like [`layout_struct!`] for a top-level message: it must start with `header: Header`.
#[macro_export]
#[doc(hidden)]
macro_rules! message {
    ($(#[$m:meta])* $name:ident = $tn:tt size $size:literal { $($(#[$fm:meta])* $f:ident : $t:ty),* $(,)? } $(used $used:expr)?) => {
        $crate::layout_struct!($(#[$m])* $name = $tn { $($(#[$fm])* $f : $t),* });
        impl $crate::Message for $name {
            const TYPE_NAME: &'static str = $tn;
            const FIELDS: &'static [$crate::FieldLayout] = $name::FIELDS;
            fn header(&self) -> &$crate::Header { &self.header }
            fn header_mut(&mut self) -> &mut $crate::Header { &mut self.header }
            $(fn used_len(&self) -> usize { ($used)(self) })?
        }
        const _: () = assert!(core::mem::offset_of!($name, header) == 0);
        const _: () = assert!(core::mem::size_of::<$name>() == $size, concat!("size of ", stringify!($name), " changed: update the size and the version"));
    };
}

/// Compile-time check helper: only types whose zero bytes are valid may be fields.
pub fn zeroed_valid_field<T: FieldOk>() {}

/// Field types allowed in messages.
pub trait FieldOk {}
macro_rules! field_ok { ($($t:ty),*) => { $(impl FieldOk for $t {})* }; }
field_ok!(u8, i8, u16, i16, u32, i32, u64, i64, f32, f64);
impl<T: FieldOk, const N: usize> FieldOk for [T; N] {}
impl<T: crate::ZeroedValid> FieldOk for T {}

layout_struct!(
    /// Common to every message. `stamp_ns` is simulated time; `tick_wall_ns` is the
    /// monotonic wall clock (CLOCK_MONOTONIC, comparable across processes) at which the
    /// tick that caused this message started, so each stage's latency can be measured.
    Header = "aisle.Header.v1" {
        /// Per-publisher sequence number, from 1.
        seq: u64,
        /// Simulated time of the data, nanoseconds since the run started.
        stamp_ns: u64,
        /// Tick that caused this message.
        tick: u64,
        /// CLOCK_MONOTONIC nanoseconds when that tick started (0 when unknown).
        tick_wall_ns: u64,
        /// CLOCK_MONOTONIC nanoseconds when this message was published.
        publish_wall_ns: u64,
        /// `NodeKind` of the writer.
        source: u32,
        _pad: u32,
    }
);

layout_struct!(
    /// A planar pose in the map frame.
    Pose2Msg = "aisle.Pose2.v1" { x: f64, y: f64, theta: f64 }
);

layout_struct!(
    /// A 3D pose: position and roll, pitch, yaw (applied yaw, then pitch, then roll).
    Pose3Msg = "aisle.Pose3.v1" { position: [f64; 3], rpy: [f64; 3] }
);

layout_struct!(
    /// One pose of a reference path; `direction` is +1 forward, -1 reverse, 0 rotate in place.
    PathPoseMsg = "aisle.PathPose.v1" { x: f64, y: f64, theta: f64, direction: i8, _pad: [u8; 7] }
);

layout_struct!(
    /// A velocity command valid from `t` seconds after the trajectory's start.
    TimedCommandMsg = "aisle.TimedCommand.v1" { t: f64, v: f64, w: f64 }
);

layout_struct!(
    /// A predicted pose at `t` seconds after the trajectory's start.
    TimedPoseMsg = "aisle.TimedPose.v1" { t: f64, x: f64, y: f64, theta: f64 }
);

layout_struct!(
    /// A rectangle placed in the map frame (or relative to the robot); `valid` 0 = absent.
    RectMsg = "aisle.Rect.v1" { pose: Pose2Msg, length: f64, width: f64, valid: u8, _pad: [u8; 7] }
);

impl From<aisle_geometry::Pose2> for Pose2Msg {
    fn from(p: aisle_geometry::Pose2) -> Self {
        Pose2Msg {
            x: p.x,
            y: p.y,
            theta: p.theta,
        }
    }
}

impl From<Pose2Msg> for aisle_geometry::Pose2 {
    fn from(p: Pose2Msg) -> Self {
        aisle_geometry::Pose2::new(p.x, p.y, p.theta)
    }
}

impl From<aisle_geometry::PathPose> for PathPoseMsg {
    fn from(p: aisle_geometry::PathPose) -> Self {
        PathPoseMsg {
            x: p.pose.x,
            y: p.pose.y,
            theta: p.pose.theta,
            direction: p.direction.as_i8(),
            _pad: [0; 7],
        }
    }
}

impl PathPoseMsg {
    /// `None` when the direction byte is not one of -1, 0, +1.
    pub fn to_path_pose(&self) -> Option<aisle_geometry::PathPose> {
        Some(aisle_geometry::PathPose::new(
            aisle_geometry::Pose2::new(self.x, self.y, self.theta),
            aisle_geometry::Direction::from_i8(self.direction)?,
        ))
    }
}

/// Copies a UTF-8 name into a fixed byte field, truncated at a character boundary.
pub fn write_name(dst: &mut [u8], name: &str) {
    dst.fill(0);
    let mut n = name.len().min(dst.len());
    while !name.is_char_boundary(n) {
        n -= 1;
    }
    dst[..n].copy_from_slice(&name.as_bytes()[..n]);
}

/// Reads a name written by [`write_name`].
pub fn read_name(src: &[u8]) -> &str {
    let end = src.iter().position(|&b| b == 0).unwrap_or(src.len());
    std::str::from_utf8(&src[..end]).unwrap_or("<invalid utf-8>")
}

//! `LidarError`: everything the library refuses, as values (it never panics on input).

use aisle_config::InvalidKey;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LidarError {
    #[error("invalid lidar config: {0}")]
    Config(#[from] InvalidKey),
    #[error("output buffer holds {got} points, the scan has {expected} rays")]
    BufferSize { expected: usize, got: usize },
    #[error("sensor pose is not finite or its rotation is not orthonormal")]
    BadSensorPose,
    #[error("sensor mount is not finite or its rotation is not orthonormal")]
    BadMount,
    #[error("body index {index} out of range (the scene has {len} bodies)")]
    BodyIndex { index: usize, len: usize },
    #[error("pose of body `{name}` is not finite")]
    BodyPose { name: String },
    #[error("body `{name}` has a part with a non-positive or non-finite size")]
    BodyPart { name: String },
}

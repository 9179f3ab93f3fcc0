//! Errors of the simulator library.

use crate::timeline::TimelineError;
use aisle_config::InvalidKey;
use aisle_geometry::Pose2;

/// Something the world refuses to do; the world is unchanged when one is returned.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error("robot config: {0}")]
    InvalidConfig(#[from] InvalidKey),
    #[error("start pose {pose:?} is not finite")]
    StartNotFinite { pose: Pose2 },
    #[error("start pose ({:.3}, {:.3}, {:.3}) is inside body `{body}`", pose.x, pose.y, pose.theta)]
    StartInCollision { body: String, pose: Pose2 },
    #[error("no body named `{name}` in the scene")]
    UnknownBody { name: String },
    #[error("body index {index} is out of range (the scene has {count} bodies)")]
    BodyIndex { index: usize, count: usize },
    #[error("body `{name}` is static and cannot be carried")]
    StaticBody { name: String },
    #[error("already carrying `{carried}`: detach it before attaching another body")]
    AlreadyCarrying { carried: String },
    #[error("the robot's carry mount is not under body `{body}`: drive under it first")]
    NotUnder { body: String },
    #[error("not carrying anything")]
    NotCarrying,
    #[error(transparent)]
    Timeline(#[from] TimelineError),
    #[error("snapshot does not fit this world: {reason}")]
    Snapshot { reason: String },
}

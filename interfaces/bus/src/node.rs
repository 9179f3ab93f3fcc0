//! What a node adapter returns when it cannot go on: a bus failure, or a setup failure
//! (a config file, a map, a URDF) that names what it was loading.

use crate::BusError;
use std::fmt::Display;

#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error("{what}: {reason}")]
    Setup { what: String, reason: String },
    #[error("{0}")]
    Protocol(String),
}

impl NodeError {
    pub fn setup(what: impl Display, reason: impl Display) -> Self {
        NodeError::Setup {
            what: what.to_string(),
            reason: reason.to_string(),
        }
    }

    /// A SIGINT/SIGTERM ended the node: a clean stop, not a failure.
    pub fn is_stop(&self) -> bool {
        matches!(self, NodeError::Bus(BusError::StopRequested))
    }
}

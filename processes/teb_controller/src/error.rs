//! Errors of the controller library: bad configuration, bad goals, bad inputs.
//!
//! A robot that cannot move is not an error: it is reported through the exit flag of a
//! [`crate::StepOutput`]. Errors are for inputs the controller refuses to interpret.

/// Why the controller refused a configuration, a goal, a restored band or a step input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TebError {
    #[error("config {0}")]
    InvalidConfig(#[from] aisle_config::InvalidKey),
    #[error("goal: {0}")]
    InvalidGoal(String),
    #[error("band: {0}")]
    InvalidBand(String),
    #[error("step input: {0}")]
    InvalidInput(String),
    #[error("no goal set")]
    NoGoal,
}

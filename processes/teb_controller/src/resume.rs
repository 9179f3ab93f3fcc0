//! The bus's controller messages as the library's types: a `ControllerGoal` as a
//! [`Goal`], a `ControllerBand` as a [`Snapshot`]. Used by the node (a goal arriving, a
//! restart resuming its band) and by recorded steps (`case.rs`). Knows the message
//! layouts, not the bus.

use crate::{Band, Goal, Mode, Snapshot};
use aisle_geometry::{Footprint, PathPose, Pose2};
use aisle_messages::{ControllerBand, ControllerGoal, GoalMode, MAX_COMMANDS};

/// The goal a `ControllerGoal` carries: `None` for `Idle` (no task), an error naming
/// what is unreadable.
pub fn goal_of(msg: &ControllerGoal) -> Option<Result<Goal, String>> {
    let footprint = Footprint::new(msg.footprint_length, msg.footprint_width);
    let mode = match GoalMode::from_u32(msg.mode) {
        Some(GoalMode::Idle) => return None,
        Some(GoalMode::Follow) => Mode::Follow,
        Some(GoalMode::RotateInPlace) => Mode::RotateInPlace {
            target_heading: msg.target.theta,
        },
        Some(GoalMode::Straight) => Mode::Straight {
            target: msg.target.into(),
        },
        None => return Some(Err(format!("unknown goal mode {}", msg.mode))),
    };
    let n = (msg.len as usize).min(msg.reference.len());
    let reference: Option<Vec<PathPose>> = msg.reference[..n]
        .iter()
        .map(|p| p.to_path_pose())
        .collect();
    let Some(reference) = reference else {
        return Some(Err("a reference pose has an unknown direction".into()));
    };
    Some(Ok(Goal {
        reference,
        footprint,
        margin: msg.margin,
        mode,
        tolerance: tolerance_of(msg),
    }))
}

/// The goal's own tolerance when the supervisor filled one in (three positive finite
/// numbers); otherwise `None`, and the controller uses `teb.toml`'s
/// `band.goal_tolerance` (an older sender leaves the field zero).
pub(crate) fn tolerance_of(msg: &ControllerGoal) -> Option<[f64; 3]> {
    let tol = msg.goal_tolerance;
    if tol.iter().all(|t| t.is_finite() && *t > 0.0) {
        return Some(tol);
    }
    if tol.iter().any(|t| *t != 0.0) {
        tracing::warn!(
            "teb_controller: goal {}: goal_tolerance {tol:?} is not three positive \
             numbers; using teb.toml band.goal_tolerance",
            msg.goal_id
        );
    }
    None
}

/// The goal's own speed limits (`max_velocity`: linear, angular) when the sender filled
/// them in (two positive finite numbers); otherwise `None`, and `teb.toml`'s apply.
pub(crate) fn speed_limit_of(msg: &ControllerGoal) -> Option<[f64; 2]> {
    let limit = msg.max_velocity;
    if limit.iter().all(|v| v.is_finite() && *v > 0.0) {
        return Some(limit);
    }
    if limit.iter().any(|v| *v != 0.0) {
        tracing::warn!(
            "teb_controller: goal {}: max_velocity {limit:?} is not two positive numbers; \
             using teb.toml's limits",
            msg.goal_id
        );
    }
    None
}

/// The band a `ControllerBand` holds, bit for bit (its `dts` are the band's own).
pub fn snapshot_of(b: &ControllerBand) -> Snapshot {
    let n = (b.len as usize).min(MAX_COMMANDS);
    let band = Band {
        poses: b.poses[..n]
            .iter()
            .map(|p| Pose2::new(p.x, p.y, p.theta))
            .collect(),
        dts: b.dts[..n.saturating_sub(1)].to_vec(),
    };
    Snapshot {
        band,
        section: b.section as usize,
        progress: b.progress,
        detour_side: b.detour_side.clamp(-1, 1) as i8,
    }
}

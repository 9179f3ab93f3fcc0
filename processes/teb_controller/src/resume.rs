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
    own_or_configured(
        msg.goal_tolerance,
        msg.goal_id,
        "goal_tolerance",
        "teb.toml band.goal_tolerance",
    )
}

/// The goal's own speed limits (`max_velocity`: linear, angular) when the sender filled
/// them in (two positive finite numbers); otherwise `None`, and `teb.toml`'s apply.
pub(crate) fn speed_limit_of(msg: &ControllerGoal) -> Option<[f64; 2]> {
    own_or_configured(
        msg.max_velocity,
        msg.goal_id,
        "max_velocity",
        "teb.toml's limits",
    )
}

/// A goal field of `N` numbers that are all positive and finite, else `None` (the
/// controller's own `configured` applies): all zero is a sender that leaves it to the
/// controller, anything else is warned about.
fn own_or_configured<const N: usize>(
    values: [f64; N],
    goal_id: u64,
    field: &str,
    configured: &str,
) -> Option<[f64; N]> {
    if values.iter().all(|v| v.is_finite() && *v > 0.0) {
        return Some(values);
    }
    if values.iter().any(|v| *v != 0.0) {
        tracing::warn!(
            "teb_controller: goal {goal_id}: {field} {values:?} is not {N} positive numbers; \
             using {configured}"
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

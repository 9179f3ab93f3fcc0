//! Where a leg's goal must lie for the leg to mean what it says: a turn in place ends
//! where it starts, an approach with a stated goal ends with the carry mount under the
//! approached body, and a goal the robot drives to alone with a stated heading leaves
//! its footprint clear of the static map with the least margin the mission backs off to
//! (a goal that touches with the full margin is planned again with less). Either would otherwise drive (or turn) to a goal the mission
//! cannot reach as asked: a turn in place only turns, and a goal beside the body leaves
//! the next carry leg nothing to pick up. Knows the legs' views, not maps or planners.

use super::goals::{Refusal, mount_gap};
use super::legs::LegView;
use super::placement::Ground;

/// A turn in place: its goal within `tolerance` (m) of where the leg may start.
pub fn check_rotate(view: &LegView, tolerance: f64) -> Result<(), Refusal> {
    if !view.leg.rotate {
        return Ok(());
    }
    let g = view.goal;
    let off = view
        .start
        .iter()
        .map(|s| (s.x - g.x).hypot(s.y - g.y))
        .fold(f64::INFINITY, f64::min);
    if off <= tolerance {
        return Ok(());
    }
    let s = view.start[0];
    Err(Refusal {
        key: format!("leg[{}].goal", view.index),
        why: format!(
            "leg `{}` turns in place, but its goal ({}, {}) is {off:.3} m from where it \
             starts ({}, {}): a turn in place only turns, so its goal must be where the leg \
             before it ends (within the goal tolerance, {tolerance:.3} m)",
            view.leg.name, g.x, g.y, s.x, s.y
        ),
    })
}

/// An approach with a stated goal: the carry mount there within `tolerance` (m) of the
/// approached body's footprint, wherever the body may stand then.
pub fn check_approach(view: &LegView, g: &Ground, tolerance: f64) -> Result<(), Refusal> {
    let (Some(body), Some(_)) = (view.approached, view.leg.goal_given) else {
        return Ok(());
    };
    let b = &g.scene.bodies[body];
    let gap = mount_gap(view.goal_poses(), body, view, g);
    if gap <= tolerance {
        return Ok(());
    }
    let (goal, at) = (view.goal, view.bodies[body][0]);
    Err(Refusal {
        key: format!("leg[{}].goal", view.index),
        why: format!(
            "leg `{}` approaches `{}`, but its goal ({}, {}) leaves the carry mount {gap:.3} m \
             outside it (`{}` stands at ({:.3}, {:.3})): state a goal under the body, or none \
             (the robot then drives under it from the side the planner chooses)",
            view.leg.name, b.name, goal.x, goal.y, b.name, at.x, at.y
        ),
    })
}

/// A leg the robot drives alone to a stated pose: its footprint grown by the least
/// margin a plan backs off to clear of the static map there (the planner's test of a
/// goal). (A carry leg's
/// footprint depends on how the rack was picked up, and a turn in place or an
/// approach is not planned to a pose: neither is tested here.)
pub fn check_goal_clear(view: &LegView, g: &Ground) -> Result<(), Refusal> {
    let leg = view.leg;
    if leg.goal_given.is_none() || leg.rotate || view.approached.is_some() || view.drop.is_some() {
        return Ok(());
    }
    let spec = &g.robot.footprint.alone;
    let goal = view.goal;
    let margin = crate::mission::least_margin(spec.margin);
    if !aisle_global_planner::footprint_touches(&g.static_map, spec.footprint(), margin, &goal) {
        return Ok(());
    }
    Err(Refusal {
        key: format!("leg[{}].goal", view.index),
        why: format!(
            "at the goal ({}, {}, {}) of leg `{}`, the robot's footprint (robot.toml \
             footprint.alone, {} x {} m) with the least margin a plan backs off to ({margin} \
             m) touches occupied cells of the static map ({}: a wall, a body's legs or the \
             map's boundary band): the planner would refuse it; move it, or turn its heading",
            goal.x,
            goal.y,
            goal.theta,
            leg.name,
            spec.length,
            spec.width,
            g.map_path.display()
        ),
    })
}

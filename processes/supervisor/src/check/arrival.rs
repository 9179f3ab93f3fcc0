//! Where a leg's goal must lie for the leg to mean what it says: a turn in place ends
//! where it starts, an approach with a stated goal ends with the carry mount under the
//! approached body, and a goal the robot drives to (alone, or carrying with the body
//! as a pick may seat it) with a stated heading leaves its footprint clear of the static
//! map with the least margin the mission backs off to (a goal that touches with the full
//! margin is planned again with less). Either would otherwise drive (or turn) to a goal the mission
//! cannot reach as asked: a turn in place only turns, and a goal beside the body leaves
//! the next carry leg nothing to pick up. Knows the legs' views, not maps or planners.

use super::goals::{Refusal, mount_gap};
use super::legs::LegView;
use super::placement::Ground;
use aisle_geometry::{Footprint, Pose2};

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

/// A leg the robot drives to a stated pose, alone or carrying: its footprint grown by
/// the least margin a plan backs off to clear of the static map there (the planner's
/// test of a goal). A carry leg's footprint depends on how the body was picked up: it
/// is refused only when every pick the walk allows touches. (A turn in place or an
/// approach is not planned to a pose: neither is tested here.)
pub fn check_goal_clear(view: &LegView, g: &Ground) -> Result<(), Refusal> {
    let leg = view.leg;
    if leg.goal_given.is_none() || leg.rotate || view.approached.is_some() {
        return Ok(());
    }
    let (spec, which) = match view.drop {
        Some(_) => (&g.robot.footprint.carrying, "carrying"),
        None => (&g.robot.footprint.alone, "alone"),
    };
    let footprints = goal_footprints(view, g);
    let margin = crate::mission::least_margin(spec.margin);
    let touches = |f: &Footprint, p: &Pose2| {
        aisle_global_planner::footprint_touches(&g.static_map, *f, margin, p)
    };
    let clear = footprints
        .iter()
        .any(|f| view.goal_poses().any(|p| !touches(f, &p)));
    if clear {
        return Ok(());
    }
    let goal = view.goal;
    let f = footprints[0];
    let grown = if view.drop.is_some() {
        " grown to the carried body as it sits on the robot"
    } else {
        ""
    };
    Err(Refusal {
        key: format!("leg[{}].goal", view.index),
        why: format!(
            "at the goal ({}, {}, {}) of leg `{}`, the robot's footprint (robot.toml \
             footprint.{which}{grown}, {:.3} x {:.3} m) with the least margin a plan backs \
             off to ({margin} m) touches occupied cells of the static map ({}: a wall, a \
             body's legs or the map's boundary band): the planner would refuse it; move it, \
             or turn its heading",
            goal.x,
            goal.y,
            goal.theta,
            leg.name,
            f.length,
            f.width,
            g.map_path.display()
        ),
    })
}

/// The footprints the robot may have at the leg's goal: its own alone; carrying, the
/// configured one grown to the carried body at each pick the walk allows.
fn goal_footprints(view: &LegView, g: &Ground) -> Vec<Footprint> {
    let Some((carried, _)) = &view.drop else {
        return vec![g.robot.footprint.alone.footprint()];
    };
    let configured = g.robot.footprint.carrying.footprint();
    let body = g.scene.bodies[*carried].footprint();
    let mut out = Vec::new();
    for pick in &view.start {
        for at in &view.bodies[*carried] {
            let rel = pick.inverse().compose(at);
            let carried = crate::mission::carried_footprint(body, rel);
            out.push(crate::mission::carrying_footprint(configured, carried));
        }
    }
    out
}

//! What stands where a leg ends, against the scene's bodies: the robot's footprint at
//! the goal (the carrying footprint too on a `carry` leg), the turning circle of a turn
//! in place, and a carried body where it is set down (against every other body, static
//! or movable, kept the least margin a carrying plan backs off to away, and the map's
//! extent); and, where a carry leg starts, the robot under the body it picks up.
//!
//! The shapes and the contact rule are the simulator's (`aisle_simulator::collision`:
//! upright boxes, touching counts, a deck above the robot is no obstacle), so what is
//! refused here is a contact the simulator would report. Where a pose is one of several
//! candidates (a heading left to the planner, see [`super::legs`]), a leg is refused
//! only when every candidate is in contact. Knows nothing of grids or planners.

use super::legs::LegView;
use super::placement::Ground;
use aisle_config::scene::Body;
use aisle_geometry::{Footprint, Pose2};
use aisle_simulator::collision::Prism;

/// Why a leg is refused: the mission file's key and the reason.
#[derive(Debug)]
pub struct Refusal {
    pub key: String,
    pub why: String,
}

/// The key that names leg `view`'s goal: `leg[i].goal`, or `leg[i].approach` when the
/// file leaves the goal out (it is the approached body's centre).
pub fn goal_key(view: &LegView) -> String {
    if view.leg.goal_given.is_some() {
        format!("leg[{}].goal", view.index)
    } else {
        format!("leg[{}].approach", view.index)
    }
}

/// Heights that meet every body: a shape that counts whatever its height.
const ALL_HEIGHTS: (f64, f64) = (-1e9, 1e9);

/// A robot or body outline placed in the map.
enum Shape {
    Rect(Prism),
    /// A disc (centre, radius) over a height range: what a rectangle covers whatever its
    /// heading (inscribed) or sweeps when it turns (circumscribed).
    Disc(Prism, f64),
}

impl Shape {
    fn rect(at: Pose2, f: Footprint, (z0, z1): (f64, f64)) -> Shape {
        Shape::Rect(Prism::at_pose(&at, f.length, f.width, z0, z1))
    }

    fn disc(x: f64, y: f64, r: f64, (z0, z1): (f64, f64)) -> Shape {
        Shape::Disc(Prism::at_pose(&Pose2::new(x, y, 0.0), 0.0, 0.0, z0, z1), r)
    }

    fn touches(&self, part: &Prism) -> bool {
        match self {
            Shape::Rect(p) => p.heights_overlap(part) && p.rects_overlap(part),
            // Strictly inside: a disc only grazing a part is not certainly in contact.
            Shape::Disc(c, r) => c.heights_overlap(part) && c.rect_distance(part) < *r,
        }
    }
}

/// The first body (scene order) that `counts` and that `shape` touches wherever the
/// body may stand during the leg.
fn first_touched(
    shape: &Shape,
    view: &LegView,
    g: &Ground,
    counts: impl Fn(usize, &Body) -> bool,
) -> Option<usize> {
    g.scene.bodies.iter().enumerate().find_map(|(i, body)| {
        let always = counts(i, body)
            && view.bodies[i].iter().all(|pose| {
                body.parts
                    .iter()
                    .any(|part| shape.touches(&Prism::from_part(pose, part)))
            });
        always.then_some(i)
    })
}

/// The robot at leg `view`'s goal: its footprint there (or, with a free heading, the
/// circle it covers whatever the heading; turning in place, the circle it sweeps)
/// against every body but the approached and the carried one, and on a carry leg the
/// carrying footprint against the static bodies.
pub fn check_goal(view: &LegView, g: &Ground) -> Result<(), Refusal> {
    let leg = view.leg;
    let alone = g.robot.footprint.alone.footprint();
    let robot_heights = (0.0, g.robot.body.height);
    let carried = view.drop.as_ref().map(|d| d.0);
    let others = |i: usize, _: &Body| Some(i) != view.approached && Some(i) != carried;
    let goal = view.goal;
    let at = format!("({}, {})", goal.x, goal.y);
    let (shape, what) = if leg.rotate {
        let r = alone.circumscribed_radius();
        (
            Shape::disc(goal.x, goal.y, r, robot_heights),
            format!(
                "leg `{}` turns in place at {at}: the robot's turning circle (radius {r:.3} m, \
                 robot.toml footprint.alone)",
                leg.name
            ),
        )
    } else if leg.free_heading {
        let r = alone.inscribed_radius();
        (
            Shape::disc(goal.x, goal.y, r, robot_heights),
            format!(
                "whatever heading the planner chooses at the goal {at} of leg `{}`, the \
                 robot's footprint (robot.toml footprint.alone, {} x {} m)",
                leg.name, alone.length, alone.width
            ),
        )
    } else {
        (
            Shape::rect(goal, alone, robot_heights),
            format!(
                "at the goal ({}, {}, {}) of leg `{}`, the robot's footprint (robot.toml \
                 footprint.alone, {} x {} m)",
                goal.x, goal.y, goal.theta, leg.name, alone.length, alone.width
            ),
        )
    };
    if let Some(i) = first_touched(&shape, view, g, others) {
        return Err(refusal(view, g, &what, i));
    }
    if carried.is_some() {
        let f = g.robot.footprint.carrying.footprint();
        let hits: Vec<Option<usize>> = view
            .goal_poses()
            .map(|p| {
                let shape = Shape::rect(p, f, ALL_HEIGHTS);
                first_touched(&shape, view, g, |_, b| b.is_static)
            })
            .collect();
        if let Some(&Some(i)) = hits.first()
            && hits.iter().all(Option::is_some)
        {
            let heading = if view.headings.len() == 1 {
                format!(", {}", view.headings[0])
            } else {
                " in every heading the planner may choose".into()
            };
            let what = format!(
                "at the goal ({}, {}{heading}) of leg `{}`, the carrying footprint \
                 (robot.toml footprint.carrying, {} x {} m)",
                goal.x, goal.y, leg.name, f.length, f.width
            );
            return Err(refusal(view, g, &what, i));
        }
    }
    Ok(())
}

fn refusal(view: &LegView, g: &Ground, what: &str, body: usize) -> Refusal {
    Refusal {
        key: goal_key(view),
        why: format!(
            "{what} overlaps body `{}` of {}",
            g.scene.bodies[body].name,
            g.scene_path.display()
        ),
    }
}

/// How far the robot's carry mount is outside body `body`'s footprint (negative:
/// inside), at the closest of the robot's `poses` and the body's candidate poses.
pub fn mount_gap(
    poses: impl Iterator<Item = Pose2>,
    body: usize,
    view: &LegView,
    g: &Ground,
) -> f64 {
    let f = g.scene.bodies[body].footprint();
    let mount = g.model.carry_mount_planar();
    poses
        .flat_map(|p| {
            let m = p.compose(&mount);
            view.bodies[body]
                .iter()
                .map(move |at| f.signed_distance(at, m.x, m.y))
        })
        .fold(f64::INFINITY, f64::min)
}

/// On a carry leg: the carry mount must be under the carried body when the leg starts
/// (the simulator's condition for picking it up), at least within the goal tolerance of
/// the previous goal.
pub fn check_pick(view: &LegView, g: &Ground, tolerance: f64) -> Result<(), Refusal> {
    let Some((carried, _)) = &view.drop else {
        return Ok(());
    };
    let body = &g.scene.bodies[*carried];
    if mount_gap(view.start.iter().copied(), *carried, view, g) <= tolerance {
        return Ok(());
    }
    let (s, b) = (view.start[0], view.bodies[*carried][0]);
    Err(Refusal {
        key: format!("leg[{}].carry", view.index),
        why: format!(
            "leg `{}` picks up `{}` where it starts, at ({}, {}), but `{}` stands at \
             ({:.3}, {:.3}): the robot must be under it (approach it on the leg before)",
            view.leg.name, body.name, s.x, s.y, body.name, b.x, b.y
        ),
    })
}

/// On a carry leg: the carried body's footprint where it is set down must stay on the
/// map and clear of every other body of the scene, static or movable, by the least
/// margin a carrying plan backs off to (a rack set down on or against a pallet, a shelf
/// or another rack is no drop).
pub fn check_drop(view: &LegView, g: &Ground) -> Result<(), Refusal> {
    let Some((carried, drops)) = &view.drop else {
        return Ok(());
    };
    let body = &g.scene.bodies[*carried];
    let f = body.footprint();
    // The clearance the planner needs at the goal (the least margin a carrying plan
    // backs off to, as `arrival::check_goal_clear` asks of the static map): a body set
    // down closer to another is a goal the lidar shows blocked.
    let clear = crate::mission::least_margin(g.robot.footprint.carrying.margin);
    let (x0, y0, x1, y1) = g.map;
    let mut first = None;
    for d in drops {
        let inside = |&(x, y): &(f64, f64)| x >= x0 && x <= x1 && y >= y0 && y <= y1;
        let why = if !f.corners(d).iter().all(inside) {
            format!("leaves the map: x {x0}..{x1} m, y {y0}..{y1} m (mapper.toml origin and size)")
        } else {
            let shape = Shape::rect(*d, f.inflated(clear), ALL_HEIGHTS);
            match first_touched(&shape, view, g, |i, _| i != *carried) {
                Some(i) => format!(
                    "overlaps body `{}` of {} or comes within {clear} m of it (the least \
                     margin a carrying plan backs off to, robot.toml footprint.carrying)",
                    g.scene.bodies[i].name,
                    g.scene_path.display()
                ),
                None => return Ok(()),
            }
        };
        first.get_or_insert((*d, why));
    }
    let Some((d, why)) = first else {
        return Ok(());
    };
    let every = if drops.len() > 1 {
        " (in every heading it may have: the pick's heading is left to the planner)"
    } else {
        ""
    };
    Err(Refusal {
        key: goal_key(view),
        why: format!(
            "leg `{}` sets `{}` down at ({:.3}, {:.3}, {:.3}), where its footprint ({} x {} m){every} {why}",
            view.leg.name, body.name, d.x, d.y, d.theta, f.length, f.width
        ),
    })
}

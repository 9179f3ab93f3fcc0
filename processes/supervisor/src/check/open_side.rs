//! Whether the robot can get under a body a leg approaches or carries: the planner
//! enters a body only straight, through a side whose swept corridor misses the parts
//! the robot can hit (those reaching below the top of its collision body: a rack's legs,
//! not its deck), and a body is picked up only from under it. A closed box (a part from
//! the floor up over its whole footprint) has no such side: a leg approaching it plans
//! in vain at run time, so `check` refuses it here, naming the leg and the body.
//!
//! The moves are the planner's own ([`aisle_global_planner::dock::entries`], with
//! `planner.toml`'s `dock_clearance`); only the body's parts are tested, not the map (a
//! wall near a side is the planner's business at run time: it shortens the run-in). A
//! side counts as open when it is open for any pose the body may have then
//! ([`super::legs`]). Knows nothing of how a leg is driven.

use super::goals::Refusal;
use super::legs::LegView;
use super::placement::Ground;
use aisle_config::scene::Body;
use aisle_geometry::{Footprint, Pose2};
use aisle_global_planner::dock::{self, DockKind, DockParams, DockSite, Placed};
use std::f64::consts::FRAC_PI_2;

/// An approach leg: some side it may enter through is open (the one its stated heading
/// enters, or any with the heading left out). A carry leg: the carried body has an open
/// side at all (the robot must be under it to pick it up).
pub fn check_open_side(view: &LegView, g: &Ground) -> Result<(), Refusal> {
    if let Some(b) = view.approached {
        let (body, poses) = (&g.scene.bodies[b], &view.bodies[b]);
        // A stated goal is where the move ends; a goal left out is the body's centre.
        let at = view.leg.goal_given.map(|_| (view.goal.x, view.goal.y));
        if !open(body, poses, at, &view.headings, g) {
            let sides = if !view.leg.free_heading && open(body, poses, at, &all_sides(poses), g) {
                format!(
                    "through the side its goal's heading ({}) enters: state a heading that \
                     enters another side, or leave the goal out",
                    view.goal.theta
                )
            } else {
                "through any of its four sides".to_string()
            };
            return Err(refusal(view, g, b, "approach", "approaches", &sides));
        }
    }
    if let Some((b, _)) = &view.drop
        && view.approached != Some(*b)
    {
        let poses = &view.bodies[*b];
        if !open(&g.scene.bodies[*b], poses, None, &all_sides(poses), g) {
            let sides = "through any of its four sides: it cannot be picked up";
            return Err(refusal(view, g, *b, "carry", "carries", sides));
        }
    }
    Ok(())
}

fn refusal(view: &LegView, g: &Ground, b: usize, key: &str, verb: &str, sides: &str) -> Refusal {
    let body = &g.scene.bodies[b];
    let f = g.robot.footprint.alone.footprint();
    Refusal {
        key: format!("leg[{}].{key}", view.index),
        why: format!(
            "leg `{}` {verb} `{}` ({} of {}), but the robot (robot.toml footprint.alone, \
             {} x {} m, {} m tall, with planner.toml dock_clearance {} m) cannot drive \
             under it {sides}: its parts lower than the robot block every straight way \
             in (a closed box, not a rack on legs)",
            view.leg.name,
            body.name,
            body.kind,
            g.scene_path.display(),
            f.length,
            f.width,
            g.robot.body.height,
            g.dock.clearance,
        ),
    }
}

/// The four sides' inward headings of a body standing at any of `poses`.
fn all_sides(poses: &[Pose2]) -> Vec<f64> {
    poses
        .iter()
        .flat_map(|p| (0..4).map(move |k| p.theta + k as f64 * FRAC_PI_2))
        .collect()
}

/// Whether the robot enters `body`, standing at one of `poses`, to `at` (default: the
/// body's centre) through a side with one of `headings`, its swept corridor clear of the
/// body's low parts.
fn open(
    body: &Body,
    poses: &[Pose2],
    at: Option<(f64, f64)>,
    headings: &[f64],
    g: &Ground,
) -> bool {
    let robot = g.robot.footprint.alone.footprint();
    let height = g.robot.body.height;
    let low: Vec<(Pose2, Footprint)> = body
        .parts
        .iter()
        .filter(|p| p.z_min() < height)
        .map(|p| {
            let at = Pose2::new(p.center[0], p.center[1], 0.0);
            (at, Footprint::new(p.size[0], p.size[1]))
        })
        .collect();
    let swept = robot.inflated(g.dock.clearance);
    poses.iter().any(|pose| {
        let parts: Vec<Placed> = low
            .iter()
            .map(|(at, f)| Placed {
                pose: pose.compose(at),
                footprint: *f,
            })
            .collect();
        let site = DockSite {
            kind: DockKind::Dock,
            body: Placed {
                pose: *pose,
                footprint: body.footprint(),
            },
            parts: &parts,
            free_heading: false,
        };
        let (x, y) = at.unwrap_or((pose.x, pose.y));
        let clear = |at: &Pose2| {
            !parts
                .iter()
                .any(|p| swept.overlaps(at, &p.footprint, &p.pose))
        };
        headings.iter().any(|&h| {
            dock::entries(&site, &Pose2::new(x, y, h), robot, &g.dock)
                .iter()
                .all(|mv| mv.poses(g.dock.step).all(|pp| clear(&pp.pose)))
        })
    })
}

/// The layout of the straight moves from `planner.toml`, as the planner lays them out.
pub fn params(cfg: &aisle_global_planner::PlannerConfig) -> DockParams {
    DockParams {
        run_in: cfg.dock_run_in,
        clearance: cfg.dock_clearance,
        step: cfg.validation_distance,
    }
}

#[cfg(test)]
mod tests {
    use super::super::testing::{Fixture, mission, seed_with};

    /// rack2b's pose with a template of these `parts` (a TOML array).
    fn template(parts: &str) -> String {
        format!(
            "pose = [2.0, 13.0, 1.5707963267948966]\ntemplate = \"variant\"\n\n\
             [templates.variant]\nparts = {parts}\n"
        )
    }

    /// rack2b as a closed crate: one box from the floor up over its footprint.
    fn crate_scene(name: &str) -> Fixture {
        Fixture::with_scene(
            name,
            "pose = [2.0, 13.0, 1.5707963267948966]\ntemplate = \"pallet_rack\"",
            "pose = [2.0, 13.0, 1.5707963267948966]\nsize = [0.88, 0.8, 1.0]",
        )
    }

    #[test]
    fn approaching_or_carrying_a_closed_box_is_refused_naming_leg_and_body() {
        let f = crate_scene("closed-box");
        // The seed: its first leg approaches rack2b with a stated heading.
        let e = f.check(&seed_with("", "")).unwrap_err();
        for want in [
            "mission.toml",
            "key `leg[0].approach`",
            "leg `to pick` approaches `rack2b`",
            "cannot drive under it through any of its four sides",
        ] {
            assert!(e.contains(want), "`{want}` not in: {e}");
        }
        // With the heading left out: no side either.
        let e = f
            .check(&mission("[[leg]]\nname = \"in\"\napproach = \"rack2b\"\n"))
            .unwrap_err();
        assert!(
            e.contains("key `leg[0].approach`") && e.contains("`rack2b`"),
            "{e}"
        );
        // A box raised above the robot (a table top) is no obstacle to driving under.
        let f = Fixture::with_scene(
            "raised-box",
            "pose = [2.0, 13.0, 1.5707963267948966]\ntemplate = \"pallet_rack\"",
            &template("[{ center = [0.0, 0.0, 0.5], size = [0.88, 0.8, 0.3] }]"),
        );
        f.check(&seed_with("", "")).unwrap();
    }

    #[test]
    fn a_stated_heading_through_a_blocked_side_says_another_is_open() {
        // A rack whose two legs across one short end are joined by a low bar: entering
        // along the rack's x axis from that end is blocked, the long sides are open.
        let f = Fixture::with_scene(
            "one-side",
            "pose = [2.0, 13.0, 1.5707963267948966]\ntemplate = \"pallet_rack\"",
            &template(
                "[{ center = [-0.415, 0.0, 0.1], size = [0.05, 0.8, 0.2] },\
                 { center = [0.415, 0.375, 0.15], size = [0.05, 0.05, 0.30] },\
                 { center = [0.415, -0.375, 0.15], size = [0.05, 0.05, 0.30] },\
                 { center = [0.0, 0.0, 0.325], size = [0.88, 0.80, 0.05] }]",
            ),
        );
        // The seed enters heading north (+pi/2): along the rack's x axis, from its
        // -x end, where the bar is.
        let e = f.check(&seed_with("", "")).unwrap_err();
        assert!(
            e.contains("key `leg[0].approach`") && e.contains("state a heading that enters"),
            "{e}"
        );
        // Entering through a long side (heading west, pi) is open.
        f.check(&seed_with(
            "goal = [2.0, 13.0, 1.5707963267948966]\napproach",
            "goal = [2.0, 13.0, 3.141592653589793]\napproach",
        ))
        .unwrap();
    }
}

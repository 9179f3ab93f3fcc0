//! Planner-level tests on the seed map and on small synthetic maps. Every returned path
//! is checked by a sweep written here, independently of the planner's checker
//! (separating-axis test of the rectangle against every nearby cell square).

use crate::seed_map::{self, RACK, RACK_MARGIN, ROBOT, ROBOT_MARGIN, Rect, rasterise};
use crate::{
    InvalidInput, Plan, PlanErrorKind, PlanRequest, Planner, PlannerConfig, check_turning_radius,
    validate_path,
};
use aisle_geometry::{Direction, Footprint, GridMap, GridView, PathPose, Pose2, wrap_angle};
use std::f64::consts::{FRAC_PI_2, PI};

const BUDGET: u32 = 200_000;

fn overlaps(corners: &[(f64, f64); 4], theta: f64, sq: (f64, f64, f64, f64)) -> bool {
    let sqc = [(sq.0, sq.1), (sq.2, sq.1), (sq.2, sq.3), (sq.0, sq.3)];
    let axes = [
        (1.0, 0.0),
        (0.0, 1.0),
        (theta.cos(), theta.sin()),
        (-theta.sin(), theta.cos()),
    ];
    axes.iter().all(|&(ax, ay)| {
        let proj = |pts: &[(f64, f64); 4]| {
            pts.iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                    let d = p.0 * ax + p.1 * ay;
                    (lo.min(d), hi.max(d))
                })
        };
        let (a0, a1) = proj(corners);
        let (b0, b1) = proj(&sqc);
        a1 >= b0 && b1 >= a0
    })
}

/// Independent collision test of one pose: the grown rectangle against every cell
/// square in its bounding box (cells outside the grid count as occupied).
fn pose_collides(map: &GridView, fp: &Footprint, p: &Pose2) -> bool {
    let corners = fp.corners(p);
    let xs = corners.map(|c| c.0);
    let ys = corners.map(|c| c.1);
    let r = map.resolution;
    let fl = |v: f64, o: f64| ((v - o) / r).floor() as i64;
    let (c0, c1) = (
        fl(
            xs.iter().cloned().fold(f64::INFINITY, f64::min),
            map.origin_x,
        ),
        fl(
            xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
            map.origin_x,
        ),
    );
    let (r0, r1) = (
        fl(
            ys.iter().cloned().fold(f64::INFINITY, f64::min),
            map.origin_y,
        ),
        fl(
            ys.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
            map.origin_y,
        ),
    );
    for iy in r0..=r1 {
        for ix in c0..=c1 {
            let c = aisle_geometry::CellIndex { ix, iy };
            if map.occupied_or_outside(c) {
                let x0 = map.origin_x + ix as f64 * r;
                let y0 = map.origin_y + iy as f64 * r;
                if overlaps(&corners, p.theta, (x0, y0, x0 + r, y0 + r)) {
                    return true;
                }
            }
        }
    }
    false
}

/// Sweeps the footprint along the path, interpolating at most 0.05 m / 0.05 rad apart.
fn assert_sweep_free(path: &[PathPose], map: &GridView, fp: &Footprint) {
    for (i, w) in path.windows(2).enumerate() {
        let (a, b) = (w[0].pose, w[1].pose);
        let dth = wrap_angle(b.theta - a.theta);
        let n = ((a.distance(&b) / 0.05).max(dth.abs() / 0.05).ceil() as usize).max(1);
        for k in 0..=n {
            let t = k as f64 / n as f64;
            let p = Pose2::new(
                a.x + (b.x - a.x) * t,
                a.y + (b.y - a.y) * t,
                a.theta + dth * t,
            );
            assert!(
                !pose_collides(map, fp, &p),
                "collision near pose {i}: {p:?}"
            );
        }
    }
}

fn check_plan(plan: &Plan, req: &PlanRequest, map: &GridView, cfg: &PlannerConfig) {
    let path = &plan.path;
    assert!(path.len() >= 2);
    assert_eq!(
        path[0].pose,
        Pose2::new(req.start.x, req.start.y, wrap_angle(req.start.theta))
    );
    assert_eq!(
        path.last().unwrap().pose,
        Pose2::new(req.goal.x, req.goal.y, wrap_angle(req.goal.theta))
    );
    let fp = req.footprint.inflated(req.margin);
    assert_sweep_free(path, map, &fp);
    validate_path(path, req.footprint, req.margin, map, 0.05).unwrap();
    check_turning_radius(path, cfg.min_turning_radius).unwrap();
    for w in path.windows(2) {
        let d = w[0].pose.distance(&w[1].pose);
        assert!(d <= cfg.validation_distance * 1.2 + 1e-9, "spacing {d}");
        if w[0].direction == Direction::Rotate {
            assert!(d < 1e-9, "rotations stay in place");
        } else if d > 1e-6 {
            // The pose heading agrees with the direction of travel.
            let (dx, dy) = (w[1].pose.x - w[0].pose.x, w[1].pose.y - w[0].pose.y);
            let along = (dx * w[0].pose.theta.cos() + dy * w[0].pose.theta.sin()) / d;
            let sign = if w[0].direction == Direction::Forward {
                1.0
            } else {
                -1.0
            };
            assert!(along * sign > 0.9, "heading vs travel: {along} {:?}", w[0]);
        }
    }
    assert!(plan.stats.path_length > 0.0 || req.start.distance(&req.goal) < 1e-9);
}

fn request(s: &seed_map::Segment) -> PlanRequest {
    PlanRequest {
        start: s.start,
        goal: s.goal,
        footprint: s.footprint,
        margin: s.margin,
        max_expansions: BUDGET,
        fixed_budget: false,
    }
}

#[test]
fn seed_segments_at_10_and_20_cells_per_metre() {
    let cfg = PlannerConfig::default();
    let mut planner = Planner::new(cfg.clone()).unwrap();
    for cpm in [10.0, 20.0] {
        let map = seed_map::seed_map(cpm);
        for seg in seed_map::seed_segments() {
            let req = request(&seg);
            let plan = planner
                .plan(&req, &map.view())
                .unwrap_or_else(|e| panic!("{} at {cpm}: {e}", seg.name));
            check_plan(&plan, &req, &map.view(), &cfg);
            let straight = seg.start.distance(&seg.goal);
            assert!(
                plan.stats.path_length < 1.6 * straight + 3.0,
                "{:?}",
                plan.stats
            );
        }
    }
}

/// A planner warmed up for the map (as the node starts it) plans what a cold one does,
/// paths and counters alike (but for `map_rebuilt`: the warm-up built the tables).
#[test]
fn warm_up_changes_no_result() {
    for cpm in [10.0, 20.0] {
        let map = seed_map::seed_map(cpm);
        let view = map.view();
        let mut cold = Planner::new(PlannerConfig::default()).unwrap();
        let mut warm = Planner::new(PlannerConfig::default()).unwrap();
        warm.warm_up(&view);
        for seg in seed_map::seed_segments() {
            let req = request(&seg);
            let mut c = cold.plan(&req, &view).unwrap();
            let w = warm.plan(&req, &view).unwrap();
            assert!(!w.stats.map_rebuilt);
            c.stats.map_rebuilt = false;
            assert_eq!(c, w, "{}", seg.name);
        }
    }
}

#[test]
fn same_request_gives_the_same_path_bit_for_bit() {
    let map = seed_map::seed_map(10.0);
    let segs = seed_map::seed_segments();
    let hard = hard_request();
    let mut a = Planner::new(PlannerConfig::default()).unwrap();
    let mut b = Planner::new(PlannerConfig::default()).unwrap();
    let first: Vec<_> = [request(&segs[1]), hard]
        .iter()
        .map(|r| a.plan(r, &map.view()).unwrap())
        .collect();
    // b plans something else first so that its buffers hold stale data.
    b.plan(&request(&segs[0]), &map.view()).unwrap();
    for (r, p) in [request(&segs[1]), hard].iter().zip(&first) {
        let again = a.plan(r, &map.view()).unwrap();
        let other = b.plan(r, &map.view()).unwrap();
        for q in [&again, &other] {
            assert_eq!(q.path.len(), p.path.len());
            for (x, y) in q.path.iter().zip(&p.path) {
                assert_eq!(x.pose.x.to_bits(), y.pose.x.to_bits());
                assert_eq!(x.pose.y.to_bits(), y.pose.y.to_bits());
                assert_eq!(x.pose.theta.to_bits(), y.pose.theta.to_bits());
                assert_eq!(x.direction, y.direction);
            }
            assert_eq!(q.stats.expansions, p.stats.expansions);
        }
    }
}

/// Into the aisle between the racks at x 5.5..8.5, facing out of its closed end: needs
/// reversing, a turn in the aisle or a rotation on the spot.
fn hard_request() -> PlanRequest {
    PlanRequest {
        start: Pose2::new(0.0, 0.0, 0.0),
        goal: Pose2::new(7.0, 14.0, -FRAC_PI_2),
        footprint: ROBOT,
        margin: ROBOT_MARGIN,
        max_expansions: BUDGET,
        fixed_budget: false,
    }
}

#[test]
fn hard_query_needs_search_and_stays_valid() {
    let cfg = PlannerConfig::default();
    let mut planner = Planner::new(cfg.clone()).unwrap();
    let map = seed_map::seed_map(10.0);
    let req = hard_request();
    let plan = planner.plan(&req, &map.view()).unwrap();
    check_plan(&plan, &req, &map.view(), &cfg);
    assert!(plan.stats.expansions > 1, "{:?}", plan.stats);
    // Carrying the rack from the pick into the neighbouring aisle.
    let req = PlanRequest {
        start: Pose2::new(2.0, 13.0, -FRAC_PI_2),
        goal: Pose2::new(-0.5, 15.0, FRAC_PI_2),
        footprint: RACK,
        margin: RACK_MARGIN,
        max_expansions: BUDGET,
        fixed_budget: false,
    };
    let plan = planner.plan(&req, &map.view()).unwrap();
    check_plan(&plan, &req, &map.view(), &cfg);
}

#[test]
fn occupied_start_or_goal_is_a_typed_error() {
    let map = seed_map::seed_map(10.0);
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let base = request(&seed_map::seed_segments()[0]);
    // Inside a rack row.
    let bad = Pose2::new(5.0, 12.0, 0.0);
    let e = planner
        .plan(&PlanRequest { start: bad, ..base }, &map.view())
        .unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::StartOccupied);
    let e = planner
        .plan(&PlanRequest { goal: bad, ..base }, &map.view())
        .unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::GoalOccupied);
    // Free for the robot's centre but too close for the grown rack.
    let near = Pose2::new(3.8, 12.0, FRAC_PI_2);
    let e = planner
        .plan(
            &PlanRequest {
                goal: near,
                footprint: RACK,
                margin: RACK_MARGIN,
                ..base
            },
            &map.view(),
        )
        .unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::GoalOccupied);
}

#[test]
fn walled_in_goal_is_no_path_before_any_expansion() {
    let mut map = seed_map::seed_map(10.0);
    // A closed box of 0.1 m walls around (0, 5).
    rasterise(
        &mut map,
        &[
            Rect::new(-1.5, 3.5, 1.5, 3.6),
            Rect::new(-1.5, 6.4, 1.5, 6.5),
            Rect::new(-1.5, 3.5, -1.4, 6.5),
            Rect::new(1.4, 3.5, 1.5, 6.5),
        ],
    );
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let req = PlanRequest {
        goal: Pose2::new(0.0, 5.0, 0.0),
        ..request(&seed_map::seed_segments()[0])
    };
    let e = planner.plan(&req, &map.view()).unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::NoPath);
    assert_eq!(e.stats.expansions, 0);
    // And from inside the box out.
    let req = PlanRequest {
        start: Pose2::new(0.0, 5.0, 0.0),
        goal: Pose2::new(0.0, 0.0, 0.0),
        ..req
    };
    assert_eq!(
        planner.plan(&req, &map.view()).unwrap_err().kind,
        PlanErrorKind::NoPath
    );
}

#[test]
fn budget_and_stop_callback_end_the_search() {
    let map = seed_map::seed_map(10.0);
    let mut planner = Planner::new(PlannerConfig {
        stop_check_interval: 4,
        // The request's budget alone.
        expansions_per_reachable_cell: 0.0,
        ..Default::default()
    })
    .unwrap();
    let req = PlanRequest {
        max_expansions: 3,
        fixed_budget: false,
        ..hard_request()
    };
    let e = planner.plan(&req, &map.view()).unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::BudgetExhausted);
    assert_eq!(e.stats.expansions, 3);
    let mut asked = 0;
    let e = planner
        .plan_with_stop(&hard_request(), &map.view(), &mut || {
            asked += 1;
            true
        })
        .unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::Stopped);
    assert_eq!(asked, 1);
    assert_eq!(e.stats.expansions, 4);
}

#[test]
fn bad_input_is_refused_not_panicked_on() {
    let map = seed_map::seed_map(10.0);
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let base = request(&seed_map::seed_segments()[0]);
    let cases = [
        (
            PlanRequest {
                start: Pose2::new(f64::NAN, 0.0, 0.0),
                ..base
            },
            InvalidInput::StartNotFinite,
        ),
        (
            PlanRequest {
                goal: Pose2::new(0.0, 0.0, f64::INFINITY),
                ..base
            },
            InvalidInput::GoalNotFinite,
        ),
        (
            PlanRequest {
                footprint: Footprint::new(-1.0, 0.4),
                ..base
            },
            InvalidInput::Footprint,
        ),
        (
            PlanRequest {
                margin: f64::NAN,
                ..base
            },
            InvalidInput::Margin,
        ),
        (
            PlanRequest {
                max_expansions: 0,
                fixed_budget: false,
                ..base
            },
            InvalidInput::ZeroBudget,
        ),
    ];
    for (req, want) in cases {
        let e = planner.plan(&req, &map.view()).unwrap_err();
        assert_eq!(e.kind, PlanErrorKind::InvalidInput(want));
    }
    let cells = vec![0u8; 10];
    let broken = GridView {
        origin_x: 0.0,
        origin_y: 0.0,
        resolution: 0.1,
        width: 4,
        height: 4,
        cells: &cells,
    };
    let e = planner.plan(&base, &broken).unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::InvalidInput(InvalidInput::Map));
    // A goal outside the map is said to be so, not "in collision".
    let e = planner
        .plan(
            &PlanRequest {
                goal: Pose2::new(100.0, 0.0, 0.0),
                ..base
            },
            &map.view(),
        )
        .unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::GoalOutsideMap);
    assert_eq!(e.kind.to_string(), "the goal pose is outside the map");
    let e = planner
        .plan(
            &PlanRequest {
                start: Pose2::new(0.0, -100.0, 0.0),
                ..base
            },
            &map.view(),
        )
        .unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::StartOutsideMap);
}

/// A dead-end corridor barely wider than the robot: turning around needs a rotation on
/// the spot (no arc of radius 1 m fits), so the path must contain Rotate poses.
#[test]
fn tight_corridor_turns_on_the_spot() {
    let mut map = GridMap::new_free(0.0, 0.0, 0.05, 8.0, 4.0).unwrap();
    rasterise(
        &mut map,
        &[
            Rect::new(0.0, 0.0, 8.0, 1.5),
            Rect::new(0.0, 2.6, 8.0, 4.0),
            Rect::new(0.0, 0.0, 0.5, 4.0),
            Rect::new(7.5, 0.0, 8.0, 4.0),
        ],
    );
    let cfg = PlannerConfig::default();
    let mut planner = Planner::new(cfg.clone()).unwrap();
    let req = PlanRequest {
        start: Pose2::new(2.0, 2.05, 0.0),
        goal: Pose2::new(5.0, 2.05, PI),
        footprint: ROBOT,
        margin: ROBOT_MARGIN,
        max_expansions: BUDGET,
        fixed_budget: false,
    };
    let plan = planner.plan(&req, &map.view()).unwrap();
    check_plan(&plan, &req, &map.view(), &cfg);
    assert!(plan.path.iter().any(|p| p.direction == Direction::Rotate));
    // Without rotations the same request cannot be solved.
    let mut no_rot = Planner::new(PlannerConfig {
        allow_rotation: false,
        ..cfg
    })
    .unwrap();
    let e = no_rot
        .plan(
            &PlanRequest {
                max_expansions: 20_000,
                fixed_budget: false,
                ..req
            },
            &map.view(),
        )
        .unwrap_err();
    assert!(matches!(
        e.kind,
        PlanErrorKind::NoPath | PlanErrorKind::BudgetExhausted
    ));
}

#[test]
fn validate_path_finds_a_collision_the_planner_would_not_make() {
    let map = seed_map::seed_map(10.0);
    // Straight through the table at (5, -2.5).
    let path: Vec<PathPose> = (0..=40)
        .map(|k| {
            PathPose::new(
                Pose2::new(3.0 + 0.1 * k as f64, -2.5, 0.0),
                Direction::Forward,
            )
        })
        .collect();
    assert!(validate_path(&path, ROBOT, ROBOT_MARGIN, &map.view(), 0.1).is_err());
    assert!(validate_path(&path[..5], ROBOT, ROBOT_MARGIN, &map.view(), 0.1).is_ok());
    assert!(validate_path(&[], ROBOT, ROBOT_MARGIN, &map.view(), 0.1).is_err());
    // A kink tighter than the turning radius.
    let kink = [
        PathPose::new(Pose2::new(0.0, 0.0, 0.0), Direction::Forward),
        PathPose::new(Pose2::new(0.1, 0.0, 0.5), Direction::Forward),
    ];
    assert!(check_turning_radius(&kink, 1.0).is_err());
    assert!(check_turning_radius(&kink, 0.1).is_ok());
}

/// A box with one door in its right wall, from `door.0` to `door.1` (y, m).
fn boxed_map(door: (f64, f64)) -> aisle_geometry::GridMap {
    let mut map = seed_map::seed_map(20.0);
    rasterise(
        &mut map,
        &[
            Rect::new(-1.1, 3.9, 1.1, 4.0),
            Rect::new(-1.1, 6.0, 1.1, 6.1),
            Rect::new(-1.1, 3.9, -1.0, 6.1),
            Rect::new(1.0, 3.9, 1.1, door.0),
            Rect::new(1.0, door.1, 1.1, 6.1),
        ],
    );
    map
}

/// A door narrower than the inscribed circle (margin included) of the robot: the
/// heuristic proves the enclosure before any expansion, from inside and from outside.
/// (It once left such doors open, and a search before a detected wall with small holes
/// in it flooded its whole side until the budget ran out.)
#[test]
fn a_door_narrower_than_the_inscribed_circle_is_proven_closed() {
    // 0.6 m of free cells; the robot needs 0.43 + 2 x 0.1 = 0.63 m.
    let map = boxed_map((4.675, 5.325));
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let inside = Pose2::new(0.0, 5.0, 0.0);
    let outside = Pose2::new(0.0, 0.0, 0.0);
    for (start, goal) in [(inside, outside), (outside, inside)] {
        let req = PlanRequest {
            start,
            goal,
            footprint: ROBOT,
            margin: ROBOT_MARGIN,
            max_expansions: BUDGET,
            fixed_budget: false,
        };
        let e = planner.plan(&req, &map.view()).unwrap_err();
        assert_eq!(e.kind, PlanErrorKind::NoPath);
        assert_eq!(e.stats.expansions, 0, "{e:?}");
    }
}

/// The same box with a door one cell wider than the robot needs: the path goes through.
#[test]
fn a_door_just_wide_enough_is_passed() {
    // 0.7 m of free cells (4.65 .. 5.35).
    let map = boxed_map((4.625, 5.375));
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let req = PlanRequest {
        start: Pose2::new(0.0, 5.0, 0.0),
        goal: Pose2::new(0.0, 0.0, 0.0),
        footprint: ROBOT,
        margin: ROBOT_MARGIN,
        max_expansions: BUDGET,
        fixed_budget: false,
    };
    let plan = planner.plan(&req, &map.view()).unwrap();
    assert!(
        plan.path.iter().any(|p| p.pose.x > 1.1),
        "leaves through the door"
    );
}

fn scene() -> aisle_config::scene::Scene {
    let path = aisle_config::testing::shipped("warehouse.toml");
    aisle_config::scene::Scene::load(&path).unwrap()
}

/// The stand-in seed map is the scene file's static map, and movable bodies (the rack
/// to pick, the unseen pallets) are not on it.
#[test]
fn scene_static_map_matches_the_stand_in_and_has_no_movable_body() {
    let scene = scene();
    for cpm in [10.0, 20.0] {
        let from_scene = seed_map::scene_map(&scene, cpm);
        let stand_in = seed_map::seed_map(cpm);
        assert_eq!(from_scene.cells, stand_in.cells, "at {cpm} cells/m");
        let v = from_scene.view();
        for body in scene.movable_bodies() {
            if body.parts.iter().any(|p| p.z_min() <= 5.0) {
                assert!(!v.occupied_at(body.pose.x, body.pose.y), "{}", body.name);
            }
        }
        assert!(v.occupied_at(5.0, -2.5), "table_1 is static");
    }
}

/// The three seed legs on the map built from `config/warehouse.toml`.
#[test]
fn seed_legs_plan_on_the_scene_static_map() {
    let scene = scene();
    let cfg = PlannerConfig::default();
    let mut planner = Planner::new(cfg.clone()).unwrap();
    for cpm in [10.0, 20.0] {
        let map = seed_map::scene_map(&scene, cpm);
        for seg in seed_map::seed_segments() {
            let req = request(&seg);
            let plan = planner
                .plan(&req, &map.view())
                .unwrap_or_else(|e| panic!("{} at {cpm}: {e}", seg.name));
            check_plan(&plan, &req, &map.view(), &cfg);
            println!(
                "{} @ {cpm} cells/m: {:.2} m, {} poses, {} expansions",
                seg.name,
                plan.stats.path_length,
                plan.path.len(),
                plan.stats.expansions
            );
        }
    }
}

/// A xorshift stream (tests only: seeded, so every run sees the same maps).
pub(crate) fn stream(mut seed: u64) -> impl FnMut(i64) -> i64 {
    move |n: i64| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed % n as u64) as i64
    }
}

mod both_ends;
mod bound;
mod fixed_budget;
mod goal_wall;
mod golden;
mod lazy;
mod meet;
mod relief;
mod validation;
mod wedged;

/// The budget grows with the area the goal can be reached from: a request whose own
/// budget is far too small for its detour still finds the path, and the expansions it
/// took stay within the scaled budget.
#[test]
fn the_budget_scales_with_the_reachable_area() {
    let map = seed_map::seed_map(10.0);
    let req = PlanRequest {
        max_expansions: 3,
        fixed_budget: false,
        ..hard_request()
    };
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let plan = planner.plan(&req, &map.view()).unwrap();
    let cfg = PlannerConfig::default();
    let scaled = cfg.expansions_per_reachable_cell * f64::from(plan.stats.heuristic_cells);
    assert!(
        f64::from(plan.stats.expansions) <= scaled,
        "{:?}",
        plan.stats
    );
    assert!(plan.stats.expansions > 3);
}

//! The mission state machine against the seed sequence and its failure modes.

use super::*;
use crate::mission::events::Dock;
use aisle_geometry::Direction;

fn mission() -> Mission {
    let cfg = MissionConfig {
        start: [0.0; 3],
        leg_timeout_s: 100.0,
        max_replans_per_leg: 2,
        replan_cooldown_steps: 1,
        stall_timeout_s: 10.0,
        update_rate_hz: 10.0,
        controller_period_s: 0.5,
        planner_timeout_s: 5.0,
        restore_max_expansions: 10_000,
        goal_tolerance: [0.2; 3],
        leg: vec![
            LegSpec {
                name: "a".into(),
                goal_given: Some([1.0, 0.0, 0.0]),
                goal: [1.0, 0.0, 0.0],
                free_heading: false,
                rotate: false,
                carry: None,
                approach: Some("rack".into()),
                depart: None,
                max_velocity: None,
            },
            LegSpec {
                name: "b".into(),
                goal_given: Some([1.0, 0.0, 3.0]),
                goal: [1.0, 0.0, 3.0],
                free_heading: false,
                rotate: true,
                carry: None,
                approach: None,
                depart: None,
                max_velocity: None,
            },
            LegSpec {
                name: "c".into(),
                goal_given: Some([2.0, 0.0, 0.0]),
                goal: [2.0, 0.0, 0.0],
                free_heading: false,
                rotate: false,
                carry: Some("rack".into()),
                approach: None,
                depart: None,
                max_velocity: None,
            },
        ],
    };
    let fp = Footprints {
        alone: Footprint::new(0.5, 0.4),
        alone_margin: 0.1,
        carrying: Footprint::new(0.9, 0.8),
        carrying_margin: 0.4,
        height: 0.25,
    };
    let bodies = vec![NamedBody {
        name: "rack".into(),
        pose: Pose2::new(1.0, 0.0, 0.0),
        footprint: Footprint::new(0.88, 0.8),
        parts: vec![(Pose2::new(0.4, 0.35, 0.0), Footprint::new(0.05, 0.05))],
    }];
    Mission::new(cfg, fp, bodies)
}

fn path() -> Vec<PathPose> {
    vec![PathPose::new(Pose2::default(), Direction::Forward)]
}

const OK: ControllerReport = ControllerReport {
    reached_goal: false,
    exit_flag: 0,
    timestamps_increasing: true,
};
const REACHED: ControllerReport = ControllerReport {
    reached_goal: true,
    exit_flag: 0,
    timestamps_increasing: true,
};

#[test]
fn the_seed_sequence_plans_rotates_attaches_and_detaches() {
    let mut m = mission();
    let p = Pose2::default();
    let a = m.start_leg(0.0, p);
    // The approached rack is an obstacle until the straight move under it begins.
    assert!(matches!(
        a[0],
        Action::MapperControl {
            ignore: None,
            carried: None,
            ..
        }
    ));
    assert!(matches!(a[1], Action::Plan { use_detections: false, margin, .. } if margin == 0.1));
    assert!(matches!(
        m.on_plan(0.0, p, Ok(Planned::plain(path())))[0],
        Action::Follow { .. }
    ));
    assert!(m.on_controller(1.0, p, OK).is_empty());
    let a = m.on_controller(2.0, Pose2::new(1.0, 0.0, 0.0), REACHED);
    assert!(
        a.iter().any(|x| matches!(x, Action::Rotate { .. })),
        "{a:?}"
    );
    let a = m.on_controller(3.0, Pose2::new(1.0, 0.0, 3.0), REACHED);
    assert_eq!(a[0], Action::Attach("rack".into()));
    assert!(matches!(
        a[1],
        Action::MapperControl {
            ignore: None,
            carried: Some(_),
            ..
        }
    ));
    assert!(matches!(a[2], Action::Plan { margin, .. } if margin == 0.4));
    m.on_plan(3.0, p, Ok(Planned::plain(path())));
    let a = m.on_controller(9.0, Pose2::new(2.0, 0.0, 0.0), REACHED);
    assert_eq!(a[0], Action::Detach);
    assert_eq!(*a.last().unwrap(), Action::Halt);
    assert!(m.succeeded());
    assert_eq!(m.results.len(), 3);
}

#[test]
fn infeasible_bands_replan_with_detections_then_fail_with_a_reason() {
    let mut m = mission();
    let p = Pose2::default();
    m.start_leg(0.0, p);
    m.on_plan(0.0, p, Ok(Planned::plain(path())));
    let bad = ControllerReport {
        reached_goal: false,
        exit_flag: 1,
        timestamps_increasing: true,
    };
    let a = m.on_controller(1.0, p, bad);
    assert!(matches!(
        a[0],
        Action::Plan {
            use_detections: true,
            ..
        }
    ));
    m.on_plan(1.0, p, Ok(Planned::plain(path())));
    // Cooldown: the next infeasible report does not replan at once.
    assert!(m.on_controller(1.5, p, bad).is_empty());
    let a = m.on_controller(
        2.0,
        p,
        ControllerReport {
            timestamps_increasing: false,
            exit_flag: 0,
            reached_goal: false,
        },
    );
    assert!(matches!(a[0], Action::Plan { .. }));
    m.on_plan(2.0, p, Ok(Planned::plain(path())));
    m.on_controller(2.5, p, bad);
    let a = m.on_controller(3.0, p, bad);
    assert_eq!(a, vec![Action::Halt]);
    assert!(
        m.failure().unwrap().contains("infeasible"),
        "{:?}",
        m.failure()
    );
}

#[test]
fn an_acceleration_flag_is_driven_not_replanned() {
    let mut m = mission();
    let p = Pose2::default();
    m.start_leg(0.0, p);
    m.on_plan(0.0, p, Ok(Planned::plain(path())));
    let hard = ControllerReport {
        reached_goal: false,
        exit_flag: 6,
        timestamps_increasing: true,
    };
    for k in 0..10 {
        assert!(m.on_controller(1.0 + f64::from(k), p, hard).is_empty());
    }
    assert!(m.failure().is_none());
}

#[test]
fn an_unreachable_goal_fails_the_mission() {
    let mut m = mission();
    let p = Pose2::default();
    m.start_leg(0.0, p);
    let a = m.on_plan(0.0, p, Err(PlanFailure::new("goal occupied")));
    assert_eq!(a, vec![Action::Halt]);
    assert!(m.failure().unwrap().contains("goal occupied"));
}

#[test]
fn a_failed_replan_keeps_the_old_reference_and_retries() {
    let mut m = mission();
    let p = Pose2::default();
    m.start_leg(0.0, p);
    m.on_plan(0.0, p, Ok(Planned::plain(path())));
    let bad = ControllerReport {
        reached_goal: false,
        exit_flag: 1,
        timestamps_increasing: true,
    };
    m.on_controller(0.5, p, bad);
    assert!(
        m.on_plan(0.5, p, Err(PlanFailure::new("no path")))
            .is_empty()
    );
    assert!(!m.is_finished());
    // Infeasible on: the failed plan used up part of the leg's replan budget, and the
    // failure says so beside the replans it counts.
    let mut t = 1.0;
    while !m.is_finished() && t < 30.0 {
        let a = m.on_controller(t, p, bad);
        if matches!(a.first(), Some(Action::Plan { .. })) {
            m.on_plan(t, p, Ok(Planned::plain(path())));
        }
        t += 0.5;
    }
    let why = m.failure().expect("the leg fails").to_string();
    assert!(why.contains("and 1 failed plan(s)"), "{why}");
}

#[test]
fn a_leg_that_takes_too_long_fails() {
    let mut m = mission();
    let p = Pose2::default();
    m.start_leg(0.0, p);
    assert!(m.on_tick(50.0, p).is_empty());
    assert_eq!(m.on_tick(100.5, p), vec![Action::Halt]);
    assert!(m.failure().unwrap().contains("not reached within"));
}

#[test]
fn a_departing_leg_drives_straight_out_first_then_plans_the_leg() {
    let mut m = mission();
    m.cfg.leg[2].depart = Some(1.2);
    let p = Pose2::default();
    m.start_leg(0.0, p);
    m.on_plan(0.0, p, Ok(Planned::plain(path())));
    m.on_controller(1.0, Pose2::new(1.0, 0.0, 0.0), REACHED);
    // Turned within the tolerance of leg b's 3.0 rad: the departure leaves along the
    // heading the robot has.
    let at = Pose2::new(1.0, 0.0, 2.9);
    let a = m.on_controller(2.0, at, REACHED);
    // Leg c carries; its first motion is the straight departure.
    let Some(Action::Plan { goal, .. }) = a.iter().find(|x| matches!(x, Action::Plan { .. }))
    else {
        panic!("{a:?}")
    };
    assert!(
        (goal.x - (1.0 + 1.2 * 2.9f64.cos())).abs() < 1e-12
            && (goal.y - 1.2 * 2.9f64.sin()).abs() < 1e-12
    );
    assert_eq!(goal.theta, 2.9);
    m.on_plan(3.0, at, Ok(Planned::plain(path())));
    let out = Pose2::new(2.0, 0.5, 0.5);
    let a = m.on_controller(4.0, out, REACHED);
    assert_eq!(a.len(), 2);
    let Action::Plan {
        start,
        goal,
        use_detections,
        ..
    } = a[1]
    else {
        panic!("{a:?}")
    };
    assert_eq!(
        (start, goal, use_detections),
        (out, Pose2::new(2.0, 0.0, 0.0), false)
    );
    assert!(!m.is_finished());
    assert_eq!(m.results.len(), 2, "the departure is part of the leg");
}

/// Adds leg d: to (5, 0), alone, after the set-down of leg c.
fn push_leg_d(m: &mut Mission) {
    m.cfg.leg.push(LegSpec {
        name: "d".into(),
        goal_given: Some([5.0, 0.0, 0.0]),
        goal: [5.0, 0.0, 0.0],
        free_heading: false,
        rotate: false,
        carry: None,
        approach: None,
        depart: None,
        max_velocity: None,
    });
}

fn poses(n: usize) -> Vec<PathPose> {
    (0..n)
        .map(|i| PathPose::new(Pose2::new(i as f64, 0.0, 0.0), Direction::Forward))
        .collect()
}

#[test]
fn a_pick_docks_straight_and_the_leg_after_the_drop_undocks_first() {
    let mut m = mission();
    push_leg_d(&mut m);
    // The turn in place keeps the heading, so the rack is carried as it stood.
    m.cfg.leg[1].goal = [1.0, 0.0, 0.0];
    m.cfg.leg[1].goal_given = Some([1.0, 0.0, 0.0]);
    let p = Pose2::default();
    let a = m.start_leg(0.0, p);
    let Action::Plan {
        dock: Some(Dock::Into { body, free_heading }),
        ..
    } = &a[1]
    else {
        panic!("{a:?}")
    };
    assert!(!free_heading);
    // The leg, in the map frame: the rack stands at (1, 0).
    assert_eq!(body.parts[0].0, Pose2::new(1.4, 0.35, 0.0));
    let planned = Planned {
        path: poses(3),
        dock_from: Some(1),
        undock_to: None,
    };
    let a = m.on_plan(0.0, p, Ok(planned));
    let Action::Follow {
        reference,
        tolerance: Some(_),
        goal,
        ..
    } = &a[0]
    else {
        panic!("{a:?}")
    };
    assert_eq!((reference.len(), goal.x), (2, 1.0));
    let a = m.on_controller(1.0, p, REACHED);
    assert!(
        matches!(
            a[0],
            Action::MapperControl {
                ignore: Some(_),
                ..
            }
        ),
        "{a:?}"
    );
    assert!(
        matches!(a[1], Action::Straight { goal, .. } if goal.x == 2.0),
        "{a:?}"
    );
    // Under the rack: the turn on the spot ignores it, then it is carried.
    let under = Pose2::new(1.0, 0.0, 0.0);
    let a = m.on_controller(2.0, under, REACHED);
    assert!(a.iter().any(|x| matches!(
        x,
        Action::MapperControl {
            ignore: Some(_),
            ..
        }
    )));
    let a = m.on_controller(3.0, under, REACHED);
    assert!(matches!(a[2], Action::Plan { dock: None, .. }), "{a:?}");
    m.on_plan(3.0, p, Ok(Planned::plain(poses(2))));
    // Set down: the next leg leaves it straight, then follows the rest.
    let drop = Pose2::new(2.0, 0.0, 0.0);
    let a = m.on_controller(4.0, drop, REACHED);
    assert_eq!(a[0], Action::Detach);
    assert!(
        a.iter().any(|x| matches!(x, Action::Plan { dock: Some(Dock::OutOf { body }), .. } if body.pose == Pose2::new(2.0, 0.0, 0.0))),
        "{a:?}"
    );
    // Still under it: ignored, not yet kept as an obstacle.
    assert!(
        a.iter().any(|x| matches!(x, Action::MapperControl { ignore: Some(_), placed, .. } if placed.is_empty())),
        "{a:?}"
    );
    let planned = Planned {
        path: poses(4),
        dock_from: None,
        undock_to: Some(1),
    };
    let a = m.on_plan(4.0, drop, Ok(planned.clone()));
    assert!(
        matches!(a[1], Action::Straight { goal, .. } if goal.x == 1.0),
        "{a:?}"
    );
    // The way out is blocked: the move out is planned again, with the detections.
    let blocked = ControllerReport { exit_flag: 1, ..OK };
    let a = m.on_controller(4.5, drop, blocked);
    assert!(
        matches!(
            &a[..],
            [Action::Plan {
                dock: Some(Dock::OutOf { .. }),
                use_detections: true,
                ..
            }]
        ),
        "{a:?}"
    );
    let a = m.on_plan(4.5, drop, Ok(planned));
    assert!(
        matches!(a[1], Action::Straight { goal, .. } if goal.x == 1.0),
        "{a:?}"
    );
    let a = m.on_controller(5.0, drop, REACHED);
    // Out from under it: the legs of the rack set down are known obstacles now.
    let leg = (Pose2::new(2.4, 0.35, 0.0), Footprint::new(0.05, 0.05));
    assert!(
        matches!(&a[0], Action::MapperControl { ignore: None, placed, .. } if *placed == [leg]),
        "{a:?}"
    );
    assert!(
        matches!(&a[1], Action::Follow { reference, .. } if reference.len() == 3),
        "{a:?}"
    );
    let a = m.on_controller(6.0, Pose2::new(5.0, 0.0, 0.0), REACHED);
    assert_eq!(*a.last().unwrap(), Action::Halt);
    assert!(m.succeeded());
}

/// The seed's mission with the robot alone keeping `margin`.
fn mission_alone_margin(margin: f64) -> Mission {
    let mut m = mission();
    m.footprints.alone_margin = margin;
    m
}

#[test]
fn a_start_inside_the_margin_backs_off_with_a_smaller_margin_then_fails() {
    let mut m = mission_alone_margin(0.3);
    let p = Pose2::default();
    m.start_leg(0.0, p);
    let blocked = || PlanFailure {
        why: "the start is in collision".into(),
        margin_bound: true,
    };
    let a = m.on_plan(0.0, p, Err(blocked()));
    assert!(
        matches!(a[0], Action::Plan { margin, use_detections: true, .. } if (margin - 0.15).abs() < 1e-12),
        "{a:?}"
    );
    // Never below 0.15 m (what the lidar cannot see): failing there too ends the leg (it
    // had no reference yet).
    assert_eq!(m.on_plan(0.0, p, Err(blocked())), vec![Action::Halt]);
    assert!(m.failure().unwrap().contains("start is in collision"));
    // The report counts both: one retry with less margin, one failure.
    let leg = &m.results[0];
    assert_eq!((leg.margin_backoffs, leg.plan_failures), (1, 1), "{leg:?}");
}

#[test]
fn a_margin_no_larger_than_the_floor_is_never_backed_off() {
    // The robot alone keeps 0.1 m, less than an unseen pallet base's overhang and half a
    // cell: a plan the margin blocks ends the leg at once.
    let mut m = mission();
    let p = Pose2::default();
    m.start_leg(0.0, p);
    let blocked = PlanFailure {
        why: "the search ran out of time".into(),
        margin_bound: true,
    };
    assert_eq!(m.on_plan(0.0, p, Err(blocked)), vec![Action::Halt]);
    let leg = &m.results[0];
    assert_eq!((leg.margin_backoffs, leg.plan_failures), (0, 1), "{leg:?}");
}

#[test]
fn a_reduced_margin_lasts_until_the_robot_is_clear_of_the_spot() {
    let mut m = mission_alone_margin(0.3);
    let p = Pose2::default();
    m.start_leg(0.0, p);
    let blocked = PlanFailure {
        why: "the start is in collision".into(),
        margin_bound: true,
    };
    // Backing off is no try: the planner's own budget, which grows with the hall.
    let a = m.on_plan(0.0, p, Err(blocked));
    assert!(
        matches!(
            a[..],
            [Action::Plan {
                fixed_budget: None,
                ..
            }]
        ),
        "{a:?}"
    );
    let a = m.on_plan(0.1, p, Ok(Planned::plain(path())));
    assert!(
        matches!(a[0], Action::Follow { margin, .. } if (margin - 0.15).abs() < 1e-12),
        "{a:?}"
    );
    // Still near where the backing off began: the reduced plan is driven on.
    assert!(m.on_tick(1.0, Pose2::new(0.6, 0.0, 0.0)).is_empty());
    // Clear of it: a plan with the full margin, a try whose search is bounded (the
    // reduced plan is its fallback).
    let a = m.on_tick(1.1, Pose2::new(1.0, 0.0, 0.0));
    assert!(
        matches!(a[..], [Action::Plan { margin, use_detections: true, fixed_budget: Some(10_000), .. }] if (margin - 0.3).abs() < 1e-12),
        "{a:?}"
    );
    // Driven with the full margin, the leg asks for nothing more.
    m.on_plan(1.2, Pose2::new(1.0, 0.0, 0.0), Ok(Planned::plain(path())));
    assert!(m.on_tick(3.0, Pose2::new(2.5, 0.0, 0.0)).is_empty());
}

fn no_path_with_this_margin() -> PlanFailure {
    PlanFailure {
        why: "no path exists".into(),
        margin_bound: true,
    }
}

fn on_x_axis(x: f64) -> Pose2 {
    Pose2::new(x, 0.0, 0.0)
}

#[test]
fn a_full_margin_try_that_backs_off_again_doubles_the_distance_to_the_next() {
    let mut m = mission_alone_margin(0.3);
    let (blocked, at) = (no_path_with_this_margin, on_x_axis);
    let full =
        |a: &[Action]| matches!(a, [Action::Plan { margin, .. }] if (margin - 0.3).abs() < 1e-12);
    m.start_leg(0.0, at(0.0));
    m.on_plan(0.0, at(0.0), Err(blocked()));
    m.on_plan(0.1, at(0.0), Ok(Planned::plain(path())));
    // 1 m on: the full margin is tried, fails, and the leg backs off again from there.
    assert!(full(&m.on_tick(1.0, at(1.0))));
    m.on_plan(1.1, at(1.0), Err(blocked()));
    m.on_plan(1.2, at(1.0), Ok(Planned::plain(path())));
    // The next try waits for 2 m, then 4 m (and no more).
    assert!(m.on_tick(2.0, at(2.5)).is_empty());
    assert!(full(&m.on_tick(2.1, at(3.0))));
    m.on_plan(2.2, at(3.0), Err(blocked()));
    m.on_plan(2.3, at(3.0), Ok(Planned::plain(path())));
    assert!(m.on_tick(3.0, at(6.5)).is_empty());
    assert!(full(&m.on_tick(3.1, at(7.0))));
    m.on_plan(3.2, at(7.0), Err(blocked()));
    m.on_plan(3.3, at(7.0), Ok(Planned::plain(path())));
    assert!(m.on_tick(4.0, at(10.5)).is_empty());
    assert!(full(&m.on_tick(4.1, at(11.0))));
    // A try that keeps the full margin makes the next backing off short again.
    m.on_plan(4.2, at(11.0), Ok(Planned::plain(path())));
    let infeasible = ControllerReport { exit_flag: 1, ..OK };
    // (after the replan's cool-down steps)
    let replan = (0..10).find(|_| !m.on_controller(4.5, at(11.0), infeasible).is_empty());
    assert!(replan.is_some());
    m.on_plan(4.6, at(11.0), Err(blocked()));
    m.on_plan(4.7, at(11.0), Ok(Planned::plain(path())));
    assert!(full(&m.on_tick(5.0, at(12.0))));
}

#[test]
fn a_full_margin_try_that_finds_no_plan_at_all_drives_on_and_is_no_plan_failure() {
    let mut m = mission_alone_margin(0.3);
    let (blocked, at) = (no_path_with_this_margin, on_x_axis);
    m.start_leg(0.0, at(0.0));
    m.on_plan(0.0, at(0.0), Err(blocked()));
    m.on_plan(0.1, at(0.0), Ok(Planned::plain(path())));
    assert!(!m.on_tick(1.0, at(1.0)).is_empty());
    // The full margin, half and 3/8 of it: no plan from here.
    m.on_plan(1.1, at(1.0), Err(blocked()));
    assert_eq!(m.on_plan(1.2, at(1.0), Err(blocked())), Vec::new());
    // The reduced plan is driven on; the next try waits for 2 m from here.
    assert!(m.on_tick(1.3, at(1.1)).is_empty());
    assert!(m.on_tick(2.0, at(2.9)).is_empty());
    assert!(!m.on_tick(2.1, at(3.0)).is_empty());
    assert_eq!(m.plan_failures, 0);
}

/// The planner's way out of a rack set down is through a side: the robot turns in place
/// under it first, then drives straight out, then follows the rest.
#[test]
fn a_way_out_through_a_side_turns_in_place_first() {
    let mut m = mission();
    push_leg_d(&mut m);
    // Legs end where the robot stands: under the rack at (1, 0) without turning, and
    // set down at (3, 0).
    m.cfg.leg[1].goal = [1.0, 0.0, 0.0];
    m.cfg.leg[1].goal_given = Some([1.0, 0.0, 0.0]);
    m.cfg.leg[2].goal = [3.0, 0.0, 0.0];
    m.cfg.leg[2].goal_given = Some([3.0, 0.0, 0.0]);
    let p = Pose2::default();
    m.start_leg(0.0, p);
    let docking = Planned {
        path: poses(3),
        dock_from: Some(1),
        undock_to: None,
    };
    m.on_plan(0.0, p, Ok(docking));
    let under = Pose2::new(1.0, 0.0, 0.0);
    for (t, at) in [(1.0, p), (2.0, under), (3.0, under)] {
        m.on_controller(t, at, REACHED);
    }
    m.on_plan(3.0, p, Ok(Planned::plain(poses(2))));
    let drop = Pose2::new(3.0, 0.0, 0.0);
    m.on_controller(4.0, drop, REACHED);
    let up = std::f64::consts::FRAC_PI_2;
    let mut path = vec![PathPose::new(drop, Direction::Rotate)];
    path.extend(
        (0..3).map(|i| PathPose::new(Pose2::new(3.0, 0.5 * i as f64, up), Direction::Forward)),
    );
    path.push(PathPose::new(Pose2::new(3.5, 1.5, 0.0), Direction::Forward));
    let planned = Planned {
        path,
        dock_from: None,
        undock_to: Some(3),
    };
    let a = m.on_plan(4.0, drop, Ok(planned));
    assert!(
        matches!(a[1], Action::Rotate { goal, .. } if goal == Pose2::new(3.0, 0.0, up)),
        "{a:?}"
    );
    let a = m.on_controller(4.5, drop, REACHED);
    assert!(
        matches!(a[..], [Action::Straight { goal, .. }] if goal == Pose2::new(3.0, 1.0, up)),
        "{a:?}"
    );
    let a = m.on_controller(5.0, Pose2::new(3.0, 1.0, up), REACHED);
    assert!(
        matches!(&a[1], Action::Follow { reference, .. } if reference.len() == 2),
        "{a:?}"
    );
}

#[test]
fn a_rack_approached_without_a_goal_counts_any_side_as_its_heading() {
    let mut m = mission();
    m.cfg.leg[0].goal_given = None;
    let facing_back = Pose2::new(1.0, 0.0, 3.1);
    m.start_leg(0.0, Pose2::default());
    m.on_plan(0.0, Pose2::default(), Ok(Planned::plain(path())));
    m.on_controller(2.0, facing_back, REACHED);
    m.on_controller(3.0, facing_back, REACHED);
    let leg = &m.results[0];
    assert!(leg.reached);
    assert!(
        (leg.final_heading_error_rad - (std::f64::consts::PI - 3.1)).abs() < 1e-9,
        "{leg:?}"
    );
    // A stated heading is the heading: the turn in place after it is 0.1 rad off 3.0.
    m.on_controller(4.0, facing_back, REACHED);
    let turn = &m.results[1];
    assert!(
        (turn.final_heading_error_rad - 0.1).abs() < 1e-9,
        "{turn:?}"
    );
    // Entered through a long side (a quarter turn off the body's heading), 0.05 rad off.
    let mut m = mission();
    m.cfg.leg[0].goal_given = None;
    let across = Pose2::new(1.0, 0.0, -std::f64::consts::FRAC_PI_2 + 0.05);
    m.start_leg(0.0, Pose2::default());
    m.on_plan(0.0, Pose2::default(), Ok(Planned::plain(path())));
    m.on_controller(2.0, across, REACHED);
    m.on_controller(3.0, across, REACHED);
    let leg = &m.results[0];
    assert!((leg.final_heading_error_rad - 0.05).abs() < 1e-9, "{leg:?}");
}

#[test]
fn a_reached_report_away_from_the_legs_goal_plans_again() {
    let mut m = mission();
    let p = Pose2::default();
    m.start_leg(0.0, p);
    m.on_plan(0.0, p, Ok(Planned::plain(path())));
    // Leg a ends at (1, 0): a report of "reached" 1 m short of it is not the leg's end.
    let a = m.on_controller(1.0, p, REACHED);
    assert!(matches!(a[..], [Action::Plan { .. }]), "{a:?}");
    assert!(m.results.is_empty() && !m.is_finished());
    m.on_plan(1.0, p, Ok(Planned::plain(path())));
    m.on_controller(1.5, p, OK);
    let a = m.on_controller(2.0, Pose2::new(1.1, 0.05, 0.1), REACHED);
    assert!(
        a.iter().any(|x| matches!(x, Action::Rotate { .. })),
        "{a:?}"
    );
    assert!(m.results[0].reached && m.results[0].replans == 1);
}

/// A sweep's mission: the move out from under a rack set down was blocked, its replan
/// failed, and the end of the move it went on driving was taken for the leg's end, 18.9
/// m from its goal.
#[test]
fn a_move_out_driven_on_after_a_failed_replan_does_not_end_the_leg() {
    // A margin to back off from, as the sweep's robot had then (the first replan backs
    // off, the second fails).
    let mut m = mission_alone_margin(0.3);
    m.cfg.leg[1].goal = [1.0, 0.0, 0.0];
    m.cfg.leg[1].goal_given = Some([1.0, 0.0, 0.0]);
    m.cfg.max_replans_per_leg = 5;
    push_leg_d(&mut m);
    let p = Pose2::default();
    let under = Pose2::new(1.0, 0.0, 0.0);
    m.start_leg(0.0, p);
    m.on_plan(0.0, p, Ok(Planned::plain(path())));
    for t in [1.0, 2.0] {
        m.on_controller(t, under, REACHED);
    }
    m.on_plan(2.0, under, Ok(Planned::plain(poses(3))));
    let drop = Pose2::new(2.0, 0.0, 0.0);
    m.on_controller(3.0, drop, REACHED);
    let out = Planned {
        path: poses(4),
        dock_from: None,
        undock_to: Some(1),
    };
    let a = m.on_plan(3.0, drop, Ok(out));
    assert!(matches!(a[1], Action::Straight { .. }), "{a:?}");
    let blocked = ControllerReport { exit_flag: 1, ..OK };
    let a = m.on_controller(3.5, drop, blocked);
    assert!(matches!(a[..], [Action::Plan { .. }]), "{a:?}");
    let in_collision = |margin_bound| PlanFailure {
        why: "the start is in collision".into(),
        margin_bound,
    };
    assert!(matches!(
        m.on_plan(3.5, drop, Err(in_collision(true)))[..],
        [Action::Plan { .. }]
    ));
    assert!(m.on_plan(3.5, drop, Err(in_collision(false))).is_empty());
    // The move out goes on and ends: the leg goes on with the rest of its plan.
    let a = m.on_controller(4.5, Pose2::new(1.0, 0.0, 0.0), REACHED);
    assert!(
        matches!(&a[1], Action::Follow { reference, .. } if reference.len() == 3),
        "{a:?}"
    );
    assert_eq!(m.results.len(), 3, "leg d is not over: {:?}", m.results);
}

#[test]
fn a_legs_speed_limit_goes_with_its_goals() {
    let mut m = mission();
    m.cfg.leg[2].max_velocity = Some([0.5, 0.4]);
    m.start_leg(0.0, Pose2::default());
    assert_eq!(m.speed_limit(), None);
    m.leg = 2;
    assert_eq!(m.speed_limit(), Some([0.5, 0.4]));
}

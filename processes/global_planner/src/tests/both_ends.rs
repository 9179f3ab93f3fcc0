//! The search from the goal's end (`both_ends.rs`): a park facing out of a dead-end
//! aisle, whose only way in is from its open end, so the robot must turn on the spot at
//! the goal (or reverse the aisle's length). The heuristic does not see the turn, and the
//! search from the start expands every heading within its cost of the shortest way.

use super::check_plan;
use crate::{PlanRequest, Planner, PlannerConfig, seed_map};
use aisle_geometry::{GridMap, Pose2, wrap_angle};
use std::f64::consts::{FRAC_PI_2, PI};

#[test]
fn a_park_facing_out_of_a_dead_end_is_found_from_the_goal() {
    let (hall, park) = seed_map::dead_end_park();
    from_the_goal_for_less(&hall, &super::request(&park));
    // The seed's aisle between the racks at x 5.5-8.5, facing out of its closed end.
    from_the_goal_for_less(&seed_map::seed_map(10.0), &super::hard_request());
}

/// `req` is found from its goal's end, for less than half the expansions of the search
/// from its start alone, at no more than the weighted search's factor over its cost.
fn from_the_goal_for_less(map: &GridMap, req: &PlanRequest) {
    let req = *req;
    let cfg = PlannerConfig::default();
    let both = Planner::new(cfg.clone())
        .unwrap()
        .plan(&req, &map.view())
        .unwrap();
    check_plan(&both, &req, &map.view(), &cfg);
    assert!(both.stats.from_goal, "{:?}", both.stats);
    let start_only = PlannerConfig {
        goal_end_after: 0,
        ..cfg.clone()
    };
    let alone = Planner::new(start_only.clone())
        .unwrap()
        .plan(&req, &map.view())
        .unwrap();
    check_plan(&alone, &req, &map.view(), &start_only);
    assert!(!alone.stats.from_goal);
    // Both turns of the start's search are counted in; still far fewer.
    assert!(
        2 * both.stats.expansions < alone.stats.expansions,
        "{} vs {}",
        both.stats.expansions,
        alone.stats.expansions
    );
    // No worse than the weighted search's factor over the start's path (on both maps
    // here, the goal's is the cheaper: 32.3 against 33.7, 19.2 against 22.0).
    assert!(both.stats.path_cost <= cfg.heuristic_weight * alone.stats.path_cost + 1e-9);
}

#[test]
fn the_mirrored_request_is_the_same_problem() {
    // Planned the other way round (from the park out of the dead end), the cost is the
    // one of the request read backwards, within the weighted search's factor.
    let (map, park) = seed_map::dead_end_park();
    let req = super::request(&park);
    let out = PlanRequest {
        start: Pose2::new(req.goal.x, req.goal.y, -FRAC_PI_2),
        goal: Pose2::new(req.start.x, req.start.y, -FRAC_PI_2),
        ..req
    };
    let cfg = PlannerConfig {
        goal_end_after: 0,
        ..Default::default()
    };
    let mut planner = Planner::new(cfg.clone()).unwrap();
    let there = planner.plan(&req, &map.view()).unwrap();
    let back = planner.plan(&out, &map.view()).unwrap();
    check_plan(&back, &out, &map.view(), &cfg);
    let w = cfg.heuristic_weight;
    assert!(back.stats.path_cost <= w * there.stats.path_cost + 1e-9);
    assert!(there.stats.path_cost <= w * back.stats.path_cost + 1e-9);
}

#[test]
fn requests_within_the_first_turn_are_unchanged_bit_for_bit() {
    let map = seed_map::seed_map(20.0);
    let mut both = Planner::new(PlannerConfig::default()).unwrap();
    let mut alone = Planner::new(PlannerConfig {
        goal_end_after: 0,
        ..Default::default()
    })
    .unwrap();
    for s in seed_map::seed_segments() {
        let req = super::request(&s);
        let a = both.plan(&req, &map.view()).unwrap();
        let b = alone.plan(&req, &map.view()).unwrap();
        assert!(a.stats.expansions < PlannerConfig::default().goal_end_after);
        assert_eq!(a, b, "{}", s.name);
    }
}

#[test]
fn a_search_from_the_start_resumed_after_turns_is_the_search_alone() {
    // Turns from 64 expansions on: every seed leg and the hard request alternate.
    let map = seed_map::seed_map(10.0);
    let turns = PlannerConfig {
        goal_end_after: 64,
        ..Default::default()
    };
    let start_only = PlannerConfig {
        goal_end_after: 0,
        ..Default::default()
    };
    let mut resumed = 0;
    let mut reqs: Vec<PlanRequest> = seed_map::seed_segments()
        .iter()
        .map(super::request)
        .collect();
    // The hard request the other way round: out of the aisle's closed end, easy from
    // its start (the other end is the hard one).
    let hard = super::hard_request();
    let turned = |p: &Pose2| Pose2::new(p.x, p.y, wrap_angle(p.theta + PI));
    reqs.push(hard);
    reqs.push(PlanRequest {
        start: turned(&hard.goal),
        goal: turned(&hard.start),
        ..hard
    });
    for req in &reqs {
        let both = Planner::new(turns.clone())
            .unwrap()
            .plan(req, &map.view())
            .unwrap();
        check_plan(&both, req, &map.view(), &turns);
        let alone = Planner::new(start_only.clone())
            .unwrap()
            .plan(req, &map.view())
            .unwrap();
        if !both.stats.from_goal && !both.stats.met {
            // The same search, turns and all: the same path, and its expansions plus
            // the other search's.
            assert_eq!(both.path, alone.path);
            if alone.stats.expansions > 64 {
                assert!(both.stats.expansions > alone.stats.expansions);
                resumed += 1;
            } else {
                assert_eq!(both.stats, alone.stats);
            }
        }
    }
    assert!(resumed > 0, "no search from the start went on past a turn");
}

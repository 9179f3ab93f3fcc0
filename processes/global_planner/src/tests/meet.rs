//! The searches from both ends meeting (`meet.rs`), in a hall of 2.2 m aisles drawn
//! here: the carried rack cannot turn in an aisle, and a goal in a cross aisle facing
//! across it is entered only by a turn at the goal (on the spot or past it and back),
//! which neither heuristic sees. An obstacle closes the aisle nearest the goal, so the
//! way runs up the next one: the search from the start alone expands that aisle in every
//! heading its slack allows.

use super::{BUDGET, check_plan};
use crate::seed_map::{RACK, RACK_MARGIN, Rect, rasterise};
use crate::{PlanRequest, Planner, PlannerConfig};
use aisle_geometry::{GridMap, Pose2};
use std::f64::consts::{FRAC_PI_2, PI};

/// A 13.6 x 40 m hall: walls, four rack rows (1.4-1.6 m deep) leaving three 2.2 m
/// aisles (centres x 3.0, 6.8 and 10.6), broken by 4 m cross aisles at y 17-21, 26-30
/// and 35-39 above an open area below y 12; a box closes the middle aisle at y 13.
fn narrow_hall() -> GridMap {
    let mut map = GridMap::new_free(0.0, 0.0, 0.05, 13.6, 40.0).expect("valid grid");
    let mut rects = vec![
        Rect::new(0.0, 0.0, 13.6, 0.5),
        Rect::new(0.0, 39.5, 13.6, 40.0),
        Rect::new(0.0, 0.0, 0.5, 40.0),
        Rect::new(13.1, 0.0, 13.6, 40.0),
        Rect::new(5.7, 13.0, 7.9, 13.6),
    ];
    for (x0, x1) in [(0.5, 1.9), (4.1, 5.7), (7.9, 9.5), (11.7, 13.1)] {
        for (y0, y1) in [(12.0, 17.0), (21.0, 26.0), (30.0, 35.0)] {
            rects.push(Rect::new(x0, y0, x1, y1));
        }
    }
    rasterise(&mut map, &rects);
    map
}

fn carry(start: Pose2, goal: Pose2) -> PlanRequest {
    PlanRequest {
        start,
        goal,
        footprint: RACK,
        margin: RACK_MARGIN,
        max_expansions: BUDGET,
    }
}

/// From the open area at the hall's west side, facing the wall, to a cross aisle at
/// the east side facing south.
fn east_cross_aisle(y: f64) -> PlanRequest {
    carry(Pose2::new(3.0, 5.0, PI), Pose2::new(10.6, y, -FRAC_PI_2))
}

#[test]
fn searches_from_both_ends_meet_for_fewer_expansions_than_the_start_alone() {
    let map = narrow_hall();
    let cfg = PlannerConfig::default();
    let start_only = PlannerConfig {
        goal_end_after: 0,
        ..cfg.clone()
    };
    // Alone: 5,594 and 6,288 expansions; met: 4,347 and 4,281 (without the meeting,
    // the turns took 6,642 and 7,562, on paths 5 % and 4 % dearer).
    for req in [east_cross_aisle(28.0), east_cross_aisle(37.5)] {
        let both = Planner::new(cfg.clone())
            .unwrap()
            .plan(&req, &map.view())
            .unwrap();
        check_plan(&both, &req, &map.view(), &cfg);
        assert!(both.stats.met, "{:?}", both.stats);
        let alone = Planner::new(start_only.clone())
            .unwrap()
            .plan(&req, &map.view())
            .unwrap();
        assert!(!alone.stats.met);
        assert!(
            both.stats.expansions < alone.stats.expansions,
            "{} vs {}",
            both.stats.expansions,
            alone.stats.expansions
        );
        assert!(both.stats.path_cost <= cfg.heuristic_weight * alone.stats.path_cost + 1e-9);
    }
}

#[test]
fn joined_paths_are_whole_paths() {
    // From the east aisle's foot, facing south, to every aisle of every cross aisle in
    // three headings: 4 of the 27 plans join the two searches (none can without it).
    let map = narrow_hall();
    let cfg = PlannerConfig::default();
    let mut planner = Planner::new(cfg.clone()).unwrap();
    let mut met = 0;
    for y in [19.0, 28.0, 37.5] {
        for x in [3.0, 6.8, 10.6] {
            for theta in [-FRAC_PI_2, 0.0, PI] {
                let req = carry(Pose2::new(10.6, 6.0, -FRAC_PI_2), Pose2::new(x, y, theta));
                let Ok(plan) = planner.plan(&req, &map.view()) else {
                    continue;
                };
                check_plan(&plan, &req, &map.view(), &cfg);
                met += usize::from(plan.stats.met);
            }
        }
    }
    assert!(met >= 3, "only {met} plans joined the searches");
}

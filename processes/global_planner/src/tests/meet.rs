//! The searches from both ends meeting (`meet.rs`), in a hall of 2.2 m aisles
//! (`seed_map::narrow_hall`): the carried rack cannot turn in an aisle, and a goal in a
//! cross aisle facing across it is entered only by a turn at the goal (on the spot or
//! past it and back), which neither heuristic sees; the search from the start alone
//! expands the aisles before it in every heading its slack allows.

use super::{BUDGET, check_plan};
use crate::seed_map::{RACK, RACK_MARGIN, narrow_hall, narrow_hall_carry};
use crate::{PlanRequest, Planner, PlannerConfig};
use aisle_geometry::Pose2;
use std::f64::consts::{FRAC_PI_2, PI};

fn carry(start: Pose2, goal: Pose2) -> PlanRequest {
    PlanRequest {
        start,
        goal,
        footprint: RACK,
        margin: RACK_MARGIN,
        max_expansions: BUDGET,
        fixed_budget: false,
    }
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
    for req in [28.0, 37.5].map(|y| super::request(&narrow_hall_carry(y))) {
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

//! A fixed budget (`PlanRequest::fixed_budget`): the most the whole request expands, over
//! every search it makes, where the ordinary budget grows with the reachable area.

use super::hard_request;
use crate::dock::{DockKind, DockSite, seed_rack};
use crate::{PlanErrorKind, PlanRequest, Planner, PlannerConfig, seed_map};
use aisle_geometry::{Footprint, GridMap, Pose2};
use std::f64::consts::FRAC_PI_2;

#[test]
fn a_fixed_budget_holds_over_both_ends_and_does_not_grow() {
    // Short turns, so that the searches from both ends take several each.
    let cfg = PlannerConfig {
        goal_end_after: 16,
        ..Default::default()
    };
    let map = seed_map::seed_map(10.0);
    let free = Planner::new(cfg.clone())
        .unwrap()
        .plan(&hard_request(), &map.view())
        .unwrap();
    let needed = free.stats.expansions;
    assert!(needed > 200, "{:?}", free.stats);
    let half = needed / 2;

    // The ordinary budget grows with the reachable area: half of what the search needs
    // is no limit.
    let growing = PlanRequest {
        max_expansions: half,
        ..hard_request()
    };
    let mut planner = Planner::new(cfg.clone()).unwrap();
    let plan = planner.plan(&growing, &map.view()).unwrap();
    assert!(plan.stats.expansions > half, "{:?}", plan.stats);

    // Fixed, it is the whole request's: both ends' searches together stop at it.
    let fixed = PlanRequest {
        fixed_budget: true,
        ..growing
    };
    let mut planner = Planner::new(cfg).unwrap();
    let e = planner.plan(&fixed, &map.view()).unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::BudgetExhausted);
    assert_eq!(e.stats.expansions, half, "{:?}", e.stats);
    assert_eq!(planner.request_expansions, half);
}

#[test]
fn a_fixed_budget_holds_over_every_docking_candidate() {
    // A rack whose sides are open, entered with a free heading: every side that leads
    // in is searched, each around a wall between the start and the rack.
    let mut map = GridMap::new_free(-6.0, -6.0, 0.1, 12.0, 12.0).unwrap();
    for k in 0..90 {
        let c = map.view().cell_of(-6.0 + 0.1 * f64::from(k), -1.5);
        map.set(c, aisle_geometry::OCCUPIED_STATIC);
    }
    let (body, legs) = seed_rack(Pose2::new(0.0, 2.0, FRAC_PI_2));
    let site = DockSite {
        kind: DockKind::Dock,
        body,
        parts: &legs,
        free_heading: true,
    };
    let req = PlanRequest {
        start: Pose2::new(-4.0, -4.0, 0.0),
        goal: body.pose,
        footprint: Footprint::new(0.508, 0.43),
        margin: 0.1,
        max_expansions: 100_000,
        fixed_budget: false,
    };
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    planner
        .plan_docked(&req, &site, &map.view(), &mut || false)
        .unwrap();
    let all = planner.request_expansions;
    assert!(all > 1000, "{all} expansions");

    let cap = all / 2;
    let fixed = PlanRequest {
        max_expansions: cap,
        fixed_budget: true,
        ..req
    };
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let e = planner
        .plan_docked(&fixed, &site, &map.view(), &mut || false)
        .unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::BudgetExhausted);
    // The candidates together: the whole budget, not a budget each.
    assert_eq!(planner.request_expansions, cap, "of {all}");
    // The next request starts its count afresh.
    let next = planner
        .plan(&hard_request(), &seed_map::seed_map(10.0).view())
        .unwrap();
    assert_eq!(planner.request_expansions, next.stats.expansions);
}

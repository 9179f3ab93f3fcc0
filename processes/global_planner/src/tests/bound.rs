//! The search's cost bound (what a docking request gives the sides searched after the
//! cheapest so far): a bound at or above the path's cost changes nothing, one below it
//! ends the search early with `AboveBound`: a weighted search that reaches the goal above
//! the bound goes on for a cheaper way rather than returning it.

use super::{check_plan, hard_request};
use crate::{PlanErrorKind, Planner, PlannerConfig, seed_map};

#[test]
fn a_bound_below_the_cost_ends_the_search_early_and_one_at_it_changes_nothing() {
    // One search's bound: from the start alone (from the goal's end, this request's
    // path is cheaper than the start's search finds, `both_ends.rs`).
    let cfg = PlannerConfig {
        goal_end_after: 0,
        ..Default::default()
    };
    let mut planner = Planner::new(cfg.clone()).unwrap();
    let map = seed_map::seed_map(10.0);
    let req = hard_request();
    let free = planner.plan(&req, &map.view()).unwrap();
    check_plan(&free, &req, &map.view(), &cfg);
    let cost = free.stats.path_cost;
    assert!(free.stats.expansions > 100, "{:?}", free.stats);

    let at = planner
        .plan_below(&req, &map.view(), cost, &mut || false)
        .unwrap();
    assert_eq!(at.path, free.path);
    // The same search to the last expansion (the map tables were built by the first),
    // except that connections to the goal costing more than the bound are not tried.
    assert!(at.stats.analytic_checks <= free.stats.analytic_checks);
    let rebuilt = crate::PlanStats {
        map_rebuilt: true,
        analytic_checks: free.stats.analytic_checks,
        collision_probes: free.stats.collision_probes,
        ..at.stats
    };
    assert_eq!(rebuilt, free.stats);

    let below = planner
        .plan_below(&req, &map.view(), 0.8 * cost, &mut || false)
        .unwrap_err();
    assert_eq!(below.kind, PlanErrorKind::AboveBound);
    assert!(
        below.stats.expansions < free.stats.expansions,
        "{} vs {}",
        below.stats.expansions,
        free.stats.expansions
    );
}

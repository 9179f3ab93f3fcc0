//! The lazy machinery every map is planned with (distance tiles computed as read, the
//! heuristic's backward search run as far as queried, its budget counted when spent)
//! against the eager reference that fills a small map's tables whole
//! (`Planner::eager_small_maps`), on the seed map: the same paths bit for bit and the same
//! counters, except the heuristic cells a lazy request counts (those it closed, not all
//! that the goal can be reached from). The state table is sparse in both; the golden
//! digests (recorded with a dense one) cover it.

use super::{hard_request, request};
use crate::seed_map::{self, Rect, rasterise};
use crate::{Plan, PlanError, PlanErrorKind, PlanRequest, Planner, PlannerConfig};
use aisle_geometry::GridMap;

fn same_outcome(a: &Result<Plan, PlanError>, b: &Result<Plan, PlanError>, what: &str) {
    let (sa, sb) = match (a, b) {
        (Ok(a), Ok(b)) => {
            assert_eq!(a.path.len(), b.path.len(), "{what}");
            for (x, y) in a.path.iter().zip(&b.path) {
                assert_eq!(x.pose.x.to_bits(), y.pose.x.to_bits(), "{what}");
                assert_eq!(x.pose.y.to_bits(), y.pose.y.to_bits(), "{what}");
                assert_eq!(x.pose.theta.to_bits(), y.pose.theta.to_bits(), "{what}");
                assert_eq!(x.direction, y.direction, "{what}");
            }
            (a.stats, b.stats)
        }
        (Err(a), Err(b)) => {
            assert_eq!(a.kind, b.kind, "{what}");
            (a.stats, b.stats)
        }
        _ => panic!("{what}: {a:?} vs {b:?}"),
    };
    let lazy_cells = sb.heuristic_cells;
    assert!(lazy_cells <= sa.heuristic_cells, "{what}");
    assert_eq!(
        sa,
        crate::PlanStats {
            heuristic_cells: sa.heuristic_cells,
            ..sb
        },
        "{what}"
    );
}

#[test]
fn lazy_tables_plan_the_same_paths_as_eager_ones() {
    // The default budget, and one so small that requests spend it after it has grown
    // with the reachable cells (counted up front when eager, when spent when lazy).
    let small = PlannerConfig {
        expansions_per_reachable_cell: 0.01,
        ..PlannerConfig::default()
    };
    let (mut fewer_cells, mut spent) = (0, 0);
    for (cfg, budget) in [(PlannerConfig::default(), 200_000), (small, 20)] {
        for cpm in [10.0, 20.0] {
            let (f, s) = compare_on_seed(&cfg, budget, cpm);
            fewer_cells += f;
            spent += s;
        }
    }
    assert!(
        fewer_cells > 10,
        "the lazy search closed fewer cells {fewer_cells} times"
    );
    assert!(spent > 3, "{spent} requests spent their budget");
}

/// Plans the seed requests on an eager and a lazy planner, with map changes between
/// rounds; returns how often the lazy one closed fewer heuristic cells and how often
/// the budget ran out.
fn compare_on_seed(cfg: &PlannerConfig, budget: u32, cpm: f64) -> (usize, usize) {
    let mut map: GridMap = seed_map::seed_map(cpm);
    let mut reqs: Vec<PlanRequest> = seed_map::seed_segments().iter().map(request).collect();
    reqs.push(hard_request());
    for r in &mut reqs {
        r.max_expansions = budget;
    }
    let (mut eager, mut lazy) = (
        Planner::new(cfg.clone()).unwrap(),
        Planner::new(cfg.clone()).unwrap(),
    );
    eager.eager_small_maps = true;
    let (mut fewer_cells, mut spent) = (0, 0);
    let cells = |o: &Result<Plan, PlanError>| match o {
        Ok(p) => p.stats.heuristic_cells,
        Err(e) => e.stats.heuristic_cells,
    };
    for round in 0..3 {
        for (i, r) in reqs.iter().enumerate() {
            let (a, b) = (eager.plan(r, &map.view()), lazy.plan(r, &map.view()));
            same_outcome(
                &a,
                &b,
                &format!("{cpm} cells/m, round {round}, request {i}"),
            );
            fewer_cells += usize::from(cells(&b) < cells(&a));
            spent += usize::from(matches!(&b, Err(e) if e.kind == PlanErrorKind::BudgetExhausted));
        }
        // Detections between rounds: a map change.
        let (x, y) = (2.0 - f64::from(round), 3.0 + 2.0 * f64::from(round));
        rasterise(&mut map, &[Rect::centred(x, y, 0.3, 0.3)]);
    }
    (fewer_cells, spent)
}

/// Replans to the same goal from other starts, with detections added between some of
/// them (the lazy planner resumes or repairs its heuristic's search, the eager one
/// searches whole each time): the same paths and counters.
#[test]
fn replans_to_one_goal_plan_the_same_paths_as_eager_ones() {
    let mut map: GridMap = seed_map::seed_map(10.0);
    let reqs: Vec<PlanRequest> = seed_map::seed_segments().iter().map(request).collect();
    let cfg = PlannerConfig::default();
    let (mut eager, mut lazy) = (
        Planner::new(cfg.clone()).unwrap(),
        Planner::new(cfg).unwrap(),
    );
    eager.eager_small_maps = true;
    let mut planned = 0;
    for (i, r) in reqs.iter().enumerate() {
        for (j, from) in reqs.iter().enumerate() {
            let replan = PlanRequest {
                start: from.start,
                footprint: r.footprint,
                margin: r.margin,
                ..*r
            };
            if j % 3 == 2 {
                // A detection somewhere in the hall.
                let k = f64::from((7 * i + 3 * j) as u32 % 13);
                let (x, y) = (-3.0 + 0.6 * k, 1.0 + 1.7 * k);
                rasterise(&mut map, &[Rect::centred(x, y, 0.3, 0.3)]);
            }
            let (a, b) = (
                eager.plan(&replan, &map.view()),
                lazy.plan(&replan, &map.view()),
            );
            same_outcome(&a, &b, &format!("goal of request {i}, start of {j}"));
            planned += usize::from(a.is_ok());
        }
    }
    assert!(planned > reqs.len(), "{planned} plans");
}

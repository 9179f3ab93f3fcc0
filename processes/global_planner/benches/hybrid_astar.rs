//! Hybrid A* on the seed map: each seed segment at 10 and 20 cells/m with 72 heading
//! bins (target: p50 <= 5 ms per segment at 20 cells/m). "warm" reuses one planner whose
//! map tables are already built for the map, as the node does while the map is
//! unchanged; "cold" builds a new planner per request (map tables and buffers included).

use aisle_geometry::Pose2;
use aisle_global_planner::seed_map::{
    ROBOT, ROBOT_MARGIN, Rect, rasterise, seed_map, seed_segments,
};
use aisle_global_planner::{PlanErrorKind, PlanRequest, Planner, PlannerConfig};
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

const BUDGET: u32 = 200_000;

fn segments(c: &mut Criterion) {
    let cfg = PlannerConfig::default();
    assert_eq!(cfg.heading_bins, 72);
    let mut group = c.benchmark_group("hybrid_astar");
    for cpm in [10u32, 20] {
        let map = seed_map(f64::from(cpm));
        let view = map.view();
        let mut planner = Planner::new(cfg.clone()).expect("default config is valid");
        for seg in seed_segments() {
            let req = PlanRequest {
                start: seg.start,
                goal: seg.goal,
                footprint: seg.footprint,
                margin: seg.margin,
                max_expansions: BUDGET,
            };
            let first = planner.plan(&req, &view).expect("seed segment plans");
            println!(
                "{} @ {cpm} cells/m: length {:.2} m, {} poses, {} expansions, {} nodes",
                seg.name,
                first.stats.path_length,
                first.path.len(),
                first.stats.expansions,
                first.stats.nodes
            );
            group.bench_function(format!("warm/{cpm}cpm/{}", seg.name), |b| {
                b.iter(|| black_box(planner.plan(black_box(&req), &view).is_ok()))
            });
            group.bench_function(format!("cold/{cpm}cpm/{}", seg.name), |b| {
                b.iter(|| {
                    let mut p = Planner::new(cfg.clone()).expect("valid");
                    black_box(p.plan(black_box(&req), &view).is_ok())
                })
            });
        }
    }
    group.finish();
}

/// A goal behind a door too narrow for the robot (the 2D heuristic cannot prove it
/// unreachable), so the search burns its whole budget: the cost per expansion, for sizing
/// budgets against a wall-clock bound.
fn exhausted_budget(c: &mut Criterion) {
    const SMALL_BUDGET: u32 = 20_000;
    let mut map = seed_map(20.0);
    rasterise(
        &mut map,
        &[
            Rect::new(-1.1, 3.9, 1.1, 4.0),
            Rect::new(-1.1, 6.0, 1.1, 6.1),
            Rect::new(-1.1, 3.9, -1.0, 6.1),
            Rect::new(1.0, 3.9, 1.1, 4.675),
            Rect::new(1.0, 5.325, 1.1, 6.1),
        ],
    );
    let view = map.view();
    let mut planner = Planner::new(PlannerConfig::default()).expect("valid");
    let req = PlanRequest {
        start: Pose2::new(0.0, 0.0, 0.0),
        goal: Pose2::new(0.0, 5.0, 0.0),
        footprint: ROBOT,
        margin: ROBOT_MARGIN,
        max_expansions: SMALL_BUDGET,
    };
    let e = planner
        .plan(&req, &view)
        .expect_err("the door is too narrow");
    assert_eq!(e.kind, PlanErrorKind::BudgetExhausted);
    c.bench_function("hybrid_astar/walled_in_goal_20k_expansions", |b| {
        b.iter(|| black_box(planner.plan(black_box(&req), &view).is_err()))
    });
}

criterion_group!(benches, segments, exhausted_budget);
criterion_main!(benches);

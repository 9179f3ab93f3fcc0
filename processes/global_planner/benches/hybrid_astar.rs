//! Hybrid A* on the seed map: each seed segment at 10 and 20 cells/m with 72 heading
//! bins (target: p50 <= 5 ms per segment at 20 cells/m). "warm" reuses one planner whose
//! map tables are already built for the map, as the node does while the map is
//! unchanged; "cold" builds a new planner per request (map tables and buffers included).

use aisle_geometry::{GridMap, Pose2};
use aisle_global_planner::seed_map::{
    ROBOT, ROBOT_MARGIN, Rect, Segment, dead_end_park, narrow_hall, narrow_hall_carry, rasterise,
    seed_map, seed_segments,
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
                fixed_budget: false,
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

/// A goal the 2D heuristic cannot prove unreachable, so the search burns its whole
/// budget: the cost per expansion, for sizing budgets against a wall-clock bound. The
/// goal lies across a 0.84 m room reached through a 0.70 m corridor: the corridor
/// admits the robot (0.43 m wide, 0.1 m margin) only along it, and the room is too small
/// for it to turn across (a 0.708 x 0.63 m rectangle needs 0.95 m at 45 degrees), while
/// every cell on the way is farther than the inscribed radius plus the margin from the
/// walls.
fn exhausted_budget(c: &mut Criterion) {
    const SMALL_BUDGET: u32 = 20_000;
    let mut map = seed_map(20.0);
    rasterise(
        &mut map,
        &[
            // The corridor's walls, y from 4 to 5.
            Rect::new(-0.45, 4.0, -0.35, 5.0),
            Rect::new(0.35, 4.0, 0.45, 5.0),
            // The room, 0.84 x 0.84 inside: bottom (with the corridor's opening), sides,
            // top.
            Rect::new(-0.52, 4.9, -0.35, 5.0),
            Rect::new(0.35, 4.9, 0.52, 5.0),
            Rect::new(-0.52, 4.9, -0.42, 5.94),
            Rect::new(0.42, 4.9, 0.52, 5.94),
            Rect::new(-0.52, 5.84, 0.52, 5.94),
        ],
    );
    let view = map.view();
    // One search's cost per expansion: no turns with a search from the goal's end.
    let mut planner = Planner::new(PlannerConfig {
        goal_end_after: 0,
        ..PlannerConfig::default()
    })
    .expect("valid");
    let req = PlanRequest {
        start: Pose2::new(0.0, 0.0, 0.0),
        goal: Pose2::new(0.0, 5.42, 0.0),
        footprint: ROBOT,
        margin: ROBOT_MARGIN,
        max_expansions: SMALL_BUDGET,
        fixed_budget: false,
    };
    let e = planner
        .plan(&req, &view)
        .expect_err("the room is too small to turn in");
    assert_eq!(e.kind, PlanErrorKind::BudgetExhausted);
    // Each run takes most of a second: ten samples say enough.
    let mut g = c.benchmark_group("hybrid_astar");
    g.sample_size(10);
    g.bench_function("walled_in_goal_20k_expansions", |b| {
        b.iter(|| black_box(planner.plan(black_box(&req), &view).is_err()))
    });
    g.finish();
}

/// A park whose goal faces out of a dead-end aisle (`both_ends.rs`).
fn dead_end(c: &mut Criterion) {
    let (map, park) = dead_end_park();
    both_ends_and_start_alone(c, "dead_end_park", &map, &park);
}

/// A carry whose two ends are both hard, so that the two searches meet (`meet.rs`).
fn narrow_meet(c: &mut Criterion) {
    both_ends_and_start_alone(
        c,
        "narrow_hall_carry",
        &narrow_hall(),
        &narrow_hall_carry(37.5),
    );
}

/// `seg` on `map` with the search from the goal's end taking turns (the shipped
/// config), and from the start alone, each with a warm planner.
fn both_ends_and_start_alone(c: &mut Criterion, case: &str, map: &GridMap, seg: &Segment) {
    let view = map.view();
    let req = PlanRequest {
        start: seg.start,
        goal: seg.goal,
        footprint: seg.footprint,
        margin: seg.margin,
        max_expansions: BUDGET,
        fixed_budget: false,
    };
    let mut g = c.benchmark_group("hybrid_astar");
    g.sample_size(10);
    for (name, goal_end_after) in [("both_ends", 4096), ("start_only", 0)] {
        let mut planner = Planner::new(PlannerConfig {
            goal_end_after,
            ..PlannerConfig::default()
        })
        .expect("valid");
        let plan = planner.plan(&req, &view).expect("the case plans");
        println!(
            "{case}/{name}: {} expansions, cost {:.2}, from the goal's end: {}, met: {}",
            plan.stats.expansions, plan.stats.path_cost, plan.stats.from_goal, plan.stats.met
        );
        g.bench_function(format!("{case}/{name}"), |b| {
            b.iter(|| black_box(planner.plan(black_box(&req), &view).is_ok()))
        });
    }
    g.finish();
}

criterion_group!(benches, segments, exhausted_budget, dead_end, narrow_meet);
criterion_main!(benches);

//! Issue 20's planner acceptance: a 100 m crossing of the generated large warehouse
//! (`config/large`, 99.2 x 199.4 m) at 20 cells/m (7.9 M cells). Targets: cold <= 20 ms,
//! warm and after a small map change <= 5 ms. "cold" builds a new planner per request
//! (its copy of the cells, distance tiles, heuristic and buffers included); "warm"
//! repeats the request on one planner; "changed" alternately adds and removes a small
//! detection (0.3 x 0.3 m) beside the path halfway along, so every request follows a
//! map change. Each runs with the planner settings `config/large` ships (weighted A*,
//! `large/...`) and with plain A* (weight 1, `large_plain/...`) for comparison.

use aisle_geometry::{CellIndex, GridMap, OCCUPIED_STATIC};
use aisle_global_planner::large_map::{crossing, params, planner_config, static_map};
use aisle_global_planner::{PlanRequest, Planner, PlannerConfig};
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

fn large(c: &mut Criterion) {
    let p = params();
    let map = static_map(&p, 20.0);
    let (req, beside) = crossing(&p);
    let mut detected = map.clone();
    let corner = map.view().cell_of(beside.0, beside.1);
    for k in 0..36 {
        let cell = CellIndex {
            ix: corner.ix + k % 6,
            iy: corner.iy + k / 6,
        };
        detected.set(cell, OCCUPIED_STATIC);
    }
    let shipped = planner_config().expect("config/large/planner.toml loads");
    cases(c, "large", &shipped, &req, &map, &detected);
    let plain = PlannerConfig {
        heuristic_weight: 1.0,
        ..PlannerConfig::default()
    };
    cases(c, "large_plain", &plain, &req, &map, &detected);
}

fn cases(
    c: &mut Criterion,
    group: &str,
    cfg: &PlannerConfig,
    req: &PlanRequest,
    map: &GridMap,
    detected: &GridMap,
) {
    let mut planner = Planner::new(cfg.clone()).expect("the config is valid");
    for m in [map, detected] {
        let plan = planner.plan(req, &m.view()).expect("the crossing plans");
        println!(
            "{group} @ 20 cells/m (heuristic weight {}): {} x {} cells, length {:.1} m, \
             {} expansions, {} heuristic cells",
            cfg.heuristic_weight,
            m.width,
            m.height,
            plan.stats.path_length,
            plan.stats.expansions,
            plan.stats.heuristic_cells
        );
    }
    let mut group = c.benchmark_group(group);
    group.sample_size(20);
    group.bench_function("cold/20cpm/crossing_100m", |b| {
        b.iter(|| {
            let mut p = Planner::new(cfg.clone()).expect("valid");
            black_box(p.plan(black_box(req), &map.view()).is_ok())
        })
    });
    let view = map.view();
    group.bench_function("warm/20cpm/crossing_100m", |b| {
        b.iter(|| black_box(planner.plan(black_box(req), &view).is_ok()))
    });
    let mut flip = false;
    group.bench_function("changed/20cpm/crossing_100m", |b| {
        b.iter(|| {
            flip = !flip;
            let m = if flip { detected } else { map };
            black_box(planner.plan(black_box(req), &m.view()).is_ok())
        })
    });
    group.finish();
}

criterion_group!(benches, large);
criterion_main!(benches);

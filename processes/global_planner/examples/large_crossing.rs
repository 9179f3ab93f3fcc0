//! A 100 m crossing of the generated large warehouse (`config/large`, 99.2 x 199.4 m) at
//! 20 cells/m (or the cells/m given): how long a cold request (new planner), a warm one
//! and one after a small map change take, with what they computed. A measurement for
//! issue 20, not a test; `cargo bench -p aisle-global-planner --bench large` times the
//! same requests.
//!
//!     cargo run --release -p aisle-global-planner --example large_crossing [cells/m]

use aisle_geometry::OCCUPIED_STATIC;
use aisle_global_planner::large_map::{crossing, params, static_map};
use aisle_global_planner::{Plan, PlanError, Planner, PlannerConfig};
use std::time::Instant;

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn summary(r: &Result<Plan, PlanError>) -> String {
    match r {
        Ok(p) => format!(
            "{:.1} m, {} expansions, {} heuristic cells",
            p.stats.path_length, p.stats.expansions, p.stats.heuristic_cells
        ),
        Err(e) => format!("{e}"),
    }
}

fn main() {
    let p = params();
    let cpm: f64 = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(20.0);
    let t = Instant::now();
    let mut map = static_map(&p, cpm);
    println!(
        "map {} x {} cells in {:.0} ms",
        map.width,
        map.height,
        ms(t)
    );
    let (req, beside) = crossing(&p);
    let cfg = PlannerConfig::default();
    for round in 0..3 {
        let t = Instant::now();
        let mut planner = Planner::new(cfg.clone()).expect("default config is valid");
        let r = planner.plan(&req, &map.view());
        let cold = ms(t);
        let t = Instant::now();
        let r2 = planner.plan(&req, &map.view());
        let warm = ms(t);
        // A small change: one detected cell beside the aisle.
        let c = map.view().cell_of(beside.0, beside.1 + f64::from(round));
        map.set(c, OCCUPIED_STATIC);
        let t = Instant::now();
        let r3 = planner.plan(&req, &map.view());
        let changed = ms(t);
        println!("cold {cold:.1} ms ({})", summary(&r));
        println!("warm {warm:.1} ms ({})", summary(&r2));
        println!("after a change {changed:.1} ms ({})", summary(&r3));
    }
}

//! A 100 m crossing of the generated large warehouse (`config/large`, 99.2 x 199.4 m) at
//! 20 cells/m: how long a cold request (new planner: map tables built), a warm one and
//! one after a small map change take. A measurement for issue 20, not a test.
//!
//!     cargo run --release -p aisle-global-planner --example large_crossing

use aisle_config::scene_gen::{GenParams, Layout, generate_scene};
use aisle_geometry::{CellIndex, GridMap, OCCUPIED_STATIC, Pose2};
use aisle_global_planner::seed_map::{ROBOT, ROBOT_MARGIN};
use aisle_global_planner::{PlanRequest, Planner, PlannerConfig};
use std::time::Instant;

/// Every static body's parts that reach below 0.5 m, as occupied cells (a cell is
/// occupied when its centre lies in a part's rectangle).
fn static_map(p: &GenParams, cells_per_m: f64) -> GridMap {
    let layout = Layout::new(p);
    let res = 1.0 / cells_per_m;
    let mut map = GridMap::new_free(0.0, 0.0, res, layout.width, layout.height).unwrap();
    for body in generate_scene(p).static_bodies() {
        let (s, c) = body.pose.theta.sin_cos();
        for part in body.parts.iter().filter(|q| q.z_min() < 0.5) {
            let (hx, hy) = (0.5 * part.size[0], 0.5 * part.size[1]);
            let cx = body.pose.x + c * part.center[0] - s * part.center[1];
            let cy = body.pose.y + s * part.center[0] + c * part.center[1];
            let r = hx.hypot(hy);
            let (ix0, iy0) = (
                ((cx - r) / res).floor() as i64,
                ((cy - r) / res).floor() as i64,
            );
            let (ix1, iy1) = (
                ((cx + r) / res).ceil() as i64,
                ((cy + r) / res).ceil() as i64,
            );
            for iy in iy0..=iy1 {
                for ix in ix0..=ix1 {
                    let (x, y) = ((ix as f64 + 0.5) * res - cx, (iy as f64 + 0.5) * res - cy);
                    let (u, v) = (c * x + s * y, -s * x + c * y);
                    if u.abs() <= hx && v.abs() <= hy {
                        map.set(CellIndex { ix, iy }, OCCUPIED_STATIC);
                    }
                }
            }
        }
    }
    map
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn main() {
    let p = GenParams::new(19, 172.0, 1);
    let layout = Layout::new(&p);
    let t = Instant::now();
    let cpm: f64 = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(20.0);
    let mut map = static_map(&p, cpm);
    println!(
        "map {} x {} cells ({:.1} x {:.1} m) in {:.0} ms",
        map.width,
        map.height,
        layout.width,
        layout.height,
        ms(t)
    );
    // From the main cross aisle, 100 m up a picking aisle near the middle.
    let main = layout.aisles[0];
    let aisle = layout.aisles[2 + p.aisles as usize / 2];
    let start = Pose2::new(main[0] + 20.0, 0.5 * (main[1] + main[3]), 0.0);
    let goal = Pose2::new(
        0.5 * (aisle[0] + aisle[2]),
        aisle[1] + 100.0,
        std::f64::consts::FRAC_PI_2,
    );
    let req = PlanRequest {
        start,
        goal,
        footprint: ROBOT,
        margin: ROBOT_MARGIN,
        max_expansions: 200_000,
    };
    let cfg = PlannerConfig::default();
    for round in 0..3 {
        let t = Instant::now();
        let mut planner = Planner::new(cfg.clone()).unwrap();
        let r = planner.plan(&req, &map.view());
        let cold = ms(t);
        let t = Instant::now();
        let r2 = planner.plan(&req, &map.view());
        let warm = ms(t);
        // A small change: one detected cell beside the aisle.
        let c = map
            .view()
            .cell_of(aisle[0] + 0.2, aisle[1] + 50.0 + round as f64);
        map.set(c, OCCUPIED_STATIC);
        let t = Instant::now();
        let r3 = planner.plan(&req, &map.view());
        let changed = ms(t);
        let summary =
            |r: &Result<aisle_global_planner::Plan, aisle_global_planner::PlanError>| match r {
                Ok(p) => format!(
                    "{:.1} m, {} expansions",
                    p.stats.path_length, p.stats.expansions
                ),
                Err(e) => format!("{e}"),
            };
        println!(
            "cold {cold:.1} ms ({}), warm {warm:.1} ms ({}), after a change {changed:.1} ms ({})",
            summary(&r),
            summary(&r2),
            summary(&r3)
        );
    }
}

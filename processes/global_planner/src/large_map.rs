//! The generated large warehouse (`config/large`, 99.2 x 199.4 m, aisles 19, length
//! 172 m, seed 1) as a static map, and a 100 m crossing of it, for benchmarks and
//! examples only (issue 20): nothing in the planner depends on this module.

use crate::PlanRequest;
use crate::seed_map::{ROBOT, ROBOT_MARGIN};
use aisle_config::scene_gen::{GenParams, Layout, generate_scene};
use aisle_geometry::{CellIndex, GridMap, OCCUPIED_STATIC, Pose2};

/// The generator's parameters of `config/large`.
pub fn params() -> GenParams {
    GenParams::new(19, 172.0, 1)
}

/// The planner settings `config/large` ships (`config/large/planner.toml` over the
/// defaults: weighted A*), read from the checkout this crate is built from.
pub fn planner_config() -> Result<crate::PlannerConfig, aisle_config::ConfigError> {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/large/planner.toml");
    aisle_config::load(&path)
}

/// Every static body's parts that reach below 0.5 m, as occupied cells (a cell is
/// occupied when its centre lies in a part's rectangle).
pub fn static_map(p: &GenParams, cells_per_m: f64) -> GridMap {
    let layout = Layout::new(p);
    let res = 1.0 / cells_per_m;
    let mut map = GridMap::new_free(0.0, 0.0, res, layout.width, layout.height)
        .expect("the layout's extent is a valid grid");
    for body in generate_scene(p).static_bodies() {
        let (s, c) = body.pose.theta.sin_cos();
        for part in body.parts.iter().filter(|q| q.z_min() < 0.5) {
            let (hx, hy) = (0.5 * part.size[0], 0.5 * part.size[1]);
            let cx = body.pose.x + c * part.center[0] - s * part.center[1];
            let cy = body.pose.y + s * part.center[0] + c * part.center[1];
            let r = hx.hypot(hy);
            let cell = |v: f64| (v / res).floor() as i64;
            for iy in cell(cy - r)..=cell(cy + r) + 1 {
                for ix in cell(cx - r)..=cell(cx + r) + 1 {
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

/// From the main cross aisle, 100 m up a picking aisle near the middle (the robot alone,
/// budget 200,000 expansions); and a point beside that aisle halfway up, where a
/// detection changes the map near the path.
pub fn crossing(p: &GenParams) -> (PlanRequest, (f64, f64)) {
    let layout = Layout::new(p);
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
        fixed_budget: false,
    };
    (req, (aisle[0] + 0.2, aisle[1] + 50.0))
}

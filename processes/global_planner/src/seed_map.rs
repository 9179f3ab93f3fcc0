//! A stand-in for the seed warehouse's static map, for tests and benchmarks only: a
//! plain rasteriser of axis-aligned rectangles and the seed's segments. The real static
//! map comes from the mapper crate; nothing in the planner depends on this module.

use aisle_geometry::{Footprint, GridMap, OCCUPIED_STATIC, Pose2};
use std::f64::consts::FRAC_PI_2;

/// The robot alone and its margin (seed).
pub const ROBOT: Footprint = Footprint::new(0.508, 0.43);
pub const ROBOT_MARGIN: f64 = 0.1;
/// The robot carrying the pallet rack and its margin (seed).
pub const RACK: Footprint = Footprint::new(0.88, 0.8);
pub const RACK_MARGIN: f64 = 0.4;

/// An axis-aligned rectangle `[min_x, max_x] x [min_y, max_y]` in metres.
#[derive(Debug, Clone, Copy)]
pub struct Rect {
    pub min_x: f64,
    pub min_y: f64,
    pub max_x: f64,
    pub max_y: f64,
}

impl Rect {
    pub const fn new(min_x: f64, min_y: f64, max_x: f64, max_y: f64) -> Self {
        Self {
            min_x,
            min_y,
            max_x,
            max_y,
        }
    }

    pub fn centred(cx: f64, cy: f64, size_x: f64, size_y: f64) -> Self {
        Self::new(
            cx - 0.5 * size_x,
            cy - 0.5 * size_y,
            cx + 0.5 * size_x,
            cy + 0.5 * size_y,
        )
    }
}

/// Marks every cell whose square overlaps the inside of a rectangle.
pub fn rasterise(map: &mut GridMap, rects: &[Rect]) {
    let (ox, oy, res) = (map.origin_x, map.origin_y, map.resolution);
    for r in rects {
        let c0 = (((r.min_x - ox) / res + 1e-9).floor() as i64).max(0);
        let c1 = (((r.max_x - ox) / res - 1e-9).ceil() as i64 - 1).min(map.width as i64 - 1);
        let r0 = (((r.min_y - oy) / res + 1e-9).floor() as i64).max(0);
        let r1 = (((r.max_y - oy) / res - 1e-9).ceil() as i64 - 1).min(map.height as i64 - 1);
        for iy in r0..=r1 {
            for ix in c0..=c1 {
                map.cells[iy as usize * map.width + ix as usize] = OCCUPIED_STATIC;
            }
        }
    }
}

/// The seed warehouse's static obstacles (our geometry; see SCENARIO.md).
pub fn seed_obstacles() -> Vec<Rect> {
    let mut v = vec![
        // The band within 1 m of the map edge (it contains the 0.2 m walls).
        Rect::new(-5.0, -10.0, -4.0, 20.0),
        Rect::new(14.0, -10.0, 15.0, 20.0),
        Rect::new(-5.0, -10.0, 15.0, -9.0),
        Rect::new(-5.0, 19.0, 15.0, 20.0),
    ];
    for (x0, x1) in [(-3.0, -2.0), (4.5, 5.5), (8.5, 9.5), (12.0, 13.0)] {
        v.push(Rect::new(x0, 8.0, x1, 18.5));
    }
    for cy in [0.5, -2.5, -5.5, -8.3] {
        v.push(Rect::centred(11.55, cy, 3.9, 0.9));
    }
    v.push(Rect::centred(5.0, -2.5, 2.0, 1.0));
    v.push(Rect::centred(8.0, -4.5, 1.0, 2.0));
    v
}

/// The seed map: 20 x 30 m from (-5, -10) at `cells_per_metre`.
pub fn seed_map(cells_per_metre: f64) -> GridMap {
    let mut g = GridMap::new_free(-5.0, -10.0, 1.0 / cells_per_metre, 20.0, 30.0)
        .expect("seed map geometry is valid");
    rasterise(&mut g, &seed_obstacles());
    g
}

/// One planning segment of the seed mission.
#[derive(Debug, Clone, Copy)]
pub struct Segment {
    pub name: &'static str,
    pub start: Pose2,
    pub goal: Pose2,
    pub footprint: Footprint,
    pub margin: f64,
}

/// The three planned segments of the seed mission (the turn in place at the pick is
/// an action, not a planned segment).
pub fn seed_segments() -> [Segment; 3] {
    [
        Segment {
            name: "start_to_pick",
            start: Pose2::new(0.0, 0.0, 0.0),
            goal: Pose2::new(2.0, 13.0, FRAC_PI_2),
            footprint: ROBOT,
            margin: ROBOT_MARGIN,
        },
        Segment {
            name: "pick_to_drop",
            start: Pose2::new(2.0, 13.0, -FRAC_PI_2),
            goal: Pose2::new(6.0, -7.0, 0.0),
            footprint: RACK,
            margin: RACK_MARGIN,
        },
        Segment {
            name: "drop_to_final",
            start: Pose2::new(6.0, -7.0, 0.0),
            goal: Pose2::new(6.0, 8.0, FRAC_PI_2),
            footprint: ROBOT,
            margin: ROBOT_MARGIN,
        },
    ]
}

/// A 10 x 20 m hall at 20 cells/m and a park in it whose goal faces out of a dead end:
/// aisle A (x 0.5-3) and the dead-end aisle B (x 5-6.8, too narrow for a U-turn on arcs
/// of 1 m) joined across the top (y above 16); from A, the robot can reach the goal in B
/// only by turning on the spot at its end or reversing down B (`both_ends.rs`).
pub fn dead_end_park() -> (GridMap, Segment) {
    let mut map = GridMap::new_free(0.0, 0.0, 0.05, 10.0, 20.0).expect("valid grid");
    rasterise(
        &mut map,
        &[
            Rect::new(0.0, 0.0, 10.0, 0.5),
            Rect::new(0.0, 19.5, 10.0, 20.0),
            Rect::new(0.0, 0.0, 0.5, 20.0),
            Rect::new(9.5, 0.0, 10.0, 20.0),
            Rect::new(3.0, 0.0, 5.0, 16.0),
            Rect::new(6.8, 0.0, 10.0, 16.0),
        ],
    );
    let park = Segment {
        name: "dead_end_park",
        start: Pose2::new(1.75, 3.0, FRAC_PI_2),
        goal: Pose2::new(5.9, 4.0, FRAC_PI_2),
        footprint: ROBOT,
        margin: ROBOT_MARGIN,
    };
    (map, park)
}

/// A 13.6 x 40 m hall at 20 cells/m with the narrow aisles of `config/narrow`: walls,
/// four rack rows (1.4-1.6 m deep) leaving three 2.2 m aisles (centres x 3.0, 6.8 and
/// 10.6), broken by 4 m cross aisles at y 17-21, 26-30 and 35-39 above an open area
/// below y 12, and a box across the middle aisle at y 13. The carried rack cannot turn
/// in an aisle, and a goal in a cross aisle facing across it is entered only by a turn
/// at the goal, which neither heuristic sees (`meet.rs`).
pub fn narrow_hall() -> GridMap {
    let mut map = GridMap::new_free(0.0, 0.0, 0.05, 13.6, 40.0).expect("valid grid");
    let mut rects = vec![
        Rect::new(0.0, 0.0, 13.6, 0.5),
        Rect::new(0.0, 39.5, 13.6, 40.0),
        Rect::new(0.0, 0.0, 0.5, 40.0),
        Rect::new(13.1, 0.0, 13.6, 40.0),
        Rect::new(5.7, 13.0, 7.9, 13.6),
    ];
    for (x0, x1) in [(0.5, 1.9), (4.1, 5.7), (7.9, 9.5), (11.7, 13.1)] {
        for (y0, y1) in [(12.0, 17.0), (21.0, 26.0), (30.0, 35.0)] {
            rects.push(Rect::new(x0, y0, x1, y1));
        }
    }
    rasterise(&mut map, &rects);
    map
}

/// A carrying request in [`narrow_hall`] whose two ends are both hard: from the open
/// area's west side, facing the wall, to the east aisle's cross aisle at `y`, facing
/// south.
pub fn narrow_hall_carry(y: f64) -> Segment {
    Segment {
        name: "narrow_hall_carry",
        start: Pose2::new(3.0, 5.0, std::f64::consts::PI),
        goal: Pose2::new(10.6, y, -FRAC_PI_2),
        footprint: RACK,
        margin: RACK_MARGIN,
    }
}

/// Rasterises a scene's static bodies into a map of the seed's extent, for tests and
/// benchmarks against the real scene file: every part of a static body that reaches into
/// the height limits [0, 5] m marks the cells its (possibly rotated) rectangle overlaps,
/// and the 1 m boundary band is added. The mapper crate owns the real static map.
pub fn scene_map(scene: &aisle_config::scene::Scene, cells_per_metre: f64) -> GridMap {
    let mut g = GridMap::new_free(-5.0, -10.0, 1.0 / cells_per_metre, 20.0, 30.0)
        .expect("seed map geometry is valid");
    rasterise(&mut g, &seed_obstacles()[..4]);
    for body in scene.static_bodies() {
        for part in &body.parts {
            if part.z_max() < 0.0 || part.z_min() > 5.0 {
                continue;
            }
            let centre = body.pose.transform_point(part.center[0], part.center[1]);
            let at = Pose2::new(centre.0, centre.1, body.pose.theta);
            mark_rotated(&mut g, &Footprint::new(part.size[0], part.size[1]), &at);
        }
    }
    g
}

/// Marks every cell whose square overlaps the rectangle `fp` placed at `at`
/// (separating-axis test against each cell of the bounding box).
fn mark_rotated(map: &mut GridMap, fp: &Footprint, at: &Pose2) {
    let corners = fp.corners(at);
    let (ox, oy, res) = (map.origin_x, map.origin_y, map.resolution);
    let lo = |v: &[f64; 4]| v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = |v: &[f64; 4]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let xs = corners.map(|c| c.0);
    let ys = corners.map(|c| c.1);
    let c0 = (((lo(&xs) - ox) / res).floor() as i64).max(0);
    let c1 = (((hi(&xs) - ox) / res).floor() as i64).min(map.width as i64 - 1);
    let r0 = (((lo(&ys) - oy) / res).floor() as i64).max(0);
    let r1 = (((hi(&ys) - oy) / res).floor() as i64).min(map.height as i64 - 1);
    let (s, c) = at.theta.sin_cos();
    // Touching edges do not count, so that axis-aligned parts give the same cells
    // as `rasterise`.
    let eps = 1e-9;
    for iy in r0..=r1 {
        for ix in c0..=c1 {
            let sq = [
                (ox + ix as f64 * res, oy + iy as f64 * res),
                (ox + (ix + 1) as f64 * res, oy + iy as f64 * res),
                (ox + (ix + 1) as f64 * res, oy + (iy + 1) as f64 * res),
                (ox + ix as f64 * res, oy + (iy + 1) as f64 * res),
            ];
            let separated = [(1.0, 0.0), (0.0, 1.0), (c, s), (-s, c)]
                .iter()
                .any(|&(ax, ay)| {
                    let proj = |pts: &[(f64, f64); 4]| {
                        let d = pts.map(|p| p.0 * ax + p.1 * ay);
                        (lo(&d), hi(&d))
                    };
                    let (a0, a1) = proj(&corners);
                    let (b0, b1) = proj(&sq);
                    a1 <= b0 + eps || b1 <= a0 + eps
                });
            if !separated {
                map.cells[iy as usize * map.width + ix as usize] = OCCUPIED_STATIC;
            }
        }
    }
}

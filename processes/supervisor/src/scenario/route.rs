//! A stand-in for "the path the planner will take" on the static map: the shortest
//! 8-connected grid route whose cells keep a disc of the footprint's inscribed radius
//! (plus margin) off the static map. Used only to put obstacles where a robot will
//! drive; it does not depend on the planner, so a scenario stays the same while the
//! planner changes. Knows the grid, not the scene or the families.

use aisle_geometry::{CellIndex, GridView};
use pathfinding::prelude::astar;

/// Cells a disc of `radius` metres centred on them would touch something static in.
fn blocked_cells(map: &GridView, radius: f64) -> Vec<bool> {
    let (w, h) = (map.width as i64, map.height as i64);
    let r = (radius / map.resolution).ceil() as i64;
    let mut blocked = vec![false; map.width * map.height];
    for iy in 0..h {
        for ix in 0..w {
            if !map.occupied_inside(CellIndex { ix, iy }) {
                continue;
            }
            for dy in -r..=r {
                for dx in -r..=r {
                    let (x, y) = (ix + dx, iy + dy);
                    if dx * dx + dy * dy <= r * r && x >= 0 && y >= 0 && x < w && y < h {
                        blocked[(y * w + x) as usize] = true;
                    }
                }
            }
        }
    }
    blocked
}

/// The route from `from` to `to` (metres) as cell centres, for a body that needs
/// `radius` metres around its centre; the straight segment when no route exists (a
/// start or goal the disc does not fit at).
pub fn route(map: &GridView, radius: f64, from: (f64, f64), to: (f64, f64)) -> Vec<(f64, f64)> {
    let blocked = blocked_cells(map, radius);
    let w = map.width as i64;
    let a = map.cell_of(from.0, from.1);
    let b = map.cell_of(to.0, to.1);
    let (a, b) = ((a.ix, a.iy), (b.ix, b.iy));
    let open = |(x, y): (i64, i64)| {
        map.contains_cell(CellIndex { ix: x, iy: y }) && !blocked[(y * w + x) as usize]
    };
    let octile = |&(x, y): &(i64, i64)| {
        let (dx, dy) = ((x - b.0).abs(), (y - b.1).abs());
        (10 * dx.max(dy) + 4 * dx.min(dy)) as u32
    };
    let found = astar(
        &a,
        |&(x, y)| {
            let mut next = Vec::with_capacity(8);
            for (dx, dy) in crate::check::reach::NEIGHBOURS {
                let c = (x + dx, y + dy);
                if c == b || open(c) {
                    next.push((c, if dx != 0 && dy != 0 { 14 } else { 10 }));
                }
            }
            next
        },
        octile,
        |&c| c == b,
    );
    match found {
        Some((cells, _)) => cells
            .into_iter()
            .map(|(ix, iy)| map.cell_center(CellIndex { ix, iy }))
            .collect(),
        None => vec![from, to],
    }
}

/// The point at fraction `t` (0..=1) of the polyline's length, and the unit direction
/// of the polyline there (averaged over about a metre, so grid steps do not show).
pub fn point_along(line: &[(f64, f64)], t: f64) -> ((f64, f64), (f64, f64)) {
    let seg = |i: usize| (line[i + 1].0 - line[i].0).hypot(line[i + 1].1 - line[i].1);
    let total: f64 = (0..line.len().saturating_sub(1)).map(seg).sum();
    let at = |s: f64| {
        let mut left = s.clamp(0.0, total);
        for i in 0..line.len().saturating_sub(1) {
            let l = seg(i);
            if left <= l && l > 0.0 {
                let f = left / l;
                let (p, q) = (line[i], line[i + 1]);
                return (p.0 + f * (q.0 - p.0), p.1 + f * (q.1 - p.1));
            }
            left -= l;
        }
        *line.last().unwrap_or(&(0.0, 0.0))
    };
    let s = t * total;
    let p = at(s);
    let (a, b) = (at(s - 0.5), at(s + 0.5));
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let n = dx.hypot(dy);
    let dir = if n > 1e-9 {
        (dx / n, dy / n)
    } else {
        (1.0, 0.0)
    };
    (p, dir)
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::GridMap;

    #[test]
    fn the_route_goes_round_a_wall_and_keeps_its_distance() {
        // 10 x 10 m at 0.1 m, a wall at x = 5 m from y = 0 to 8 m.
        let mut map = GridMap::new_free(0.0, 0.0, 0.1, 10.0, 10.0).unwrap();
        for iy in 0..80 {
            map.set(CellIndex { ix: 50, iy }, aisle_geometry::OCCUPIED_STATIC);
        }
        let r = route(&map.view(), 0.5, (2.0, 2.0), (8.0, 2.0));
        assert!(r.len() > 60, "{}", r.len());
        let top = r.iter().map(|p| p.1).fold(f64::MIN, f64::max);
        assert!(top > 8.4, "passes above the wall's end with room: {top}");
        let (p, d) = point_along(&r, 0.5);
        assert!(p.1 > 7.5 && d.0 > 0.9, "{p:?} {d:?}");
    }

    #[test]
    fn no_route_is_the_straight_segment() {
        let mut map = GridMap::new_free(0.0, 0.0, 0.1, 10.0, 10.0).unwrap();
        for iy in 0..100 {
            map.set(CellIndex { ix: 50, iy }, aisle_geometry::OCCUPIED_STATIC);
        }
        assert_eq!(
            route(&map.view(), 0.3, (2.0, 2.0), (8.0, 2.0)),
            vec![(2.0, 2.0), (8.0, 2.0)]
        );
    }
}

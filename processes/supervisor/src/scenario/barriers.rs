//! The families that build walls of unseen obstacles: a barrier across the carry leg's
//! way with a gap just wider than the carrying footprint plus its margin (feasible),
//! and the infeasible ones: a gap too narrow for the rack, or a drop or park pose
//! enclosed on all four sides. Knows the layout and the sampler, not the files.

use super::geom::Rect;
use super::ground::{Ground, OBSTACLE_GAP};
use super::route::{point_along, route};
use super::sample::{mm, rad, uniform};
use super::{Draft, NewBody};
use aisle_geometry::{CellIndex, Footprint, GridMap, OCCUPIED_STATIC, Pose2};
use rand::RngExt;
use rand::rngs::ChaCha8Rng;

/// Places to try along the way before the draw is given up.
const TRIES: usize = 40;
/// How far a barrier reaches into the static body it ends at (closes the slit a
/// slanted face would leave), metres.
const INTO_STATIC: f64 = 0.1;

/// The carry leg's way: from the carried rack to the drop pose, on the static map, for
/// a body of the carrying footprint's inscribed radius plus `margin`.
fn carry_route(g: &Ground, d: &Draft, margin: f64) -> Option<Vec<(f64, f64)>> {
    let leg = d.legs.iter().find(|l| l.carry.is_some())?;
    let (_, rack) = g.scene.body(leg.carry.as_deref()?)?;
    let [x, y, _] = leg.goal?;
    let radius = 0.5 * g.carrying.length.min(g.carrying.width) + margin;
    Some(route(
        &g.static_map.view(),
        radius,
        (rack.pose.x, rack.pose.y),
        (x, y),
    ))
}

/// Distance from `p` along `dir` to the first static body, or to the map's edge.
fn reach(g: &Ground, p: (f64, f64), dir: (f64, f64)) -> f64 {
    let (x0, y0, x1, y1) = g.map;
    let edge = |v: f64, d: f64, lo: f64, hi: f64| {
        if d > 1e-12 {
            (hi - v) / d
        } else if d < -1e-12 {
            (lo - v) / d
        } else {
            f64::INFINITY
        }
    };
    let mut t = edge(p.0, dir.0, x0, x1).min(edge(p.1, dir.1, y0, y1));
    for b in g.scene.static_bodies() {
        if let Some(e) = Rect::new(b.pose, b.footprint()).ray_entry(p, dir) {
            t = t.min(e);
        }
    }
    t
}

/// A barrier across the way at a point of `way`: from static body to static body (or
/// the map's edge), in two pieces with a gap of `width` between them. Returns the
/// pieces, or None when no place along the way took them.
fn barrier(
    g: &Ground,
    rng: &mut ChaCha8Rng,
    d: &Draft,
    way: &[(f64, f64)],
    width: f64,
) -> Option<[NewBody; 2]> {
    for _ in 0..TRIES {
        let ((px, py), (dx, dy)) = point_along(way, uniform(rng, 0.2, 0.8));
        let n = (-dy, dx);
        let a = reach(g, (px, py), (-n.0, -n.1));
        let b = reach(g, (px, py), n);
        let (thick, height) = (mm(uniform(rng, 0.3, 0.6)), mm(uniform(rng, 0.6, 1.0)));
        if a < 0.5 || b < 0.5 || a + b < width + 0.6 {
            continue;
        }
        // The gap's near edge, at least 0.3 m from either end.
        let s = uniform(rng, -a + 0.3, b - width - 0.3);
        let piece = |name: &str, lo: f64, hi: f64| {
            let mid = 0.5 * (lo + hi);
            NewBody {
                name: name.into(),
                kind: "barrier".into(),
                pose: Pose2::new(mm(px + n.0 * mid), mm(py + n.1 * mid), rad(n.1.atan2(n.0))),
                size: [mm(hi - lo), thick, height],
            }
        };
        let pieces = [
            piece("barrier_a", -a - INTO_STATIC, s),
            piece("barrier_b", s + width, b + INTO_STATIC),
        ];
        if pieces.iter().all(|p| fits_movable(d, p)) {
            return Some(pieces);
        }
    }
    None
}

fn rect_of(b: &NewBody) -> Rect {
    Rect::new(b.pose, Footprint::new(b.size[0], b.size[1]))
}

/// A wall piece may stand on static bodies, not on movable ones or the mission's areas.
fn fits_movable(d: &Draft, b: &NewBody) -> bool {
    let r = rect_of(b);
    let grown = r.grown(OBSTACLE_GAP);
    d.layout
        .bodies
        .iter()
        .filter(|p| !p.is_static)
        .all(|p| !p.rect.overlaps(&grown))
        && d.layout.keep_out.iter().all(|k| !k.overlaps(&r))
}

/// A barrier across the carry leg's way leaving a gap 5 to 30 cm wider than the
/// carrying footprint's width plus twice its margin.
pub fn gap(g: &Ground, rng: &mut ChaCha8Rng, d: &mut Draft) -> bool {
    let Some(way) = carry_route(g, d, g.carrying_margin) else {
        return false;
    };
    let need = g.carrying.width + 2.0 * g.carrying_margin;
    let width = mm(need + uniform(rng, 0.05, 0.30));
    let Some(pieces) = barrier(g, rng, d, &way, width) else {
        return false;
    };
    d.varied.push(format!(
        "barrier across the carry leg's way leaving a {width} m gap (carrying width {} + 2 x margin {} + {:.3}) between {} and {}",
        g.carrying.width,
        g.carrying_margin,
        width - need,
        describe(&pieces[0]),
        describe(&pieces[1])
    ));
    pieces.into_iter().for_each(|p| d.add(p));
    true
}

fn describe(b: &NewBody) -> String {
    format!(
        "{} ({} m long at ({}, {}))",
        b.name, b.size[0], b.pose.x, b.pose.y
    )
}

/// Half the time a gap too narrow for the rack itself (0.45 to 0.75 m), checked to be
/// the only way; else a drop or park pose walled in on all four sides. The other kind
/// when the first finds no room.
pub fn infeasible(g: &Ground, rng: &mut ChaCha8Rng, d: &mut Draft) -> bool {
    type Kind = fn(&Ground, &mut ChaCha8Rng, &mut Draft) -> bool;
    let order: [Kind; 2] = if rng.random_bool(0.5) {
        [narrow, enclose]
    } else {
        [enclose, narrow]
    };
    order.iter().any(|kind| kind(g, rng, d))
}

fn narrow(g: &Ground, rng: &mut ChaCha8Rng, d: &mut Draft) -> bool {
    let Some(way) = carry_route(g, d, g.carrying_margin) else {
        return false;
    };
    let width = mm(uniform(rng, 0.45, 0.75));
    let Some(pieces) = barrier(g, rng, d, &way, width) else {
        return false;
    };
    // The only way: with the barrier on the static map, the bare rack (no margin) has
    // no route from its place to the drop pose.
    let mut map = g.static_map.clone();
    pieces.iter().for_each(|p| rasterise(&mut map, &rect_of(p)));
    let Some(leg) = d.legs.iter().find(|l| l.carry.is_some()) else {
        return false;
    };
    let (Some([x, y, _]), Some((_, rack))) =
        (leg.goal, leg.carry.as_deref().and_then(|n| g.scene.body(n)))
    else {
        return false;
    };
    let half = 0.5 * g.carrying.length.min(g.carrying.width);
    if route(&map.view(), half, (rack.pose.x, rack.pose.y), (x, y)).len() > 2 {
        return false;
    }
    d.varied.push(format!(
        "infeasible: barrier across the carry leg's way leaving a {width} m gap (the rack is {} m wide) between {} and {}",
        g.carrying.width,
        describe(&pieces[0]),
        describe(&pieces[1])
    ));
    pieces.into_iter().for_each(|p| d.add(p));
    true
}

fn rasterise(map: &mut GridMap, r: &Rect) {
    let cells: Vec<CellIndex> = {
        let view = map.view();
        let grown = r.grown(0.5 * view.resolution);
        let (w, h) = (view.width as i64, view.height as i64);
        (0..h)
            .flat_map(|iy| (0..w).map(move |ix| CellIndex { ix, iy }))
            .filter(|&c| {
                let (x, y) = view.cell_center(c);
                grown.size.contains(&grown.at, x, y)
            })
            .collect()
    };
    for c in cells {
        map.set(c, OCCUPIED_STATIC);
    }
}

/// Four walls round the drop pose (room for the carried rack) or the park pose (room
/// for the robot), 0.3 m from the footprint's circumscribed circle.
fn enclose(g: &Ground, rng: &mut ChaCha8Rng, d: &mut Draft) -> bool {
    let drop = d.legs.iter().rposition(|l| l.carry.is_some());
    let park = d
        .legs
        .iter()
        .rposition(|l| l.carry.is_none() && l.approach.is_none() && !l.rotate);
    let pick_drop = rng.random_bool(0.5);
    let Some(i) = (if pick_drop {
        drop.or(park)
    } else {
        park.or(drop)
    }) else {
        return false;
    };
    let Some([x, y, h]) = d.legs[i].goal else {
        return false;
    };
    let carrying = d.legs[i].carry.is_some();
    let fp = if carrying { g.carrying } else { g.alone };
    let inner = mm(fp.circumscribed_radius() + 0.3);
    let (thick, height) = (0.3, mm(uniform(rng, 0.6, 1.0)));
    let at = Pose2::new(x, y, h);
    let walls: Vec<NewBody> = (0..4)
        .map(|k| {
            let yaw = h + k as f64 * std::f64::consts::FRAC_PI_2;
            let (cx, cy) = at.transform_point(
                (inner + 0.5 * thick) * (yaw - h).cos(),
                (inner + 0.5 * thick) * (yaw - h).sin(),
            );
            NewBody {
                name: format!("ring_{}", k + 1),
                kind: "barrier".into(),
                pose: Pose2::new(mm(cx), mm(cy), rad(aisle_geometry::wrap_angle(yaw))),
                size: [thick, mm(2.0 * (inner + thick)), height],
            }
        })
        .collect();
    // The start and the rack being picked must stay outside; other movable bodies clear.
    let outer = Rect::new(
        at,
        Footprint::new(2.0 * (inner + thick), 2.0 * (inner + thick)),
    );
    let start = g.robot_rect(d.start, 0.0);
    let named = d.named();
    let clear = d.layout.bodies.iter().filter(|b| !b.is_static).all(|b| {
        let grown = b.rect.grown(OBSTACLE_GAP);
        if named.contains(&b.name) {
            !grown.overlaps(&outer)
        } else {
            walls.iter().all(|w| !grown.overlaps(&rect_of(w)))
        }
    });
    if start.overlaps(&outer) || !clear {
        return false;
    }
    let what = if carrying { "drop" } else { "park" };
    d.varied.push(format!(
        "infeasible: the {what} pose ({x}, {y}) walled in on four sides (ring_1..4, {} m square inside)",
        2.0 * inner
    ));
    walls.into_iter().for_each(|w| d.add(w));
    true
}

//! The families that move things or make another mission: unseen obstacles moved along
//! the corridors, extra obstacles (some on the way), another start, another mission.
//! Each returns false when this draw found no room (the caller draws again). Knows the
//! layout and the sampler, not the files.

use super::geom::Rect;
use super::ground::{ALONE_CLEARANCE, CARRY_CLEARANCE, Ground, Placed};
use super::route::{point_along, route};
use super::sample::{any_pose, free_pose, heading, mm, rad, uniform};
use super::{Draft, Leg, NewBody};
use aisle_geometry::{Footprint, Pose2, wrap_angle};
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use std::f64::consts::{FRAC_PI_2, PI};

/// Draws per obstacle before it is left where it is (moved) or left out (extra).
const OBSTACLE_TRIES: usize = 40;

/// Unseen obstacles: movable bodies that are not racks and that the mission does not
/// name.
pub fn unseen(d: &Draft) -> Vec<Placed> {
    let named = d.named();
    d.layout
        .bodies
        .iter()
        .filter(|b| !b.is_static && b.kind != "pallet_rack" && !named.contains(&b.name))
        .cloned()
        .collect()
}

fn xy(p: &Pose2) -> String {
    format!("({:.3}, {:.3}, {:.4})", p.x, p.y, p.theta)
}

/// Each unseen obstacle, with probability 0.8, slides 0.5 to 4 m along x or y (the
/// corridors run along the axes) and turns by up to 0.3 rad.
pub fn moved(g: &Ground, rng: &mut ChaCha8Rng, d: &mut Draft) -> bool {
    for body in unseen(d) {
        if !rng.random_bool(0.8) {
            continue;
        }
        for _ in 0..OBSTACLE_TRIES {
            let dist = uniform(rng, 0.5, 4.0) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let along_x = rng.random_bool(0.5);
            let turn = uniform(rng, -0.3, 0.3);
            let from = body.rect.at;
            let (dx, dy) = if along_x { (dist, 0.0) } else { (0.0, dist) };
            let to = Pose2::new(
                mm(from.x + dx),
                mm(from.y + dy),
                rad(wrap_angle(from.theta + turn)),
            );
            let r = Rect::new(to, body.rect.size);
            if r.inside(g.interior) && d.layout.obstacle_fits(&r, &body.name) {
                if let Some(b) = d.layout.get_mut(&body.name) {
                    b.rect = r;
                }
                d.varied.push(format!(
                    "moved {} from {} to {}",
                    body.name,
                    xy(&from),
                    xy(&to)
                ));
                d.moved.push((body.name.clone(), to));
                break;
            }
        }
    }
    !d.moved.is_empty()
}

/// The way each driving leg takes on the static map, roughly (see [`route`]).
pub fn leg_routes(g: &Ground, d: &Draft) -> Vec<Vec<(f64, f64)>> {
    let map = g.static_map.view();
    let mut at = (d.start.x, d.start.y);
    let mut out = Vec::new();
    for leg in &d.legs {
        let goal = match (
            leg.goal,
            leg.approach.as_deref().and_then(|n| g.scene.body(n)),
        ) {
            (Some([x, y, _]), _) => (x, y),
            (None, Some((_, b))) => (b.pose.x, b.pose.y),
            (None, None) => continue,
        };
        if !leg.rotate {
            let radius = if leg.carry.is_some() {
                0.5 * g.carrying.length.min(g.carrying.width) + g.carrying_margin
            } else {
                0.5 * g.alone.length.min(g.alone.width) + g.alone_margin
            };
            out.push(route(&map, radius, at, goal));
        }
        at = goal;
    }
    out
}

/// Two to five extra boxes and carts; half of them (rounded up) on the way a leg will
/// drive, the others anywhere free.
pub fn extra(g: &Ground, rng: &mut ChaCha8Rng, d: &mut Draft) -> bool {
    let routes = leg_routes(g, d);
    let count = rng.random_range(2..=5_usize);
    for i in 1..=count {
        let on_way = i <= count.div_ceil(2) && !routes.is_empty();
        for _ in 0..OBSTACLE_TRIES {
            let cart = rng.random_bool(0.3);
            let size = if cart {
                [mm(uniform(rng, 0.6, 1.0)), mm(uniform(rng, 0.5, 0.7)), 0.9]
            } else {
                [
                    mm(uniform(rng, 0.3, 0.7)),
                    mm(uniform(rng, 0.3, 0.7)),
                    mm(uniform(rng, 0.4, 0.9)),
                ]
            };
            let pose = if on_way {
                let r = &routes[rng.random_range(0..routes.len())];
                let ((x, y), (dx, dy)) = point_along(r, uniform(rng, 0.15, 0.85));
                let off = uniform(rng, -0.3, 0.3);
                Pose2::new(mm(x - dy * off), mm(y + dx * off), heading(rng))
            } else {
                any_pose(rng, g)
            };
            let r = Rect::new(pose, Footprint::new(size[0], size[1]));
            if r.inside(g.interior) && d.layout.obstacle_fits(&r, "") {
                let name = format!("extra_{i}");
                let kind = if cart { "cart" } else { "box" };
                let place = if on_way { "on the way" } else { "anywhere" };
                d.varied.push(format!(
                    "added {kind} {name} {place}: {} m at {}",
                    format_size(&size),
                    xy(&pose)
                ));
                d.add(NewBody {
                    name,
                    kind: kind.into(),
                    pose,
                    size,
                });
                break;
            }
        }
    }
    !d.added.is_empty()
}

fn format_size(s: &[f64; 3]) -> String {
    format!("{} x {} x {}", s[0], s[1], s[2])
}

/// A start pose anywhere free (robot margin plus [`ALONE_CLEARANCE`]), at least 2 m
/// from the first goal.
pub fn start(g: &Ground, rng: &mut ChaCha8Rng, d: &mut Draft) -> bool {
    let first = d.legs.first().and_then(|l| l.goal).map(|[x, y, _]| (x, y));
    let far = |p: Pose2| first.is_none_or(|(x, y)| (p.x - x).hypot(p.y - y) >= 2.0);
    let need = |p: Pose2| vec![g.robot_rect(p, ALONE_CLEARANCE)];
    match free_pose(rng, g, &d.layout, &[], need, far) {
        Some(p) => {
            d.varied
                .push(format!("start {} (was {})", xy(&p), xy(&d.start)));
            d.start = p;
            true
        }
        None => false,
    }
}

/// Another mission: pick one of the movable racks from its front or back end, or with
/// the heading left to the planner; sometimes turn in place under it; carry it to a
/// free drop pose and heading at least 3 m away; in a third of the draws, pick a second
/// rack the same way straight after (the leg to it starts under the first, just set
/// down) and carry it away too; park at a free pose at least 2.5 m from the drops. No
/// `depart`. On a base whose mission does not fit its scene, the start is drawn too
/// (as by [`start`]).
pub fn mission(g: &Ground, rng: &mut ChaCha8Rng, d: &mut Draft) -> bool {
    let racks = g.racks();
    if racks.is_empty() {
        return false;
    }
    // A base mission that does not fit the scene has no start to keep either.
    if g.mission_unfit.is_some() && !start(g, rng, d) {
        return false;
    }
    let first = racks[rng.random_range(0..racks.len())];
    let (mut legs, mut said) = pick_legs(rng, first);
    let away = |p: Pose2| p.distance(&first.pose) >= 3.0;
    let Some(drop) = drop_pose(g, rng, d, first, away) else {
        return false;
    };
    let need = |p: Pose2| vec![g.robot_rect(p, ALONE_CLEARANCE)];
    let apart = |p: Pose2| p.distance(&drop) >= 2.5;
    let Some(park) = free_pose(rng, g, &d.layout, &[], need, apart) else {
        return false;
    };
    legs.push(carry_leg("carry to drop", &first.name, drop));
    said.push_str(&format!(", drop at {}", xy(&drop)));
    // Drawn after everything else, so the one-rack missions stay what they were.
    if racks.len() > 1 && rng.random_bool(1.0 / 3.0) {
        let others: Vec<_> = racks.iter().filter(|r| r.name != first.name).collect();
        let second = others[rng.random_range(0..others.len())];
        let (more, said_more) = pick_legs(rng, second);
        let clear = |p: Pose2| p.distance(&second.pose) >= 3.0 && p.distance(&park) >= 2.5;
        let Some(drop2) = drop_pose(g, rng, d, second, clear) else {
            return false;
        };
        legs.extend(more.into_iter().map(|l| Leg {
            name: format!("{} 2", l.name),
            ..l
        }));
        legs.push(carry_leg("carry to drop 2", &second.name, drop2));
        said.push_str(&format!(", then {said_more}, drop at {}", xy(&drop2)));
    }
    legs.push(Leg {
        name: "park".into(),
        goal: Some([park.x, park.y, park.theta]),
        rotate: false,
        carry: None,
        approach: None,
        depart: None,
        max_velocity: None,
    });
    d.varied
        .push(format!("mission: {said}, park at {}", xy(&park)));
    d.legs = legs;
    true
}

/// The legs that pick `rack`: from its front or back end, or with the heading free;
/// half of the time a turn in place under it follows. With what they do, in words.
fn pick_legs(rng: &mut ChaCha8Rng, rack: &aisle_config::scene::Body) -> (Vec<Leg>, String) {
    let (name, at) = (rack.name.clone(), rack.pose);
    let side = rng.random_range(0..3_u32);
    let entry = match side {
        0 => Some(at.theta),
        1 => Some(wrap_angle(at.theta + PI)),
        _ => None,
    };
    let mut legs = vec![Leg {
        name: "to pick".into(),
        goal: entry.map(|h| [at.x, at.y, rad(h)]),
        rotate: false,
        carry: None,
        approach: Some(name.clone()),
        depart: None,
        max_velocity: None,
    }];
    let mut said = match entry {
        Some(h) => format!("pick {name} heading {:.4}", rad(h)),
        None => format!("pick {name} heading free"),
    };
    if rng.random_bool(0.5) {
        let k = rng.random_range(1..4_u32) as f64;
        let h = rad(wrap_angle(entry.unwrap_or(at.theta) + k * FRAC_PI_2));
        legs.push(Leg {
            name: "turn in place".into(),
            goal: Some([at.x, at.y, h]),
            rotate: true,
            carry: None,
            approach: Some(name.clone()),
            depart: None,
            max_velocity: None,
        });
        said.push_str(&format!(", turn to {h:.4}"));
    }
    (legs, said)
}

/// A free pose for `rack` set down (with room for both of its orientations on the
/// robot: its yaw relative to the robot depends on the side it was entered from) that
/// `accept`s; the layout has the rack there from then on.
fn drop_pose(
    g: &Ground,
    rng: &mut ChaCha8Rng,
    d: &mut Draft,
    rack: &aisle_config::scene::Body,
    accept: impl Fn(Pose2) -> bool,
) -> Option<Pose2> {
    let fp = rack.footprint();
    let need = |p: Pose2| {
        let turned = Pose2::new(p.x, p.y, p.theta + FRAC_PI_2);
        let m = g.carrying_margin + CARRY_CLEARANCE;
        vec![Rect::new(p, fp).grown(m), Rect::new(turned, fp).grown(m)]
    };
    let drop = free_pose(rng, g, &d.layout, &[&rack.name], need, accept)?;
    if let Some(b) = d.layout.get_mut(&rack.name) {
        b.rect = Rect::new(Pose2::new(drop.x, drop.y, drop.theta), fp);
    }
    Some(drop)
}

fn carry_leg(name: &str, rack: &str, to: Pose2) -> Leg {
    Leg {
        name: name.into(),
        goal: Some([to.x, to.y, to.theta]),
        rotate: false,
        carry: Some(rack.into()),
        approach: None,
        depart: None,
        max_velocity: None,
    }
}

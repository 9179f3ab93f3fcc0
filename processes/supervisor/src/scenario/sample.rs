//! Random poses and sizes from a seeded generator, rounded so that the files read well
//! and the same seed gives the same bytes; free poses by rejection against the layout.
//! Knows the ground and the layout, not the families.

use super::Leg;
use super::geom::Rect;
use super::ground::{Ground, KEEP_OUT, Layout};
use aisle_geometry::{Footprint, Pose2};
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use std::f64::consts::PI;

/// Draws before a free pose is given up.
const TRIES: usize = 600;

/// Metres to the millimetre, radians to 1e-4.
pub fn mm(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

pub fn rad(v: f64) -> f64 {
    (v * 10_000.0).round() / 10_000.0
}

pub fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    if hi > lo {
        rng.random_range(lo..hi)
    } else {
        lo
    }
}

pub fn heading(rng: &mut ChaCha8Rng) -> f64 {
    rad(uniform(rng, -PI, PI))
}

/// A pose drawn uniformly over the map's interior, any heading.
pub fn any_pose(rng: &mut ChaCha8Rng, g: &Ground) -> Pose2 {
    let (x0, y0, x1, y1) = g.interior;
    let x = mm(uniform(rng, x0, x1));
    let y = mm(uniform(rng, y0, y1));
    Pose2::new(x, y, heading(rng))
}

/// A pose whose every rectangle from `needs` is free (inside the interior, touching no
/// body but those in `except`) and that `accept` takes.
pub fn free_pose(
    rng: &mut ChaCha8Rng,
    g: &Ground,
    layout: &Layout,
    except: &[&str],
    needs: impl Fn(Pose2) -> Vec<Rect>,
    accept: impl Fn(Pose2) -> bool,
) -> Option<Pose2> {
    (0..TRIES)
        .map(|_| any_pose(rng, g))
        .find(|&p| accept(p) && needs(p).iter().all(|r| layout.free(r, g.interior, except)))
}

/// The areas obstacles must leave free for a mission: its start, every goal (with the
/// carried rack where a leg carries), and each named rack with room to drive under it
/// along its axis from either end.
pub fn keep_out(g: &Ground, start: Pose2, legs: &[Leg]) -> Vec<Rect> {
    let mut out = vec![g.robot_rect(start, KEEP_OUT)];
    for leg in legs {
        let rack = leg.approach.as_ref().or(leg.carry.as_ref());
        if let Some((_, body)) = rack.and_then(|n| g.scene.body(n)) {
            let fp = body.footprint();
            out.push(Rect::new(body.pose, fp).grown(KEEP_OUT));
            let run_in = 2.0 * (g.alone.length + g.alone_margin + KEEP_OUT);
            out.push(Rect::new(
                body.pose,
                Footprint::new(fp.length + run_in, fp.width),
            ));
        }
        if let Some([x, y, h]) = leg.goal {
            let at = Pose2::new(x, y, h);
            out.push(if leg.carry.is_some() {
                g.carried_rect(at, KEEP_OUT)
            } else {
                g.robot_rect(at, KEEP_OUT)
            });
        }
    }
    out
}

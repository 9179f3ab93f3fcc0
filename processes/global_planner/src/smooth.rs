//! Path smoothing that never trades validity for looks: each stretch driven in one
//! direction is relaxed by gradient smoothing of its positions (pull towards the original
//! plus pull towards the neighbours' mean), headings are re-derived from the new tangents,
//! and the stretch keeps its smoothed shape only if it still respects the turning radius
//! and passes the caller's collision check. Stretch ends (cusps, rotations, start, goal)
//! and their neighbours never move. Knows nothing of grids: collision is a callback.

use crate::validate::check_turning_radius;
use aisle_geometry::{Direction, PathPose, wrap_angle};
use std::f64::consts::PI;

pub(crate) struct SmoothParams {
    pub weight_data: f64,
    pub weight_smooth: f64,
    pub iterations: u32,
    pub radius: f64,
}

/// Smooths `path` in place. `valid(stretch)` must say whether a stretch of poses is
/// collision-free. Returns whether any stretch changed; `kept` gets, for every smoothed
/// stretch kept, the range of its poses (`valid` passed them as they now stand).
pub(crate) fn smooth_path(
    path: &mut [PathPose],
    params: &SmoothParams,
    scratch: &mut Vec<PathPose>,
    kept: &mut Vec<std::ops::Range<usize>>,
    mut valid: impl FnMut(&[PathPose]) -> bool,
) -> bool {
    kept.clear();
    let mut changed = false;
    let mut start = 0;
    while start + 1 < path.len() {
        let dir = path[start].direction;
        let mut end = start + 1;
        while end < path.len() - 1 && path[end].direction == dir {
            end += 1;
        }
        // Poses start..=end: `end` is where the next stretch starts (or the goal).
        if dir != Direction::Rotate
            && end - start >= 6
            && smooth_stretch(&mut path[start..=end], dir, params, scratch, &mut valid)
        {
            changed = true;
            kept.push(start..end + 1);
        }
        start = end;
    }
    changed
}

fn smooth_stretch(
    s: &mut [PathPose],
    dir: Direction,
    p: &SmoothParams,
    scratch: &mut Vec<PathPose>,
    valid: &mut impl FnMut(&[PathPose]) -> bool,
) -> bool {
    scratch.clear();
    scratch.extend_from_slice(s);
    let n = s.len();
    for _ in 0..p.iterations {
        let mut change = 0.0;
        for i in 2..n - 2 {
            let (ox, oy) = (scratch[i].pose.x, scratch[i].pose.y);
            let (x, y) = (s[i].pose.x, s[i].pose.y);
            let nx = x
                + p.weight_data * (ox - x)
                + p.weight_smooth * (s[i - 1].pose.x + s[i + 1].pose.x - 2.0 * x);
            let ny = y
                + p.weight_data * (oy - y)
                + p.weight_smooth * (s[i - 1].pose.y + s[i + 1].pose.y - 2.0 * y);
            change += (nx - x).abs() + (ny - y).abs();
            s[i].pose.x = nx;
            s[i].pose.y = ny;
        }
        if change < 1e-9 {
            break;
        }
    }
    let flip = if dir == Direction::Reverse { PI } else { 0.0 };
    for i in 2..n - 2 {
        let dx = s[i + 1].pose.x - s[i - 1].pose.x;
        let dy = s[i + 1].pose.y - s[i - 1].pose.y;
        s[i].pose.theta = wrap_angle(dy.atan2(dx) + flip);
    }
    let moved = s.iter().zip(scratch.iter()).any(|(a, b)| a.pose != b.pose);
    if !moved {
        return false;
    }
    if check_turning_radius(s, p.radius).is_ok() && valid(s) {
        true
    } else {
        s.copy_from_slice(scratch);
        false
    }
}

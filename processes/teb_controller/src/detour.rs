//! Moving band poses that sit in obstacles sideways until they are clear, before the
//! optimiser runs. Linearised clearances are only informative outside obstacles (from
//! inside a pallet every cell pulls another way), so a reference path through an unseen
//! pallet is first bent around it on one side; the side is the homotopy class.
//!
//! Knows nothing of time or of the optimiser.

use aisle_geometry::{Footprint, GridView, Pose2};

use crate::band::Band;
use crate::clearance::min_clearance;
use crate::scp::FEASIBLE;

/// Which way blocked poses are pushed, seen along the band's heading.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Side {
    Left,
    Right,
}

impl Side {
    fn sign(self) -> f64 {
        match self {
            Side::Left => 1.0,
            Side::Right => -1.0,
        }
    }

    /// 1 left, -1 right (as a snapshot stores it).
    pub fn code(self) -> i8 {
        match self {
            Side::Left => 1,
            Side::Right => -1,
        }
    }

    /// The side of [`Side::code`]; anything else is none.
    pub fn from_code(code: i8) -> Option<Side> {
        match code {
            1 => Some(Side::Left),
            -1 => Some(Side::Right),
            _ => None,
        }
    }

    pub fn other(self) -> Side {
        match self {
            Side::Left => Side::Right,
            Side::Right => Side::Left,
        }
    }
}

const OFFSET_STEP: f64 = 0.05;

fn shifted(p: &Pose2, d: f64) -> Pose2 {
    let (s, c) = p.theta.sin_cos();
    Pose2::new(p.x - s * d, p.y + c * d, p.theta)
}

/// Smallest sideways offset (multiples of 0.05 m up to `max_offset`) that clears pose
/// `p` by `margin`, pushed towards `side`. When the side is `held` (the band already
/// went around on it), a pose clear of every obstacle but short of the margin moves at
/// most the margin: a push further than that to the held side carries it past an
/// obstacle (through a wall, out of the aisle) to a place the band cannot bend to, and
/// the optimiser, whose clearances are informative outside obstacles, does better.
fn clearing_offset(
    map: &GridView,
    fp: &Footprint,
    margin: f64,
    p: &Pose2,
    side: Side,
    max_offset: f64,
    held: bool,
) -> Option<f64> {
    let limit = if held && min_clearance(map, fp, p, margin) >= 0.0 {
        max_offset.min(margin + OFFSET_STEP)
    } else {
        max_offset
    };
    let mut d = OFFSET_STEP;
    while d <= limit + 1e-9 {
        let q = shifted(p, side.sign() * d);
        if min_clearance(map, fp, &q, margin) >= margin {
            return Some(d);
        }
        d += OFFSET_STEP;
    }
    None
}

/// Whether `p` is short of the margin by more than the optimiser's feasibility
/// tolerance (a band the optimiser left a fraction of a millimetre inside the margin is
/// feasible to it).
fn short_of_margin(map: &GridView, fp: &Footprint, p: &Pose2, margin: f64) -> bool {
    min_clearance(map, fp, p, margin) < margin - FEASIBLE
}

/// Whether any pose but the first is short of the margin.
pub(crate) fn blocked(band: &Band, map: &GridView, fp: &Footprint, margin: f64) -> bool {
    band.poses[1..]
        .iter()
        .any(|p| short_of_margin(map, fp, p, margin))
}

/// Pushes every run of blocked poses (the first pose never moves) sideways. With
/// `side = None` each run goes the way that needs the smaller offset (left on a tie);
/// the side chosen for the first run is returned. Runs that cannot be cleared within
/// `max_offset` stay where they are.
pub(crate) fn repair(
    band: &mut Band,
    map: &GridView,
    fp: &Footprint,
    margin: f64,
    side: Option<Side>,
    max_offset: f64,
) -> Option<Side> {
    let n = band.poses.len();
    let held = side.is_some();
    let mut chosen = None;
    let mut i = 1;
    while i < n {
        if !short_of_margin(map, fp, &band.poses[i], margin) {
            i += 1;
            continue;
        }
        let mut j = i;
        while j + 1 < n && short_of_margin(map, fp, &band.poses[j + 1], margin) {
            j += 1;
        }
        // Offset of the run for one side: the largest any of its poses needs.
        let run_offset = |s: Side| -> Option<f64> {
            let mut worst: f64 = 0.0;
            for p in &band.poses[i..=j] {
                worst = worst.max(clearing_offset(map, fp, margin, p, s, max_offset, held)?);
            }
            Some(worst)
        };
        let pick = match side {
            Some(s) => run_offset(s).map(|d| (s, d)),
            None => match (run_offset(Side::Left), run_offset(Side::Right)) {
                (Some(l), Some(r)) => Some(if r < l - 1e-9 {
                    (Side::Right, r)
                } else {
                    (Side::Left, l)
                }),
                (Some(l), None) => Some((Side::Left, l)),
                (None, Some(r)) => Some((Side::Right, r)),
                (None, None) => None,
            },
        };
        if let Some((s, d)) = pick {
            chosen.get_or_insert(s);
            for k in i..=j {
                let q = shifted(&band.poses[k], s.sign() * d);
                band.poses[k] = if min_clearance(map, fp, &q, margin) >= margin {
                    q
                } else {
                    // The run's offset does not clear this pose; use its own.
                    clearing_offset(map, fp, margin, &band.poses[k], s, max_offset, held)
                        .map_or(band.poses[k], |dk| shifted(&band.poses[k], s.sign() * dk))
                };
            }
        }
        i = j + 1;
    }
    chosen
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::{GridMap, OCCUPIED_DETECTED};

    #[test]
    fn a_band_through_a_pallet_is_pushed_to_the_cheaper_side() {
        let mut g = GridMap::new_free(-5.0, -5.0, 0.1, 10.0, 10.0).unwrap();
        // Pallet 1.2 x 0.8 centred at (2, 0.1): slightly left of the band, so the
        // right side is cheaper.
        for ix in 0..12 {
            for iy in 0..8 {
                let c = g.view().cell_of(
                    1.4 + 0.1 * ix as f64 + 0.05,
                    -0.3 + 0.1 + 0.1 * iy as f64 + 0.05,
                );
                g.set(c, OCCUPIED_DETECTED);
            }
        }
        let mut band = Band {
            poses: (0..9)
                .map(|i| Pose2::new(0.5 * i as f64, 0.0, 0.0))
                .collect(),
            dts: vec![0.3; 8],
        };
        let fp = Footprint::new(0.508, 0.43);
        assert!(blocked(&band, &g.view(), &fp, 0.1));
        let side = repair(&mut band, &g.view(), &fp, 0.1, None, 3.0);
        assert_eq!(side, Some(Side::Right));
        assert!(!blocked(&band, &g.view(), &fp, 0.1));
        assert_eq!(band.poses[0], Pose2::new(0.0, 0.0, 0.0));
        let mut left = Band {
            poses: (0..9)
                .map(|i| Pose2::new(0.5 * i as f64, 0.0, 0.0))
                .collect(),
            dts: vec![0.3; 8],
        };
        assert_eq!(
            repair(&mut left, &g.view(), &fp, 0.1, Some(Side::Left), 3.0),
            Some(Side::Left)
        );
        assert!(left.poses[4].y > 0.5);
    }

    #[test]
    fn a_pose_near_a_wall_is_not_pushed_through_it_to_the_held_side() {
        // A 0.3 m wall from y = 0.3 to 0.6 with free floor beyond it; the band runs
        // along y = 0, 0.02 m short of the 0.1 m margin below the wall.
        let mut g = GridMap::new_free(-5.0, -5.0, 0.1, 10.0, 10.0).unwrap();
        for ix in 0..100 {
            for iy in 0..3 {
                let c = g
                    .view()
                    .cell_of(-5.0 + 0.1 * ix as f64 + 0.05, 0.35 + 0.1 * iy as f64);
                g.set(c, OCCUPIED_DETECTED);
            }
        }
        let fp = Footprint::new(0.508, 0.43);
        let straight = || Band {
            poses: (0..9)
                .map(|i| Pose2::new(0.5 * i as f64, 0.0, 0.0))
                .collect(),
            dts: vec![0.3; 8],
        };
        let mut band = straight();
        assert!(blocked(&band, &g.view(), &fp, 0.1));
        // Held to the wall's side, the run has no reachable clearing offset: it stays.
        assert_eq!(
            repair(&mut band, &g.view(), &fp, 0.1, Some(Side::Left), 3.0),
            None
        );
        assert_eq!(band.poses, straight().poses);
        // Free to choose, it moves away from the wall, a little.
        let mut band = straight();
        assert_eq!(
            repair(&mut band, &g.view(), &fp, 0.1, None, 3.0),
            Some(Side::Right)
        );
        assert!(band.poses[1..].iter().all(|p| (-0.2..0.0).contains(&p.y)));
    }
}

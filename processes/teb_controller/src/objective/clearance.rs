//! Obstacle clearance, penalised (L1) at `w_constraint`: margin (plus
//! `solver.clearance_allowance`, what the robot's tracking may lose) - clearance of the
//! footprint at every pose but the robot's and at points between poses (a stretched
//! segment would otherwise cut a corner unchecked). Points between poses lie on the arc
//! the robot drives (`feasibility::SegmentPath`), which the exit flag checks, not on
//! the chord: a converged band meets the margin exactly at its samples, and a turning
//! segment's arc bulges centimetres off its chord. The model takes the nearest cell in
//! each sector of every sample, linear in the pose step (a sample moving with its two
//! poses in proportion to where it lies between them), one slack per sample (the merit
//! charges a sample's worst cell). Between the robot and the next pose the kept
//! clearance is relaxed to what the robot itself has (`Kept`).

use aisle_geometry::Pose2;

use super::segment::{pc, slack_non_negative};
use super::{Problem, Tally};
use crate::band::{Band, chord};
use crate::clearance::{CellHit, min_clearance, nearest_per_sector};
use crate::feasibility::SegmentPath;
use crate::qp::{Qp, Row};
use crate::trust_region::TrustRegion;

const SAMPLE_SPACING: f64 = 0.3;
const MAX_INTERIOR_SAMPLES: usize = 6;

/// The clearance the optimiser keeps at each sample: the margin and the tracking
/// allowance, except between the robot and the next pose when the robot itself stands
/// closer: there a sample keeps what the robot has, relaxed towards the next pose in
/// proportion to its weight. (A sample near the robot moves with it: charging it the
/// full margin charges a shortfall no step can remove, and the subproblem, which
/// believes it can, spends the step on it.)
struct Kept {
    margin: f64,
    /// How far the robot's own clearance falls short of `margin`.
    robot_deficit: f64,
}

impl Kept {
    fn new(p: &Problem, band: &Band) -> Kept {
        let margin = p.margin + p.cfg.solver.clearance_allowance;
        let robot = min_clearance(p.map, &p.footprint, &band.poses[0], margin);
        Kept {
            margin,
            robot_deficit: (margin - robot).max(0.0),
        }
    }

    /// The kept clearance of a sample of segment `i` with weight `weight_prev` on
    /// pose `i - 1`.
    fn at(&self, i: usize, weight_prev: f64) -> f64 {
        if i == 1 {
            self.margin - weight_prev * self.robot_deficit
        } else {
            self.margin
        }
    }
}

/// Clearance samples strictly between two poses: one per started `SAMPLE_SPACING`,
/// at least one (the midpoint), at most `MAX_INTERIOR_SAMPLES`.
fn interior_samples(a: &Pose2, b: &Pose2) -> usize {
    let n = (chord(a, b) / SAMPLE_SPACING).ceil();
    if n.is_finite() {
        (n as usize).clamp(1, MAX_INTERIOR_SAMPLES)
    } else {
        1
    }
}

/// The samples of segment `i` (from pose `i - 1` to pose `i`), in order: pose `i`
/// itself, then the interior ones along the driven arc; each with the weight of pose
/// `i - 1` in it (0 at pose `i`, 1 - u at fraction u).
fn segment_samples(band: &Band, i: usize) -> impl Iterator<Item = (Pose2, f64)> {
    let (a, b) = (band.poses[i - 1], band.poses[i]);
    let n = interior_samples(&a, &b);
    let path = SegmentPath::new(&a, &b);
    (0..=n).map(move |j| {
        if j == 0 {
            (b, 0.0)
        } else {
            let u = j as f64 / (n + 1) as f64;
            (path.at(u), 1.0 - u)
        }
    })
}

/// Exact value: every sample's shortfall below the margin.
pub(super) fn merit(p: &Problem, band: &Band, t: &mut Tally) {
    let kept = Kept::new(p, band);
    for i in 1..band.poses.len() {
        for (q, weight_prev) in segment_samples(band, i) {
            let margin = kept.at(i, weight_prev);
            let g = (margin - min_clearance(p.map, &p.footprint, &q, margin)).max(0.0);
            t.sum += g;
            t.worst.clearance = t.worst.clearance.max(g);
        }
    }
}

/// The deepest sample of one segment below the kept clearance, for the second-order
/// correction (`correction.rs`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Shortfall {
    /// The sample's clearance less the kept clearance (negative).
    pub excess: f64,
    /// d clearance / d (x, y, theta) of the sample, to the nearest cell.
    pub grad: [f64; 3],
    /// The weight of the segment's first pose in the sample (0 at its last pose).
    pub weight_prev: f64,
}

/// For every segment k (poses k to k + 1), its deepest sample below the kept
/// clearance, if any: the same samples the merit charges.
pub(crate) fn shortfalls(p: &Problem, band: &Band, out: &mut Vec<Option<Shortfall>>) {
    let kept = Kept::new(p, band);
    let mut hits = [None; 4];
    out.clear();
    for i in 1..band.poses.len() {
        let mut deepest: Option<(f64, Pose2, f64)> = None;
        for (q, weight_prev) in segment_samples(band, i) {
            let margin = kept.at(i, weight_prev);
            let c = min_clearance(p.map, &p.footprint, &q, margin);
            if c < margin && deepest.is_none_or(|(d, _, _)| c - margin < d) {
                deepest = Some((c - margin, q, weight_prev));
            }
        }
        out.push(deepest.and_then(|(_, q, weight_prev)| {
            let margin = kept.at(i, weight_prev);
            nearest_per_sector(p.map, &p.footprint, &q, margin, &mut hits);
            let hit = hits
                .iter()
                .flatten()
                .min_by(|a, b| a.clearance.total_cmp(&b.clearance))?;
            Some(Shortfall {
                excess: hit.clearance - margin,
                grad: hit.grad,
                weight_prev,
            })
        }));
    }
}

/// The same samples in the step variables: margin - (c + g.d) <= slack for the nearest
/// cell of each sector, `hits` a reusable buffer.
pub(super) fn linearise(
    qp: &mut Qp,
    p: &Problem,
    band: &Band,
    region: &TrustRegion,
    hits: &mut [Option<CellHit>; 4],
) {
    let kept = Kept::new(p, band);
    let reach = kept.margin + p.cfg.solver.obstacle_influence + region.radius;
    for i in 1..band.poses.len() {
        for (pose, weight_prev) in segment_samples(band, i) {
            let margin = kept.at(i, weight_prev);
            nearest_per_sector(p.map, &p.footprint, &pose, reach, hits);
            // A cell the trust region cannot bring inside the margin gives a row
            // that is never active: leaving it out does not change the subproblem.
            for h in hits.iter_mut() {
                if let Some(hit) = h {
                    let change = (hit.grad[0].abs() + hit.grad[1].abs()) * region.radius
                        + hit.grad[2].abs() * region.heading;
                    if hit.clearance - change > margin {
                        *h = None;
                    }
                }
            }
            if hits.iter().all(|h| h.is_none()) {
                continue;
            }
            let s = qp.new_column(p.cfg.weights.constraint);
            for hit in hits.iter().flatten() {
                let mut r = Row::new();
                let own = 1.0 - weight_prev;
                for c in 0..3 {
                    r.add(pc(i, c), -own * hit.grad[c]);
                    r.add(pc(i - 1, c), -weight_prev * hit.grad[c]);
                }
                r.add(Some(s), -1.0);
                qp.leq(&r, hit.clearance - margin);
            }
            slack_non_negative(qp, s);
        }
    }
}

#[cfg(test)]
mod tests {
    use aisle_geometry::{Direction, Footprint, GridMap, OCCUPIED_DETECTED, PathPose, Pose2};

    use super::*;
    use crate::config::TebConfig;
    use crate::reference::{Reference, Section};

    /// Charges `band` beside a wall of cells filling y in [1.0, 1.2], x in [-2, 8].
    fn charged(band: &Band, margin: f64) -> f64 {
        let mut g = GridMap::new_free(-3.0, -3.0, 0.1, 12.0, 6.0).unwrap();
        for ix in 0..100 {
            for y in [1.05, 1.15] {
                let c = g.view().cell_of(-2.0 + 0.1 * ix as f64 + 0.05, y);
                g.set(c, OCCUPIED_DETECTED);
            }
        }
        let view = g.view();
        let cfg = TebConfig::default();
        let path = [0.0, 5.0].map(|x| PathPose::new(Pose2::new(x, 0.0, 0.0), Direction::Forward));
        let reference = Reference::new(path.to_vec());
        let p = Problem {
            cfg: &cfg,
            map: &view,
            footprint: Footprint::new(0.5, 0.4),
            margin,
            v0: 0.0,
            w0: 0.0,
            goal: Pose2::new(4.0, 0.0, 0.0),
            at_rest: false,
            direction: Direction::Forward,
            reference: &reference,
            section: Section {
                first: 0,
                last: 1,
                direction: Direction::Forward,
            },
            s_lo: 0.0,
            s_hi: 5.0,
        };
        let mut t = Tally::default();
        merit(&p, band, &mut t);
        t.sum
    }

    fn band(ys: &[f64]) -> Band {
        let mut b = Band::default();
        for (i, &y) in ys.iter().enumerate() {
            b.poses.push(Pose2::new(i as f64, y, 0.0));
        }
        b.dts.resize(ys.len() - 1, 1.0);
        b
    }

    #[test]
    fn a_robot_inside_its_margin_may_leave_it_but_not_go_deeper() {
        // The footprint's side at y + 0.2, the wall's discs reach down to about
        // 1.05 - 0.071: a robot at y = 0.35 keeps about 0.43 m, short of 0.5 + 0.02.
        let margin = 0.5;
        // Leaving the wall in a straight line from the robot: charged nothing.
        assert_eq!(charged(&band(&[0.35, 0.2, 0.2]), margin), 0.0);
        // The same band with the robot 0.15 m farther from the wall keeps the margin
        // from pose 1 on, as the band above does.
        assert_eq!(charged(&band(&[0.2, 0.2, 0.2]), margin), 0.0);
        // Along the wall at the robot's own clearance: its first segment is charged
        // the part of the robot's shortfall a sample at its place may no longer keep.
        let along = charged(&band(&[0.35, 0.35, 0.2]), margin);
        assert!(along > 0.0, "{along}");
        // Deeper than the robot: charged more.
        let deeper = charged(&band(&[0.35, 0.4, 0.2]), margin);
        assert!(deeper > along, "{deeper} vs {along}");
    }
}

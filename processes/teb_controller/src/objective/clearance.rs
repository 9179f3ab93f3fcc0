//! Obstacle clearance, penalised (L1) at `w_constraint`: margin (plus
//! `solver.clearance_allowance`, what the robot's tracking may lose) - clearance of the
//! footprint at every pose but the robot's and at points between poses (a stretched
//! segment would otherwise cut a corner unchecked). Points between poses lie on the arc
//! the robot drives (`feasibility::SegmentPath`), which the exit flag checks, not on
//! the chord: a converged band meets the margin exactly at its samples, and a turning
//! segment's arc bulges centimetres off its chord. The model takes the nearest cell in
//! each sector of every sample, linear in the pose step (a sample moving with its two
//! poses in proportion to where it lies between them), one slack per sample (the merit
//! charges a sample's worst cell).

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

/// The clearance the optimiser keeps: the margin and the tracking allowance.
fn kept(p: &Problem) -> f64 {
    p.margin + p.cfg.solver.clearance_allowance
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
    let margin = kept(p);
    for i in 1..band.poses.len() {
        for (q, _) in segment_samples(band, i) {
            let g = (margin - min_clearance(p.map, &p.footprint, &q, margin)).max(0.0);
            t.sum += g;
            t.worst.clearance = t.worst.clearance.max(g);
        }
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
    let margin = kept(p);
    let reach = margin + p.cfg.solver.obstacle_influence + region.radius;
    for i in 1..band.poses.len() {
        for (pose, weight_prev) in segment_samples(band, i) {
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

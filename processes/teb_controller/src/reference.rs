//! The reference path cut into sections of one drive direction, with projection and
//! interpolation by arc length.
//!
//! A section ends at a cusp (forward <-> reverse), at the start or end of an in-place
//! rotation, or at the path's end; the band never spans two sections, because the
//! robot must stop at each of those points. Knows nothing of obstacles or of time.

use aisle_geometry::{Direction, PathPose, Pose2, wrap_angle};

/// Poses `first..=last` of the path, driven in one direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Section {
    pub first: usize,
    pub last: usize,
    pub direction: Direction,
}

/// Closest point of a section to a query position.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Projection {
    /// Arc length from the path's start, m.
    pub s: f64,
    pub distance: f64,
    pub x: f64,
    pub y: f64,
    /// Unit tangent of the polyline there (zero on a degenerate section).
    pub tx: f64,
    pub ty: f64,
}

#[derive(Debug, Clone, Default)]
pub(crate) struct Reference {
    pub poses: Vec<PathPose>,
    /// Arc length at each pose, m.
    pub cum: Vec<f64>,
    pub sections: Vec<Section>,
}

impl Reference {
    /// Builds the sections. The direction of each step is read from the geometry (see
    /// [`step_direction`]), not from the labels: which pose of a step carries its label
    /// differs between producers, and a label one pose off once turned the last 0.1 m
    /// of a drive into a "rotation" the controller could not finish.
    pub fn new(poses: Vec<PathPose>) -> Reference {
        let mut cum = Vec::with_capacity(poses.len());
        let mut s = 0.0;
        for (j, p) in poses.iter().enumerate() {
            if j > 0 {
                s += poses[j - 1].pose.distance(&p.pose);
            }
            cum.push(s);
        }
        let mut sections = Vec::new();
        if poses.len() == 1 {
            sections.push(Section {
                first: 0,
                last: 0,
                direction: Direction::Forward,
            });
        }
        let steps: Vec<Direction> = poses
            .windows(2)
            .map(|w| step_direction(&w[0].pose, &w[1].pose))
            .collect();
        let mut j = 0;
        while j + 1 < poses.len() {
            let dir = steps[j];
            let mut k = j + 1;
            while k + 1 < poses.len() && steps[k] == dir {
                k += 1;
            }
            sections.push(Section {
                first: j,
                last: k,
                direction: dir,
            });
            j = k;
        }
        Reference {
            poses,
            cum,
            sections,
        }
    }

    /// End pose of a section.
    pub fn section_end(&self, sec: &Section) -> Pose2 {
        self.poses[sec.last].pose
    }

    /// Closest point of the section's polyline to (x, y), among segments that overlap
    /// the arc-length window [s_lo, s_hi] (so a path that loops back near itself does
    /// not make the robot jump ahead).
    pub fn project(&self, sec: &Section, x: f64, y: f64, s_lo: f64, s_hi: f64) -> Projection {
        let p0 = self.poses[sec.first].pose;
        let mut best = Projection {
            s: self.cum[sec.first],
            distance: (x - p0.x).hypot(y - p0.y),
            x: p0.x,
            y: p0.y,
            tx: 0.0,
            ty: 0.0,
        };
        let mut best_tangent_set = false;
        for j in sec.first..sec.last {
            if self.cum[j + 1] < s_lo || self.cum[j] > s_hi {
                continue;
            }
            let a = self.poses[j].pose;
            let b = self.poses[j + 1].pose;
            let (dx, dy) = (b.x - a.x, b.y - a.y);
            let len2 = dx * dx + dy * dy;
            let u = if len2 > 1e-18 {
                (((x - a.x) * dx + (y - a.y) * dy) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let (px, py) = (a.x + u * dx, a.y + u * dy);
            let d2 = (x - px) * (x - px) + (y - py) * (y - py);
            // Most segments are farther than the best so far: skip their roots (this
            // loop runs for every band pose in every merit evaluation).
            let bound = best.distance + 1e-9;
            if d2 > bound * bound {
                continue;
            }
            let d = d2.sqrt();
            let len = len2.sqrt();
            if d < best.distance - 1e-12 || (!best_tangent_set && d <= best.distance + 1e-12) {
                best = Projection {
                    s: self.cum[j] + u * len,
                    distance: d,
                    x: px,
                    y: py,
                    tx: if len > 1e-9 { dx / len } else { 0.0 },
                    ty: if len > 1e-9 { dy / len } else { 0.0 },
                };
                best_tangent_set = len > 1e-9;
            }
        }
        best
    }

    /// Pose at arc length `s` (clamped to the section), heading interpolated the short
    /// way round.
    pub fn sample(&self, sec: &Section, s: f64) -> Pose2 {
        let s = s.clamp(self.cum[sec.first], self.cum[sec.last]);
        let mut j = sec.first;
        while j < sec.last && self.cum[j + 1] < s {
            j += 1;
        }
        if j >= sec.last {
            return self.poses[sec.last].pose;
        }
        let a = self.poses[j].pose;
        let b = self.poses[j + 1].pose;
        let len = self.cum[j + 1] - self.cum[j];
        let u = if len > 1e-12 {
            (s - self.cum[j]) / len
        } else {
            1.0
        };
        Pose2::new(
            a.x + u * (b.x - a.x),
            a.y + u * (b.y - a.y),
            wrap_angle(a.theta + u * wrap_angle(b.theta - a.theta)),
        )
    }
}

/// Positions closer than this are one place: the step between them is a rotation.
const SAME_PLACE: f64 = 1e-6;

/// How a differential-drive robot moves from `a` to `b`: on the spot when the position
/// does not change, else forward or reverse by the side of `a`'s heading the chord
/// points to (a drive step turns by far less than 90 degrees).
pub(crate) fn step_direction(a: &Pose2, b: &Pose2) -> Direction {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    if dx.hypot(dy) < SAME_PLACE {
        Direction::Rotate
    } else if dx * a.theta.cos() + dy * a.theta.sin() < 0.0 {
        Direction::Reverse
    } else {
        Direction::Forward
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pp(x: f64, y: f64, t: f64, d: Direction) -> PathPose {
        PathPose::new(Pose2::new(x, y, t), d)
    }

    #[test]
    fn sections_split_at_cusps_and_rotations() {
        let r = Reference::new(vec![
            pp(0.0, 0.0, 0.0, Direction::Forward),
            pp(1.0, 0.0, 0.0, Direction::Forward),
            pp(2.0, 0.0, 0.0, Direction::Forward),
            pp(1.0, 0.0, 0.0, Direction::Reverse),
            pp(1.0, 0.0, 1.0, Direction::Rotate),
            pp(1.0, 0.0, 2.0, Direction::Rotate),
        ]);
        assert_eq!(r.sections.len(), 3);
        assert_eq!((r.sections[0].first, r.sections[0].last), (0, 2));
        assert_eq!(r.sections[1].direction, Direction::Reverse);
        assert_eq!((r.sections[2].first, r.sections[2].last), (3, 5));
        let p = r.project(&r.sections[0], 1.5, 0.3, 0.0, 10.0);
        assert!((p.s - 1.5).abs() < 1e-12 && (p.distance - 0.3).abs() < 1e-12);
        let q = r.sample(&r.sections[0], 0.25);
        assert!((q.x - 0.25).abs() < 1e-12);
    }

    /// The planner labels each pose with the motion that leaves it; the sections must
    /// be the same as with labels on the arriving pose, or with no labels at all.
    #[test]
    fn sections_do_not_depend_on_which_pose_carries_the_label() {
        let geometry = [
            (0.0, 0.0, 0.0),
            (0.1, 0.0, 0.0),
            (0.2, 0.0, 0.0),
            (0.2, 0.0, 0.5),
            (0.2, 0.0, 1.0),
            (0.2, -0.1, 1.0),
        ];
        // Leaving: forward, forward, rotate, rotate, reverse, (last repeats).
        let leaving = [
            Direction::Forward,
            Direction::Forward,
            Direction::Rotate,
            Direction::Rotate,
            Direction::Reverse,
            Direction::Reverse,
        ];
        let arriving = [
            Direction::Forward,
            Direction::Forward,
            Direction::Forward,
            Direction::Rotate,
            Direction::Rotate,
            Direction::Reverse,
        ];
        let build = |labels: &[Direction]| {
            Reference::new(
                geometry
                    .iter()
                    .zip(labels)
                    .map(|(&(x, y, t), &d)| pp(x, y, t, d))
                    .collect(),
            )
            .sections
        };
        let a = build(&leaving);
        assert_eq!(a, build(&arriving));
        assert_eq!(a, build(&[Direction::Forward; 6]));
        let spans: Vec<(usize, usize, Direction)> =
            a.iter().map(|s| (s.first, s.last, s.direction)).collect();
        assert_eq!(
            spans,
            [
                (0, 2, Direction::Forward),
                (2, 4, Direction::Rotate),
                (4, 5, Direction::Reverse)
            ]
        );
    }
}

//! Relief: the clearance a path keeps near a start or a goal that stands inside the
//! search's allowance.
//!
//! The controller keeps the margin as a soft cost, so a robot can stop a few millimetres
//! inside it (a detour around an obstacle found late). A request from there used to fail
//! at once (no motion from the start keeps the margin), and the mission then planned the
//! whole leg again with half the margin, which the band followed past everything met
//! later: a margin below what a sensor cannot see (the base of a pallet stack under a
//! level lidar) is a collision waiting to happen. Instead, motions that leave from within
//! `start_relief_radius` of the start keep at least the clearance the start has (to
//! 1 mm), and every other motion the full margin. A start with the full margin gets no
//! relief, so the rule changes nothing for it.
//!
//! The goal needs the same rule for another reason. A goal is accepted when the
//! footprint with the margin is free there (exactly), but the search holds every pose to
//! the margin plus the interpolation sagitta plus `sweep_cover` (3.2 cm with the shipped
//! settings): a goal accepted beside a wall with less than that to spare could not be
//! reached by any motion, and the search spent its whole expansion budget before it
//! failed. So motions that end (or leave from) within `start_relief_radius` of such a
//! goal keep the clearance the goal has, less the sagitta and a short reach (at worst
//! 7 mm below the margin, and only beside a goal that sits at the margin), checked with
//! the short reach; others keep the full margin. A goal the search can reach as it is
//! gets no relief.
//!
//! A start can also keep the margin and have no way out: boxed in, where every motion
//! (a turn on the spot too) comes closer to something. A search that fails without
//! closing a node beyond the relief radius is run once more (`both_ends.rs`) with the
//! start relieved to `boxed_in_margin` of the margin: the mission has no other way to
//! move a robot its controller stopped there.
//!
//! Knows footprints, the distance map and the checkers; nothing of search or requests.

use crate::collision::FootprintChecker;
use crate::distance_map::DistanceMap;
use crate::motion::Motion;
use aisle_geometry::{Footprint, Pose2};

/// Resolution (m) of the start's clearance: the bisection stops this close to it.
const MARGIN_TOLERANCE_M: f64 = 1e-3;

/// Reach (m) of one exact check near a relieved start. The search's usual reach
/// (`sweep_cover`, a few cm) is clearance its first check demands beyond the margin, so
/// it would take that much from what the start keeps; a short reach costs a few more
/// checks per motion, only within the relief.
const RELIEF_COVER_M: f64 = 0.005;

/// The sizes one request's checks are made of.
pub(crate) struct Sizes {
    pub footprint: Footprint,
    pub margin: f64,
    /// Extra clearance (m) the search keeps over the output (interpolation sagitta).
    pub sagitta: f64,
    /// Reach (m) of one exact check (`sweep_cover`).
    pub cover: f64,
    /// `start_relief_radius` (m); 0: no relief at the start, and at the goal only for
    /// the motions that end on it.
    pub radius: f64,
    /// The margin (m) motions leaving near a boxed-in start keep on its second search
    /// (`boxed_in_margin` of the margin); `None`: the first search.
    pub escape: Option<f64>,
}

/// What one request's search and output path are held to.
pub(crate) struct Checks<'a> {
    pub search: Clearance<'a>,
    pub output: Clearance<'a>,
    /// The margin kept near a start inside the full one; `None`: no relief.
    pub kept: Option<f64>,
}

/// The checks for a request from `start`: with the full margin when the search's first
/// check passes there (or relief is off), else relieved near the start to the margin it
/// has. `None` when the start is occupied: the output's margin fails without relief,
/// the bare footprint (with the sagitta and a short reach) fails with it.
pub(crate) fn checks<'a>(dm: &'a DistanceMap, s: &Sizes, start: &Pose2) -> Option<Checks<'a>> {
    let checker = |m: f64, cover: f64| FootprintChecker::new(dm, s.footprint.inflated(m), cover);
    let search = checker(s.margin + s.sagitta, s.cover);
    let output = checker(s.margin, s.cover);
    let escape = s.escape.map(|m| m.min(s.margin));
    if escape.is_none() && (s.radius <= 0.0 || search_reaches(dm, s, start)) {
        return output.pose_free(start).then(|| Checks {
            search: Clearance::full(search),
            output: Clearance::full(output),
            kept: None,
        });
    }
    let most = escape.unwrap_or(s.margin);
    let kept = start_margin(dm, s.footprint, most, s.sagitta + RELIEF_COVER_M, start)?;
    let near_search = checker(kept + s.sagitta, RELIEF_COVER_M);
    let near_output = checker(kept, RELIEF_COVER_M);
    Some(Checks {
        search: Clearance::with_relief(search, near_search, *start, s.radius, kept),
        output: Clearance::with_relief(output, near_output, *start, s.radius, kept),
        kept: Some(kept),
    })
}

/// Whether the search's first check (the margin, the sagitta and the full reach) passes
/// at `pose`: a start or goal where it does needs no relief.
fn search_reaches(dm: &DistanceMap, s: &Sizes, pose: &Pose2) -> bool {
    let grown = s.footprint.inflated(s.margin + s.sagitta + s.cover);
    FootprintChecker::new(dm, grown, s.cover).pose_free(pose)
}

/// What a goal the output's margin accepts (`Clearance::full_checker().pose_free`)
/// asks of the checks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum GoalRelief {
    /// The search reaches it with the full margin.
    None,
    /// Motions near it keep this margin (m).
    Kept(f64),
    /// Not even the bare footprint keeps the sagitta and the short reach there (only
    /// with a margin below them): no motion could be proven to reach it.
    Unreachable,
}

impl<'a> Checks<'a> {
    /// Relieves both checks near `goal` when the search's first check fails there:
    /// motions ending (or leaving) within the relief radius keep the margin the goal
    /// has (less the sagitta and the short reach), checked with the short reach.
    pub(crate) fn relieve_goal(
        &mut self,
        dm: &'a DistanceMap,
        s: &Sizes,
        goal: &Pose2,
    ) -> GoalRelief {
        if search_reaches(dm, s, goal) {
            return GoalRelief::None;
        }
        let extra = s.sagitta + RELIEF_COVER_M;
        let Some(kept) = start_margin(dm, s.footprint, s.margin, extra, goal) else {
            return GoalRelief::Unreachable;
        };
        let checker = |m: f64| FootprintChecker::new(dm, s.footprint.inflated(m), RELIEF_COVER_M);
        let relief = |checker| Relief {
            checker,
            centre: *goal,
            radius: s.radius,
            kept,
        };
        self.search.goal = Some(relief(checker(kept + s.sagitta)));
        self.output.goal = Some(relief(checker(kept)));
        GoalRelief::Kept(kept)
    }
}

/// The checks a path is held to: the full margin, except for motions that leave from
/// near a start standing inside it, or end (or leave) near a goal the search could not
/// reach with it.
pub(crate) struct Clearance<'a> {
    full: FootprintChecker<'a>,
    start: Option<Relief<'a>>,
    goal: Option<Relief<'a>>,
}

struct Relief<'a> {
    checker: FootprintChecker<'a>,
    centre: Pose2,
    radius: f64,
    /// The margin (m) `checker` keeps (before the sagitta).
    kept: f64,
}

impl Relief<'_> {
    /// Whether `p` is within a goal's relief; the 1 um tolerance takes in the end of a
    /// motion that lands on the goal (within round-off of it) when the radius is 0.
    #[inline]
    fn near(&self, p: &Pose2) -> bool {
        p.distance(&self.centre) <= self.radius + 1e-6
    }
}

impl<'a> Clearance<'a> {
    /// `full` alone: every motion keeps the full margin.
    pub(crate) fn full(full: FootprintChecker<'a>) -> Self {
        Self {
            full,
            start: None,
            goal: None,
        }
    }

    /// `full`, and `relief` (which keeps `kept`) for motions leaving within `radius`
    /// of `start`.
    pub(crate) fn with_relief(
        full: FootprintChecker<'a>,
        relief: FootprintChecker<'a>,
        start: Pose2,
        radius: f64,
        kept: f64,
    ) -> Self {
        let relief = Relief {
            checker: relief,
            centre: start,
            radius,
            kept,
        };
        Self {
            full,
            start: Some(relief),
            goal: None,
        }
    }

    /// The checker `motion` from `from` is held to: a relief's where one applies (the
    /// laxer where both do), else the full margin's.
    #[inline]
    fn for_motion(&self, from: &Pose2, motion: &Motion) -> &FootprintChecker<'a> {
        let start = self
            .start
            .as_ref()
            .filter(|r| from.distance(&r.centre) <= r.radius);
        // The end is computed only beside a relieved goal.
        let goal = self
            .goal
            .as_ref()
            .filter(|r| r.near(from) || r.near(&motion.end(from)));
        match (start, goal) {
            (Some(s), Some(g)) if g.kept < s.kept => &g.checker,
            (Some(r), _) | (None, Some(r)) => &r.checker,
            (None, None) => &self.full,
        }
    }

    /// Whether `motion` from `from` is free under the check that applies to it.
    #[inline]
    pub(crate) fn motion_free(&self, from: &Pose2, motion: &Motion, probes: &mut u64) -> bool {
        self.for_motion(from, motion)
            .motion_free(from, motion, probes)
    }

    /// Whether the footprint is free at `p` (exactly, no reach) under the margin that
    /// `motion` from `from`, which passes `p`, is held to.
    pub(crate) fn pose_free_on(&self, from: &Pose2, motion: &Motion, p: &Pose2) -> bool {
        self.for_motion(from, motion).pose_free(p)
    }

    /// Whether the start stands inside the full margin (its motions keep the clearance
    /// it has).
    pub(crate) fn start_relieved(&self) -> bool {
        self.start.is_some()
    }

    /// The full-margin checker (its circumscribed radius sizes rotation steps).
    pub(crate) fn full_checker(&self) -> &FootprintChecker<'a> {
        &self.full
    }
}

/// The largest margin in `[0, margin]` (to 1 mm, rounded down) at which `footprint`,
/// grown by it and by `extra`, is free at `start`; `None` when it is not free even at 0.
fn start_margin(
    dm: &DistanceMap,
    footprint: Footprint,
    margin: f64,
    extra: f64,
    start: &Pose2,
) -> Option<f64> {
    // `pose_free` is exact: the checker's own cover plays no part in it.
    let free_at = |m: f64| {
        FootprintChecker::new(dm, footprint.inflated(m + extra), MARGIN_TOLERANCE_M)
            .pose_free(start)
    };
    if free_at(margin) {
        return Some(margin);
    }
    if !free_at(0.0) {
        return None;
    }
    // Invariant: free at `lo`, not at `hi`.
    let (mut lo, mut hi) = (0.0, margin);
    while hi - lo > MARGIN_TOLERANCE_M {
        let mid = 0.5 * (lo + hi);
        if free_at(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(lo)
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::{CellIndex, GridMap, OCCUPIED_STATIC};

    /// A 4 x 3 m map of 0.05 m cells with one occupied column of cells at x = 2.0-2.05.
    fn wall_map() -> DistanceMap {
        let mut g = GridMap::new_free(0.0, 0.0, 0.05, 4.0, 3.0).unwrap();
        for iy in 0..60 {
            g.set(CellIndex { ix: 40, iy }, OCCUPIED_STATIC);
        }
        let mut dm = DistanceMap::default();
        dm.ensure(&g.view());
        dm
    }

    #[test]
    fn the_start_margin_is_the_gap_to_the_wall_to_a_millimetre() {
        let dm = wall_map();
        let fp = Footprint::new(0.5, 0.4);
        // Front edge at x = 1.5 + 0.25 = 1.75: 0.25 m from the wall's face at 2.0.
        let start = Pose2::new(1.5, 1.5, 0.0);
        let m = start_margin(&dm, fp, 0.4, 0.0, &start).unwrap();
        assert!((0.248..0.25).contains(&m), "{m}");
        // With the full margin free there is nothing to relieve.
        assert_eq!(start_margin(&dm, fp, 0.1, 0.0, &start), Some(0.1));
        // A footprint over the wall is not free at any margin.
        let on_wall = Pose2::new(1.9, 1.5, 0.0);
        assert_eq!(start_margin(&dm, fp, 0.1, 0.0, &on_wall), None);
    }
}

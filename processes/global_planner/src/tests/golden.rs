//! Golden digest of the planner's outputs: every pose of every returned path (f64 bits),
//! its directions, and every counter and cost of [`PlanStats`], on success and on
//! failure, folded into a 64-bit FNV-1a hash per case.
//!
//! The constants were recorded on the code before `plan_with_stop` was split into named
//! phases (two re-recorded when the output sweep stopped re-checking the stretches the
//! smoothing had checked, six when it stopped sweeping the traced ones: their digests
//! without `collision_probes` were unchanged); a
//! mismatch means a floating-point operation moved or changed, or the search
//! took another turn, and the per-case digests printed on failure say where.

use super::{BUDGET, hard_request, request};
use crate::seed_map::{self, RACK, RACK_MARGIN, ROBOT, ROBOT_MARGIN, Rect, rasterise};
use crate::{Plan, PlanError, PlanRequest, Planner, PlannerConfig};
use aisle_geometry::{Direction, GridMap, GridView, Pose2};
use std::f64::consts::{FRAC_PI_2, PI};

/// 64-bit FNV-1a over the bytes of the values folded in.
struct Fnv(u64);

impl Fnv {
    fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    fn u64(&mut self, v: u64) {
        for b in v.to_le_bytes() {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    fn f64(&mut self, v: f64) {
        self.u64(v.to_bits());
    }

    fn outcome(&mut self, r: &Result<Plan, PlanError>) {
        let stats = match r {
            Ok(plan) => {
                self.u64(0);
                self.u64(plan.path.len() as u64);
                for p in &plan.path {
                    self.f64(p.pose.x);
                    self.f64(p.pose.y);
                    self.f64(p.pose.theta);
                    self.u64(match p.direction {
                        Direction::Forward => 1,
                        Direction::Reverse => 2,
                        Direction::Rotate => 3,
                    });
                }
                plan.stats
            }
            Err(e) => {
                self.u64(1);
                // The kind's text names it (and an invalid input's reason).
                for b in e.kind.to_string().bytes() {
                    self.u64(u64::from(b));
                }
                e.stats
            }
        };
        self.u64(u64::from(stats.expansions));
        self.u64(u64::from(stats.nodes));
        self.u64(u64::from(stats.analytic_checks));
        self.u64(stats.collision_probes);
        self.u64(u64::from(stats.heuristic_cells));
        self.u64(u64::from(stats.map_rebuilt));
        self.f64(stats.path_length);
        self.f64(stats.path_cost);
        self.u64(u64::from(stats.smoothed));
    }
}

fn digest(planner: &mut Planner, map: &GridView, reqs: &[PlanRequest]) -> u64 {
    let mut h = Fnv::new();
    for r in reqs {
        h.outcome(&planner.plan(r, map));
    }
    h.0
}

/// The seed legs on one warm planner (map tables reused from leg to leg, as in the node).
fn seed_legs(cfg: PlannerConfig, cpm: f64) -> u64 {
    let map = seed_map::seed_map(cpm);
    let mut planner = Planner::new(cfg).unwrap();
    let reqs: Vec<_> = seed_map::seed_segments().iter().map(request).collect();
    // Twice: the second round runs on stale buffers.
    let mut h = Fnv::new();
    h.u64(digest(&mut planner, &map.view(), &reqs));
    h.u64(digest(&mut planner, &map.view(), &reqs));
    h.0
}

fn hard_and_rack(cfg: PlannerConfig) -> u64 {
    let map = seed_map::seed_map(10.0);
    let mut planner = Planner::new(cfg).unwrap();
    let rack = PlanRequest {
        start: Pose2::new(2.0, 13.0, -FRAC_PI_2),
        goal: Pose2::new(-0.5, 15.0, FRAC_PI_2),
        footprint: RACK,
        margin: RACK_MARGIN,
        max_expansions: BUDGET,
        fixed_budget: false,
    };
    digest(&mut planner, &map.view(), &[hard_request(), rack])
}

fn tight_corridor(allow_rotation: bool) -> u64 {
    let mut map = GridMap::new_free(0.0, 0.0, 0.05, 8.0, 4.0).unwrap();
    rasterise(
        &mut map,
        &[
            Rect::new(0.0, 0.0, 8.0, 1.5),
            Rect::new(0.0, 2.6, 8.0, 4.0),
            Rect::new(0.0, 0.0, 0.5, 4.0),
            Rect::new(7.5, 0.0, 8.0, 4.0),
        ],
    );
    let mut planner = Planner::new(PlannerConfig {
        allow_rotation,
        ..Default::default()
    })
    .unwrap();
    let req = PlanRequest {
        start: Pose2::new(2.0, 2.05, 0.0),
        goal: Pose2::new(5.0, 2.05, PI),
        footprint: ROBOT,
        margin: ROBOT_MARGIN,
        max_expansions: 20_000,
        fixed_budget: false,
    };
    digest(&mut planner, &map.view(), &[req])
}

/// Failures: a too-narrow door (budget and no path), occupied ends, the stop callback.
fn failures() -> u64 {
    let mut map = seed_map::seed_map(20.0);
    rasterise(
        &mut map,
        &[
            Rect::new(-1.1, 3.9, 1.1, 4.0),
            Rect::new(-1.1, 6.0, 1.1, 6.1),
            Rect::new(-1.1, 3.9, -1.0, 6.1),
            Rect::new(1.0, 3.9, 1.1, 4.675),
            Rect::new(1.0, 5.325, 1.1, 6.1),
        ],
    );
    let mut planner = Planner::new(PlannerConfig {
        stop_check_interval: 64,
        ..Default::default()
    })
    .unwrap();
    let inside = Pose2::new(0.0, 5.0, 0.0);
    let outside = Pose2::new(0.0, 0.0, 0.0);
    let base = PlanRequest {
        start: inside,
        goal: outside,
        footprint: ROBOT,
        margin: ROBOT_MARGIN,
        max_expansions: BUDGET,
        fixed_budget: false,
    };
    let reqs = [
        base,
        PlanRequest {
            start: outside,
            goal: inside,
            max_expansions: 5_000,
            fixed_budget: false,
            ..base
        },
        PlanRequest {
            start: Pose2::new(5.0, 12.0, 0.0),
            ..base
        },
        PlanRequest {
            goal: Pose2::new(5.0, 12.0, 0.0),
            ..base
        },
        PlanRequest {
            max_expansions: 0,
            fixed_budget: false,
            ..base
        },
    ];
    let mut h = Fnv::new();
    h.u64(digest(&mut planner, &map.view(), &reqs));
    let mut asked = 0u64;
    let r = planner.plan_with_stop(&hard_request(), &map.view(), &mut || {
        asked += 1;
        asked == 3
    });
    h.outcome(&r);
    h.u64(asked);
    h.0
}

fn digests() -> Vec<(&'static str, u64)> {
    let no_smoothing = PlannerConfig {
        smoothing: false,
        ..Default::default()
    };
    let no_rotation = PlannerConfig {
        allow_rotation: false,
        ..Default::default()
    };
    let start_only = PlannerConfig {
        goal_end_after: 0,
        ..Default::default()
    };
    vec![
        ("seed_legs_10", seed_legs(PlannerConfig::default(), 10.0)),
        ("seed_legs_20", seed_legs(PlannerConfig::default(), 20.0)),
        ("seed_legs_20_raw", seed_legs(no_smoothing, 20.0)),
        ("seed_legs_10_no_rotation", seed_legs(no_rotation, 10.0)),
        ("hard_and_rack", hard_and_rack(start_only)),
        (
            "hard_and_rack_both_ends",
            hard_and_rack(PlannerConfig::default()),
        ),
        ("tight_corridor", tight_corridor(true)),
        ("tight_corridor_no_rotation", tight_corridor(false)),
        ("failures", failures()),
    ]
}

/// Recorded when every map's tables became lazy (`Planner::eager_small_maps` off): the
/// paths and every counter but `heuristic_cells` are the eager reference's (with that
/// counter left out of the digest, both give the same eight digests; with it, the eager
/// reference gives the previous constants). Those were recorded when the default search
/// became weighted (`heuristic_weight` 1.05; with weight 1 the code gave the constants
/// before, recorded when the heuristic's blocked test became exact), six of them again
/// when the output check stopped sweeping the traced stretches again (their digests
/// without `collision_probes` were unchanged). `hard_and_rack` is the search from the
/// start alone (`goal_end_after = 0`) since requests could be searched from the goal's
/// end too (`both_ends.rs`), which changes only the hard request (over 4,096 expansions
/// from its start): `hard_and_rack_both_ends`.
const RECORDED: &[(&str, u64)] = &[
    ("seed_legs_10", 0x8dc3c76a3bdc0dad),
    ("seed_legs_20", 0x87d7f3bdbc63fd9b),
    ("seed_legs_20_raw", 0x87d7f3bdbc63fd9b),
    ("seed_legs_10_no_rotation", 0x60c42084fd0e5d45),
    ("hard_and_rack", 0xa68653b2095e63f5),
    ("hard_and_rack_both_ends", 0x75625c0e628be213),
    ("tight_corridor", 0x4c3d8765677473d5),
    ("tight_corridor_no_rotation", 0x104559dfc34e620b),
    ("failures", 0x291b381d9eb5dcd9),
];

#[test]
fn outputs_are_bit_identical_to_the_recorded_digest() {
    let got = digests();
    for (name, v) in &got {
        println!("    (\"{name}\", 0x{v:016x}),");
    }
    assert_eq!(got, RECORDED, "digests changed (printed above as Rust)");
}

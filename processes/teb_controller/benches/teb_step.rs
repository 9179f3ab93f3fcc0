//! One controller step in the three situations of the issue: a free corridor, an unseen
//! pallet straight ahead, and carrying the rack (0.88 x 0.8 m, margin 0.4 m) through a
//! 2.5 m aisle. Target: p50 <= 2 ms, p99 <= 5 ms on one core.
//!
//! "warm" is the node's steady state: the band of the previous period (restored from a
//! snapshot taken after two closed-loop periods) and the robot where that band said it
//! would be 0.5 s later. "cold" is the first step of a goal (band built from scratch).
//! Besides criterion's figures, the p50 / p99 over a fixed number of steps, the SCP
//! iterations and the largest constraint violation are printed, and the subproblems of
//! every step of a 16-period closed loop. A fourth, informative case follows a 3 m
//! radius curve (no target; the linearised kinematics used to reject most steps there).
//! Last, a straight docking step (goal mode Straight, no optimiser): from 0.15 m off the
//! line and 0.15 rad off its heading into the gap between a rack's four legs.
//! The `mission/*` cases are the seed mission's slowest steps (`benches/cases/
//! seed_worst.mcap`, exported from a lockstep record by `examples/export_steps.rs`), each
//! replayed from the exact state the mission had; target p99 <= 5 ms each.

use aisle_geometry::{
    CellIndex, Direction, Footprint, GridMap, OCCUPIED_DETECTED, PathPose, Pose2,
};
use aisle_teb_controller::{Goal, Mode, Snapshot, StepOutput, TebConfig, TebController};
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

#[path = "support/step_cases.rs"]
mod step_cases;
use aisle_teb_controller::case::{RecordedStep, reproduces};
use step_cases::AlignedStep;

const RES: f64 = 0.1;
const PERIOD: f64 = 0.5;

struct Situation {
    name: &'static str,
    footprint: Footprint,
    margin: f64,
    boxes: Vec<[f64; 4]>,
    homotopy: bool,
    /// Radius of the reference arc, m (infinite: the straight line y = 0).
    radius: f64,
}

fn situations() -> Vec<Situation> {
    let walls = |half: f64| {
        vec![
            [-10.0, half, 30.0, half + 0.3],
            [-10.0, -half - 0.3, 30.0, -half],
        ]
    };
    let mut pallet = walls(1.5);
    pallet.push([3.5, -0.5, 4.7, 0.3]);
    vec![
        Situation {
            name: "free_corridor",
            footprint: Footprint::new(0.508, 0.43),
            margin: 0.1,
            boxes: walls(1.5),
            homotopy: false,
            radius: f64::INFINITY,
        },
        Situation {
            name: "pallet_ahead",
            footprint: Footprint::new(0.508, 0.43),
            margin: 0.1,
            boxes: pallet.clone(),
            homotopy: false,
            radius: f64::INFINITY,
        },
        Situation {
            name: "pallet_ahead_homotopy",
            footprint: Footprint::new(0.508, 0.43),
            margin: 0.1,
            boxes: pallet,
            homotopy: true,
            radius: f64::INFINITY,
        },
        Situation {
            name: "rack_2.5m_aisle",
            footprint: Footprint::new(0.88, 0.8),
            margin: 0.4,
            boxes: walls(1.25),
            homotopy: false,
            radius: f64::INFINITY,
        },
        // Not a target case: a free 3 m-radius curve, where the linearised kinematics
        // used to reject most steps.
        Situation {
            name: "curve_r3",
            footprint: Footprint::new(0.508, 0.43),
            margin: 0.1,
            boxes: Vec::new(),
            homotopy: false,
            radius: 3.0,
        },
    ]
}

/// The node's local map: 15 x 15 m at 10 cells/m centred on the robot.
fn local_map(robot: &Pose2, boxes: &[[f64; 4]]) -> GridMap {
    let ox = ((robot.x - 7.5) / RES).round() * RES;
    let oy = ((robot.y - 7.5) / RES).round() * RES;
    let mut g = GridMap::new_free(ox, oy, RES, 15.0, 15.0).expect("valid grid");
    for b in boxes {
        let lo = g.view().cell_of(b[0], b[1]);
        let hi = g.view().cell_of(b[2], b[3]);
        for iy in lo.iy..=hi.iy {
            for ix in lo.ix..=hi.ix {
                let c = CellIndex { ix, iy };
                if g.view().contains_cell(c) {
                    let (cx, cy) = g.view().cell_center(c);
                    if cx >= b[0] && cx <= b[2] && cy >= b[1] && cy <= b[3] {
                        g.set(c, OCCUPIED_DETECTED);
                    }
                }
            }
        }
    }
    g
}

fn goal(s: &Situation) -> Goal {
    let along = |d: f64| {
        if s.radius.is_finite() {
            // Left turn from the origin, heading +x, centre (0, r).
            let a = d / s.radius;
            Pose2::new(s.radius * a.sin(), s.radius * (1.0 - a.cos()), a)
        } else {
            Pose2::new(d, 0.0, 0.0)
        }
    };
    Goal {
        // 20 m straight, or three quarters of a circle.
        reference: (0..=200)
            .map(|i| 0.1 * i as f64)
            .take_while(|&d| d <= 1.5 * std::f64::consts::PI * s.radius)
            .map(|d| PathPose::new(along(d), Direction::Forward))
            .collect(),
        footprint: s.footprint,
        margin: s.margin,
        mode: Mode::Follow,
        tolerance: None,
    }
}

/// Where the output says the robot is `dt` after its start (linear between poses).
fn predicted(out: &StepOutput, dt: f64) -> (Pose2, f64) {
    let t = out.t0 + dt;
    let k = out
        .poses
        .partition_point(|p| p.t <= t)
        .clamp(1, out.poses.len() - 1);
    let (a, b) = (out.poses[k - 1], out.poses[k]);
    let u = ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0);
    let p = Pose2::new(
        a.pose.x + u * (b.pose.x - a.pose.x),
        a.pose.y + u * (b.pose.y - a.pose.y),
        a.pose.theta + u * aisle_geometry::wrap_angle(b.pose.theta - a.pose.theta),
    );
    (p, out.command_at(t).0)
}

fn config(s: &Situation) -> TebConfig {
    let mut cfg = TebConfig::default();
    cfg.homotopy.enabled = s.homotopy;
    cfg
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    sorted[((sorted.len() as f64 - 1.0) * q).round() as usize]
}

fn steps(c: &mut Criterion) {
    let mut group = c.benchmark_group("teb_step");
    for s in situations() {
        let g = goal(&s);
        let start = Pose2::new(0.0, 0.0, 0.0);
        let start_map = local_map(&start, &s.boxes);
        // Two closed-loop periods, then the warm state.
        let mut teb = TebController::new(config(&s)).expect("valid config");
        teb.set_goal(&g).expect("valid goal");
        let (mut pose, mut v, mut t) = (start, 0.0, 0.0);
        for _ in 0..2 {
            let out = teb
                .step(pose, (v, 0.0), t, &local_map(&pose, &s.boxes).view())
                .expect("step");
            (pose, v) = predicted(out, PERIOD);
            t += PERIOD;
        }
        let snap: Snapshot = teb.snapshot();
        let map = local_map(&pose, &s.boxes);
        let view = map.view();

        let out = {
            teb.restore(&snap).expect("restore");
            teb.step(pose, (v, 0.0), t, &view).expect("step").clone()
        };
        let cold = {
            let mut fresh = TebController::new(config(&s)).expect("valid config");
            fresh.set_goal(&g).expect("valid goal");
            fresh
                .step(start, (0.0, 0.0), 0.0, &start_map.view())
                .expect("step")
                .clone()
        };
        println!(
            "{}: warm: flag {}, {} poses, {} iterations, max violation {:.2e}, cost {:.3}; \
             cold: flag {}, {} iterations, max violation {:.2e}",
            s.name,
            out.exit_flag.code(),
            out.poses.len(),
            out.iterations,
            out.max_violation,
            out.cost,
            cold.exit_flag.code(),
            cold.iterations,
            cold.max_violation
        );
        // Percentiles over a fixed number of identical warm steps.
        let mut times = Vec::with_capacity(300);
        for _ in 0..300 {
            teb.restore(&snap).expect("restore");
            let t0 = Instant::now();
            black_box(teb.step(pose, (v, 0.0), t, &view).expect("step").exit_flag);
            times.push(t0.elapsed().as_secs_f64() * 1e3);
        }
        times.sort_by(f64::total_cmp);
        println!(
            "{}: warm step p50 {:.3} ms, p99 {:.3} ms (300 steps)",
            s.name,
            percentile(&times, 0.5),
            percentile(&times, 0.99)
        );

        // A closed loop of 16 periods (the robot exactly where each band says it is
        // half a second later): subproblems per step and step times.
        let mut looped = TebController::new(config(&s)).expect("valid config");
        looped.set_goal(&g).expect("valid goal");
        let (mut lp, mut lv, mut lt) = (start, 0.0, 0.0);
        let mut iters = Vec::new();
        let mut loop_times = Vec::new();
        for _ in 0..16 {
            let m = local_map(&lp, &s.boxes);
            let t0 = Instant::now();
            let out = looped.step(lp, (lv, 0.0), lt, &m.view()).expect("step");
            loop_times.push(t0.elapsed().as_secs_f64() * 1e3);
            iters.push(out.iterations);
            if out.reached_goal || out.poses.len() < 2 {
                break;
            }
            (lp, lv) = predicted(out, PERIOD);
            lt += PERIOD;
        }
        loop_times.sort_by(f64::total_cmp);
        println!(
            "{}: closed loop {} steps, subproblems {:?} (mean {:.2}), step p50 {:.3} ms, max {:.3} ms",
            s.name,
            iters.len(),
            iters,
            iters.iter().sum::<usize>() as f64 / iters.len() as f64,
            percentile(&loop_times, 0.5),
            percentile(&loop_times, 1.0)
        );

        group.bench_function(format!("warm/{}", s.name), |b| {
            b.iter(|| {
                teb.restore(&snap).expect("restore");
                black_box(teb.step(pose, (v, 0.0), t, &view).expect("step").exit_flag)
            })
        });
        let mut fresh = TebController::new(config(&s)).expect("valid config");
        group.bench_function(format!("cold/{}", s.name), |b| {
            b.iter(|| {
                fresh.clear_goal();
                fresh.set_goal(&g).expect("valid goal");
                black_box(
                    fresh
                        .step(start, (0.0, 0.0), 0.0, &start_map.view())
                        .expect("step")
                        .exit_flag,
                )
            })
        });
    }
    group.finish();
}

/// One docking step: the rollout and its footprint sweep against four leg cells.
fn docking(c: &mut Criterion) {
    let centre = Pose2::new(3.0, 1.0, 0.0);
    let start = Pose2::new(1.5, 1.15, 0.15);
    let mut map = local_map(&start, &[]);
    for (sx, sy) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
        let (x, y) = (centre.x + sx * 0.415, centre.y + sy * 0.375);
        // Every cell the 0.05 m leg touches.
        for (dx, dy) in [
            (-0.025, -0.025),
            (0.0249, -0.025),
            (-0.025, 0.0249),
            (0.0249, 0.0249),
        ] {
            let cell = map.view().cell_of(x + dx, y + dy);
            map.set(cell, OCCUPIED_DETECTED);
        }
    }
    let goal = Goal {
        reference: Vec::new(),
        footprint: Footprint::new(0.508, 0.43),
        margin: 0.1,
        mode: Mode::Straight { target: centre },
        tolerance: Some([0.02, 0.02, 0.02]),
    };
    let mut teb = TebController::new(TebConfig::default()).expect("valid config");
    teb.set_goal(&goal).expect("valid goal");
    let view = map.view();
    let out = teb.step(start, (0.0, 0.0), 0.0, &view).expect("step");
    println!(
        "docking: flag {}, {} commands, {} poses",
        out.exit_flag.code(),
        out.commands.len(),
        out.poses.len()
    );
    let mut times = Vec::with_capacity(300);
    for _ in 0..300 {
        let t0 = Instant::now();
        black_box(
            teb.step(start, (0.0, 0.0), 0.0, &view)
                .expect("step")
                .exit_flag,
        );
        times.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "docking: step p50 {:.3} ms, p99 {:.3} ms (300 steps)",
        percentile(&times, 0.5),
        percentile(&times, 0.99)
    );
    c.bench_function("teb_step/straight/docking", |b| {
        b.iter(|| {
            black_box(
                teb.step(start, (0.0, 0.0), 0.0, &view)
                    .expect("step")
                    .exit_flag,
            )
        })
    });
}

/// Times `step` from its recorded state `n` times; sorted times in ms.
fn replay_times(step: &mut RecordedStep, n: usize) -> Vec<f64> {
    let mut times: Vec<f64> = (0..n)
        .map(|_| {
            step.reset().expect("reset");
            let t0 = Instant::now();
            black_box(step.step().expect("step").exit_flag);
            t0.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times
}

/// The mission's worst steps, replayed from the state the mission had, under the
/// seed's `config/teb.toml`.
fn mission(c: &mut Criterion) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let cfg: TebConfig =
        aisle_config::load(&dir.join("../../config/teb.toml")).expect("config/teb.toml");
    let cases = dir.join("benches/cases/seed_worst.mcap");
    let steps = step_cases::steps_in(&cases).expect("the exported steps");
    let mut group = c.benchmark_group("teb_step/mission");
    let mut all = Vec::new();
    for s in &steps {
        let aligned = AlignedStep::of(s);
        let inputs = aligned.inputs().expect("step messages");
        let mut step = RecordedStep::new(cfg.clone(), &inputs).expect("a step");
        let name = format!("t{:.1}s", s.trajectory.publish_time as f64 * 1e-9);
        let warm = step.warm_poses();
        let out = step.step().expect("step");
        let recorded = aligned.trajectory().expect("trajectory");
        println!(
            "mission {name}: {} poses ({} warm), {} iterations (recorded {}, {:.2} ms), \
             flag {}, {}",
            out.poses.len(),
            warm,
            out.iterations,
            recorded.iterations,
            recorded.solve_ns as f64 * 1e-6,
            out.exit_flag.code(),
            if reproduces(out, recorded) {
                "the recorded step bit for bit"
            } else {
                "differs from the recorded step (an older build's record)"
            }
        );
        if let Some((cost, converged)) =
            step_cases::converged_cost(&cfg, &inputs).expect("converged step")
        {
            println!(
                "mission {name}: cost {cost:.4}, run on to convergence {converged:.4} ({:+.2} %)",
                100.0 * (cost / converged - 1.0)
            );
        }
        let times = replay_times(&mut step, 100);
        println!(
            "mission {name}: p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms (100 steps)",
            percentile(&times, 0.5),
            percentile(&times, 0.99),
            percentile(&times, 1.0)
        );
        all.extend(times);
        group.bench_function(name, |b| {
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    step.reset().expect("reset");
                    let t0 = Instant::now();
                    black_box(step.step().expect("step").exit_flag);
                    total += t0.elapsed();
                }
                total
            })
        });
    }
    all.sort_by(f64::total_cmp);
    println!(
        "mission: {} worst steps together: p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms",
        steps.len(),
        percentile(&all, 0.5),
        percentile(&all, 0.99),
        percentile(&all, 1.0)
    );
    group.finish();
}

criterion_group!(benches, steps, docking, mission);
criterion_main!(benches);

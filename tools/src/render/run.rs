//! What a top view shows, read from a record: the final global map, the static bodies,
//! every movable body's poses over time (with when it was carried), the mission's legs by
//! name (from `MissionStatus`), the driven path by leg, the turns in place, the reference
//! paths and sampled bands, and the run's seed and outcome.
//!
//! Knows the message layouts and the scene file (for the kind of each body); not how any
//! of it is drawn.

use super::RenderOptions;
use crate::reader::RecordFile;
use aisle_geometry::GridView;
use aisle_messages::topics::names as s;
use aisle_messages::{
    BodyTruth, ControllerBand, ControllerGoal, GlobalGrid, GlobalMapCopy, GridCopy, GridMessage,
    MAX_BODIES, MAX_COMMANDS, MAX_PATH_POSES, MapChanges, MissionState, MissionStatus, RobotState,
    WorldTruth, read_name,
};
use std::path::Path;

/// What a movable body is, for its colour and its legend entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BodyKind {
    /// A pallet rack: the robot drives under it and may carry it.
    Rack,
    /// Anything else movable: pallets, box stacks, loose boxes. Not on the map; only the
    /// lidar finds them.
    Unseen,
}

/// One pose of a body from a given time on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyPose {
    pub t: f64,
    pub x: f64,
    pub y: f64,
    pub theta: f64,
    pub carried: bool,
}

/// A movable body and its poses over the run (a new entry only when the pose or the
/// carried flag changed).
#[derive(Debug, Clone, PartialEq)]
pub struct MovableBody {
    pub name: String,
    pub kind: BodyKind,
    pub length: f64,
    pub width: f64,
    pub poses: Vec<BodyPose>,
}

impl MovableBody {
    /// Where the body was at time `t` (its first pose before the first record).
    pub fn pose_at(&self, t: f64) -> Option<BodyPose> {
        let i = self.poses.partition_point(|p| p.t <= t);
        self.poses.get(i.saturating_sub(1)).copied()
    }

    /// When the body was last set down (carried, then not), if it ever was.
    pub fn dropped_at(&self) -> Option<f64> {
        self.poses
            .windows(2)
            .filter(|w| w[0].carried && !w[1].carried)
            .map(|w| w[1].t)
            .next_back()
    }

    pub fn moved(&self) -> bool {
        self.poses.len() > 1
    }
}

/// A static body's rectangle: x, y, theta, length, width.
pub type StaticBox = [f64; 5];

/// One pose of the robot: time, x, y, heading and the leg it belongs to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Driven {
    pub t: f64,
    pub x: f64,
    pub y: f64,
    pub theta: f64,
    pub leg: usize,
}

/// A turn in place: where, from which heading to which, in which leg.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Turn {
    pub leg: usize,
    pub x: f64,
    pub y: f64,
    pub from: f64,
    /// The heading at the end, unwrapped from `from` (so the sign is the direction).
    pub to: f64,
}

/// Everything read from one record.
#[derive(Default)]
pub struct Run {
    /// The global map at the end (a valid grid).
    pub map: Option<GridCopy>,
    pub statics: Vec<StaticBox>,
    pub movables: Vec<MovableBody>,
    /// Leg names by index (from `MissionStatus.text` while the leg ran; "leg N" when
    /// a leg left no name).
    pub legs: Vec<String>,
    pub driven: Vec<Driven>,
    pub turns: Vec<Turn>,
    pub references: Vec<Vec<(f64, f64)>>,
    pub bands: Vec<Vec<(f64, f64)>>,
    pub seed: Option<String>,
    /// The last mission state and its text (the failure, when it failed).
    pub outcome: Option<(MissionState, String)>,
    pub distance: f64,
    pub truncated: Option<String>,
}

impl Run {
    pub fn end_time(&self) -> f64 {
        self.driven.last().map_or(0.0, |d| d.t)
    }

    /// The global map at the end, if the record had a valid one.
    pub fn map_view(&self) -> Option<GridView<'_>> {
        self.map.as_ref().and_then(|m| m.view().ok())
    }
}

fn finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite() && x.abs() < 1e5)
}

/// The `warehouse.toml` the record holds (`None` when it holds none or it does not
/// parse).
fn scene_of(file: &RecordFile) -> Option<aisle_config::scene::Scene> {
    let attachments = file.attachments().ok()?;
    attachments
        .iter()
        .filter(|a| a.name == "warehouse.toml")
        .find_map(|a| {
            let text = std::str::from_utf8(&a.data).ok()?;
            aisle_config::scene::Scene::parse(Path::new(&a.name), text).ok()
        })
}

/// The kinds of the scene's bodies by name.
fn kinds_of(scene: &aisle_config::scene::Scene) -> Vec<(String, String)> {
    let kind = |b: &aisle_config::scene::Body| (b.name.clone(), b.kind.clone());
    scene.bodies.iter().map(kind).collect()
}

/// The static bodies of the scene (ground truth lists only those in contact).
fn static_boxes(scene: &aisle_config::scene::Scene) -> Vec<StaticBox> {
    scene
        .static_bodies()
        .map(|b| {
            let fp = b.footprint();
            [b.pose.x, b.pose.y, b.pose.theta, fp.length, fp.width]
        })
        .filter(|v| finite(v))
        .collect()
}

/// A body is a rack when the scene says so, or (without a scene) when it is named one
/// or was ever carried.
fn kind_of(name: &str, kinds: &[(String, String)], carried: bool) -> BodyKind {
    let rack = match kinds.iter().find(|(n, _)| n == name) {
        Some((_, kind)) => kind.contains("rack"),
        None => carried || name.contains("rack"),
    };
    if rack {
        BodyKind::Rack
    } else {
        BodyKind::Unseen
    }
}

/// Whether a full map's geometry can be drawn.
fn drawable(g: &GlobalGrid) -> bool {
    g.view().is_ok() && finite(&[g.origin_x, g.origin_y, g.resolution])
}

/// Reads `file` into a [`Run`].
pub fn collect(file: &RecordFile, opts: &RenderOptions) -> Run {
    let scene = scene_of(file);
    let kinds = scene.as_ref().map(kinds_of).unwrap_or_default();
    let mut run = Run {
        seed: file.run_metadata().get("seed").cloned(),
        statics: scene.as_ref().map(static_boxes).unwrap_or_default(),
        ..Run::default()
    };
    let mut band_count = 0;
    let mut leg = 0;
    let mut state = MissionState::Starting;
    let mut t = 0.0;
    // The global map as the last full map and the newest changes make it.
    let mut global = GlobalMapCopy::default();
    let truncated = file.for_each_payload(|topic, buf| match topic {
        // A full map or changes that do not fit are left out.
        s::GLOBAL_MAP => {
            if let Some(g) = buf.view::<GlobalGrid>().filter(|g| drawable(g)) {
                let _ = global.update(Some(g), None);
            }
        }
        s::GLOBAL_MAP_CHANGES => {
            let _ = buf
                .view::<MapChanges>()
                .map(|c| global.update(None, Some(c)));
        }
        s::WORLD_TRUTH => {
            if let Some(w) = buf.view::<WorldTruth>() {
                let n = (w.len as usize).min(MAX_BODIES);
                bodies(&mut run, &w.bodies[..n], w.header.stamp_ns as f64 * 1e-9);
            }
        }
        s::CONTROLLER_GOAL => {
            if let Some(g) = buf.view::<ControllerGoal>() {
                let n = (g.len as usize).min(MAX_PATH_POSES);
                let pts: Vec<(f64, f64)> = g.reference[..n]
                    .iter()
                    .filter(|p| finite(&[p.x, p.y]))
                    .map(|p| (p.x, p.y))
                    .collect();
                if pts.len() > 1 && run.references.last() != Some(&pts) {
                    run.references.push(pts);
                }
            }
        }
        s::CONTROLLER_BAND => {
            if let Some(b) = buf.view::<ControllerBand>() {
                let n = (b.len as usize).min(MAX_COMMANDS);
                if opts.band_every > 0 && n > 1 && band_count % opts.band_every == 0 {
                    let pts = b.poses[..n].iter().filter(|p| finite(&[p.x, p.y]));
                    run.bands.push(pts.map(|p| (p.x, p.y)).collect());
                }
                band_count += 1;
            }
        }
        s::MISSION_STATUS => {
            if let Some(st) = buf.view::<MissionStatus>() {
                status(&mut run, st);
                leg = leg_of(st);
                state = MissionState::from_u32(st.state).unwrap_or(state);
            }
        }
        s::ROBOT_STATE => {
            if let Some(r) = buf.view::<RobotState>()
                && finite(&[r.pose.x, r.pose.y, r.pose.theta])
            {
                t = r.header.stamp_ns as f64 * 1e-9;
                let d = Driven {
                    t,
                    x: r.pose.x,
                    y: r.pose.y,
                    theta: r.pose.theta,
                    leg,
                };
                if state == MissionState::Rotating {
                    turn(&mut run.turns, run.driven.last(), &d);
                }
                run.driven.push(d);
            }
        }
        _ => {}
    });
    run.truncated = truncated;
    run.map = global.view().is_ok().then(|| global.grid().clone());
    for b in &mut run.movables {
        b.kind = kind_of(&b.name, &kinds, b.poses.iter().any(|p| p.carried));
    }
    let legs_seen = run.driven.iter().map(|d| d.leg + 1).max().unwrap_or(0);
    while run.legs.len() < legs_seen {
        run.legs.push(String::new());
    }
    for (i, name) in run.legs.iter_mut().enumerate() {
        if name.is_empty() {
            *name = format!("leg {}", i + 1);
        }
    }
    run
}

/// Each movable body's pose whenever it changed. The static bodies come from the
/// record's scene: ground truth lists only those in contact.
fn bodies(run: &mut Run, truth: &[BodyTruth], t: f64) {
    for b in truth {
        let v = [b.pose.x, b.pose.y, b.pose.theta, b.size[0], b.size[1]];
        if !finite(&v) || b.is_static != 0 {
            continue;
        }
        let name = read_name(&b.name);
        let pose = BodyPose {
            t,
            x: v[0],
            y: v[1],
            theta: v[2],
            carried: b.carried != 0,
        };
        match run.movables.iter_mut().find(|m| m.name == name) {
            Some(m) => {
                let last = m.poses.last().copied();
                if last.is_none_or(|l| {
                    (l.x, l.y, l.theta, l.carried) != (v[0], v[1], v[2], pose.carried)
                }) {
                    m.poses.push(pose);
                }
            }
            None => run.movables.push(MovableBody {
                name: name.to_string(),
                kind: BodyKind::Unseen,
                length: v[3],
                width: v[4],
                poses: vec![pose],
            }),
        }
    }
}

/// The leg a status is about: at the end the index may point past the last leg.
fn leg_of(st: &MissionStatus) -> usize {
    let last = st.segments.max(1) - 1;
    st.segment.min(last) as usize
}

/// The leg's name while it runs, the outcome at the end.
fn status(run: &mut Run, st: &MissionStatus) {
    let state = MissionState::from_u32(st.state).unwrap_or(MissionState::Starting);
    let text = read_name(&st.text).to_string();
    let leg = leg_of(st);
    let running = !matches!(state, MissionState::Failed | MissionState::Succeeded);
    if running && leg < 64 {
        if run.legs.len() <= leg {
            run.legs.resize(leg + 1, String::new());
        }
        if run.legs[leg].is_empty() {
            run.legs[leg] = text.clone();
        }
    }
    run.distance = st.distance;
    run.outcome = Some((state, text));
}

/// Extends the current turn in place, or starts one from the pose before (the status
/// that says "rotating" comes a tick after the rotation began).
fn turn(turns: &mut Vec<Turn>, before: Option<&Driven>, d: &Driven) {
    match turns.last_mut() {
        Some(t) if t.leg == d.leg && (t.x - d.x).hypot(t.y - d.y) < 0.3 => {
            // Unwrap so that a half turn reads as +-pi and not as a jump.
            let step = (d.theta - t.to + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            t.to += step;
        }
        _ => {
            let start = before
                .filter(|b| (b.x - d.x).hypot(b.y - d.y) < 0.3)
                .unwrap_or(d);
            turns.push(Turn {
                leg: d.leg,
                x: start.x,
                y: start.y,
                from: start.theta,
                to: start.theta,
            });
            turn(turns, None, d);
        }
    }
}

//! The mapper process: every point cloud goes into the obstacle layer; then the local
//! map (every scan) and the global map (when it changed; history 1, so a late or
//! restarted subscriber gets the newest) are written in place into loaned samples.
//!
//! What to ignore comes from the supervisor's `MapperControl` (history 1): the rack
//! being approached (map frame) and the carried rack (robot frame). The robot's own
//! footprint is always ignored. The same message names the legs of racks the mission
//! set down, which the map keeps as known obstacles (`Mapper::set_placed`).
//!
//! Adapter only: the mapping is [`crate::Mapper`]; the loop around it is the node
//! runtime's (`aisle_node::run`).

use crate::{
    BeamGeometry, IgnoreZone, MapConfig, Mapper, OrganizedCloud, Scan, SensorPose, load_static_map,
};
use aisle_bus::{NodeArgs, NodeError, StageTimer, Stamp};
use aisle_geometry::{Footprint, GridView, Pose2};
use aisle_messages::{
    GlobalMapCopy, GridKind, GridMessage, MAX_MAP_CHANGES, NodeKind, PointCloud, RectMsg,
    StageStatus, Topic, topics,
};
use aisle_node::{Cycle, Io, RunContext, Stage};
use std::time::Duration;

/// The lidar's beam pattern, from `lidar.toml` (the mapper clears along rays without a
/// return, so it needs their directions).
fn beams(config_dir: &std::path::Path) -> Result<BeamGeometry, NodeError> {
    let path = config_dir.join("lidar.toml");
    let l = aisle_config::load::<aisle_robot::LidarConfig>(&path)
        .map_err(|e| NodeError::setup("mapper", e))?;
    l.beams()
        .map_err(|e| NodeError::setup(format!("mapper: {}", path.display()), e))
}

fn zone(r: &RectMsg) -> Option<IgnoreZone> {
    (r.valid != 0 && r.length > 0.0 && r.width > 0.0).then(|| IgnoreZone {
        pose: r.pose.into(),
        footprint: Footprint::new(r.length, r.width),
    })
}

/// Publishes the global map's changes since the last full map, or the full map when
/// they no longer pay: more than a `MapChanges` holds, or more bytes than half the map.
fn publish_global(io: &impl Io, stamp: Stamp, mapper: &mut Mapper) -> Result<(), NodeError> {
    let listed = mapper.changes().touched().len();
    let change_bytes = listed * size_of::<aisle_messages::CellChangeMsg>();
    if listed > MAX_MAP_CHANGES || change_bytes > mapper.global_map().cells.len() / 2 {
        return publish_full(io, stamp, mapper);
    }
    publish_changes(io, stamp, mapper)
}

/// The global map whole, made the base of the changes, then its (empty) changes: so
/// there are always changes since the newest full map, and a restarted mapper can wait
/// for the retained ones as long as for the full map, never guessing they do not exist.
fn publish_full(io: &impl Io, stamp: Stamp, mapper: &mut Mapper) -> Result<(), NodeError> {
    publish_grid(
        io,
        topics::GLOBAL_MAP,
        stamp,
        GridKind::Global,
        mapper.version(),
        &mapper.global_map(),
    )?;
    mapper.rebase_changes();
    publish_changes(io, stamp, mapper)
}

fn publish_changes(io: &impl Io, stamp: Stamp, mapper: &Mapper) -> Result<(), NodeError> {
    let (log, map) = (mapper.changes(), mapper.global_map());
    io.publish(topics::GLOBAL_MAP_CHANGES, stamp, |m| {
        m.base_version = log.base_version();
        m.version = mapper.version();
        (m.width, m.height) = (map.width as u32, map.height as u32);
        m.len = log.touched().len() as u32;
        for (e, &i) in m.changes.iter_mut().zip(log.touched()) {
            e.index = i;
            e.value = map.cells[i as usize];
        }
    })
}

fn publish_grid<G: GridMessage>(
    io: &impl Io,
    topic: Topic<G>,
    stamp: Stamp,
    kind: GridKind,
    version: u64,
    map: &GridView<'_>,
) -> Result<(), NodeError> {
    let mut written = Ok(());
    io.publish(topic, stamp, |m| {
        written = m.write(kind as u32, version, map)
    })?;
    written.map_err(|e| NodeError::Protocol(format!("mapper: {e}")))
}

/// The mapper as a stage: one cycle per point cloud, in arrival order.
pub struct MapperStage {
    mapper: Mapper,
    robot_footprint: Footprint,
    side: usize,
    /// The newest scan integrated; a cloud of that tick or earlier is only acknowledged.
    last_tick: Option<u64>,
    ignore: Option<IgnoreZone>,
    carried: Option<IgnoreZone>,
    /// The placed parts of the newest control message (capacity fixed: no allocation).
    placed: Vec<(Pose2, Footprint)>,
    published_version: u64,
}

impl MapperStage {
    /// Loads `mapper.toml`, the static map, the robot and the beam pattern.
    pub fn new(config_dir: &std::path::Path) -> Result<MapperStage, NodeError> {
        let mapper_toml = config_dir.join("mapper.toml");
        let cfg = aisle_config::load::<MapConfig>(&mapper_toml)
            .map_err(|e| NodeError::setup("mapper", e))?;
        let static_map =
            load_static_map(&cfg, &config_dir.join("warehouse.toml")).map_err(|e| {
                NodeError::setup(format!("mapper: static map ({})", mapper_toml.display()), e)
            })?;
        use crate::config as own;
        const _: () = assert!(own::MAX_GRID_CELLS == aisle_messages::MAX_GRID_CELLS);
        const _: () = assert!(own::MAX_GRID_SIDE == aisle_messages::MAX_GRID_SIDE);
        const _: () = assert!(own::MAX_GLOBAL_GRID_CELLS == aisle_messages::MAX_GLOBAL_GRID_CELLS);
        const _: () = assert!(own::MAX_GLOBAL_GRID_SIDE == aisle_messages::MAX_GLOBAL_GRID_SIDE);
        const _: () = assert!(crate::config::MAX_LISTED_CHANGES == aisle_messages::MAX_MAP_CHANGES);
        if static_map.cells.len() > aisle_messages::MAX_GLOBAL_GRID_CELLS {
            return Err(NodeError::setup(
                format!("mapper: {}", mapper_toml.display()),
                format!(
                    "a {} x {} map exceeds the GlobalGrid capacity of {} cells",
                    static_map.width,
                    static_map.height,
                    aisle_messages::MAX_GLOBAL_GRID_CELLS
                ),
            ));
        }
        let robot = aisle_config::load::<aisle_robot::RobotConfig>(&config_dir.join("robot.toml"))
            .map_err(|e| NodeError::setup("mapper", e))?;
        let robot_footprint = robot.footprint.alone.footprint();
        let beams = beams(config_dir)?;
        let mapper =
            Mapper::new(static_map, &cfg, beams).map_err(|e| NodeError::setup("mapper", e))?;
        Ok(MapperStage {
            side: mapper.local_side(),
            published_version: mapper.version(),
            mapper,
            robot_footprint,
            last_tick: None,
            ignore: None,
            carried: None,
            placed: Vec::with_capacity(aisle_messages::MAX_PLACED_PARTS),
        })
    }

    /// Integrates one cloud; `Failed` when the cloud or the scan is refused.
    /// The zones of the latest `MapperControl`: ignored and carried bodies, and the
    /// set-down parts the map keeps as known obstacles.
    fn apply_control(&mut self, io: &impl Io) -> Result<(), NodeError> {
        if let Some(c) = io.latest(topics::MAPPER_CONTROL)? {
            self.ignore = zone(&c.ignore);
            self.carried = zone(&c.carried);
            let n = (c.placed_count as usize).min(c.placed.len());
            self.placed.clear();
            self.placed.extend(
                c.placed[..n]
                    .iter()
                    .filter_map(zone)
                    .filter(|z| z.pose.is_finite())
                    .map(|z| (z.pose, z.footprint)),
            );
            self.mapper.set_placed(&self.placed);
        }
        Ok(())
    }

    fn integrate(&mut self, cloud: &PointCloud) -> StageStatus {
        let sp = cloud.sensor_pose;
        let sensor = SensorPose::from_rpy(sp.position, sp.rpy[0], sp.rpy[1], sp.rpy[2]);
        let (rows, cols) = (cloud.rows as usize, cloud.cols as usize);
        let n = rows.saturating_mul(cols).min(cloud.points.len());
        let ignore_list: &[IgnoreZone] = match &self.ignore {
            Some(z) => std::slice::from_ref(z),
            None => &[],
        };
        match OrganizedCloud::new(rows, cols, &cloud.points[..n]) {
            Ok(points) => {
                let scan = Scan {
                    cloud: points,
                    sensor,
                    robot: cloud.robot_pose.into(),
                    robot_footprint: self.robot_footprint,
                    carried: self.carried,
                    ignore: ignore_list,
                };
                match self.mapper.integrate(&scan) {
                    Ok(_) => StageStatus::Done,
                    Err(e) => {
                        tracing::warn!("mapper: scan of tick {} refused: {e}", cloud.header.tick);
                        StageStatus::Failed
                    }
                }
            }
            Err(e) => {
                tracing::warn!("mapper: cloud of tick {} refused: {e}", cloud.header.tick);
                StageStatus::Failed
            }
        }
    }

    /// The global map when it changed (its changes, or whole), then the local window
    /// around the robot.
    fn publish_maps(&mut self, io: &impl Io, stamp: Stamp, robot: Pose2) -> Result<(), NodeError> {
        if self.mapper.version() != self.published_version {
            self.published_version = self.mapper.version();
            publish_global(io, stamp, &mut self.mapper)?;
        }
        let mut failure = None;
        let version = self.mapper.version();
        let side = self.side;
        let mapper = &self.mapper;
        io.publish(topics::LOCAL_MAP, stamp, |m| {
            m.kind = GridKind::Local as u32;
            m.version = version;
            let cells = &mut m.cells[..side * side];
            match mapper.local_map_into((robot.x, robot.y), cells) {
                Ok(info) => {
                    m.width = info.width as u32;
                    m.height = info.height as u32;
                    m.origin_x = info.origin_x;
                    m.origin_y = info.origin_y;
                    m.resolution = info.resolution;
                }
                Err(e) => {
                    // A 0 x 0 grid uses none of its cells: the bus keeps them zero.
                    cells.fill(0);
                    failure = Some(e);
                }
            }
        })?;
        match failure {
            Some(e) => Err(NodeError::Protocol(format!("mapper: local map: {e}"))),
            None => Ok(()),
        }
    }
}

impl Stage for MapperStage {
    const KIND: NodeKind = NodeKind::Mapper;
    type Trigger = PointCloud;
    const TRIGGER: Topic<PointCloud> = topics::POINT_CLOUD;
    const NEWEST_ONLY: bool = false;

    fn start(&mut self, io: &impl Io, ctx: &RunContext) -> Result<(), NodeError> {
        if ctx.restarted {
            return Ok(());
        }
        publish_full(io, Stamp::default(), &mut self.mapper)
    }

    /// A restarted mapper takes the zones of the latest `MapperControl` back (the set-down
    /// racks' legs are part of its static layer) and its detections from the last global
    /// map (the full map and its changes, kept and published again by the supervisor),
    /// at that map's version, with the same full map as the base of its changes: it goes
    /// on exactly as the mapper before it, and publishes the next map when that one
    /// would have. Scans are integrated again after a restart: integrating a scan twice
    /// changes nothing, so the newest one is simply redone.
    fn restore(&mut self, io: &impl Io, _ctx: &RunContext) -> Result<(), NodeError> {
        self.apply_control(io)?;
        if let Some(full) = io.retained(topics::GLOBAL_MAP, Duration::from_secs(1))? {
            // The changes since that full map (published with every full map).
            let changes = io.retained(topics::GLOBAL_MAP_CHANGES, Duration::from_secs(1))?;
            let mut held = GlobalMapCopy::default();
            let update = held
                .update(Some(&*full), changes.as_deref())
                .map_err(|e| NodeError::Protocol(format!("mapper: published changes: {e}")))?;
            let view = held
                .view()
                .map_err(|e| NodeError::Protocol(format!("mapper: published global map: {e}")))?;
            self.mapper
                .restore_detections(&view, held.version())
                .map_err(|e| NodeError::Protocol(format!("mapper: resuming: {e}")))?;
            let listed = match (update.changes, &changes) {
                (Some(n), Some(c)) => &c.changes[..n],
                _ => &[],
            };
            self.mapper
                .resume_changes(full.version, listed.iter().map(|e| e.index));
        }
        tracing::warn!("mapper: resumed with map version {}", self.mapper.version());
        self.published_version = self.mapper.version();
        Ok(())
    }

    fn process(&mut self, cloud: &PointCloud, io: &impl Io) -> Result<Cycle, NodeError> {
        if self.last_tick.is_some_and(|t| cloud.header.tick <= t) {
            return Ok(Cycle::repeat());
        }
        self.last_tick = Some(cloud.header.tick);
        let timer = StageTimer::start();
        self.apply_control(io)?;
        let status = self.integrate(cloud);
        self.publish_maps(io, Stamp::of(&cloud.header), cloud.robot_pose.into())?;
        Ok(Cycle {
            status,
            compute_ns: Some(timer.elapsed_ns()),
        })
    }
}

pub fn run(args: &NodeArgs) -> Result<(), NodeError> {
    let mut stage = MapperStage::new(&args.config_dir)?;
    aisle_node::run(&mut stage, args)
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_node::testing::MemIo;

    fn ctx() -> RunContext {
        RunContext {
            mode: aisle_messages::TickMode::Lockstep,
            seed: 1,
            restarted: false,
        }
    }

    fn cloud(tick: u64) -> Box<PointCloud> {
        let mut c = aisle_messages::zeroed_box::<PointCloud>();
        c.header.tick = tick;
        c.rows = 2;
        c.cols = 3;
        c.points[..6].fill([f32::NAN; 3]);
        c
    }

    /// A set-down part for `MapperControl.placed`.
    fn part(pose: Pose2, length: f64, width: f64) -> RectMsg {
        RectMsg {
            pose: pose.into(),
            length,
            width,
            valid: 1,
            _pad: [0; 7],
        }
    }

    /// The newest full map published on `io` with the newest changes on it.
    fn held(io: &MemIo) -> GlobalMapCopy {
        let mut held = GlobalMapCopy::default();
        if let Some(n) = io.published_len(topics::GLOBAL_MAP).checked_sub(1) {
            io.published(topics::GLOBAL_MAP, n, |m| {
                held.update(Some(m), None).unwrap()
            });
        }
        if let Some(n) = io.published_len(topics::GLOBAL_MAP_CHANGES).checked_sub(1) {
            io.published(topics::GLOBAL_MAP_CHANGES, n, |c| {
                held.update(None, Some(c)).unwrap()
            });
        }
        held
    }

    fn held_cell(io: &MemIo, at: (f64, f64)) -> u8 {
        let held = held(io);
        let v = held.view().unwrap();
        let c = v.cell_of(at.0, at.1);
        v.cells[c.iy as usize * v.width + c.ix as usize]
    }

    #[test]
    fn each_cloud_gives_a_local_map_and_a_repeat_only_an_acknowledgement() {
        let dir = aisle_config::testing::shipped_dir();
        let mut stage = MapperStage::new(&dir).unwrap();
        let io = MemIo::new();
        stage.start(&io, &ctx()).unwrap();
        assert_eq!(
            io.published_len(topics::GLOBAL_MAP),
            1,
            "the static map at start"
        );
        // A cloud that does not match the configured beam pattern is refused, the maps
        // still go out.
        let c = stage.process(&cloud(4), &io).unwrap();
        assert_eq!(c.status, StageStatus::Failed);
        assert_eq!(io.published_len(topics::LOCAL_MAP), 1);
        let (kind, tick, side) = io
            .published(topics::LOCAL_MAP, 0, |m| (m.kind, m.header.tick, m.width))
            .unwrap();
        assert_eq!(
            (kind, tick, side as usize),
            (GridKind::Local as u32, 4, stage.side)
        );
        assert_eq!(stage.process(&cloud(4), &io).unwrap(), Cycle::repeat());
        assert_eq!(io.published_len(topics::LOCAL_MAP), 1);
    }

    #[test]
    fn a_restarted_mapper_takes_its_detections_back() {
        let dir = aisle_config::testing::shipped_dir();
        let mut stage = MapperStage::new(&dir).unwrap();
        let io = MemIo::new();
        let fresh = MemIo::new();
        let mut first = MapperStage::new(&dir).unwrap();
        first.start(&fresh, &ctx()).unwrap();
        let (w, h) = fresh
            .published(topics::GLOBAL_MAP, 0, |m| (m.width, m.height))
            .unwrap();
        io.retain(topics::GLOBAL_MAP, |m| {
            fresh.published(topics::GLOBAL_MAP, 0, |g| {
                (m.width, m.height, m.resolution) = (g.width, g.height, g.resolution);
                (m.origin_x, m.origin_y) = (g.origin_x, g.origin_y);
                m.cells.copy_from_slice(&g.cells);
            });
            m.version = 9;
        });
        stage.restore(&io, &ctx()).unwrap();
        assert_eq!(stage.mapper.version(), 9);
        assert!(w > 0 && h > 0);
    }

    #[test]
    fn a_restarted_mapper_goes_on_from_the_same_full_map_and_list_of_changes() {
        let dir = aisle_config::testing::shipped_dir();
        let io = MemIo::new();
        let mut first = MapperStage::new(&dir).unwrap();
        first.start(&io, &ctx()).unwrap();
        let leg = |x: f64| part(Pose2::new(x, 1.0, 0.0), 0.1, 0.1);
        let control = |io: &MemIo| {
            io.push(topics::MAPPER_CONTROL, |m| {
                (m.placed[0], m.placed[1]) = (leg(1.0), leg(2.0));
                m.placed_count = 2;
            })
        };
        control(&io);
        first.process(&cloud(1), &io).unwrap();
        // What the supervisor retained for the restarted mapper: the newest of each.
        let again = MemIo::new();
        io.published(topics::GLOBAL_MAP, 0, |g| {
            again.retain(topics::GLOBAL_MAP, |m| {
                (m.width, m.height, m.resolution) = (g.width, g.height, g.resolution);
                (m.origin_x, m.origin_y, m.version) = (g.origin_x, g.origin_y, g.version);
                m.cells.copy_from_slice(&g.cells);
            })
        });
        let newest = io.published_len(topics::GLOBAL_MAP_CHANGES) - 1;
        io.published(topics::GLOBAL_MAP_CHANGES, newest, |c| {
            again.retain(topics::GLOBAL_MAP_CHANGES, |m| {
                (m.base_version, m.version, m.len) = (c.base_version, c.version, c.len);
                (m.width, m.height) = (c.width, c.height);
                m.changes.copy_from_slice(&c.changes);
            })
        });
        control(&again);
        let mut second = MapperStage::new(&dir).unwrap();
        second.restore(&again, &ctx()).unwrap();
        let log = |s: &MapperStage| {
            let c = s.mapper.changes();
            (c.base_version(), c.touched().to_vec(), s.mapper.version())
        };
        assert_eq!(log(&second), log(&first));
        assert!(!log(&first).1.is_empty());
        assert_eq!(
            held(&again).version(),
            0,
            "nothing published again on restore"
        );
        assert_eq!(
            second.mapper.global_map().cells,
            first.mapper.global_map().cells
        );
    }

    #[test]
    fn changes_that_outgrow_half_the_map_go_out_as_a_full_map_and_start_again_from_it() {
        let dir = aisle_config::testing::shipped_dir();
        let mut stage = MapperStage::new(&dir).unwrap();
        let io = MemIo::new();
        stage.start(&io, &ctx()).unwrap();
        let cells = stage.mapper.global_map().cells.len();
        // A set-down part of 4 x 5 m: 2,000 cells of a 60,000-cell map, 32 kB of changes.
        let set_down = |length: f64| {
            io.push(topics::MAPPER_CONTROL, |m| {
                m.placed[0] = part(Pose2::new(5.0, 5.0, 0.0), length, 5.0);
                m.placed_count = 1;
            })
        };
        set_down(0.5);
        stage.process(&cloud(1), &io).unwrap();
        let published = |io: &MemIo| {
            (
                io.published_len(topics::GLOBAL_MAP),
                io.published_len(topics::GLOBAL_MAP_CHANGES),
            )
        };
        // At start the full map and its (empty) changes, then the change's cells.
        assert_eq!(published(&io), (1, 2), "a small change: its cells");
        let listed = stage.mapper.changes().touched().len();
        assert!(listed > 100 && 16 * listed < cells / 2, "{listed}");
        set_down(4.0);
        stage.process(&cloud(2), &io).unwrap();
        assert_eq!(published(&io), (2, 3), "past half the map: the map whole");
        let empty = io
            .published(topics::GLOBAL_MAP_CHANGES, 2, |c| {
                (c.base_version, c.version, c.len)
            })
            .unwrap();
        assert_eq!(empty, (2, 2, 0), "with its empty changes");
        let base = io.published(topics::GLOBAL_MAP, 1, |m| m.version).unwrap();
        assert_eq!((base, stage.mapper.changes().base_version()), (2, 2));
        assert!(stage.mapper.changes().touched().is_empty());
        // The next change is listed against the new full map.
        set_down(0.5);
        stage.process(&cloud(3), &io).unwrap();
        assert_eq!(published(&io), (2, 4));
        let newest = io
            .published(topics::GLOBAL_MAP_CHANGES, 3, |c| {
                (c.base_version, c.version)
            })
            .unwrap();
        assert_eq!(newest, (2, 3));
        assert_eq!(
            held(&io).view().unwrap().cells,
            stage.mapper.global_map().cells
        );
    }

    #[test]
    fn legs_named_placed_are_static_cells_of_the_published_maps_until_dropped_from_the_list() {
        let dir = aisle_config::testing::shipped_dir();
        let mut stage = MapperStage::new(&dir).unwrap();
        let io = MemIo::new();
        stage.start(&io, &ctx()).unwrap();
        // A free spot of the shipped warehouse: the start pose's surroundings.
        let leg = part(Pose2::new(1.0, 1.0, 0.3), 0.1, 0.1);
        assert_eq!(held_cell(&io, (1.0, 1.0)), aisle_geometry::FREE);
        io.push(topics::MAPPER_CONTROL, |m| {
            m.placed[0] = leg;
            m.placed_count = 1;
        });
        stage.process(&cloud(1), &io).unwrap();
        assert_eq!(
            (
                io.published_len(topics::GLOBAL_MAP),
                io.published_len(topics::GLOBAL_MAP_CHANGES)
            ),
            (1, 2),
            "the map changed: its changes are published (after the start's empty ones), \
             not the whole map"
        );
        assert_eq!(held_cell(&io, (1.0, 1.0)), aisle_geometry::OCCUPIED_STATIC);
        io.push(topics::MAPPER_CONTROL, |m| m.placed_count = 0);
        stage.process(&cloud(2), &io).unwrap();
        assert_eq!(held_cell(&io, (1.0, 1.0)), aisle_geometry::FREE);
        let listed = io
            .published(topics::GLOBAL_MAP_CHANGES, 2, |c| {
                (c.base_version, c.version, c.len)
            })
            .unwrap();
        assert!(listed.0 == 0 && listed.1 == 2 && listed.2 > 0, "{listed:?}");
    }
}

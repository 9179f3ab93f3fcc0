//! The mapper process: every point cloud goes into the obstacle layer; then the local
//! map (every scan) and the global map (when it changed; history 1, so a late or
//! restarted subscriber gets the newest) are written in place into loaned samples.
//!
//! What to ignore comes from the supervisor's `MapperControl` (history 1): the rack
//! being approached (map frame) and the carried rack (robot frame). The robot's own
//! footprint is always ignored.
//!
//! Adapter only: the mapping is [`crate::Mapper`].

use crate::{
    BeamGeometry, IgnoreZone, MapConfig, Mapper, OrganizedCloud, Scan, SensorPose, load_static_map,
};
use aisle_bus::{
    Bus, NodeArgs, NodeError, Publisher, StageTimer, Stamp, TickFollower, WaitOutcome,
};
use aisle_geometry::{Footprint, GridView, Pose2};
use aisle_messages::{
    GridKind, MapperControl, NodeKind, NodeState, OccupancyGrid, PointCloud, RectMsg, StageStatus,
    services,
};
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

/// A restarted mapper takes its detections back from the last global map (kept and
/// published again by the supervisor).
fn resume(bus: &Bus, mapper: &mut Mapper) -> Result<Option<u64>, NodeError> {
    let wait = Duration::from_secs(1);
    let globals = bus.subscriber::<OccupancyGrid>(services::GLOBAL_MAP)?;
    if let (WaitOutcome::Matched, Some(g)) = globals.wait_for(wait, |_| true, || {})? {
        let view = g
            .view()
            .map_err(|e| NodeError::Protocol(format!("mapper: published global map: {e}")))?;
        mapper
            .restore_detections(&view, g.version)
            .map_err(|e| NodeError::Protocol(format!("mapper: resuming: {e}")))?;
    }
    tracing::warn!("mapper: resumed with map version {}", mapper.version());
    // Scans are integrated again after a restart: integrating a scan twice changes
    // nothing, so the newest one is simply redone.
    Ok(None)
}

fn zone(r: &RectMsg) -> Option<IgnoreZone> {
    (r.valid != 0 && r.length > 0.0 && r.width > 0.0).then(|| IgnoreZone {
        pose: r.pose.into(),
        footprint: Footprint::new(r.length, r.width),
    })
}

fn publish_grid(
    port: &mut Publisher<OccupancyGrid>,
    stamp: Stamp,
    kind: GridKind,
    version: u64,
    map: &GridView<'_>,
) -> Result<(), NodeError> {
    port.publish(stamp, |m| {
        m.kind = kind as u32;
        m.width = map.width as u32;
        m.height = map.height as u32;
        m.origin_x = map.origin_x;
        m.origin_y = map.origin_y;
        m.resolution = map.resolution;
        m.version = version;
        m.cells[..map.cells.len()].copy_from_slice(map.cells);
    })?;
    Ok(())
}

pub fn run(args: &NodeArgs) -> Result<(), NodeError> {
    let mapper_toml = args.config_dir.join("mapper.toml");
    let cfg =
        aisle_config::load::<MapConfig>(&mapper_toml).map_err(|e| NodeError::setup("mapper", e))?;
    let static_map =
        load_static_map(&cfg, &args.config_dir.join("warehouse.toml")).map_err(|e| {
            NodeError::setup(format!("mapper: static map ({})", mapper_toml.display()), e)
        })?;
    if static_map.cells.len() > aisle_messages::MAX_GRID_CELLS
        || static_map.width > aisle_messages::MAX_GRID_SIDE
        || static_map.height > aisle_messages::MAX_GRID_SIDE
    {
        return Err(NodeError::setup(
            format!("mapper: {}", mapper_toml.display()),
            format!(
                "a {} x {} map exceeds the OccupancyGrid capacity of {} cells per side",
                static_map.width,
                static_map.height,
                aisle_messages::MAX_GRID_SIDE
            ),
        ));
    }
    let robot = aisle_config::load::<aisle_robot::RobotConfig>(&args.config_dir.join("robot.toml"))
        .map_err(|e| NodeError::setup("mapper", e))?;
    let robot_footprint = robot.footprint.alone.footprint();
    let beams = beams(&args.config_dir)?;
    let mut mapper =
        Mapper::new(static_map, &cfg, beams).map_err(|e| NodeError::setup("mapper", e))?;
    let side = mapper.local_side();

    let (bus, _) = Bus::join(&args.instance, NodeKind::Mapper, NodeArgs::JOIN_TIMEOUT)?;
    let mut global = bus.publisher::<OccupancyGrid>(services::GLOBAL_MAP)?;
    let mut local = bus.publisher::<OccupancyGrid>(services::LOCAL_MAP)?;
    let clouds = bus.subscriber::<PointCloud>(services::POINT_CLOUD)?;
    let control = bus.subscriber::<MapperControl>(services::MAPPER_CONTROL)?;
    let mut ticks = TickFollower::new(&bus)?;
    // The newest scan integrated; a cloud of that tick or earlier is only acknowledged.
    let mut last_tick: Option<u64> = None;
    if args.restarted {
        last_tick = resume(&bus, &mut mapper)?;
    } else {
        publish_grid(
            &mut global,
            Stamp::default(),
            GridKind::Global,
            mapper.version(),
            &mapper.global_map(),
        )?;
    }
    ticks.ready()?;

    let mut ignore: Option<IgnoreZone> = None;
    let mut carried: Option<IgnoreZone> = None;
    let mut published_version = mapper.version();
    loop {
        let hb = ticks.heartbeat();
        let (global_ref, local_ref) = (&global, &local);
        let (outcome, sample) = clouds.wait_for(
            Duration::from_millis(500),
            |_| true,
            || {
                let _ = hb.tick(NodeState::Running);
                // Late subscribers (a restarted planner or controller) get the history.
                let _ = global_ref.update_connections();
                let _ = local_ref.update_connections();
            },
        )?;
        let (WaitOutcome::Matched, Some(cloud)) = (outcome, sample) else {
            continue;
        };
        if last_tick.is_some_and(|t| cloud.header.tick <= t) {
            let header = cloud.header;
            drop(cloud);
            ticks.done_for(&header, StageStatus::Done, 0)?;
            continue;
        }
        last_tick = Some(cloud.header.tick);
        let timer = StageTimer::start();
        if let Some(c) = control.latest()? {
            ignore = zone(&c.ignore);
            carried = zone(&c.carried);
        }
        let robot_pose: Pose2 = cloud.robot_pose.into();
        let sp = cloud.sensor_pose;
        let sensor = SensorPose::from_rpy(sp.position, sp.rpy[0], sp.rpy[1], sp.rpy[2]);
        let (rows, cols) = (cloud.rows as usize, cloud.cols as usize);
        let n = rows.saturating_mul(cols).min(cloud.points.len());
        let ignore_list: &[IgnoreZone] = match &ignore {
            Some(z) => std::slice::from_ref(z),
            None => &[],
        };
        let status = match OrganizedCloud::new(rows, cols, &cloud.points[..n]) {
            Ok(points) => {
                let scan = Scan {
                    cloud: points,
                    sensor,
                    robot: robot_pose,
                    robot_footprint,
                    carried,
                    ignore: ignore_list,
                };
                match mapper.integrate(&scan) {
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
        };
        let stamp = Stamp::of(&cloud.header);
        if mapper.version() != published_version {
            published_version = mapper.version();
            publish_grid(
                &mut global,
                stamp,
                GridKind::Global,
                published_version,
                &mapper.global_map(),
            )?;
        }
        let mut failure = None;
        let version = mapper.version();
        local.publish(stamp, |m| {
            m.kind = GridKind::Local as u32;
            m.version = version;
            match mapper.local_map_into((robot_pose.x, robot_pose.y), &mut m.cells[..side * side]) {
                Ok(info) => {
                    m.width = info.width as u32;
                    m.height = info.height as u32;
                    m.origin_x = info.origin_x;
                    m.origin_y = info.origin_y;
                    m.resolution = info.resolution;
                }
                Err(e) => failure = Some(e),
            }
        })?;
        if let Some(e) = failure {
            return Err(NodeError::Protocol(format!("mapper: local map: {e}")));
        }
        let header = cloud.header;
        drop(cloud);
        ticks.done_for(&header, status, timer.elapsed_ns())?;
    }
}

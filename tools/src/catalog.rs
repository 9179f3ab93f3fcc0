//! The recorded services: each service name paired with its message type, and the
//! per-type layout hash written into channel metadata.
//!
//! This module knows which type travels on which service (from `aisle_messages`); it
//! does not know how messages are stored in a file or published on the bus.

use aisle_messages::services as s;
use aisle_messages::{
    ControllerBand, ControllerGoal, Heartbeat, InstanceInfo, MapperControl, Message, MissionStatus,
    NodeKind, OccupancyGrid, PlanRequest, PlanResponse, PointCloud, RobotState, SimCommand,
    SimState, Tick, TickDone, Trajectory, WorldTruth,
};

/// Calls `$m!(service_const, Type)` for every service of the catalogue. Used to build
/// typed ports (subscribers, publishers) without repeating the table.
#[macro_export]
#[doc(hidden)]
macro_rules! for_each_service {
    ($m:ident) => {
        $m!(
            aisle_messages::services::INSTANCE,
            aisle_messages::InstanceInfo
        );
        $m!(aisle_messages::services::TICK, aisle_messages::Tick);
        $m!(
            aisle_messages::services::TICK_DONE,
            aisle_messages::TickDone
        );
        $m!(
            aisle_messages::services::HEARTBEAT,
            aisle_messages::Heartbeat
        );
        $m!(
            aisle_messages::services::ROBOT_STATE,
            aisle_messages::RobotState
        );
        $m!(
            aisle_messages::services::WORLD_TRUTH,
            aisle_messages::WorldTruth
        );
        $m!(
            aisle_messages::services::SIM_COMMAND,
            aisle_messages::SimCommand
        );
        $m!(
            aisle_messages::services::SIM_STATE,
            aisle_messages::SimState
        );
        $m!(
            aisle_messages::services::POINT_CLOUD,
            aisle_messages::PointCloud
        );
        $m!(
            aisle_messages::services::GLOBAL_MAP,
            aisle_messages::OccupancyGrid
        );
        $m!(
            aisle_messages::services::LOCAL_MAP,
            aisle_messages::OccupancyGrid
        );
        $m!(
            aisle_messages::services::MAPPER_CONTROL,
            aisle_messages::MapperControl
        );
        $m!(
            aisle_messages::services::PLAN_REQUEST,
            aisle_messages::PlanRequest
        );
        $m!(
            aisle_messages::services::PLAN_RESPONSE,
            aisle_messages::PlanResponse
        );
        $m!(
            aisle_messages::services::CONTROLLER_GOAL,
            aisle_messages::ControllerGoal
        );
        $m!(
            aisle_messages::services::TRAJECTORY,
            aisle_messages::Trajectory
        );
        $m!(
            aisle_messages::services::CONTROLLER_BAND,
            aisle_messages::ControllerBand
        );
        $m!(
            aisle_messages::services::MISSION_STATUS,
            aisle_messages::MissionStatus
        );
    };
}

/// One service and the layout of the message it carries.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServiceInfo {
    pub service: &'static str,
    pub type_name: &'static str,
    pub size: usize,
    pub align: usize,
    /// FNV-1a over this type's layout and every nested (non-message) struct layout.
    pub layout_hash: u64,
}

impl ServiceInfo {
    fn of<M: Message>(service: &'static str) -> ServiceInfo {
        ServiceInfo {
            service,
            type_name: M::TYPE_NAME,
            size: std::mem::size_of::<M>(),
            align: std::mem::align_of::<M>(),
            layout_hash: layout_hash(M::TYPE_NAME),
        }
    }

    pub fn layout_hash_hex(&self) -> String {
        format!("{:016x}", self.layout_hash)
    }
}

/// Every service, in the order of [`for_each_service!`].
pub fn services() -> Vec<ServiceInfo> {
    vec![
        ServiceInfo::of::<InstanceInfo>(s::INSTANCE),
        ServiceInfo::of::<Tick>(s::TICK),
        ServiceInfo::of::<TickDone>(s::TICK_DONE),
        ServiceInfo::of::<Heartbeat>(s::HEARTBEAT),
        ServiceInfo::of::<RobotState>(s::ROBOT_STATE),
        ServiceInfo::of::<WorldTruth>(s::WORLD_TRUTH),
        ServiceInfo::of::<SimCommand>(s::SIM_COMMAND),
        ServiceInfo::of::<SimState>(s::SIM_STATE),
        ServiceInfo::of::<PointCloud>(s::POINT_CLOUD),
        ServiceInfo::of::<OccupancyGrid>(s::GLOBAL_MAP),
        ServiceInfo::of::<OccupancyGrid>(s::LOCAL_MAP),
        ServiceInfo::of::<MapperControl>(s::MAPPER_CONTROL),
        ServiceInfo::of::<PlanRequest>(s::PLAN_REQUEST),
        ServiceInfo::of::<PlanResponse>(s::PLAN_RESPONSE),
        ServiceInfo::of::<ControllerGoal>(s::CONTROLLER_GOAL),
        ServiceInfo::of::<Trajectory>(s::TRAJECTORY),
        ServiceInfo::of::<ControllerBand>(s::CONTROLLER_BAND),
        ServiceInfo::of::<MissionStatus>(s::MISSION_STATUS),
    ]
}

/// The catalogue entry of `service`, if it is one of ours.
pub fn service_info(service: &str) -> Option<ServiceInfo> {
    services().into_iter().find(|i| i.service == service)
}

/// The process that publishes `service` in a run (`TickDone` and heartbeats come from
/// every process: `None`). The supervisor also republishes some state after a restart.
pub fn producer(service: &str) -> Option<NodeKind> {
    Some(match service {
        s::TICK | s::ROBOT_STATE | s::WORLD_TRUTH | s::SIM_STATE => NodeKind::Simulator,
        s::POINT_CLOUD => NodeKind::Lidar,
        s::GLOBAL_MAP | s::LOCAL_MAP => NodeKind::Mapper,
        s::PLAN_RESPONSE => NodeKind::GlobalPlanner,
        s::TRAJECTORY | s::CONTROLLER_BAND => NodeKind::TebController,
        s::INSTANCE
        | s::SIM_COMMAND
        | s::MAPPER_CONTROL
        | s::PLAN_REQUEST
        | s::CONTROLLER_GOAL
        | s::MISSION_STATUS => NodeKind::Supervisor,
        _ => return None,
    })
}

fn fnv1a(hash: &mut u64, bytes: &[u8]) {
    for b in bytes {
        *hash ^= u64::from(*b);
        *hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
    }
}

/// Layout hash of one message type. Nested structs are named in the field types only by
/// their Rust identifier, so the hash covers every nested (non-message) layout too: a
/// change in `Header` changes every type's hash, a change in `Trajectory` only its own.
pub fn layout_hash(type_name: &str) -> u64 {
    let layouts = aisle_messages::all_layouts();
    let is_message = |name: &str| MESSAGE_TYPES.contains(&name);
    let mut h = 0xcbf2_9ce4_8422_2325_u64;
    for (name, size, align, fields) in &layouts {
        if *name != type_name && is_message(name) {
            continue;
        }
        fnv1a(&mut h, name.as_bytes());
        fnv1a(&mut h, &(*size as u64).to_le_bytes());
        fnv1a(&mut h, &(*align as u64).to_le_bytes());
        for f in fields.iter() {
            fnv1a(&mut h, f.name.as_bytes());
            fnv1a(&mut h, f.ty.as_bytes());
            fnv1a(&mut h, &(f.offset as u64).to_le_bytes());
            fnv1a(&mut h, &(f.size as u64).to_le_bytes());
        }
    }
    h
}

const MESSAGE_TYPES: [&str; 17] = [
    InstanceInfo::TYPE_NAME,
    Tick::TYPE_NAME,
    TickDone::TYPE_NAME,
    Heartbeat::TYPE_NAME,
    RobotState::TYPE_NAME,
    WorldTruth::TYPE_NAME,
    SimCommand::TYPE_NAME,
    SimState::TYPE_NAME,
    PointCloud::TYPE_NAME,
    OccupancyGrid::TYPE_NAME,
    MapperControl::TYPE_NAME,
    PlanRequest::TYPE_NAME,
    PlanResponse::TYPE_NAME,
    ControllerGoal::TYPE_NAME,
    Trajectory::TYPE_NAME,
    ControllerBand::TYPE_NAME,
    MissionStatus::TYPE_NAME,
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_service_is_listed_once_and_hashes_differ_by_type() {
        let all = services();
        // Every service name the message crate declares is recorded.
        let declared = include_str!("../../interfaces/messages/src/services.rs")
            .matches("pub const ")
            .count();
        assert_eq!(all.len(), declared);
        let mut names: Vec<_> = all.iter().map(|i| i.service).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), all.len());
        let g = service_info(s::GLOBAL_MAP).unwrap();
        let l = service_info(s::LOCAL_MAP).unwrap();
        assert_eq!(g.layout_hash, l.layout_hash);
        for i in &all {
            let kind = producer(i.service);
            assert_eq!(
                kind.is_none(),
                i.service == s::TICK_DONE || i.service == s::HEARTBEAT,
                "{}",
                i.service
            );
        }
        let t = service_info(s::TICK).unwrap();
        assert_ne!(t.layout_hash, g.layout_hash);
        assert_eq!(t.size, 72);
        assert!(all.iter().all(|i| i.align <= 8));
    }

    #[test]
    fn every_catalogue_message_is_a_service_type() {
        let listed: Vec<&str> = services().iter().map(|i| i.type_name).collect();
        for name in MESSAGE_TYPES {
            assert!(listed.contains(&name), "{name}");
        }
        // And every top-level layout (one with a header) is in MESSAGE_TYPES.
        for (name, _, _, fields) in aisle_messages::all_layouts() {
            let top = fields.first().is_some_and(|f| f.name == "header");
            assert_eq!(top, MESSAGE_TYPES.contains(&name), "{name}");
        }
    }
}

//! Service names. One name per data stream; the bus pairs each with an event service.

pub const INSTANCE: &str = "aisle/instance";
pub const TICK: &str = "aisle/tick";
pub const TICK_DONE: &str = "aisle/tick_done";
pub const HEARTBEAT: &str = "aisle/heartbeat";
pub const ROBOT_STATE: &str = "aisle/robot_state";
pub const WORLD_TRUTH: &str = "aisle/world_truth";
pub const SIM_COMMAND: &str = "aisle/sim_command";
pub const SIM_STATE: &str = "aisle/sim_state";
pub const POINT_CLOUD: &str = "aisle/lidar/points";
pub const GLOBAL_MAP: &str = "aisle/map/global";
pub const LOCAL_MAP: &str = "aisle/map/local";
pub const MAPPER_CONTROL: &str = "aisle/map/control";
pub const PLAN_REQUEST: &str = "aisle/planner/request";
pub const PLAN_RESPONSE: &str = "aisle/planner/response";
pub const CONTROLLER_GOAL: &str = "aisle/controller/goal";
pub const TRAJECTORY: &str = "aisle/controller/trajectory";
pub const CONTROLLER_BAND: &str = "aisle/controller/band";
pub const MISSION_STATUS: &str = "aisle/mission/status";

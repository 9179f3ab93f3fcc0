//! The message catalogue (DESIGN.md section 4) and the wire codes of its enums.

use iceoryx2::prelude::ZeroCopySend;

use crate::NodeKind;
use crate::common::{
    Header, PathPoseMsg, Pose2Msg, Pose3Msg, RectMsg, TimedCommandMsg, TimedPoseMsg,
};
use crate::message;

/// Organised point clouds: up to 64 rows (elevation channels) x 2048 columns (azimuth).
pub const MAX_CLOUD_ROWS: usize = 64;
pub const MAX_CLOUD_COLS: usize = 2048;
pub const MAX_CLOUD_POINTS: usize = MAX_CLOUD_ROWS * MAX_CLOUD_COLS;
pub use crate::catalog_maps::{
    MAX_GLOBAL_GRID_CELLS, MAX_GLOBAL_GRID_SIDE, MAX_GRID_CELLS, MAX_GRID_SIDE, MAX_MAP_CHANGES,
};
/// Parts of a docking body a plan request can name (a rack's four legs, and more).
pub const MAX_DOCK_PARTS: usize = 8;
/// Parts of bodies set down by the mission the mapper keeps as known obstacles (four
/// racks' worth of `MAX_DOCK_PARTS`).
pub const MAX_PLACED_PARTS: usize = 4 * MAX_DOCK_PARTS;
/// Paths up to 4096 poses.
pub const MAX_PATH_POSES: usize = 4096;
/// Command timelines (and predicted poses) up to 512 entries.
pub const MAX_COMMANDS: usize = 512;
/// Entries of the ground-truth message: every body that can move (a scene may have any
/// number of static ones, which never move and are not sent) and the static bodies in
/// contact.
pub const MAX_BODIES: usize = 256;
/// Bodies in contact at once that `SimState` keeps.
pub const MAX_CONTACTS: usize = 32;
pub const NAME_LEN: usize = 32;
pub const TEXT_LEN: usize = 192;

/// Declares a `u32` wire code enum with checked decoding.
macro_rules! wire_enum {
    ($(#[$m:meta])* $name:ident { $($(#[$vm:meta])* $v:ident = $n:literal),* $(,)? }) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        #[repr(u32)]
        pub enum $name { $($(#[$vm])* $v = $n),* }
        impl $name {
            /// (variant name, wire code), for generated bindings.
            pub const VARIANTS: &'static [(&'static str, u32)] = &[$((stringify!($v), $n)),*];
            pub fn from_u32(v: u32) -> Option<Self> {
                match v { $($n => Some(Self::$v),)* _ => None }
            }
        }
    };
}

wire_enum!(TickMode { Lockstep = 0, Realtime = 1 });
wire_enum!(
    /// Tick flags: bit set when that stage must act on this tick.
    StageStatus { Done = 0, Idle = 1, Failed = 2 }
);
wire_enum!(
    /// Why a plan request ended.
    PlanStatus { Ok = 0, StartOccupied = 1, GoalOccupied = 2, NoPath = 3, Timeout = 4, InvalidRequest = 5, StartOutsideMap = 6, GoalOutsideMap = 7, NoOpenSide = 8 }
);
wire_enum!(
    /// A plan's straight move under or out of a body (`PlanRequest::dock`).
    DockMove { None = 0, Dock = 1, Undock = 2 }
);
wire_enum!(
    /// What the controller is asked to do. `Straight`: drive along the line through
    /// `target` in its heading (forwards or backwards, whichever reaches it) to `target`:
    /// docking under a rack and leaving it.
    GoalMode { Idle = 0, Follow = 1, RotateInPlace = 2, Straight = 3 }
);
wire_enum!(
    /// `Start` lets the simulator begin ticking once every process is ready.
    SimCommandKind { Attach = 1, Detach = 2, Stop = 3, Start = 4 }
);
wire_enum!(NodeState { Starting = 0, Ready = 1, Running = 2, Stopping = 3, Failed = 4 });
wire_enum!(GridKind { Global = 0, Local = 1 });
wire_enum!(MissionState { Starting = 0, Planning = 1, Driving = 2, Rotating = 3, Succeeded = 4, Failed = 5 });

/// Bit in [`Tick::stages`]: the controller must act (and acknowledge) on this tick.
pub const STAGE_CONTROLLER: u32 = 1 << 0;

message!(
    /// The simulator starts tick `tick` at simulated time `header.stamp_ns`.
    Tick = "aisle.Tick.v1" size 72 {
        header: Header,
        dt_ns: u64,
        /// `TickMode` code.
        mode: u32,
        /// `STAGE_*` bits of the stages that act on this tick.
        stages: u32,
        /// Seed of the run (the lidar derives its noise stream from it).
        seed: u64,
    }
);

message!(
    /// A stage finished its work for `header.tick`.
    TickDone = "aisle.TickDone.v2" size 72 {
        header: Header,
        /// `NodeKind` code of the stage.
        node: u32,
        /// `StageStatus` code.
        status: u32,
        /// Wall time the stage spent computing for this tick.
        compute_ns: u64,
        /// CPU time of the computing thread over the cycle (CLOCK_THREAD_CPUTIME_ID);
        /// 0 when not measured.
        cpu_ns: u64,
    }
);

message!(
    /// The robot as the simulator moves it: what odometry would report.
    RobotState = "aisle.RobotState.v1" size 128 {
        header: Header,
        pose: Pose2Msg,
        /// Linear and angular velocity actually applied (after wheel clamping).
        twist: [f64; 2],
        /// Left, right wheel speed in rad/s.
        wheel_speeds: [f64; 2],
        /// Index of the carried body in the scene, -1 when none.
        carried_body: i32,
        /// 1 when the watchdog holds the robot still (no valid command).
        watchdog_stopped: u32,
        /// Collision events so far (ground truth).
        collisions: u32,
        _pad: u32,
        /// Goal id of the trajectory in force (0 when none).
        active_goal_id: u64,
    }
);

crate::layout_struct!(
    /// A body of the world, from ground truth: name, pose, bounding box.
    BodyTruth = "aisle.BodyTruth.v3" {
        name: [u8; NAME_LEN],
        pose: Pose2Msg,
        /// Bounding box of the body: length, width (body frame) and height.
        size: [f64; 3],
        /// The body's index in the scene (`warehouse.toml` order; v3).
        index: u32,
        is_static: u8,
        carried: u8,
        /// 1 while the robot (or the rack it carries) touches this body: a collision
        /// event is this flag turning on (v2; the supervisor names the body from it).
        in_contact: u8,
        _pad: u8,
    }
);

message!(
    /// Ground truth for metrics, rendering and tests only: navigation processes must not
    /// subscribe to it. `bodies` holds every body that can move (the non-static ones, in
    /// scene order), then every static body in contact; the static ones never move, so
    /// their poses are the scene's (v3: a scene may have any number of them).
    WorldTruth = "aisle.WorldTruth.v3" size 22592 {
        header: Header,
        len: u32,
        collisions: u32,
        /// Smallest 2D distance between the robot (plus carried rack) and any body so far.
        min_clearance: f64,
        bodies: [BodyTruth; MAX_BODIES],
    }
);

message!(
    /// An organised lidar scan: `rows` elevation channels x `cols` azimuth channels,
    /// row-major, xyz in the sensor frame, NaN for no return.
    PointCloud = "aisle.PointCloud.v1" size 1573000 {
        header: Header,
        rows: u32,
        cols: u32,
        /// Sensor pose in the map frame when the scan was taken.
        sensor_pose: Pose3Msg,
        /// Robot base pose in the map frame when the scan was taken.
        robot_pose: Pose2Msg,
        /// Index of the body the robot carries, -1 when none (copied from RobotState).
        carried_body: i32,
        _pad: u32,
        points: [[f32; 3]; MAX_CLOUD_POINTS],
    }
    used |m: &PointCloud| core::mem::offset_of!(PointCloud, points)
        + 12 * (m.rows as usize * m.cols as usize).min(MAX_CLOUD_POINTS)
);

message!(
    /// Tells the mapper which footprints are not obstacles: the rack being approached for
    /// a pick (map frame) and the carried rack (relative to the robot base); and which
    /// are, whatever the lidar sees: the parts (legs) of bodies the mission set down
    /// (map frame), which the robot cannot see once it has driven out from under them.
    MapperControl = "aisle.MapperControl.v2" size 1688 {
        header: Header,
        ignore: RectMsg,
        carried: RectMsg,
        /// How many of `placed` hold parts.
        placed_count: u32,
        _pad: u32,
        placed: [RectMsg; MAX_PLACED_PARTS],
    }
);

message!(
    /// Ask the global planner for a reference path.
    PlanRequest = "aisle.PlanRequest.v3" size 584 {
        header: Header,
        request_id: u64,
        start: Pose2Msg,
        goal: Pose2Msg,
        footprint_length: f64,
        footprint_width: f64,
        margin: f64,
        /// 1: plan on the global map with lidar detections; 0: static map only.
        use_detections: u32,
        /// Expansion budget (0: the planner's default). It grows with the area the goal
        /// can be reached from, unless `fixed_budget`.
        max_expansions: u32,
        /// Wall-clock bound the planner enforces on top of the expansion budget.
        timeout_ms: u32,
        /// `DockMove` code: 1 the path ends under `body` (entered straight through an
        /// open side, the goal is its last pose), 2 it starts under `body` (leaves it
        /// straight first), 0 neither.
        dock: u32,
        /// 1: the goal's heading is free (docking: the planner chooses the side).
        free_heading: u32,
        /// 1: `max_expansions` is the most the whole request expands (every search it
        /// makes), not raised with the reachable area: a try the asker has a fallback for.
        fixed_budget: u32,
        /// The body the robot drives under (map frame; `valid` 0 when `dock` is 0).
        body: RectMsg,
        /// Its parts the robot can hit (a rack's legs), map frame; `valid` 0 ends the list.
        parts: [RectMsg; MAX_DOCK_PARTS],
    }
);

message!(
    /// The planner's answer to the request with the same `request_id`.
    PlanResponse = "aisle.PlanResponse.v2" size 131168 {
        header: Header,
        request_id: u64,
        /// `PlanStatus` code.
        status: u32,
        expansions: u32,
        solve_ns: u64,
        path_length: f64,
        len: u32,
        /// `DockMove` code of the straight part: 1 the poses from `split` on are the
        /// docking move, 2 the poses up to `split` are the undocking move, 0 none.
        straight: u32,
        split: u32,
        _pad: u32,
        poses: [PathPoseMsg; MAX_PATH_POSES],
    }
);

message!(
    /// What the controller should do next.
    ControllerGoal = "aisle.ControllerGoal.v1" size 131232 {
        header: Header,
        /// Increments with every new goal; 0 never names a goal.
        goal_id: u64,
        /// `GoalMode` code.
        mode: u32,
        len: u32,
        footprint_length: f64,
        footprint_width: f64,
        margin: f64,
        /// x, y, heading tolerances to count the goal as reached.
        goal_tolerance: [f64; 3],
        /// Linear and angular speed limits for this goal (m/s, rad/s): the lower of these
        /// and the controller's own apply; zero (or anything not positive) leaves its own.
        max_velocity: [f64; 2],
        look_ahead_time: f64,
        /// Final pose (the rotate-in-place target heading is `target.theta`).
        target: Pose2Msg,
        reference: [PathPoseMsg; MAX_PATH_POSES],
    }
);

message!(
    /// One controller step: a timeline of commands starting at `start_ns` (simulated),
    /// the predicted poses, and MATLAB controllerTEB's info record.
    Trajectory = "aisle.Trajectory.v2" size 28792 {
        header: Header,
        goal_id: u64,
        /// Simulated time at which `commands[0].t` = 0 applies.
        start_ns: u64,
        /// The oldest tick among the inputs the step acted on (its local map and robot
        /// state). After a stop stamped with tick s the simulator drives a trajectory only
        /// if this is after s: made from what was sensed after the stop, not before it.
        inputs_tick: u64,
        len: u32,
        poses_len: u32,
        /// 0 valid, 1 collision, 2 margin, 3 turning radius, 4 time not increasing, 5 off
        /// path (MATLAB's codes); 6 an acceleration over its limit (aisle's; still driven);
        /// 7 stopped because an input (local map, robot state) was too old (aisle's).
        exit_flag: u32,
        last_feasible_index: i32,
        reached_goal: u32,
        iterations: u32,
        cost: f64,
        solve_ns: u64,
        max_violation: f64,
        commands: [TimedCommandMsg; MAX_COMMANDS],
        poses: [TimedPoseMsg; MAX_COMMANDS],
    }
);

message!(
    /// The controller's band and its progress along the reference, published with
    /// history 1 so a restarted controller resumes exactly where it was (`dts` are the
    /// band's own time steps, bit for bit; `poses[i].t` is their running sum, for viewers).
    ControllerBand = "aisle.ControllerBand.v3" size 20560 {
        header: Header,
        goal_id: u64,
        len: u32,
        /// Reference section being driven.
        section: u32,
        /// Arc length along the reference reached, m.
        progress: f64,
        /// Side the band was last pushed around a blocker: 1 left, -1 right, 0 none.
        detour_side: i32,
        _pad: u32,
        poses: [TimedPoseMsg; MAX_COMMANDS],
        dts: [f64; MAX_COMMANDS],
    }
);

crate::layout_struct!(
    /// One entry of the simulator's command timeline: offset from its start and twist.
    TimedTwistMsg = "aisle.TimedTwist.v1" { offset_ns: u64, v: f64, w: f64 }
);

message!(
    /// The simulator's whole state at the start of tick `next_tick`, published with
    /// history 1 before that tick's `RobotState`, so a restarted simulator resumes
    /// bit for bit: every float is copied, none recomputed.
    SimState = "aisle.SimState.v3" size 18792 {
        header: Header,
        next_tick: u64,
        time_ns: u64,
        pose: Pose2Msg,
        twist: [f64; 2],
        wheels: [f64; 2],
        watchdog_stopped: u8,
        wheels_clamped: u8,
        _pad: [u8; 2],
        /// Scene index of the carried body, -1 for none.
        carried_body: i32,
        /// The carried body's pose on the carry mount.
        carried_offset: Pose2Msg,
        collisions: u64,
        min_clearance: f64,
        /// The last `SimCommand` applied (its `command_id`).
        last_command_id: u64,
        /// The last trajectory applied: its sequence number and tick.
        last_trajectory_seq: u64,
        last_trajectory_tick: u64,
        /// The tick stamped on the last `Stop` applied (u64::MAX: none): trajectories of
        /// that tick or older were computed before it and are not driven.
        last_stop_tick: u64,
        /// How many `body_poses` hold poses: the scene's non-static bodies.
        bodies_len: u32,
        timeline_len: u32,
        timeline_start_ns: u64,
        /// When the timeline stops being in force (its successor overdue); u64::MAX: never.
        timeline_expiry_ns: u64,
        /// Scene indices of the bodies in contact (v3: static ones too, any scene size).
        contacts_len: u32,
        contacts: [u32; MAX_CONTACTS],
        _pad_contacts: u32,
        /// Poses of the bodies that can move (the non-static ones, in scene order; v3).
        body_poses: [Pose2Msg; MAX_BODIES],
        timeline: [TimedTwistMsg; MAX_COMMANDS],
    }
);

message!(
    /// A command to the simulator from the supervisor.
    SimCommand = "aisle.SimCommand.v1" size 96 {
        header: Header,
        command_id: u64,
        /// `SimCommandKind` code.
        kind: u32,
        /// Scene index of the body to attach.
        body_index: i32,
        name: [u8; NAME_LEN],
    }
);

message!(
    /// Liveness and identity of a process.
    Heartbeat = "aisle.Heartbeat.v1" size 264 {
        header: Header,
        /// `NodeKind` code.
        node: u32,
        /// `NodeState` code.
        state: u32,
        pid: u32,
        _pad: u32,
        schema_hash: u64,
        /// Last error, UTF-8, NUL-padded.
        text: [u8; TEXT_LEN],
    }
);

message!(
    /// The supervisor's view of the mission, for recorders and dashboards.
    MissionStatus = "aisle.MissionStatus.v1" size 272 {
        header: Header,
        /// `MissionState` code.
        state: u32,
        segment: u32,
        segments: u32,
        replans: u32,
        distance: f64,
        text: [u8; TEXT_LEN],
        _pad: [u8; 8],
    }
);

message!(
    /// What a joining process checks first: the supervisor's schema hash and the run seed.
    InstanceInfo = "aisle.InstanceInfo.v1" size 72 {
        header: Header,
        schema_hash: u64,
        seed: u64,
        /// `TickMode` code.
        mode: u32,
        _pad: u32,
    }
);

message!(
    /// Who is in the group, from the supervisor (history 1): a lockstep tick waits only
    /// for the acknowledgements of members. Published before the first tick and again
    /// when a member leaves for good (a recorder that died or failed).
    GroupMembers = "aisle.GroupMembers.v2" size 184 {
        header: Header,
        /// How many entries of `nodes` are used.
        count: u32,
        _pad: u32,
        /// The members' node codes (`NodeKind::code`).
        nodes: [u32; MAX_GROUP_MEMBERS],
    }
);

/// Most nodes a group can have (built-in and external).
pub const MAX_GROUP_MEMBERS: usize = 32;

impl GroupMembers {
    /// Sets the members; `Err` with the count when there are more than fit.
    pub fn set(&mut self, members: impl IntoIterator<Item = NodeKind>) -> Result<(), usize> {
        let members: Vec<u32> = members.into_iter().map(NodeKind::code).collect();
        if members.len() > MAX_GROUP_MEMBERS {
            return Err(members.len());
        }
        self.nodes = [0; MAX_GROUP_MEMBERS];
        self.nodes[..members.len()].copy_from_slice(&members);
        self.count = members.len() as u32;
        Ok(())
    }

    /// The members' codes.
    pub fn codes(&self) -> &[u32] {
        &self.nodes[..(self.count as usize).min(MAX_GROUP_MEMBERS)]
    }

    pub fn contains(&self, kind: NodeKind) -> bool {
        self.codes().contains(&kind.code())
    }
}

//! The topic table: every data stream of the group, declared once with its name, its
//! message type and its QoS.
//!
//! A [`Topic<T>`] constant is what ports are opened with (`bus.subscriber(topics::TICK)`),
//! so the type travelling on a name is fixed here and nowhere else. Code that must handle
//! every topic generically (the recorder, replay, the graph check) walks [`ALL`] for the
//! untyped facts, or [`for_each`] / [`visit`] with a [`TopicVisitor`] to get the type back.
//!
//! This module knows names, types and limits; it does not know how topics travel (see
//! `aisle-bus`) or which node publishes them (see `config/graph.toml`).

use crate::Message;
use std::marker::PhantomData;

/// Publish/subscribe limits of one topic, the same in every process.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    pub max_publishers: usize,
    pub max_subscribers: usize,
    /// Samples a late subscriber can ask for (state that must survive a restart).
    pub history: usize,
    /// Samples buffered per subscriber before the oldest is overwritten.
    pub buffer: usize,
}

/// A named stream of `T` messages with its QoS.
pub struct Topic<T> {
    pub name: &'static str,
    pub qos: Qos,
    message: PhantomData<fn() -> T>,
}

impl<T> Clone for Topic<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Topic<T> {}

impl<T> std::fmt::Debug for Topic<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Topic").field("name", &self.name).finish()
    }
}

impl<T: Message> Topic<T> {
    pub const fn new(name: &'static str, qos: Qos) -> Self {
        Topic {
            name,
            qos,
            message: PhantomData,
        }
    }

    /// The untyped facts of this topic.
    pub const fn info(&self) -> TopicInfo {
        TopicInfo {
            name: self.name,
            type_name: T::TYPE_NAME,
            size: std::mem::size_of::<T>(),
            align: std::mem::align_of::<T>(),
            qos: self.qos,
        }
    }
}

/// A topic without its type: what tables and files record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TopicInfo {
    pub name: &'static str,
    pub type_name: &'static str,
    pub size: usize,
    pub align: usize,
    pub qos: Qos,
}

/// Generic code over every topic type: [`for_each`] and [`visit`] call `visit` with the
/// typed constant.
pub trait TopicVisitor {
    fn visit<T: Message>(&mut self, topic: Topic<T>);
}

// The QoS classes. Subscribers: the consumers of DESIGN.md plus a recorder and a replay
// checker. History 1 on the state a restarted process needs to resume (DESIGN.md
// section 6): the current tick, the inputs of that tick, and each stage's own state.
const SENSOR: Qos = Qos {
    max_publishers: 2,
    max_subscribers: 4,
    history: 1,
    buffer: 2,
};
const GLOBAL: Qos = Qos {
    max_publishers: 2,
    max_subscribers: 6,
    history: 1,
    buffer: 2,
};
const RETAINED: Qos = Qos {
    max_publishers: 2,
    max_subscribers: 8,
    history: 1,
    buffer: 2,
};
const STATE: Qos = Qos {
    max_publishers: 2,
    max_subscribers: 8,
    history: 1,
    buffer: 4,
};
/// Commands are events: a restarted simulator applies those it has not seen.
const COMMANDS: Qos = Qos {
    max_publishers: 2,
    max_subscribers: 4,
    history: 16,
    buffer: 16,
};
/// Every process publishes these (external nodes too, up to `MAX_GROUP_MEMBERS`, and
/// a restarted one beside its dead predecessor); nobody needs their past.
const PROTOCOL: Qos = Qos {
    max_publishers: 40,
    max_subscribers: 4,
    history: 0,
    buffer: 16,
};
/// Requests, responses and status: only what arrives while a peer listens counts (a
/// restarted planner must not answer an old request again).
const EXCHANGE: Qos = Qos {
    max_publishers: 3,
    max_subscribers: 8,
    history: 0,
    buffer: 8,
};

/// The QoS of a topic a graph declares beyond this table (`[[topic]]` in `graph.toml`,
/// carrying a catalogue type): state-like, history 1, so a late subscriber sees the newest.
pub const USER: Qos = STATE;

macro_rules! topics {
    ($($(#[$m:meta])* $konst:ident: $ty:ident = $name:literal, $qos:expr;)*) => {
        $($(#[$m])* pub const $konst: Topic<crate::$ty> = Topic::new($name, $qos);)*

        /// The topic names as plain strings, for code that handles recorded channels by
        /// name (a record stores names, not types).
        pub mod names {
            $(pub const $konst: &str = $name;)*
        }

        /// Every topic, in declaration order.
        pub const ALL: &[TopicInfo] = &[$($konst.info()),*];

        /// The constant names of [`ALL`]'s topics, in the same order (for generated
        /// bindings: `topics.ROBOT_STATE` in Python too).
        pub const CONST_NAMES: &[&str] = &[$(stringify!($konst)),*];

        /// Calls `v.visit` with every typed topic, in the order of [`ALL`].
        pub fn for_each(v: &mut impl TopicVisitor) {
            $(v.visit($konst);)*
        }

        /// Calls `v.visit` with the typed topic called `name`; false when there is none.
        pub fn visit(name: &str, v: &mut impl TopicVisitor) -> bool {
            match name {
                $($name => { v.visit($konst); true })*
                _ => match crate::user_topics::find(name) {
                    Some(t) => visit_type(t, v),
                    None => false,
                },
            }
        }

        /// Calls `v.visit` with `info`'s name and QoS typed as the catalogue type it
        /// names; false when no topic of the table carries that type.
        fn visit_type(info: TopicInfo, v: &mut impl TopicVisitor) -> bool {
            $(if info.type_name == <crate::$ty>::TYPE_NAME {
                v.visit(Topic::<crate::$ty>::new(info.name, info.qos));
                return true;
            })*
            false
        }
    };
}

topics! {
    /// The supervisor's announcement: schema hash, seed, clock mode.
    INSTANCE: InstanceInfo = "aisle/instance", RETAINED;
    /// The simulator starts tick k.
    TICK: Tick = "aisle/tick", STATE;
    /// A stage finished tick k.
    TICK_DONE: TickDone = "aisle/tick_done", PROTOCOL;
    HEARTBEAT: Heartbeat = "aisle/heartbeat", PROTOCOL;
    ROBOT_STATE: RobotState = "aisle/robot_state", STATE;
    /// Ground truth, for metrics, the lidar's simulation and rendering only.
    WORLD_TRUTH: WorldTruth = "aisle/world_truth", STATE;
    SIM_COMMAND: SimCommand = "aisle/sim_command", COMMANDS;
    /// The simulator's resumable state.
    SIM_STATE: SimState = "aisle/sim_state", RETAINED;
    POINT_CLOUD: PointCloud = "aisle/lidar/points", SENSOR;
    /// The full global map: at start, and whenever its changes outgrow `MapChanges`.
    GLOBAL_MAP: GlobalGrid = "aisle/map/global", GLOBAL;
    /// The global map's changes since the newest full map (see `MapChanges`).
    GLOBAL_MAP_CHANGES: MapChanges = "aisle/map/global_changes", GLOBAL;
    LOCAL_MAP: OccupancyGrid = "aisle/map/local", SENSOR;
    MAPPER_CONTROL: MapperControl = "aisle/map/control", RETAINED;
    PLAN_REQUEST: PlanRequest = "aisle/planner/request", EXCHANGE;
    PLAN_RESPONSE: PlanResponse = "aisle/planner/response", EXCHANGE;
    CONTROLLER_GOAL: ControllerGoal = "aisle/controller/goal", RETAINED;
    TRAJECTORY: Trajectory = "aisle/controller/trajectory", STATE;
    /// The controller's resumable state.
    CONTROLLER_BAND: ControllerBand = "aisle/controller/band", RETAINED;
    MISSION_STATUS: MissionStatus = "aisle/mission/status", EXCHANGE;
    /// Who is in the group: whose acknowledgements a lockstep tick waits for.
    GROUP: GroupMembers = "aisle/group", RETAINED;
}

/// The untyped facts of the topic called `name`.
/// The untyped facts of the topic called `name`: one of the table, or a user topic a
/// graph declared in this process (see [`crate::user_topics`]).
pub fn info(name: &str) -> Option<TopicInfo> {
    ALL.iter()
        .find(|t| t.name == name)
        .copied()
        .or_else(|| crate::user_topics::find(name))
}

/// Every topic of the table, then the user topics declared in this process.
pub fn all() -> Vec<TopicInfo> {
    let mut all = ALL.to_vec();
    all.extend(crate::user_topics::declared());
    all
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Names(Vec<&'static str>);
    impl TopicVisitor for Names {
        fn visit<T: Message>(&mut self, topic: Topic<T>) {
            assert_eq!(topic.info().type_name, T::TYPE_NAME);
            self.0.push(topic.name);
        }
    }

    #[test]
    fn names_are_unique_and_visits_follow_the_table() {
        let mut names = Names(Vec::new());
        for_each(&mut names);
        let listed: Vec<_> = ALL.iter().map(|t| t.name).collect();
        assert_eq!(names.0, listed);
        let mut sorted = listed.clone();
        sorted.sort();
        sorted.dedup();
        assert_eq!(sorted.len(), listed.len());
        let mut one = Names(Vec::new());
        assert!(visit("aisle/map/local", &mut one));
        assert_eq!(one.0, ["aisle/map/local"]);
        assert!(!visit("aisle/nothing", &mut one));
    }

    #[test]
    fn every_message_type_travels_on_some_topic() {
        for (name, _, _, fields) in crate::all_layouts() {
            if fields.first().is_some_and(|f| f.name == "header") {
                assert!(ALL.iter().any(|t| t.type_name == name), "{name}");
            }
        }
    }
}

//! One QoS table for every service, so whichever process creates a service first, all
//! agree on its limits, and shared memory is sized for the real number of ports.

use aisle_messages::services as s;

/// Publish/subscribe limits of one service.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    pub max_publishers: usize,
    pub max_subscribers: usize,
    /// Samples a late subscriber can ask for (state that must survive a restart).
    pub history: usize,
    /// Samples buffered per subscriber before the oldest is overwritten.
    pub buffer: usize,
}

impl Qos {
    pub fn for_service(name: &str) -> Qos {
        // Subscribers: the consumers named in DESIGN.md plus a recorder and a replay checker.
        // History 1 on the state a restarted process needs to resume (DESIGN.md section
        // 6): the current tick and the inputs of that tick, and each stage's own state.
        match name {
            s::POINT_CLOUD => Qos {
                max_publishers: 2,
                max_subscribers: 4,
                history: 1,
                buffer: 2,
            },
            s::GLOBAL_MAP => Qos {
                max_publishers: 2,
                max_subscribers: 6,
                history: 1,
                buffer: 2,
            },
            s::LOCAL_MAP => Qos {
                max_publishers: 2,
                max_subscribers: 4,
                history: 1,
                buffer: 2,
            },
            s::INSTANCE
            | s::CONTROLLER_BAND
            | s::CONTROLLER_GOAL
            | s::MAPPER_CONTROL
            | s::SIM_STATE => Qos {
                max_publishers: 2,
                max_subscribers: 8,
                history: 1,
                buffer: 2,
            },
            s::ROBOT_STATE | s::WORLD_TRUTH | s::TICK | s::TRAJECTORY => Qos {
                max_publishers: 2,
                max_subscribers: 8,
                history: 1,
                buffer: 4,
            },
            // Commands are events: a restarted simulator applies those it has not seen.
            s::SIM_COMMAND => Qos {
                max_publishers: 2,
                max_subscribers: 4,
                history: 16,
                buffer: 16,
            },
            s::TICK_DONE | s::HEARTBEAT => Qos {
                max_publishers: 10,
                max_subscribers: 4,
                history: 0,
                buffer: 16,
            },
            _ => Qos {
                max_publishers: 3,
                max_subscribers: 8,
                history: 0,
                buffer: 8,
            },
        }
    }
}

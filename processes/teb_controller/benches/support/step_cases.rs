//! Controller steps found in a record file: for each recorded `Trajectory`, the
//! messages its step acted on (by sim time: the tick, the newest robot state and local
//! map not after it, the goal by the trajectory's `goal_id`, the band the previous step
//! published). Shared by `examples/export_steps.rs` (which writes the worst steps of a
//! run to a small record) and `benches/teb_step.rs` (which times them).

use std::path::Path;

use aisle_messages::{
    ControllerBand, ControllerGoal, Message, OccupancyGrid, RobotState, Tick, Trajectory, topics,
};
use aisle_teb_controller::case::StepInputs;
use aisle_tools::aligned::AlignedBuf;
use aisle_tools::{FileMessage, RecordFile};

/// The raw messages of one step, as recorded.
pub struct StepMessages {
    pub tick: FileMessage,
    pub goal: FileMessage,
    pub band: Option<FileMessage>,
    pub state: FileMessage,
    pub map: FileMessage,
    pub trajectory: FileMessage,
}

/// The same, aligned for viewing as messages.
pub struct AlignedStep {
    tick: AlignedBuf,
    goal: AlignedBuf,
    band: Option<AlignedBuf>,
    state: AlignedBuf,
    map: AlignedBuf,
    trajectory: AlignedBuf,
}

fn view<M: Message>(b: &AlignedBuf) -> Result<&M, String> {
    b.view::<M>()
        .ok_or_else(|| format!("a payload is not a {}", M::TYPE_NAME))
}

impl AlignedStep {
    pub fn of(m: &StepMessages) -> AlignedStep {
        let a = |f: &FileMessage| AlignedBuf::from_bytes(&f.data);
        AlignedStep {
            tick: a(&m.tick),
            goal: a(&m.goal),
            band: m.band.as_ref().map(a),
            state: a(&m.state),
            map: a(&m.map),
            trajectory: a(&m.trajectory),
        }
    }

    pub fn inputs(&self) -> Result<StepInputs<'_>, String> {
        Ok(StepInputs {
            tick: view::<Tick>(&self.tick)?,
            goal: view::<ControllerGoal>(&self.goal)?,
            band: self.band.as_ref().map(view::<ControllerBand>).transpose()?,
            state: view::<RobotState>(&self.state)?,
            map: view::<OccupancyGrid>(&self.map)?,
        })
    }

    pub fn trajectory(&self) -> Result<&Trajectory, String> {
        view::<Trajectory>(&self.trajectory)
    }
}

fn stamp(m: &FileMessage) -> u64 {
    // Every message starts with its header; the sim-time stamp is its second field.
    u64::from_le_bytes(m.data[8..16].try_into().unwrap_or_default())
}

fn goal_id(m: &FileMessage) -> u64 {
    // goal_id follows the 48-byte header in ControllerGoal, ControllerBand, Trajectory.
    u64::from_le_bytes(m.data[48..56].try_into().unwrap_or_default())
}

/// Newest message of `list` stamped at or before `t` (`strict`: before).
fn newest(list: &[FileMessage], t: u64, strict: bool) -> Option<&FileMessage> {
    list.iter()
        .rev()
        .find(|m| if strict { stamp(m) < t } else { stamp(m) <= t })
}

/// Every controller step of the record at `path` whose inputs it holds.
pub fn steps_in(path: &Path) -> Result<Vec<StepMessages>, String> {
    let file = RecordFile::open(path).map_err(|e| e.to_string())?;
    let mut by_topic: std::collections::BTreeMap<String, Vec<FileMessage>> = Default::default();
    for m in file.raw_messages() {
        let m = m.map_err(|e| e.to_string())?;
        by_topic.entry(m.channel.topic.clone()).or_default().push(m);
    }
    let list = |name: &str| by_topic.get(name).map(Vec::as_slice).unwrap_or(&[]);
    let mut steps = Vec::new();
    for traj in list(topics::TRAJECTORY.name) {
        let t = stamp(traj);
        let id = goal_id(traj);
        let goal = list(topics::CONTROLLER_GOAL.name)
            .iter()
            .rev()
            .find(|g| goal_id(g) == id && stamp(g) <= t);
        let tick = list(topics::TICK.name).iter().find(|k| stamp(k) == t);
        let state = newest(list(topics::ROBOT_STATE.name), t, false);
        let map = newest(list(topics::LOCAL_MAP.name), t, false);
        let band = newest(list(topics::CONTROLLER_BAND.name), t, true)
            .filter(|b| goal_id(b) == id)
            .cloned();
        if let (Some(goal), Some(tick), Some(state), Some(map)) = (goal, tick, state, map) {
            steps.push(StepMessages {
                tick: tick.clone(),
                goal: goal.clone(),
                band,
                state: state.clone(),
                map: map.clone(),
                trajectory: traj.clone(),
            });
        }
    }
    Ok(steps)
}

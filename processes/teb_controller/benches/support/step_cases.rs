//! Controller steps found in a record file: for each recorded `Trajectory`, the
//! messages its step acted on (by sim time: the tick, the newest robot state and local
//! map not after it, the goal by the trajectory's `goal_id`, the band the previous step
//! published). Shared by `examples/export_steps.rs` (which writes the worst steps of a
//! run to a small record) and `benches/teb_step.rs` (which times them).

use std::mem::offset_of;
use std::path::Path;

use aisle_messages::{
    ControllerBand, ControllerGoal, Header, Message, OccupancyGrid, RobotState, Tick, Trajectory,
    topics,
};
use aisle_teb_controller::TebConfig;
use aisle_teb_controller::case::{RecordedStep, StepInputs};
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

fn u64_at(m: &FileMessage, at: usize) -> u64 {
    m.data
        .get(at..at + 8)
        .and_then(|b| b.try_into().ok())
        .map_or(0, u64::from_le_bytes)
}

/// The sim-time stamp of any message (every one starts with its header).
fn stamp(m: &FileMessage) -> u64 {
    u64_at(m, offset_of!(Header, stamp_ns))
}

/// The goal id of a `ControllerGoal`, `ControllerBand` or `Trajectory`.
fn goal_id(m: &FileMessage) -> u64 {
    const AT: usize = offset_of!(ControllerGoal, goal_id);
    const _: () =
        assert!(AT == offset_of!(ControllerBand, goal_id) && AT == offset_of!(Trajectory, goal_id));
    u64_at(m, AT)
}

/// Subproblems a step's band is run on for [`converged_cost`]: far more than any step
/// needs to converge.
pub const CONVERGE_SUBPROBLEMS: usize = 60;

/// The step of `inputs`: its cost and that of its band with the SCP run on to
/// convergence on the same problem (until a subproblem promises under 1e-7 of the
/// merit), `None` when the step optimised nothing. The first over the second is how far
/// the step stopped from the local optimum it was heading for.
#[allow(dead_code)] // the bench and the example use it; the test that includes this does not
pub fn converged_cost(cfg: &TebConfig, inputs: &StepInputs) -> Result<Option<(f64, f64)>, String> {
    let mut step = RecordedStep::new(cfg.clone(), inputs)?;
    step.converged_cost(CONVERGE_SUBPROBLEMS)
        .map_err(|e| e.to_string())
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

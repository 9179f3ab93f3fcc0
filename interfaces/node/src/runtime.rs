//! The one loop every stage runs in: join, ports from the graph, restore after a
//! restart, start, the node's real-time options (`config/realtime.toml`), ready, then wait
//! for the trigger, process, wake the subscribers of what the cycle sent, acknowledge,
//! forever (until SIGINT/SIGTERM, which ends it as `BusError::StopRequested`).

use crate::graph::{Acknowledges, Graph};
use crate::{BusIo, RunContext, Stage, realtime};
use aisle_bus::{Bus, NodeArgs, NodeError, StageTimer, Stamp};
use aisle_messages::{Message, NodeState, TickDone, TickMode, topics};

/// Runs `stage` as the node `S::KIND` of the instance in `args`.
pub fn run<S: Stage>(stage: &mut S, args: &NodeArgs) -> Result<(), NodeError> {
    let name = S::KIND.name();
    let graph = Graph::load_dir(&args.config_dir).map_err(|e| NodeError::setup(name, e))?;
    let decl = graph
        .node(S::KIND)
        .ok_or_else(|| NodeError::setup(name, "the graph does not declare this node"))?
        .clone();
    if !decl.may_subscribe(S::TRIGGER.name) {
        return Err(NodeError::setup(
            name,
            format!(
                "its trigger `{}` is not in its `subscribes` in graph.toml",
                S::TRIGGER.name
            ),
        ));
    }
    let (bus, info) = Bus::join(&args.instance, S::KIND, NodeArgs::JOIN_TIMEOUT)?;
    let ctx = RunContext {
        mode: TickMode::from_u32(info.mode).unwrap_or(TickMode::Lockstep),
        seed: info.seed,
        restarted: args.restarted,
    };
    let io = BusIo::open(&bus, &decl, S::TRIGGER.name)?;
    let mut acks = (decl.acknowledges != Acknowledges::None)
        .then(|| bus.publisher(topics::TICK_DONE))
        .transpose()?;
    if S::ANNOUNCES_START {
        io.heartbeat(NodeState::Starting, "")?;
    }
    if ctx.restarted {
        stage.restore(&io, &ctx)?;
    }
    stage.start(&io, &ctx)?;
    io.wake_subscribers()?;
    // After `start` (its allocations are then pre-faulted and locked with the rest),
    // before the first cycle.
    realtime::apply_for(name, &args.config_dir, &graph, realtime::Forks::Inherit)
        .map_err(|e| NodeError::setup(name, e))?;
    io.heartbeat(NodeState::Ready, "")?;
    loop {
        let trigger = io.wait_trigger(S::TRIGGER, S::NEWEST_ONLY)?;
        let timer = StageTimer::start();
        let cycle = stage.process(&trigger, &io);
        let (elapsed_ns, cpu_ns) = (timer.elapsed_ns(), timer.cpu_ns());
        // Every output of the cycle is sent; its subscribers are woken now, once the
        // cycle's time is taken: a consumer woken mid-cycle could take this CPU and its
        // run would count as this stage's (`bus_io.rs`).
        let woken = io.wake_subscribers();
        let cycle = cycle?;
        woken?;
        let compute_ns = cycle.compute_ns.unwrap_or(elapsed_ns);
        if let Some(acks) = acks.as_mut() {
            let kind = S::KIND;
            acks.publish(Stamp::of(Message::header(&*trigger)), |m: &mut TickDone| {
                m.node = kind.code();
                m.status = cycle.status as u32;
                m.compute_ns = compute_ns;
                m.cpu_ns = cpu_ns;
            })?;
        }
        io.on_slice();
    }
}

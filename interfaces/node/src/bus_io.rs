//! [`BusIo`]: a node's ports in shared memory, opened from its graph declaration.
//!
//! Ports are opened once, when the node starts, for exactly the topics the graph lists
//! for it; a stage that reads or writes a topic its declaration does not list gets an
//! error naming the node and the topic. Waits heartbeat and hand the history of this
//! node's state outputs to subscribers that (re)joined, so no stage has to.
//!
//! A cycle's messages are sent as the stage publishes them, but the subscribers asleep
//! on them are woken once, after the cycle ([`BusIo::wake_subscribers`], which the
//! runtime calls before it acknowledges, and every wait calls first). Waking is a
//! system call after which the woken process may take this CPU at once: woken
//! mid-cycle, a consumer (the controller, 1-8 ms a step) ran before the rest of the
//! mapper's cycle, which then counted the consumer's step as its own compute time.

use crate::Io;
use crate::graph::NodeDecl;
use aisle_bus::{
    Bus, HeartbeatSender, NodeError, Publisher, Received, Stamp, Subscriber, WaitOutcome,
};
use aisle_messages::{Message, NodeState, Topic, TopicVisitor, topics};
use std::any::Any;
use std::cell::{Cell, RefCell};
use std::time::Duration;

/// How long one sleep of a wait lasts at most, so heartbeats keep going.
const SLICE: Duration = Duration::from_millis(25);

struct InPort {
    topic: &'static str,
    port: Box<dyn Any>,
    /// `update_connections` of the typed subscriber, run between the sleeps of every
    /// wait: connecting to a publisher maps its data segment, which must not happen
    /// inside the first cycle that receives from it (it took 4-15 ms there).
    connect: fn(&dyn Any),
}

struct OutPort {
    topic: &'static str,
    port: Box<dyn Any>,
    /// `update_connections` of the typed publisher (history reaches late subscribers).
    refresh: fn(&dyn Any),
    /// Wakes the typed publisher's subscribers.
    wake: fn(&dyn Any) -> Result<(), aisle_bus::BusError>,
}

pub struct BusIo<'b> {
    bus: &'b Bus,
    node: String,
    inputs: Vec<InPort>,
    outputs: Vec<OutPort>,
    heartbeat: RefCell<HeartbeatSender>,
    /// What the heartbeats of waits say: `Starting` until the stage is ready.
    state: Cell<NodeState>,
    /// Outputs sent since their subscribers were last woken, in the order of their
    /// first send (capacity: every output, reserved when the ports open).
    unwoken: RefCell<Vec<usize>>,
}

struct Opener<'a, 'b> {
    bus: &'b Bus,
    decl: &'a NodeDecl,
    io: &'a mut BusIo<'b>,
    /// The trigger is left out of the first pass and opened alone, last.
    trigger: &'a str,
    trigger_pass: bool,
    error: Option<NodeError>,
}

fn connect_port<T: Message>(port: &dyn Any) {
    if let Some(s) = port.downcast_ref::<Subscriber<T>>() {
        let _ = s.update_connections();
    }
}

fn refresh_port<T: Message>(port: &dyn Any) {
    if let Some(p) = port.downcast_ref::<RefCell<Publisher<T>>>() {
        let _ = p.borrow().update_connections();
    }
}

fn wake_port<T: Message>(port: &dyn Any) -> Result<(), aisle_bus::BusError> {
    match port.downcast_ref::<RefCell<Publisher<T>>>() {
        Some(p) => p.borrow().wake(),
        None => Ok(()),
    }
}

impl TopicVisitor for Opener<'_, '_> {
    fn visit<T: Message>(&mut self, topic: Topic<T>) {
        if self.error.is_some() || (topic.name == self.trigger) != self.trigger_pass {
            return;
        }
        let listed = |l: &[String]| l.iter().any(|t| t == topic.name);
        if listed(&self.decl.subscribes) {
            match self.bus.subscriber(topic) {
                Ok(s) => self.io.inputs.push(InPort {
                    topic: topic.name,
                    port: Box::new(s),
                    connect: connect_port::<T>,
                }),
                Err(e) => self.error = Some(e.into()),
            }
        }
        if listed(&self.decl.publishes) {
            match self.bus.publisher(topic) {
                Ok(p) => self.io.outputs.push(OutPort {
                    topic: topic.name,
                    port: Box::new(RefCell::new(p)),
                    refresh: if topic.qos.history > 0 {
                        refresh_port::<T>
                    } else {
                        |_| {}
                    },
                    wake: wake_port::<T>,
                }),
                Err(e) => self.error = Some(e.into()),
            }
        }
    }
}

impl<'b> BusIo<'b> {
    /// Opens every port `decl` lists, the subscriber of `trigger` last: a restarted
    /// stage receives the history of its trigger only once every other input's
    /// subscriber exists, so the inputs of the tick it resumes at have arrived too
    /// (history reaches the ports a publisher sees when it next updates connections).
    pub fn open(bus: &'b Bus, decl: &NodeDecl, trigger: &str) -> Result<BusIo<'b>, NodeError> {
        let mut io = BusIo {
            bus,
            node: decl.name.clone(),
            inputs: Vec::new(),
            outputs: Vec::new(),
            heartbeat: RefCell::new(bus.heartbeat()?),
            state: Cell::new(NodeState::Starting),
            unwoken: RefCell::new(Vec::new()),
        };
        let mut opener = Opener {
            bus,
            decl,
            io: &mut io,
            trigger,
            trigger_pass: false,
            error: None,
        };
        topics::for_each(&mut opener);
        opener.trigger_pass = true;
        topics::visit(trigger, &mut opener);
        if let Some(e) = opener.error {
            return Err(e);
        }
        let outputs = io.outputs.len();
        io.unwoken.get_mut().reserve_exact(outputs);
        Ok(io)
    }

    fn undeclared(&self, topic: &str, how: &str) -> NodeError {
        NodeError::Protocol(format!(
            "{}: `{topic}` is not in the node's `{how}` in graph.toml",
            self.node
        ))
    }

    fn input<T: Message>(&self, topic: Topic<T>) -> Result<&Subscriber<T>, NodeError> {
        self.inputs
            .iter()
            .find(|i| i.topic == topic.name)
            .and_then(|i| i.port.downcast_ref::<Subscriber<T>>())
            .ok_or_else(|| self.undeclared(topic.name, "subscribes"))
    }

    fn output<T: Message>(&self, topic: Topic<T>) -> Result<&RefCell<Publisher<T>>, NodeError> {
        self.output_at(topic).map(|(_, p)| p)
    }

    /// The output port of `topic` and its index in `outputs`.
    fn output_at<T: Message>(
        &self,
        topic: Topic<T>,
    ) -> Result<(usize, &RefCell<Publisher<T>>), NodeError> {
        self.outputs
            .iter()
            .enumerate()
            .find(|(_, o)| o.topic == topic.name)
            .and_then(|(i, o)| Some((i, o.port.downcast_ref::<RefCell<Publisher<T>>>()?)))
            .ok_or_else(|| self.undeclared(topic.name, "publishes"))
    }

    /// Wakes the subscribers of every output sent since the last call, in the order the
    /// outputs were first sent (see the module docs). Every wait calls it first, so a
    /// stage that publishes and then waits for an answer is never left waiting on a
    /// message nobody was woken for.
    pub fn wake_subscribers(&self) -> Result<(), NodeError> {
        let mut unwoken = self.unwoken.borrow_mut();
        let mut first_error = None;
        for &i in unwoken.iter() {
            let o = &self.outputs[i];
            if let Err(e) = (o.wake)(o.port.as_ref()) {
                first_error.get_or_insert(e);
            }
        }
        unwoken.clear();
        match first_error {
            Some(e) => Err(e.into()),
            None => Ok(()),
        }
    }

    /// Heartbeat, connections to new publishers and history hand-over; runs between
    /// the sleeps of every wait.
    pub fn on_slice(&self) {
        if let Ok(mut hb) = self.heartbeat.try_borrow_mut() {
            let _ = hb.tick(self.state.get());
        }
        for i in &self.inputs {
            (i.connect)(i.port.as_ref());
        }
        for o in &self.outputs {
            (o.refresh)(o.port.as_ref());
        }
    }

    /// Sends a heartbeat now; later ones (from waits) say `state` too.
    pub fn heartbeat(&self, state: NodeState, text: &str) -> Result<(), NodeError> {
        self.heartbeat.borrow_mut().send(state, text)?;
        self.state.set(match state {
            NodeState::Ready => NodeState::Running,
            other => other,
        });
        Ok(())
    }

    /// Waits for the next trigger: the newest sample (`newest_only`) or the next in order.
    pub fn wait_trigger<T: Message>(
        &self,
        topic: Topic<T>,
        newest_only: bool,
    ) -> Result<Received<T>, NodeError> {
        let port = self.input(topic)?;
        self.wake_subscribers()?;
        loop {
            let (outcome, sample) = port.wait_for(SLICE, |_| true, || self.on_slice())?;
            if let (WaitOutcome::Matched, Some(first)) = (outcome, sample) {
                if !newest_only {
                    return Ok(first);
                }
                let mut newest = first;
                while let Some(newer) = port.receive()? {
                    newest = newer;
                }
                return Ok(newest);
            }
        }
    }
}

impl Io for BusIo<'_> {
    type Sample<'a, T: Message>
        = Received<T>
    where
        Self: 'a;

    fn latest<T: Message>(&self, topic: Topic<T>) -> Result<Option<Received<T>>, NodeError> {
        Ok(self.input(topic)?.latest()?)
    }

    fn receive<T: Message>(&self, topic: Topic<T>) -> Result<Option<Received<T>>, NodeError> {
        Ok(self.input(topic)?.receive()?)
    }

    fn wait_for<T: Message>(
        &self,
        topic: Topic<T>,
        timeout: Duration,
        pred: impl FnMut(&T) -> bool,
    ) -> Result<Option<Received<T>>, NodeError> {
        self.wake_subscribers()?;
        let (outcome, sample) = self
            .input(topic)?
            .wait_for(timeout, pred, || self.on_slice())?;
        Ok(match outcome {
            WaitOutcome::Matched => sample,
            WaitOutcome::TimedOut => None,
        })
    }

    fn publish<T: Message>(
        &self,
        topic: Topic<T>,
        stamp: Stamp,
        fill: impl FnOnce(&mut T),
    ) -> Result<(), NodeError> {
        let (i, port) = self.output_at(topic)?;
        port.borrow_mut().publish_quiet(stamp, fill)?;
        let mut unwoken = self.unwoken.borrow_mut();
        if !unwoken.contains(&i) {
            unwoken.push(i);
        }
        Ok(())
    }

    fn keep_alive(&self) {
        if let Ok(mut hb) = self.heartbeat.try_borrow_mut() {
            let _ = hb.tick(self.state.get());
        }
    }

    fn retained<T: Message>(
        &self,
        topic: Topic<T>,
        timeout: Duration,
    ) -> Result<Option<Received<T>>, NodeError> {
        self.output(topic)?;
        self.wake_subscribers()?;
        // A subscriber of one's own output, opened only to read its history once.
        let own = self.bus.subscriber(topic)?;
        let (outcome, sample) = own.wait_for(timeout, |_| true, || {})?;
        let (WaitOutcome::Matched, Some(mut newest)) = (outcome, sample) else {
            return Ok(None);
        };
        while let Some(s) = own.receive()? {
            newest = s;
        }
        Ok(Some(newest))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Graph;
    use aisle_bus::Instance;
    use aisle_messages::{NodeKind, TickMode};
    use std::path::Path;

    /// The mapper's ports on a fresh instance (as the supervisor's process: the test
    /// is both ends), and a subscriber of its local map.
    fn with_mapper_io(
        test: impl FnOnce(&BusIo<'_>, &aisle_bus::Subscriber<aisle_messages::OccupancyGrid>),
    ) {
        let inst = Instance::unique(Path::new("/tmp/aisle-node-tests"));
        {
            let (bus, _info) = Bus::create_instance(&inst, 1, TickMode::Lockstep).unwrap();
            let graph = Graph::shipped();
            let decl = graph.node(NodeKind::Mapper).unwrap();
            let io = BusIo::open(&bus, decl, topics::POINT_CLOUD.name).unwrap();
            let local = bus.subscriber(topics::LOCAL_MAP).unwrap();
            test(&io, &local);
        }
        inst.remove().unwrap();
    }

    fn names(io: &BusIo<'_>) -> Vec<&'static str> {
        let unwoken = io.unwoken.borrow();
        unwoken.iter().map(|&i| io.outputs[i].topic).collect()
    }

    #[test]
    fn a_cycle_sends_at_once_and_wakes_each_output_once_after_it_in_the_order_sent() {
        with_mapper_io(|io, local| {
            let stamp = |tick| Stamp {
                tick,
                ..Stamp::default()
            };
            io.publish(topics::LOCAL_MAP, stamp(1), |m| m.version = 1)
                .unwrap();
            io.publish(topics::GLOBAL_MAP_CHANGES, stamp(1), |_| {})
                .unwrap();
            io.publish(topics::LOCAL_MAP, stamp(2), |m| m.version = 2)
                .unwrap();
            // Delivered as sent, before anyone is woken.
            let versions: Vec<u64> = std::iter::from_fn(|| local.receive().unwrap())
                .map(|m| m.version)
                .collect();
            assert_eq!(versions, [1, 2]);
            assert_eq!(
                names(io),
                [topics::LOCAL_MAP.name, topics::GLOBAL_MAP_CHANGES.name]
            );
            io.wake_subscribers().unwrap();
            assert!(names(io).is_empty());
        });
    }

    #[test]
    fn every_wait_wakes_what_was_sent_before_it_sleeps() {
        with_mapper_io(|io, _local| {
            io.publish(topics::LOCAL_MAP, Stamp::default(), |_| {})
                .unwrap();
            let got = io
                .wait_for(topics::MAPPER_CONTROL, Duration::ZERO, |_| true)
                .unwrap();
            assert!(got.is_none());
            assert!(names(io).is_empty(), "wait_for");
            io.publish(topics::LOCAL_MAP, Stamp::default(), |_| {})
                .unwrap();
            assert!(io.retained(topics::LOCAL_MAP, Duration::ZERO).is_ok());
            assert!(names(io).is_empty(), "retained");
        });
    }
}

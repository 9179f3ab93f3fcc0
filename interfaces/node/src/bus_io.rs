//! [`BusIo`]: a node's ports in shared memory, opened from its graph declaration.
//!
//! Ports are opened once, when the node starts, for exactly the topics the graph lists
//! for it; a stage that reads or writes a topic its declaration does not list gets an
//! error naming the node and the topic. Waits heartbeat and hand the history of this
//! node's state outputs to subscribers that (re)joined, so no stage has to.

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
}

pub struct BusIo<'b> {
    bus: &'b Bus,
    node: String,
    inputs: Vec<InPort>,
    outputs: Vec<OutPort>,
    heartbeat: RefCell<HeartbeatSender>,
    /// What the heartbeats of waits say: `Starting` until the stage is ready.
    state: Cell<NodeState>,
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
        match opener.error {
            Some(e) => Err(e),
            None => Ok(io),
        }
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
        self.outputs
            .iter()
            .find(|o| o.topic == topic.name)
            .and_then(|o| o.port.downcast_ref::<RefCell<Publisher<T>>>())
            .ok_or_else(|| self.undeclared(topic.name, "publishes"))
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
        self.output(topic)?.borrow_mut().publish(stamp, fill)?;
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

//! [`MemIo`]: an in-memory [`Io`] for unit tests of stages. Inputs are queued per topic
//! with [`MemIo::push`]; published outputs are kept per topic and read back with
//! [`MemIo::published`]. Nothing is launched and no shared memory is used.

use crate::Io;
use aisle_bus::{NodeError, Stamp};
use aisle_messages::{Message, Topic, zeroed_box};
use std::any::Any;
use std::cell::{Cell, RefCell};
use std::collections::{HashMap, VecDeque};
use std::time::Duration;

#[derive(Default)]
pub struct MemIo {
    inputs: RefCell<HashMap<&'static str, VecDeque<Box<dyn Any>>>>,
    outputs: RefCell<HashMap<&'static str, Vec<Box<dyn Any>>>>,
    retained: RefCell<HashMap<&'static str, Box<dyn Any>>>,
    keep_alives: Cell<u64>,
}

impl MemIo {
    pub fn new() -> Self {
        Self::default()
    }

    /// Queues an input sample of `topic`, filled by `fill` from zero.
    pub fn push<T: Message>(&self, topic: Topic<T>, fill: impl FnOnce(&mut T)) {
        let mut m = zeroed_box::<T>();
        fill(&mut m);
        self.inputs
            .borrow_mut()
            .entry(topic.name)
            .or_default()
            .push_back(m);
    }

    /// Sets what [`Io::retained`] returns (once) for `topic` (state kept across a crash).
    pub fn retain<T: Message>(&self, topic: Topic<T>, fill: impl FnOnce(&mut T)) {
        let mut m = zeroed_box::<T>();
        fill(&mut m);
        self.retained.borrow_mut().insert(topic.name, m);
    }

    /// How many times the stage said it is alive ([`Io::keep_alive`]).
    pub fn keep_alives(&self) -> u64 {
        self.keep_alives.get()
    }

    /// How many samples of `topic` were published so far.
    pub fn published_len<T: Message>(&self, topic: Topic<T>) -> usize {
        self.outputs.borrow().get(topic.name).map_or(0, Vec::len)
    }

    /// The `i`-th sample published on `topic`, passed to `read`.
    pub fn published<T: Message, R>(
        &self,
        topic: Topic<T>,
        i: usize,
        read: impl FnOnce(&T) -> R,
    ) -> Option<R> {
        let outputs = self.outputs.borrow();
        let m = outputs.get(topic.name)?.get(i)?.downcast_ref::<T>()?;
        Some(read(m))
    }

    fn pop<T: Message>(&self, topic: Topic<T>) -> Option<Box<T>> {
        let mut inputs = self.inputs.borrow_mut();
        let m = inputs.get_mut(topic.name)?.pop_front()?;
        m.downcast::<T>().ok()
    }
}

impl Io for MemIo {
    type Sample<'a, T: Message>
        = Box<T>
    where
        Self: 'a;

    fn latest<T: Message>(&self, topic: Topic<T>) -> Result<Option<Box<T>>, NodeError> {
        let mut newest = None;
        while let Some(m) = self.pop(topic) {
            newest = Some(m);
        }
        Ok(newest)
    }

    fn receive<T: Message>(&self, topic: Topic<T>) -> Result<Option<Box<T>>, NodeError> {
        Ok(self.pop(topic))
    }

    fn wait_for<T: Message>(
        &self,
        topic: Topic<T>,
        _timeout: Duration,
        mut pred: impl FnMut(&T) -> bool,
    ) -> Result<Option<Box<T>>, NodeError> {
        while let Some(m) = self.pop(topic) {
            if pred(&m) {
                return Ok(Some(m));
            }
        }
        Ok(None)
    }

    fn publish<T: Message>(
        &self,
        topic: Topic<T>,
        stamp: Stamp,
        fill: impl FnOnce(&mut T),
    ) -> Result<(), NodeError> {
        let mut m = zeroed_box::<T>();
        fill(&mut m);
        let h = m.header_mut();
        h.stamp_ns = stamp.stamp_ns;
        h.tick = stamp.tick;
        h.tick_wall_ns = stamp.tick_wall_ns;
        self.outputs
            .borrow_mut()
            .entry(topic.name)
            .or_default()
            .push(m);
        Ok(())
    }

    fn keep_alive(&self) {
        self.keep_alives.set(self.keep_alives.get() + 1);
    }

    fn retained<T: Message>(
        &self,
        topic: Topic<T>,
        _timeout: Duration,
    ) -> Result<Option<Box<T>>, NodeError> {
        let m = self.retained.borrow_mut().remove(topic.name);
        Ok(m.and_then(|m| m.downcast::<T>().ok()))
    }
}

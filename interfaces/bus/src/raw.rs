//! Ports whose message type is known only by the topic's name at run time (recorders,
//! replays, the supervisor's retained state): payloads go in and out as the exact bytes
//! that lie in shared memory. The type is looked up once, when the port is opened.
//!
//! A payload comes out as its used part ([`used_bytes`]): the bytes past it are zero,
//! and a 16 MiB global map holding a 60 kB map is not read (nor its shared-memory pages
//! faulted in) to its end. A payload goes in whole or as such a prefix.

use crate::{Bus, BusError, Publisher, Subscriber, WaitOutcome, used_bytes};
use aisle_messages::{Message, Topic, TopicVisitor, topics};
use std::time::Duration;

/// A publisher of recorded or retained payloads, whatever the message type.
pub trait RawPublisher {
    /// Publishes an exact copy of `bytes` (header included; a prefix of the message, the
    /// rest zero).
    fn publish_raw(&mut self, bytes: &[u8]) -> Result<(), BusError>;
    /// Hands the history to subscribers that (re)joined.
    fn update_connections(&self) -> Result<(), BusError>;
}

/// A subscriber that hands out payloads as bytes, whatever the message type: each
/// payload's used part ([`used_bytes`]), past which the message is zero.
pub trait RawSubscriber {
    /// The size of the topic's message type: what a payload is, zero-padded.
    fn message_size(&self) -> usize;
    /// Calls `f` with the next payload in arrival order; false when none is waiting.
    fn receive_raw(&self, f: &mut dyn FnMut(&[u8])) -> Result<bool, BusError>;
    /// Replaces `copy` with the newest payload, if one arrived (older ones are dropped).
    fn latest_into(&self, copy: &mut Vec<u8>) -> Result<bool, BusError>;
    /// Sleeps until a payload arrives (then calls `f` with it) or `timeout` passes;
    /// false on timeout. A stop request ends the wait with `BusError::StopRequested`.
    fn wait_raw(&self, timeout: Duration, f: &mut dyn FnMut(&[u8])) -> Result<bool, BusError>;
}

impl<M: Message> RawPublisher for Publisher<M> {
    fn publish_raw(&mut self, bytes: &[u8]) -> Result<(), BusError> {
        self.publish_bytes(bytes)
    }
    fn update_connections(&self) -> Result<(), BusError> {
        Publisher::update_connections(self)
    }
}

impl<M: Message> RawSubscriber for Subscriber<M> {
    fn message_size(&self) -> usize {
        std::mem::size_of::<M>()
    }
    fn receive_raw(&self, f: &mut dyn FnMut(&[u8])) -> Result<bool, BusError> {
        match self.receive()? {
            Some(s) => {
                f(used_bytes(&*s));
                Ok(true)
            }
            None => Ok(false),
        }
    }
    fn latest_into(&self, copy: &mut Vec<u8>) -> Result<bool, BusError> {
        match self.latest()? {
            Some(s) => {
                copy.clear();
                copy.extend_from_slice(used_bytes(&*s));
                Ok(true)
            }
            None => Ok(false),
        }
    }
    fn wait_raw(&self, timeout: Duration, f: &mut dyn FnMut(&[u8])) -> Result<bool, BusError> {
        match self.wait_for(timeout, |_| true, || {})? {
            (WaitOutcome::Matched, Some(s)) => {
                f(used_bytes(&*s));
                Ok(true)
            }
            _ => Ok(false),
        }
    }
}

enum Want {
    Publisher,
    Subscriber,
}

enum Opened {
    Publisher(Box<dyn RawPublisher>),
    Subscriber(Box<dyn RawSubscriber>),
}

struct Opener<'b> {
    bus: &'b Bus,
    want: Want,
    opened: Option<Result<Opened, BusError>>,
}

impl TopicVisitor for Opener<'_> {
    fn visit<T: Message>(&mut self, topic: Topic<T>) {
        self.opened = Some(match self.want {
            Want::Publisher => self
                .bus
                .publisher(topic)
                .map(|p| Opened::Publisher(Box::new(p))),
            Want::Subscriber => self
                .bus
                .subscriber(topic)
                .map(|s| Opened::Subscriber(Box::new(s))),
        });
    }
}

impl Bus {
    fn open_raw(&self, name: &str, want: Want) -> Result<Option<Opened>, BusError> {
        let mut opener = Opener {
            bus: self,
            want,
            opened: None,
        };
        topics::visit(name, &mut opener);
        opener.opened.transpose()
    }

    /// A raw publisher on the topic called `name`; `None` when no topic has that name.
    pub fn raw_publisher(&self, name: &str) -> Result<Option<Box<dyn RawPublisher>>, BusError> {
        Ok(match self.open_raw(name, Want::Publisher)? {
            Some(Opened::Publisher(p)) => Some(p),
            _ => None,
        })
    }

    /// A raw subscriber on the topic called `name`; `None` when no topic has that name.
    pub fn raw_subscriber(&self, name: &str) -> Result<Option<Box<dyn RawSubscriber>>, BusError> {
        Ok(match self.open_raw(name, Want::Subscriber)? {
            Some(Opened::Subscriber(s)) => Some(s),
            _ => None,
        })
    }
}

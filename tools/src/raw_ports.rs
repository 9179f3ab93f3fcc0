//! Type-erased bus ports opened by topic name: a [`RawSink`] publishes recorded bytes and
//! a [`RawSource`] hands received samples over as bytes, whatever the message type.
//!
//! One opener serves both: the topic table's visitor finds the typed topic of a name and
//! [`Opens`] says which port to make of it. Knows the bus and the topic table; not what
//! the bytes mean, nor which topics a caller wants.

use aisle_bus::{Bus, BusError, Publisher, Subscriber};
use aisle_messages::topics::{Topic, TopicVisitor};
use aisle_messages::{Message, topics};
use std::marker::PhantomData;

/// A publisher of recorded bytes, whatever its message type.
pub(crate) trait RawSink {
    fn publish(&mut self, bytes: &[u8]) -> Result<(), BusError>;
}

impl<M: Message> RawSink for Publisher<M> {
    fn publish(&mut self, bytes: &[u8]) -> Result<(), BusError> {
        self.publish_bytes(bytes)
    }
}

/// A subscriber whose samples are handed over as bytes, whatever its message type.
pub(crate) trait RawSource {
    /// Calls `f` with the next sample's bytes; false when there was none.
    fn next_bytes(&self, f: &mut dyn FnMut(&[u8])) -> Result<bool, BusError>;
}

impl<M: Message> RawSource for Subscriber<M> {
    fn next_bytes(&self, f: &mut dyn FnMut(&[u8])) -> Result<bool, BusError> {
        match self.receive()? {
            Some(sample) => {
                f(crate::aligned::message_bytes::<M>(&sample));
                Ok(true)
            }
            None => Ok(false),
        }
    }
}

/// Which port to make of a typed topic.
trait Opens {
    type Port: ?Sized;
    fn open<T: Message>(bus: &Bus, topic: Topic<T>) -> Result<Box<Self::Port>, BusError>;
}

struct Sinks;

impl Opens for Sinks {
    type Port = dyn RawSink;
    fn open<T: Message>(bus: &Bus, topic: Topic<T>) -> Result<Box<dyn RawSink>, BusError> {
        Ok(Box::new(bus.publisher(topic)?))
    }
}

struct Sources;

impl Opens for Sources {
    type Port = dyn RawSource;
    fn open<T: Message>(bus: &Bus, topic: Topic<T>) -> Result<Box<dyn RawSource>, BusError> {
        Ok(Box::new(bus.subscriber(topic)?))
    }
}

/// The visitor that opens the port of the one topic it is shown.
struct Opener<'b, K: Opens> {
    bus: &'b Bus,
    made: Option<Result<Box<K::Port>, BusError>>,
    kind: PhantomData<K>,
}

impl<K: Opens> TopicVisitor for Opener<'_, K> {
    fn visit<T: Message>(&mut self, topic: Topic<T>) {
        self.made = Some(K::open(self.bus, topic));
    }
}

fn open<K: Opens>(bus: &Bus, service: &str) -> Result<Option<Box<K::Port>>, BusError> {
    let mut opener = Opener::<K> {
        bus,
        made: None,
        kind: PhantomData,
    };
    topics::visit(service, &mut opener);
    opener.made.transpose()
}

/// A publisher of raw payloads on `service`; `None` when no topic has that name.
pub(crate) fn open_sink(bus: &Bus, service: &str) -> Result<Option<Box<dyn RawSink>>, BusError> {
    open::<Sinks>(bus, service)
}

/// A subscriber of raw payloads on `service`; `None` when no topic has that name.
pub(crate) fn open_source(
    bus: &Bus,
    service: &str,
) -> Result<Option<Box<dyn RawSource>>, BusError> {
    open::<Sources>(bus, service)
}

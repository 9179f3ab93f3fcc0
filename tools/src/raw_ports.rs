//! Type-erased bus ports opened by topic name, under the names the tools use: a
//! [`RawSink`] publishes recorded bytes and a [`RawSource`] hands received samples over
//! as bytes, whatever the message type. The ports themselves are `aisle_bus`'s.

use aisle_bus::{Bus, BusError};

pub(crate) use aisle_bus::{RawPublisher as RawSink, RawSubscriber as RawSource};

/// A publisher of raw payloads on `service`; `None` when no topic has that name.
pub(crate) fn open_sink(bus: &Bus, service: &str) -> Result<Option<Box<dyn RawSink>>, BusError> {
    bus.raw_publisher(service)
}

/// A subscriber of raw payloads on `service`; `None` when no topic has that name.
pub(crate) fn open_source(
    bus: &Bus,
    service: &str,
) -> Result<Option<Box<dyn RawSource>>, BusError> {
    bus.raw_subscriber(service)
}

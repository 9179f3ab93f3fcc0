//! Services held open without ports, by topic name: a host's link bridges only services
//! that exist on its host, and a service must exist with the settings every process opens
//! it with (its [`Qos`](aisle_messages::Qos) and [`crate::SERVICE_SETTINGS`]) before a
//! link sees it, or the link would create it with iceoryx2's defaults, which the
//! processes could then not open.

use crate::port::{event_service, pubsub_service};
use crate::{Bus, BusError};
use aisle_messages::{Message, Topic, TopicVisitor, topics};
use std::any::Any;

/// The publish/subscribe and event halves of one topic's service, kept open while held.
pub struct HeldService {
    name: String,
    _factories: Box<dyn Any>,
}

impl HeldService {
    pub fn name(&self) -> &str {
        &self.name
    }
}

struct Holder<'b> {
    bus: &'b Bus,
    held: Option<Result<HeldService, BusError>>,
}

impl TopicVisitor for Holder<'_> {
    fn visit<T: Message>(&mut self, topic: Topic<T>) {
        let open = || -> Result<HeldService, BusError> {
            let pubsub = pubsub_service::<T>(&self.bus.node, topic.name, &topic.qos)?;
            let event = event_service(&self.bus.node, topic.name)?;
            Ok(HeldService {
                name: topic.name.to_string(),
                _factories: Box::new((pubsub, event)),
            })
        };
        self.held = Some(open());
    }
}

impl Bus {
    /// Opens (or creates) the service of the topic called `name` with its agreed
    /// settings and holds it open; `None` when no topic has that name.
    pub fn hold_service(&self, name: &str) -> Result<Option<HeldService>, BusError> {
        let mut holder = Holder {
            bus: self,
            held: None,
        };
        topics::visit(name, &mut holder);
        holder.held.transpose()
    }
}

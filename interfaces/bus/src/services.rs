//! The publish/subscribe services of an instance as iceoryx2 lists them: name, payload
//! type name and, for the topics of the topic table, how many publishers and
//! subscribers are connected. For tools that look at a group from outside
//! (`aisle topics`); knows nothing of what the services carry.

use crate::{Bus, BusError};
use aisle_messages::{Message, Topic, TopicVisitor, topics};
use iceoryx2::prelude::*;
use iceoryx2::service::static_config::messaging_pattern::MessagingPattern;

/// One publish/subscribe service of the instance.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServiceSummary {
    pub name: String,
    /// The payload's type name as iceoryx2 compares it (`aisle.RobotState.v1`).
    pub type_name: String,
    /// Connected publishers and subscribers; `None` for a service that is not in the
    /// topic table (its type is unknown to this build, so it cannot be opened).
    pub ports: Option<(usize, usize)>,
}

struct Counter<'b> {
    bus: &'b Bus,
    counted: Option<(usize, usize)>,
}

impl TopicVisitor for Counter<'_> {
    fn visit<T: Message>(&mut self, topic: Topic<T>) {
        let Ok(name) = ServiceName::new(topic.name) else {
            return;
        };
        // Opened without any requirement, so it never conflicts with the creator's QoS.
        if let Ok(svc) = self
            .bus
            .node
            .service_builder(&name)
            .publish_subscribe::<T>()
            .open()
        {
            let d = svc.dynamic_config();
            self.counted = Some((d.number_of_publishers(), d.number_of_subscribers()));
        }
    }
}

impl Bus {
    /// Every publish/subscribe service of this instance, sorted by name.
    pub fn services(&self) -> Result<Vec<ServiceSummary>, BusError> {
        let mut found = Vec::new();
        ipc::Service::list(&self.config, |details| {
            if let MessagingPattern::PublishSubscribe(p) =
                details.static_details.messaging_pattern()
            {
                found.push((
                    details.static_details.name().to_string(),
                    p.message_type_details().payload.type_name().to_string(),
                ));
            }
            CallbackProgression::Continue
        })
        .map_err(|e| BusError::Instance {
            prefix: self.instance().prefix.clone(),
            what: format!("cannot list its services: {e:?}"),
        })?;
        let mut out: Vec<ServiceSummary> = found
            .into_iter()
            .map(|(name, type_name)| {
                let mut counter = Counter {
                    bus: self,
                    counted: None,
                };
                let known = topics::info(&name).is_some_and(|t| t.type_name == type_name);
                if known {
                    topics::visit(&name, &mut counter);
                }
                ServiceSummary {
                    name,
                    type_name,
                    ports: counter.counted,
                }
            })
            .collect();
        out.sort_by(|a, b| a.name.cmp(&b.name));
        Ok(out)
    }
}

//! Request/response over two pub/sub services (so a recorder sees both directions):
//! the caller stamps a request id, the server echoes it, and the caller waits for the
//! matching answer with a deadline, so a request never hangs.

use crate::{BusError, Publisher, Received, Stamp, Subscriber, WaitOutcome};
use aisle_messages::{Message, PlanRequest, PlanResponse};
use std::time::Duration;

/// Messages that carry the id of the request they belong to.
pub trait Correlated {
    fn request_id(&self) -> u64;
    fn set_request_id(&mut self, id: u64);
}

impl Correlated for PlanRequest {
    fn request_id(&self) -> u64 {
        self.request_id
    }
    fn set_request_id(&mut self, id: u64) {
        self.request_id = id;
    }
}

impl Correlated for PlanResponse {
    fn request_id(&self) -> u64 {
        self.request_id
    }
    fn set_request_id(&mut self, id: u64) {
        self.request_id = id;
    }
}

/// The calling side.
pub struct Client<Req: Message + Correlated, Resp: Message + Correlated> {
    requests: Publisher<Req>,
    responses: Subscriber<Resp>,
    next_id: u64,
}

impl<Req: Message + Correlated, Resp: Message + Correlated> Client<Req, Resp> {
    /// Connects both ports to the peers that exist now (see
    /// [`Subscriber::update_connections`]).
    pub fn update_connections(&self) -> Result<(), BusError> {
        self.requests.update_connections()?;
        self.responses.update_connections()
    }

    pub fn new(requests: Publisher<Req>, responses: Subscriber<Resp>) -> Self {
        Self {
            requests,
            responses,
            next_id: 1,
        }
    }

    /// Sends a request filled by `fill` and returns its id.
    pub fn send(&mut self, stamp: Stamp, fill: impl FnOnce(&mut Req)) -> Result<u64, BusError> {
        let id = self.next_id;
        self.next_id += 1;
        // Answers to earlier requests that timed out are stale now.
        while self.responses.receive()?.is_some() {}
        self.requests.publish(stamp, |m| {
            fill(m);
            m.set_request_id(id);
        })?;
        Ok(id)
    }

    /// Waits for the answer to request `id`; `None` when `timeout` passes first.
    /// `on_slice` runs between sleeps (heartbeats, child supervision).
    pub fn wait(
        &mut self,
        id: u64,
        timeout: Duration,
        on_slice: impl FnMut(),
    ) -> Result<Option<Received<Resp>>, BusError> {
        let (outcome, sample) =
            self.responses
                .wait_for(timeout, |r| r.request_id() == id, on_slice)?;
        Ok(match outcome {
            WaitOutcome::Matched => sample,
            WaitOutcome::TimedOut => None,
        })
    }
}

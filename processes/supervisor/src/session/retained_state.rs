//! The state that must survive a node's crash. A publisher's history dies with its
//! process, so the supervisor keeps a copy of the newest simulator state, global map
//! and controller band, and publishes it again when that node is restarted; the
//! successor resumes from it. Knows nothing of when a node dies (see `health`).

use super::RunAborted;
use aisle_bus::{Bus, Publisher, Subscriber, message_bytes};
use aisle_messages::{ControllerBand, NodeKind, OccupancyGrid, SimState, topics};

/// The newest state each stateful node published, as raw message bytes.
pub(super) struct RetainedState {
    sim_state: Subscriber<SimState>,
    global_map: Subscriber<OccupancyGrid>,
    band: Subscriber<ControllerBand>,
    sim_state_out: Publisher<SimState>,
    global_map_out: Publisher<OccupancyGrid>,
    band_out: Publisher<ControllerBand>,
    sim_state_copy: Vec<u8>,
    global_map_copy: Vec<u8>,
    band_copy: Vec<u8>,
}

impl RetainedState {
    pub fn open(bus: &Bus) -> anyhow::Result<RetainedState> {
        Ok(RetainedState {
            sim_state: bus.subscriber(topics::SIM_STATE)?,
            global_map: bus.subscriber(topics::GLOBAL_MAP)?,
            band: bus.subscriber(topics::CONTROLLER_BAND)?,
            sim_state_out: bus.publisher(topics::SIM_STATE)?,
            global_map_out: bus.publisher(topics::GLOBAL_MAP)?,
            band_out: bus.publisher(topics::CONTROLLER_BAND)?,
            sim_state_copy: Vec::new(),
            global_map_copy: Vec::new(),
            band_copy: Vec::new(),
        })
    }

    /// Copies what each node published last (nothing new: the old copy stays).
    pub fn copy_newest(&mut self) -> Result<(), RunAborted> {
        fn keep<M: aisle_messages::Message>(
            sub: &Subscriber<M>,
            copy: &mut Vec<u8>,
        ) -> Result<(), RunAborted> {
            if let Some(s) = sub.latest()? {
                copy.clear();
                copy.extend_from_slice(message_bytes(&*s));
            }
            Ok(())
        }
        keep(&self.sim_state, &mut self.sim_state_copy)?;
        keep(&self.global_map, &mut self.global_map_copy)?;
        keep(&self.band, &mut self.band_copy)
    }

    /// Hands a restarted node the state its predecessor published, if it has any.
    pub fn republish(&mut self, kind: NodeKind) -> Result<(), RunAborted> {
        match kind {
            NodeKind::Simulator if !self.sim_state_copy.is_empty() => {
                self.sim_state_out.publish_bytes(&self.sim_state_copy)?
            }
            NodeKind::Mapper if !self.global_map_copy.is_empty() => {
                self.global_map_out.publish_bytes(&self.global_map_copy)?
            }
            NodeKind::TebController if !self.band_copy.is_empty() => {
                self.band_out.publish_bytes(&self.band_copy)?
            }
            _ => {}
        }
        Ok(())
    }

    /// Connects the republishers to nodes that (re)joined.
    pub fn update_connections(&self) -> Result<(), RunAborted> {
        self.sim_state_out.update_connections()?;
        self.global_map_out.update_connections()?;
        self.band_out.update_connections()?;
        Ok(())
    }
}

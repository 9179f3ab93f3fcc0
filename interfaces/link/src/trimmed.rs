//! A carrier that sends a message as the part of it in use: the link's frames of a
//! catalogue message stop at [`Message::used_len`] (a grid's cells, a cloud's points),
//! and the receiving side restores the zeros past it before the sample is loaned.
//!
//! The messages have fixed capacities sized for the largest warehouse (the global map
//! 16 MiB, a point cloud 1.57 MB), and a publisher keeps every byte past the used part
//! zero (`aisle_bus::Publisher::publish`). iceoryx2's tunnel sends a sample whole, so
//! without this every crossing of the seed's 60,000-cell map moved 16 MiB.
//!
//! What crosses the wire is then the sample's user header and the payload's used part;
//! a reader on the Zenoh network (not iceoryx2) pads the payload with zeros to the
//! type's size. Types outside the catalogue, dynamic payloads and event services cross
//! whole, as the wrapped carrier sends them.
//!
//! Knows the carrier and channel traits and the catalogue's `used_len`; not Zenoh,
//! which topics cross, nor the bus.

use aisle_messages::{Message, MessageTypeVisitor, visit_message_type};
use iceoryx2::service::static_config::message_type_details::TypeVariant;
use iceoryx2_bb_elementary::generation::Generation;
use iceoryx2_link_backend::service_description::{ServiceDescriptor, ServiceTypes};
use iceoryx2_link_backend::{Reactive, WakeHandle};
use iceoryx2_link_carrier::{Announcement, Carrier, Channel, Frame, Offer};

/// The used part of a payload of one message type, in bytes.
type UsedLen = fn(&[u8]) -> usize;

/// `M::used_len` of `payload` read in place; the whole payload when it is not an `M`
/// (another size, or not aligned for one).
fn used_len_of<M: Message>(payload: &[u8]) -> usize {
    if payload.len() != size_of::<M>()
        || !(payload.as_ptr() as usize).is_multiple_of(align_of::<M>())
    {
        return payload.len();
    }
    // SAFETY: the bytes are exactly an `M`'s size and aligned for it, they outlive the
    // borrow, and `M: ZeroedValid` makes every bit pattern a valid `M`.
    let m = unsafe { &*(payload.as_ptr() as *const M) };
    m.used_len().min(payload.len())
}

/// Picks [`used_len_of`] for the type the catalogue names.
struct Resolve;

impl MessageTypeVisitor for Resolve {
    type Output = UsedLen;
    fn visit<M: Message>(self) -> UsedLen {
        used_len_of::<M>
    }
}

/// How the frames of one service are cut and restored.
#[derive(Debug, Clone, Copy)]
struct Cut {
    used_len: UsedLen,
    /// User header and payload of a whole sample, bytes.
    whole: usize,
}

impl Cut {
    /// The cut of a publish-subscribe service of a fixed-size catalogue message.
    fn of(descriptor: &ServiceDescriptor) -> Option<Cut> {
        let ServiceTypes::PublishSubscribe(types) = &descriptor.types else {
            return None;
        };
        if types.payload.variant != TypeVariant::FixedSize {
            return None;
        }
        let used_len = visit_message_type(&types.payload.type_name, Resolve)?;
        Some(Cut {
            used_len,
            whole: types.user_header.size + types.payload.size,
        })
    }
}

/// Wraps a carrier so that its channels carry catalogue messages as their used part.
pub struct Trimmed<C> {
    inner: C,
}

impl<C> Trimmed<C> {
    pub fn new(inner: C) -> Trimmed<C> {
        Trimmed { inner }
    }
}

impl<C: Carrier> Carrier for Trimmed<C> {
    type AnnouncementError = C::AnnouncementError;
    type ListError = C::ListError;
    type ChannelError = C::ChannelError;
    type Channel = TrimmedChannel<C::Channel>;

    fn announce(&mut self, announcement: Announcement) -> Result<(), Self::AnnouncementError> {
        self.inner.announce(announcement)
    }

    fn generation(&self) -> Generation {
        self.inner.generation()
    }

    fn offers(&self, callback: &mut dyn FnMut(Offer)) -> Result<(), Self::ListError> {
        self.inner.offers(callback)
    }

    fn open_channel(
        &mut self,
        descriptor: &ServiceDescriptor,
    ) -> Result<Self::Channel, Self::ChannelError> {
        Ok(TrimmedChannel {
            inner: self.inner.open_channel(descriptor)?,
            cut: Cut::of(descriptor),
            restored: Vec::new(),
        })
    }
}

impl<C: Reactive> Reactive for Trimmed<C> {
    fn attach(&mut self, wake: WakeHandle) {
        self.inner.attach(wake);
    }
}

/// One service's channel: frames out as their used part, in restored to full size.
pub struct TrimmedChannel<Ch> {
    inner: Ch,
    cut: Option<Cut>,
    /// A received frame padded to a whole sample; grown once to the largest.
    restored: Vec<u8>,
}

impl<Ch: Channel> Channel for TrimmedChannel<Ch> {
    type Error = Ch::Error;

    fn send(&mut self, frame: Frame<'_>) -> Result<(), Self::Error> {
        match self.cut {
            Some(cut) => {
                let used = (cut.used_len)(frame.payload);
                self.inner.send(Frame {
                    header: frame.header,
                    payload: &frame.payload[..used],
                })
            }
            None => self.inner.send(frame),
        }
    }

    fn receive<R>(&mut self, on_frame: impl FnOnce(&[u8]) -> R) -> Result<Option<R>, Self::Error> {
        let (cut, restored) = (self.cut, &mut self.restored);
        self.inner.receive(|bytes| match cut {
            Some(cut) if bytes.len() < cut.whole => {
                restored.clear();
                restored.extend_from_slice(bytes);
                restored.resize(cut.whole, 0);
                on_frame(restored)
            }
            _ => on_frame(bytes),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_bus::message_bytes as bytes_of;
    use aisle_geometry::GridView;
    use aisle_messages::{GlobalGrid, GridMessage, RobotState, zeroed_box};

    /// A channel that keeps what it was sent and hands it back.
    #[derive(Default)]
    struct Loop {
        sent: Vec<Vec<u8>>,
    }

    impl Channel for Loop {
        type Error = std::convert::Infallible;
        fn send(&mut self, frame: Frame<'_>) -> Result<(), Self::Error> {
            self.sent.push(frame.to_bytes());
            Ok(())
        }
        fn receive<R>(&mut self, f: impl FnOnce(&[u8]) -> R) -> Result<Option<R>, Self::Error> {
            Ok(self.sent.pop().map(|b| f(&b)))
        }
    }

    fn channel<M: Message>(header: usize) -> TrimmedChannel<Loop> {
        TrimmedChannel {
            inner: Loop::default(),
            cut: Some(Cut {
                used_len: visit_message_type(M::TYPE_NAME, Resolve).expect("a catalogue type"),
                whole: header + size_of::<M>(),
            }),
            restored: Vec::new(),
        }
    }

    #[test]
    fn a_small_map_crosses_as_its_cells_and_comes_back_whole() {
        let mut grid = zeroed_box::<GlobalGrid>();
        let cells = vec![100u8; 200 * 300];
        let map = GridView::new(-5.0, -10.0, 0.1, 200, 300, &cells).unwrap();
        grid.write(0, 1, &map).expect("the seed's map fits");
        let header = [7u8; 8];
        let mut ch = channel::<GlobalGrid>(header.len());
        let payload = bytes_of(&*grid);
        ch.send(Frame {
            header: &header,
            payload,
        })
        .unwrap();
        let wire = ch.inner.sent[0].len();
        assert_eq!(wire, header.len() + grid.used_len());
        assert!(wire < 70_000, "{wire} bytes for 60,000 cells");
        let back = ch.receive(|b| b.to_vec()).unwrap().expect("a frame");
        assert_eq!(back.len(), header.len() + size_of::<GlobalGrid>());
        assert_eq!(&back[..header.len()], &header);
        assert!(back[header.len()..] == *payload, "restored byte for byte");
    }

    #[test]
    fn a_message_without_spare_capacity_crosses_whole() {
        let mut state = zeroed_box::<RobotState>();
        state.pose.x = 1.5;
        let mut ch = channel::<RobotState>(0);
        ch.send(Frame {
            header: &[],
            payload: bytes_of(&*state),
        })
        .unwrap();
        assert_eq!(ch.inner.sent[0].len(), size_of::<RobotState>());
        let back = ch.receive(|b| b.to_vec()).unwrap().expect("a frame");
        assert!(back == bytes_of(&*state));
    }

    #[test]
    fn a_payload_that_is_not_the_type_crosses_whole() {
        let odd = vec![1u8; 24];
        assert_eq!(used_len_of::<GlobalGrid>(&odd), 24);
        // Misaligned by one byte: not read in place.
        let grid = zeroed_box::<GlobalGrid>();
        let mut shifted = vec![0u8; size_of::<GlobalGrid>() + 1];
        shifted[1..].copy_from_slice(bytes_of(&*grid));
        let at = &shifted[1..];
        assert!(!(at.as_ptr() as usize).is_multiple_of(align_of::<GlobalGrid>()));
        assert_eq!(used_len_of::<GlobalGrid>(at), at.len());
    }
}

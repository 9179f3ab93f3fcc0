//! Byte buffers aligned for message types, so recorded payloads can be viewed as the
//! `#[repr(C)]` messages they are without copying field by field.
//!
//! Knows only sizes and alignment; what the bytes mean is up to the caller.

use aisle_messages::Message;

/// A byte buffer whose start is 8-byte aligned (the largest alignment of any message).
#[derive(Debug, Clone, Default)]
pub struct AlignedBuf {
    words: Vec<u64>,
    len: usize,
}

impl AlignedBuf {
    pub fn new() -> Self {
        Self::default()
    }

    /// A buffer holding a copy of `bytes`.
    pub fn from_bytes(bytes: &[u8]) -> Self {
        let mut b = Self::new();
        b.set(bytes);
        b
    }

    /// Replaces the content with `bytes`, reusing the allocation when it is large enough.
    pub fn set(&mut self, bytes: &[u8]) {
        let words = bytes.len().div_ceil(8);
        if self.words.len() < words {
            self.words.resize(words, 0);
        }
        self.len = bytes.len();
        self.bytes_mut().copy_from_slice(bytes);
    }

    /// Replaces the content with `bytes` followed by zeros up to `len` bytes (a payload
    /// stored without its trailing zeros).
    pub fn set_padded(&mut self, bytes: &[u8], len: usize) {
        let len = len.max(bytes.len());
        let words = len.div_ceil(8);
        if self.words.len() < words {
            self.words.resize(words, 0);
        }
        self.len = len;
        let out = self.bytes_mut();
        out[..bytes.len()].copy_from_slice(bytes);
        out[bytes.len()..].fill(0);
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn bytes(&self) -> &[u8] {
        // SAFETY: `words` holds at least `len` initialised bytes; u8 has alignment 1.
        unsafe { std::slice::from_raw_parts(self.words.as_ptr() as *const u8, self.len) }
    }

    fn bytes_mut(&mut self) -> &mut [u8] {
        // SAFETY: as in `bytes`, and we hold the only reference.
        unsafe { std::slice::from_raw_parts_mut(self.words.as_mut_ptr() as *mut u8, self.len) }
    }

    /// Views the bytes as a message of type `M`; `None` when the size differs.
    pub fn view<M: Message>(&self) -> Option<&M> {
        if self.len != std::mem::size_of::<M>() || std::mem::align_of::<M>() > 8 {
            return None;
        }
        // SAFETY: the buffer is 8-byte aligned and exactly `size_of::<M>()` long, and
        // `M: ZeroedValid` means every field is a plain number, so any bit pattern is a
        // valid `M`.
        Some(unsafe { &*(self.words.as_ptr() as *const M) })
    }
}

pub use aisle_bus::message_bytes;
pub use aisle_messages::zeroed_box;

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_messages::Tick;

    #[test]
    fn view_round_trips_and_checks_size() {
        let mut t = zeroed_box::<Tick>();
        t.header.seq = 7;
        t.seed = 42;
        let buf = AlignedBuf::from_bytes(message_bytes(&*t));
        assert_eq!(buf.len(), 72);
        assert_eq!(buf.view::<Tick>().unwrap().seed, 42);
        let mut padded = AlignedBuf::from_bytes(&[7; 100]);
        let bytes = message_bytes(&*t);
        padded.set_padded(&bytes[..crate::writer::trimmed_len(bytes)], 72);
        assert_eq!(padded.bytes(), message_bytes(&*t));
        let short = AlignedBuf::from_bytes(&message_bytes(&*t)[..71]);
        assert!(short.view::<Tick>().is_none());
    }
}

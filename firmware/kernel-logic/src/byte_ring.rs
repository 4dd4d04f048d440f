//! A first-in first-out ring of bytes with a fixed capacity, for the kernel's link receive path:
//! the receive interrupt pushes what the UART holds, the I/O partition's `SYS_LINK_READ` takes
//! it out. A full ring refuses the byte (the caller leaves it in the UART and counts the
//! occasion); it never overwrites.

/// A ring of at most `N` bytes (`N` > 0).
pub struct ByteRing<const N: usize> {
    bytes: [u8; N],
    /// Index of the oldest byte.
    head: usize,
    len: usize,
}

impl<const N: usize> Default for ByteRing<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> ByteRing<N> {
    pub const CAPACITY: usize = N;

    pub const fn new() -> Self {
        assert!(N > 0, "a ring needs room for at least one byte");
        Self {
            bytes: [0; N],
            head: 0,
            len: 0,
        }
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn is_full(&self) -> bool {
        self.len == N
    }

    /// Bytes that can still be pushed.
    pub fn room(&self) -> usize {
        N - self.len
    }

    /// Append `byte`; false (and nothing changes) when the ring is full.
    pub fn push(&mut self, byte: u8) -> bool {
        if self.is_full() {
            return false;
        }
        let tail = (self.head + self.len) % N;
        match self.bytes.get_mut(tail) {
            Some(slot) => {
                *slot = byte;
                self.len += 1;
                true
            }
            None => false,
        }
    }

    /// The oldest byte, removed.
    pub fn pop(&mut self) -> Option<u8> {
        if self.is_empty() {
            return None;
        }
        let byte = *self.bytes.get(self.head)?;
        self.head = (self.head + 1) % N;
        self.len -= 1;
        Some(byte)
    }

    /// Move the oldest bytes into `out`, as many as fit; returns how many.
    pub fn pop_into(&mut self, out: &mut [u8]) -> usize {
        let n = out.len().min(self.len);
        let Some((wrapped, from_head)) = self.bytes.split_at_checked(self.head) else {
            return 0;
        };
        // At most two contiguous runs: up to the end of the storage, then from its start.
        let mut given = 0;
        for run in [from_head, wrapped] {
            let to = out.get_mut(given..n).unwrap_or_default();
            let len = to.len().min(run.len());
            if let (Some(to), Some(from)) = (to.get_mut(..len), run.get(..len)) {
                to.copy_from_slice(from);
                given += len;
            }
        }
        self.head = (self.head + given) % N;
        self.len -= given;
        given
    }

    /// Forget every byte.
    pub fn clear(&mut self) {
        self.head = 0;
        self.len = 0;
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::collections::VecDeque;
    use std::vec::Vec;

    use super::ByteRing;

    #[test]
    fn bytes_come_out_in_the_order_they_went_in() {
        let mut ring = ByteRing::<8>::new();
        for b in 1..=5 {
            assert!(ring.push(b));
        }
        assert_eq!(ring.len(), 5);
        let mut out = [0u8; 3];
        assert_eq!(ring.pop_into(&mut out), 3);
        assert_eq!(out, [1, 2, 3]);
        assert_eq!(ring.pop(), Some(4));
        assert_eq!(ring.pop(), Some(5));
        assert_eq!(ring.pop(), None);
        assert!(ring.is_empty());
    }

    #[test]
    fn a_full_ring_refuses_a_byte_and_keeps_what_it_has() {
        let mut ring = ByteRing::<4>::new();
        for b in 0..4 {
            assert!(ring.push(b));
        }
        assert!(ring.is_full());
        assert_eq!(ring.room(), 0);
        assert!(!ring.push(99), "a full ring must refuse");
        let mut out = [0u8; 8];
        assert_eq!(ring.pop_into(&mut out), 4);
        assert_eq!(&out[..4], &[0, 1, 2, 3]);
    }

    #[test]
    fn reads_across_the_end_of_the_storage_come_out_whole() {
        let mut ring = ByteRing::<5>::new();
        for b in 0..4 {
            ring.push(b);
        }
        let mut out = [0u8; 3];
        ring.pop_into(&mut out);
        // head is at 3 now: these wrap around the end of the storage.
        for b in 10..14 {
            assert!(ring.push(b));
        }
        let mut out = [0u8; 5];
        assert_eq!(ring.pop_into(&mut out), 5);
        assert_eq!(out, [3, 10, 11, 12, 13]);
    }

    #[test]
    fn behaves_like_a_queue_under_any_mix_of_pushes_and_reads() {
        // A deterministic pseudo-random mix, checked against VecDeque as the model.
        let mut ring = ByteRing::<7>::new();
        let mut model = VecDeque::new();
        let mut x: u32 = 0x1234_5678;
        for step in 0..20_000u32 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            if !x.is_multiple_of(3) {
                let byte = step as u8;
                let pushed = ring.push(byte);
                assert_eq!(pushed, model.len() < 7);
                if pushed {
                    model.push_back(byte);
                }
            } else {
                let mut out = std::vec![0u8; (x as usize >> 8) % 9];
                let n = ring.pop_into(&mut out);
                let expected: Vec<u8> = (0..n).filter_map(|_| model.pop_front()).collect();
                assert_eq!(&out[..n], &expected[..]);
                assert_eq!(n, expected.len());
            }
            assert_eq!(ring.len(), model.len());
            assert_eq!(ring.room(), 7 - model.len());
        }
    }
}

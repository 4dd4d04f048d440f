//! The shared-memory link transport of the emulated target: two byte rings in a QEMU
//! `ivshmem-plain` device whose backing file the host maps too, one per direction, carrying the
//! same byte stream as the serial line (COBS frames with their 0 delimiters), so the frame codec
//! on both ends, the transcript and every decision are the same on either transport. The serial
//! line stays as the doorbell: after writing into a ring, the writer sends one byte over the
//! UART (its value means nothing), which wakes the reader (on the target, the receive interrupt
//! that ends a parked schedule). A byte per batch instead of a QEMU main-loop turn per byte.
//!
//! Layout (offsets in bytes; every word big-endian, the target's byte order):
//!
//! | offset           | word / bytes                                             | written by |
//! |------------------|----------------------------------------------------------|------------|
//! | 0x00             | magic `RLNK`                                             | host       |
//! | 0x04             | layout version ([`VERSION`])                             | host       |
//! | 0x08             | bytes of each ring ([`RING_BYTES`])                      | host       |
//! | 0x10             | host-to-target write count                               | host       |
//! | 0x14             | host-to-target read count                                | target     |
//! | 0x18             | target-to-host write count                               | target     |
//! | 0x1c             | target-to-host read count                                | host       |
//! | 0x100            | host-to-target ring data                                 | host       |
//! | 0x100+RING_BYTES | target-to-host ring data                                 | target     |
//!
//! Counts run free (wrapping); a ring holds `write - read` bytes, at most [`RING_BYTES`], at
//! `count % RING_BYTES`. Each count is written by one side only: the writer stores the data
//! before it publishes the new write count, the reader reads the data before it publishes the
//! new read count. A reader never trusts the other side's count: one that claims more than a
//! ring's worth is reported as [`RingError::Corrupt`].

/// `RLNK`.
pub const MAGIC: u32 = u32::from_be_bytes(*b"RLNK");
pub const VERSION: u32 = 1;
/// Size of the device (its BAR): a power of two, and at least the 750's smallest BAT block.
pub const DEVICE_BYTES: u32 = 128 * 1024;
/// Bytes of each ring (a power of two).
pub const RING_BYTES: u32 = 32 * 1024;

pub const OFFSET_MAGIC: usize = 0x00;
pub const OFFSET_VERSION: usize = 0x04;
pub const OFFSET_RING_BYTES: usize = 0x08;
const DATA_START: usize = 0x100;

const _: () = {
    assert!(DEVICE_BYTES.is_power_of_two() && RING_BYTES.is_power_of_two());
    assert!(DATA_START + 2 * RING_BYTES as usize <= DEVICE_BYTES as usize);
};

/// One direction: where its counts and data are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Ring {
    pub write_count: usize,
    pub read_count: usize,
    pub data: usize,
}

/// Written by the host, read by the target.
pub const HOST_TO_TARGET: Ring = Ring {
    write_count: 0x10,
    read_count: 0x14,
    data: DATA_START,
};
/// Written by the target, read by the host.
pub const TARGET_TO_HOST: Ring = Ring {
    write_count: 0x18,
    read_count: 0x1c,
    data: DATA_START + RING_BYTES as usize,
};

/// The shared memory as each side reaches it.
pub trait SharedMemory {
    /// The big-endian word at `offset`, read after everything this side read before.
    fn load_word(&self, offset: usize) -> u32;
    /// Store a big-endian word at `offset`, visible to the other side only after every byte
    /// this side wrote before it.
    fn store_word(&mut self, offset: usize, value: u32);
    fn read_bytes(&self, offset: usize, out: &mut [u8]);
    fn write_bytes(&mut self, offset: usize, data: &[u8]);
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RingError {
    /// The counts say the ring holds more than it can (the other side wrote garbage).
    Corrupt { write: u32, read: u32 },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeaderError {
    NoMagic(u32),
    Version(u32),
    RingBytes(u32),
}

/// Fill in a fresh header (host, before the target runs): magic, version, ring size, all counts
/// 0.
pub fn initialise(memory: &mut impl SharedMemory) {
    for ring in [HOST_TO_TARGET, TARGET_TO_HOST] {
        memory.store_word(ring.write_count, 0);
        memory.store_word(ring.read_count, 0);
    }
    memory.store_word(OFFSET_VERSION, VERSION);
    memory.store_word(OFFSET_RING_BYTES, RING_BYTES);
    memory.store_word(OFFSET_MAGIC, MAGIC);
}

/// Check the header the host wrote.
pub fn check_header(memory: &impl SharedMemory) -> Result<(), HeaderError> {
    let magic = memory.load_word(OFFSET_MAGIC);
    if magic != MAGIC {
        return Err(HeaderError::NoMagic(magic));
    }
    match (
        memory.load_word(OFFSET_VERSION),
        memory.load_word(OFFSET_RING_BYTES),
    ) {
        (VERSION, RING_BYTES) => Ok(()),
        (VERSION, bytes) => Err(HeaderError::RingBytes(bytes)),
        (version, _) => Err(HeaderError::Version(version)),
    }
}

/// `ring`'s write and read counts and the bytes it holds, checked.
fn counts(memory: &impl SharedMemory, ring: &Ring) -> Result<(u32, u32, u32), RingError> {
    let write = memory.load_word(ring.write_count);
    let read = memory.load_word(ring.read_count);
    let used = write.wrapping_sub(read);
    if used > RING_BYTES {
        return Err(RingError::Corrupt { write, read });
    }
    Ok((write, read, used))
}

/// Bytes waiting in `ring`.
pub fn readable(memory: &impl SharedMemory, ring: &Ring) -> Result<u32, RingError> {
    counts(memory, ring).map(|(_, _, used)| used)
}

/// The two contiguous pieces (offset within the ring's data, length) of `len` bytes at
/// `count`.
fn pieces(count: u32, len: usize) -> [(usize, usize); 2] {
    let at = (count % RING_BYTES) as usize;
    let first = len.min(RING_BYTES as usize - at);
    [(at, first), (0, len - first)]
}

/// Append as much of `data` as fits; returns how many bytes were written (0 when full).
pub fn produce(
    memory: &mut impl SharedMemory,
    ring: &Ring,
    data: &[u8],
) -> Result<usize, RingError> {
    let (write, _, used) = counts(memory, ring)?;
    let n = data.len().min((RING_BYTES - used) as usize);
    let mut taken = 0;
    for (at, len) in pieces(write, n) {
        // The pieces add up to `n`, at most `data.len()`.
        let Some(piece) = data.get(taken..taken + len) else {
            break;
        };
        memory.write_bytes(ring.data + at, piece);
        taken += len;
    }
    memory.store_word(ring.write_count, write.wrapping_add(taken as u32));
    Ok(taken)
}

/// Take up to `out.len()` bytes; returns how many.
pub fn consume(
    memory: &mut impl SharedMemory,
    ring: &Ring,
    out: &mut [u8],
) -> Result<usize, RingError> {
    let (_, read, used) = counts(memory, ring)?;
    let n = out.len().min(used as usize);
    let mut given = 0;
    for (at, len) in pieces(read, n) {
        // The pieces add up to `n`, at most `out.len()`.
        let Some(piece) = out.get_mut(given..given + len) else {
            break;
        };
        memory.read_bytes(ring.data + at, piece);
        given += len;
    }
    memory.store_word(ring.read_count, read.wrapping_add(given as u32));
    Ok(given)
}

/// Forget what `ring` holds (the reader catches up with the writer), after a corrupt count.
pub fn discard(memory: &mut impl SharedMemory, ring: &Ring) {
    let write = memory.load_word(ring.write_count);
    memory.store_word(ring.read_count, write);
}

#[cfg(test)]
mod tests {
    extern crate std;

    use std::vec;
    use std::vec::Vec;

    use super::*;

    /// The device as a byte array, words big-endian as on the target.
    struct FakeDevice(Vec<u8>);

    impl FakeDevice {
        fn new() -> Self {
            let mut device = Self(vec![0; DEVICE_BYTES as usize]);
            initialise(&mut device);
            device
        }
    }

    impl SharedMemory for FakeDevice {
        fn load_word(&self, offset: usize) -> u32 {
            u32::from_be_bytes(self.0[offset..offset + 4].try_into().unwrap())
        }
        fn store_word(&mut self, offset: usize, value: u32) {
            self.0[offset..offset + 4].copy_from_slice(&value.to_be_bytes());
        }
        fn read_bytes(&self, offset: usize, out: &mut [u8]) {
            out.copy_from_slice(&self.0[offset..offset + out.len()]);
        }
        fn write_bytes(&mut self, offset: usize, data: &[u8]) {
            self.0[offset..offset + data.len()].copy_from_slice(data);
        }
    }

    #[test]
    fn a_fresh_header_passes_and_a_foreign_one_is_refused() {
        let mut device = FakeDevice::new();
        assert_eq!(check_header(&device), Ok(()));
        assert_eq!(&device.0[..4], b"RLNK");
        device.store_word(OFFSET_RING_BYTES, 4096);
        assert_eq!(check_header(&device), Err(HeaderError::RingBytes(4096)));
        device.store_word(OFFSET_VERSION, 7);
        assert_eq!(check_header(&device), Err(HeaderError::Version(7)));
        // A non-volatile memory file never carries the magic.
        let blank = FakeDevice(vec![0; DEVICE_BYTES as usize]);
        assert_eq!(check_header(&blank), Err(HeaderError::NoMagic(0)));
    }

    #[test]
    fn bytes_cross_in_order_in_both_directions() {
        let mut device = FakeDevice::new();
        assert_eq!(produce(&mut device, &HOST_TO_TARGET, b"grant\0"), Ok(6));
        assert_eq!(produce(&mut device, &TARGET_TO_HOST, b"done\0"), Ok(5));
        assert_eq!(readable(&device, &HOST_TO_TARGET), Ok(6));
        let mut out = [0u8; 16];
        assert_eq!(consume(&mut device, &HOST_TO_TARGET, &mut out), Ok(6));
        assert_eq!(&out[..6], b"grant\0");
        assert_eq!(consume(&mut device, &TARGET_TO_HOST, &mut out), Ok(5));
        assert_eq!(&out[..5], b"done\0");
        assert_eq!(readable(&device, &HOST_TO_TARGET), Ok(0));
        assert_eq!(consume(&mut device, &HOST_TO_TARGET, &mut out), Ok(0));
    }

    #[test]
    fn a_full_ring_takes_what_fits_and_wraps_around_its_end() {
        let mut device = FakeDevice::new();
        let ring = RING_BYTES as usize;
        let big: Vec<u8> = (0..ring + 100).map(|i| (i % 251) as u8).collect();
        assert_eq!(produce(&mut device, &HOST_TO_TARGET, &big), Ok(ring));
        assert_eq!(produce(&mut device, &HOST_TO_TARGET, b"x"), Ok(0));
        let mut out = vec![0u8; ring - 10];
        assert_eq!(
            consume(&mut device, &HOST_TO_TARGET, &mut out),
            Ok(ring - 10)
        );
        assert_eq!(&out[..], &big[..ring - 10]);
        // The next write wraps around the end of the data.
        assert_eq!(produce(&mut device, &HOST_TO_TARGET, &big[ring..]), Ok(100));
        let mut rest = vec![0u8; 200];
        assert_eq!(consume(&mut device, &HOST_TO_TARGET, &mut rest), Ok(110));
        assert_eq!(&rest[..10], &big[ring - 10..ring]);
        assert_eq!(&rest[10..110], &big[ring..]);
        // Nothing spilled into the other direction's data.
        assert_eq!(readable(&device, &TARGET_TO_HOST), Ok(0));
    }

    #[test]
    fn counts_keep_working_when_they_wrap_past_u32_max() {
        let mut device = FakeDevice::new();
        let start = u32::MAX - 5;
        device.store_word(HOST_TO_TARGET.write_count, start);
        device.store_word(HOST_TO_TARGET.read_count, start);
        assert_eq!(produce(&mut device, &HOST_TO_TARGET, b"0123456789"), Ok(10));
        assert_eq!(device.load_word(HOST_TO_TARGET.write_count), 4);
        let mut out = [0u8; 10];
        assert_eq!(consume(&mut device, &HOST_TO_TARGET, &mut out), Ok(10));
        assert_eq!(&out, b"0123456789");
    }

    #[test]
    fn a_count_claiming_more_than_a_ring_is_refused_and_can_be_discarded() {
        let mut device = FakeDevice::new();
        device.store_word(HOST_TO_TARGET.write_count, RING_BYTES + 1);
        let mut out = [0u8; 8];
        assert_eq!(
            consume(&mut device, &HOST_TO_TARGET, &mut out),
            Err(RingError::Corrupt {
                write: RING_BYTES + 1,
                read: 0
            })
        );
        assert!(readable(&device, &HOST_TO_TARGET).is_err());
        discard(&mut device, &HOST_TO_TARGET);
        assert_eq!(readable(&device, &HOST_TO_TARGET), Ok(0));
        assert_eq!(produce(&mut device, &HOST_TO_TARGET, b"ok"), Ok(2));
    }
}

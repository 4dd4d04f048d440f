//! Inter-partition ports, copied by the kernel: sampling ports keep the latest message (readers
//! see its age), queuing ports keep a FIFO of `depth` messages. Every message carries its
//! sender's generation, so a receiver can recognise messages sent before the sender restarted.
//!
//! Storage is one array in kernel RAM sized from the configuration at compile time; each slot is
//! a 16-byte header (length, generation, timestamp) followed by the message.
use kernel_config::abi::SysError;
use kernel_config::{port_slot_bytes, PortKind, PORT_SLOT_HEADER};
use kernel_logic::port_queue::QueueState;

use crate::config::{PORT_COUNT, PORT_OFFSETS, PORT_STORAGE_BYTES, SYSTEM};

/// Queuing: the ring's head and count. Sampling: count 1 once written, head unused.
type PortState = QueueState;

pub struct Ports {
    state: [PortState; PORT_COUNT],
    storage: [u8; PORT_STORAGE_BYTES],
    /// Queuing-port messages dropped on receive because their sender had restarted since it
    /// sent them, since boot.
    pub stale_dropped: u32,
}

/// What a receive found.
pub struct Received {
    pub len: usize,
    pub generation: u32,
    pub sent_at: u64,
}

/// The big-endian word at `at` of a slot (0 past its end: slots are at least a header long).
fn word(bytes: &[u8], at: usize) -> u32 {
    bytes
        .get(at..)
        .and_then(|rest| rest.first_chunk::<4>())
        .map_or(0, |be| u32::from_be_bytes(*be))
}

fn put_word(bytes: &mut [u8], at: usize, value: u32) {
    if let Some(be) = bytes
        .get_mut(at..)
        .and_then(|rest| rest.first_chunk_mut::<4>())
    {
        *be = value.to_be_bytes();
    }
}

impl Ports {
    pub const fn new() -> Self {
        Self {
            state: [QueueState::EMPTY; PORT_COUNT],
            storage: [0; PORT_STORAGE_BYTES],
            stale_dropped: 0,
        }
    }

    /// Slot `index` of `port` in the storage (the configuration sized the storage for every
    /// slot of every port at compile time, so only a bad port or index misses).
    fn slot(&mut self, port: usize, index: usize) -> Result<&mut [u8], SysError> {
        let config = SYSTEM.ports.get(port).ok_or(SysError::BadPort)?;
        let size = port_slot_bytes(config);
        let start = PORT_OFFSETS.get(port).ok_or(SysError::BadPort)? + index * size;
        self.storage
            .get_mut(start..start + size)
            .ok_or(SysError::BadPort)
    }

    /// `sender` sends `message` on `port`.
    pub fn send(
        &mut self,
        sender: usize,
        port: usize,
        message: &[u8],
        generation: u32,
        now: u64,
    ) -> Result<(), SysError> {
        let config = SYSTEM.ports.get(port).ok_or(SysError::BadPort)?;
        if config.source != sender {
            return Err(SysError::BadPort);
        }
        if message.len() > config.message_size as usize {
            return Err(SysError::TooBig);
        }
        let index = match config.kind {
            PortKind::Sampling => 0,
            PortKind::Queuing => self
                .state
                .get(port)
                .ok_or(SysError::BadPort)?
                .push_slot(config.depth)
                .ok_or(SysError::Full)?,
        };
        let slot = self.slot(port, index)?;
        let body = slot
            .get_mut(PORT_SLOT_HEADER..PORT_SLOT_HEADER + message.len())
            .ok_or(SysError::TooBig)?;
        body.copy_from_slice(message);
        put_word(slot, 0, message.len() as u32);
        put_word(slot, 4, generation);
        put_word(slot, 8, (now >> 32) as u32);
        put_word(slot, 12, now as u32);
        let state = self.state.get_mut(port).ok_or(SysError::BadPort)?;
        match config.kind {
            PortKind::Sampling => state.count = 1,
            PortKind::Queuing => state.pushed(),
        }
        Ok(())
    }

    /// True if any queuing port holds a message its destination has not taken.
    pub fn any_queued(&self) -> bool {
        SYSTEM
            .ports
            .iter()
            .zip(self.state.iter())
            .any(|(config, state)| config.kind == PortKind::Queuing && state.count > 0)
    }

    /// Messages waiting in `port` (queuing ports; 0 or 1 for a sampling port).
    pub fn queued(&self, port: usize) -> u16 {
        self.state.get(port).map_or(0, |s| s.count)
    }

    /// The port's source partition, for the caller to look up its current generation.
    pub fn source(port: usize) -> Option<usize> {
        SYSTEM.ports.get(port).map(|config| config.source)
    }

    /// `receiver` takes (queuing) or reads (sampling) the next message on `port` into `buffer`.
    /// On a queuing port, messages sent before the sender's current generation
    /// (`sender_generation`) are dropped first and counted.
    pub fn receive(
        &mut self,
        receiver: usize,
        port: usize,
        buffer: &mut [u8],
        sender_generation: u32,
    ) -> Result<Received, SysError> {
        let config = SYSTEM.ports.get(port).ok_or(SysError::BadPort)?;
        if !config.destinations.contains(&receiver) {
            return Err(SysError::BadPort);
        }
        let base = *PORT_OFFSETS.get(port).ok_or(SysError::BadPort)?;
        let state = self.state.get_mut(port).ok_or(SysError::BadPort)?;
        if config.kind == PortKind::Queuing && state.count > 0 {
            let size = port_slot_bytes(config);
            let storage = &self.storage;
            let dropped = state.drop_stale(config.depth, sender_generation, |index| {
                word(storage, base + index * size + 4)
            });
            self.stale_dropped = self.stale_dropped.wrapping_add(u32::from(dropped));
        }
        let state = *state;
        if state.count == 0 {
            return Err(SysError::Empty);
        }
        let index = match config.kind {
            PortKind::Sampling => 0,
            PortKind::Queuing => state.head as usize,
        };
        let slot = self.slot(port, index)?;
        let len = word(slot, 0) as usize;
        let (Some(to), Some(from)) = (
            buffer.get_mut(..len),
            slot.get(PORT_SLOT_HEADER..PORT_SLOT_HEADER + len),
        ) else {
            return Err(SysError::TooBig);
        };
        let received = Received {
            len,
            generation: word(slot, 4),
            sent_at: (u64::from(word(slot, 8)) << 32) | u64::from(word(slot, 12)),
        };
        to.copy_from_slice(from);
        if config.kind == PortKind::Queuing {
            if let Some(state) = self.state.get_mut(port) {
                let _ = state.pop(config.depth);
            }
        }
        Ok(received)
    }
}

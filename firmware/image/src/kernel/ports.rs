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

fn word(bytes: &[u8], at: usize) -> u32 {
    u32::from_be_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
}

fn put_word(bytes: &mut [u8], at: usize, value: u32) {
    bytes[at..at + 4].copy_from_slice(&value.to_be_bytes());
}

impl Ports {
    pub const fn new() -> Self {
        Self {
            state: [QueueState::EMPTY; PORT_COUNT],
            storage: [0; PORT_STORAGE_BYTES],
            stale_dropped: 0,
        }
    }

    fn slot(&mut self, port: usize, index: usize) -> &mut [u8] {
        let size = port_slot_bytes(&SYSTEM.ports[port]);
        let start = PORT_OFFSETS[port] + index * size;
        &mut self.storage[start..start + size]
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
            PortKind::Queuing => self.state[port]
                .push_slot(config.depth)
                .ok_or(SysError::Full)?,
        };
        let slot = self.slot(port, index);
        put_word(slot, 0, message.len() as u32);
        put_word(slot, 4, generation);
        put_word(slot, 8, (now >> 32) as u32);
        put_word(slot, 12, now as u32);
        slot[PORT_SLOT_HEADER..PORT_SLOT_HEADER + message.len()].copy_from_slice(message);
        let state = &mut self.state[port];
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
        if config.kind == PortKind::Queuing && self.state[port].count > 0 {
            let size = port_slot_bytes(config);
            let base = PORT_OFFSETS[port];
            let storage = &self.storage;
            let dropped = self.state[port].drop_stale(config.depth, sender_generation, |index| {
                word(storage, base + index * size + 4)
            });
            self.stale_dropped = self.stale_dropped.wrapping_add(u32::from(dropped));
        }
        let state = self.state[port];
        if state.count == 0 {
            return Err(SysError::Empty);
        }
        let index = match config.kind {
            PortKind::Sampling => 0,
            PortKind::Queuing => state.head as usize,
        };
        let slot = self.slot(port, index);
        let len = word(slot, 0) as usize;
        if len > buffer.len() {
            return Err(SysError::TooBig);
        }
        let received = Received {
            len,
            generation: word(slot, 4),
            sent_at: (u64::from(word(slot, 8)) << 32) | u64::from(word(slot, 12)),
        };
        buffer[..len].copy_from_slice(&slot[PORT_SLOT_HEADER..PORT_SLOT_HEADER + len]);
        if config.kind == PortKind::Queuing {
            let _ = self.state[port].pop(config.depth);
        }
        Ok(received)
    }
}

//! Inter-partition ports, copied by the kernel: sampling ports keep the latest message (readers
//! see its age), queuing ports keep a FIFO of `depth` messages. Every message carries its
//! sender's generation, so a receiver can recognise messages sent before the sender restarted.
//!
//! Storage is one array in kernel RAM sized from the configuration at compile time; each slot is
//! a 16-byte header (length, generation, timestamp) followed by the message.
use kernel_config::abi::SysError;
use kernel_config::{port_slot_bytes, PortKind, PORT_SLOT_HEADER};

use crate::config::{PORT_COUNT, PORT_OFFSETS, PORT_STORAGE_BYTES, SYSTEM};

#[derive(Clone, Copy)]
struct PortState {
    /// Queuing: index of the oldest message. Sampling: unused.
    head: u16,
    /// Queuing: messages held. Sampling: 1 once written.
    count: u16,
}

pub struct Ports {
    state: [PortState; PORT_COUNT],
    storage: [u8; PORT_STORAGE_BYTES],
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
            state: [PortState { head: 0, count: 0 }; PORT_COUNT],
            storage: [0; PORT_STORAGE_BYTES],
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
        let depth = config.depth as usize;
        let state = self.state[port];
        let index = match config.kind {
            PortKind::Sampling => 0,
            PortKind::Queuing => {
                if state.count as usize >= depth {
                    return Err(SysError::Full);
                }
                (state.head as usize + state.count as usize) % depth
            }
        };
        let slot = self.slot(port, index);
        put_word(slot, 0, message.len() as u32);
        put_word(slot, 4, generation);
        put_word(slot, 8, (now >> 32) as u32);
        put_word(slot, 12, now as u32);
        slot[PORT_SLOT_HEADER..PORT_SLOT_HEADER + message.len()].copy_from_slice(message);
        let state = &mut self.state[port];
        state.count = match config.kind {
            PortKind::Sampling => 1,
            PortKind::Queuing => state.count + 1,
        };
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

    /// `receiver` takes (queuing) or reads (sampling) the next message on `port` into `buffer`.
    pub fn receive(
        &mut self,
        receiver: usize,
        port: usize,
        buffer: &mut [u8],
    ) -> Result<Received, SysError> {
        let config = SYSTEM.ports.get(port).ok_or(SysError::BadPort)?;
        if !config.destinations.contains(&receiver) {
            return Err(SysError::BadPort);
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
            let state = &mut self.state[port];
            state.head = ((state.head as usize + 1) % config.depth as usize) as u16;
            state.count -= 1;
        }
        Ok(received)
    }
}

//! Typed ports, the partitions' side (after Hubris's typed IPC): a [`Port<T>`] is a port of the
//! configuration, found by its name at compile time, that carries values of `T` encoded with
//! postcard. A partition sends and receives `T`; the bytes, the port's size and the decoding
//! stay here, and a port's id is never written down by hand.
use core::marker::PhantomData;

use kernel_config::abi::SysError;
use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::sys;
use crate::SYSTEM;

/// Bytes of the largest message of any port of this image (the buffers' size).
const MAX_MESSAGE: usize = kernel_config::max_port_message(&SYSTEM);

/// A port carrying `T`.
pub struct Port<T> {
    id: usize,
    message: PhantomData<fn(T) -> T>,
}

// Not derived: a port is a copyable id whatever `T` is.
impl<T> Clone for Port<T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Port<T> {}

/// Why a typed send or receive failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PortError {
    /// The kernel refused the call (a full queue: [`SysError::Full`]).
    Sys(SysError),
    /// The value does not fit in the port's message size.
    TooBig,
    /// The message taken off the port did not decode as `T` (it is gone).
    Undecodable,
}

impl From<SysError> for PortError {
    fn from(error: SysError) -> Self {
        PortError::Sys(error)
    }
}

/// A value received, with what the kernel says about it.
pub struct Message<T> {
    pub value: T,
    /// The sender's generation when it sent the message.
    pub generation: u32,
    /// Ticks since it was sent.
    pub age: u32,
}

impl<T> Port<T> {
    /// The port named `name` in this image's configuration. For `const` items: there, a name
    /// the configuration lacks stops the build.
    pub const fn named(name: &str) -> Self {
        Self {
            id: kernel_config::port_id(&SYSTEM, name),
            message: PhantomData,
        }
    }

    /// The port's id (the system calls' argument).
    pub const fn id(self) -> usize {
        self.id
    }

    /// The port's message size in bytes.
    fn size(self) -> usize {
        SYSTEM
            .ports
            .get(self.id)
            .map_or(0, |p| p.message_size as usize)
    }
}

impl<T: Serialize> Port<T> {
    /// Send `value` (sampling: replaces the port's value; queuing: appends, Sys(Full) when
    /// full).
    pub fn send(self, value: &T) -> Result<(), PortError> {
        let mut buf = [0u8; MAX_MESSAGE];
        let size = self.size().min(MAX_MESSAGE);
        let room = buf.get_mut(..size).ok_or(PortError::TooBig)?;
        let bytes = postcard::to_slice(value, room).map_err(|_| PortError::TooBig)?;
        sys::port_send(self.id, bytes)?;
        Ok(())
    }
}

impl<T: DeserializeOwned> Port<T> {
    /// The next message (queuing: taken off; sampling: the current value); None when there is
    /// none.
    pub fn receive(self) -> Result<Option<Message<T>>, PortError> {
        let mut buf = [0u8; MAX_MESSAGE];
        let got = match sys::port_receive(self.id, &mut buf) {
            Ok(got) => got,
            Err(SysError::Empty) => return Ok(None),
            Err(error) => return Err(PortError::Sys(error)),
        };
        let bytes = buf.get(..got.len).ok_or(PortError::Undecodable)?;
        let value = postcard::from_bytes(bytes).map_err(|_| PortError::Undecodable)?;
        Ok(Some(Message {
            value,
            generation: got.generation,
            age: got.age,
        }))
    }
}

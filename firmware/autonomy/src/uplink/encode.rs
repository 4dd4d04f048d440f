//! Encoding a network spec in the uplink format.

use super::*;

/// The uplink did not fit in the output buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BufferTooSmall;

pub(super) struct Writer<'a> {
    buf: &'a mut [u8],
    len: usize,
}

impl Writer<'_> {
    pub(super) fn put<T: Serialize>(&mut self, value: &T) -> Result<(), BufferTooSmall> {
        let rest = self.buf.get_mut(self.len..).ok_or(BufferTooSmall)?;
        let used = postcard::to_slice(value, rest)
            .map_err(|_| BufferTooSmall)?
            .len();
        self.len += used;
        Ok(())
    }

    pub(super) fn list<T: Serialize>(&mut self, items: &[T]) -> Result<(), BufferTooSmall> {
        let n = u16::try_from(items.len()).map_err(|_| BufferTooSmall)?;
        self.put(&n)?;
        items.iter().try_for_each(|i| self.put(i))
    }
}

/// Encodes `spec` into `buf` in the uplink format; returns the length used.
pub fn encode_spec(spec: &NetworkSpec, buf: &mut [u8]) -> Result<usize, BufferTooSmall> {
    let mut w = Writer { buf, len: 0 };
    w.put(&spec.header)?;
    w.list(&spec.timelines)?;
    w.list(&spec.conditions)?;
    w.list(&spec.tasks)?;
    w.list(&spec.temporal)?;
    w.list(&spec.timed)?;
    w.list(&spec.params)?;
    Ok(w.len)
}

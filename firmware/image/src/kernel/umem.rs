//! Memory handed in by a partition (after Hubris's `USlice`): a pointer and a length from
//! registers become a [`USlice`] only if they do not wrap around, and become a Rust slice only
//! after the caller's region table says the whole range lies inside one region with the access
//! needed. The kernel touches partition memory through nothing else.
use kernel_config::abi::SysError;
use kernel_config::{Access, Region, SHARED_CODE_BASE, SHARED_CODE_SIZE};

use super::at;
use crate::config::SYSTEM;

/// A range of a partition's address space, not yet trusted.
#[derive(Clone, Copy, Debug)]
pub struct USlice {
    base: u32,
    len: u32,
}

/// The shared code block: partitions may pass pointers into it for reading (string literals,
/// constants).
const SHARED_CODE: Region = Region {
    base: SHARED_CODE_BASE,
    size: SHARED_CODE_SIZE,
    access: Access::ReadOnly,
};

impl USlice {
    /// Refuses ranges that wrap around the address space.
    pub fn from_raw(base: u32, len: u32) -> Result<Self, SysError> {
        base.checked_add(len).ok_or(SysError::BadPointer)?;
        Ok(Self { base, len })
    }

    fn inside(&self, partition: usize, writable: bool) -> bool {
        if self.len == 0 {
            return true;
        }
        let own = at(SYSTEM.partitions, partition).regions.iter().any(|r| {
            let ok = match r.access {
                Access::ReadWrite => true,
                Access::ReadOnly => !writable,
                // The kernel never reads or writes devices on a partition's behalf.
                Access::Device => false,
            };
            ok && r.contains(self.base, self.len)
        });
        own || (!writable && SHARED_CODE.contains(self.base, self.len))
    }

    /// The range as bytes the kernel may read on behalf of `partition`.
    pub fn readable_by(self, partition: usize) -> Result<&'static [u8], SysError> {
        if !self.inside(partition, false) {
            return Err(SysError::BadPointer);
        }
        if self.len == 0 {
            return Ok(&[]);
        }
        // SAFETY:
        // 1. The range lies inside one of the partition's regions (or the shared code), which is
        //    RAM mapped 1:1 and readable with the MMU off.
        // 2. The partition is stopped while the kernel runs, so nothing writes it concurrently.
        Ok(unsafe { core::slice::from_raw_parts(self.base as *const u8, self.len as usize) })
    }

    /// The range as bytes the kernel may write on behalf of `partition`.
    pub fn writable_by(self, partition: usize) -> Result<&'static mut [u8], SysError> {
        if !self.inside(partition, true) {
            return Err(SysError::BadPointer);
        }
        if self.len == 0 {
            return Ok(&mut []);
        }
        // SAFETY:
        // 1. The range lies inside a ReadWrite region of the partition: RAM that belongs to it
        //    alone and never overlaps kernel memory (checked by the configuration checker).
        // 2. The partition is stopped while the kernel runs; the slice does not outlive the
        //    system call.
        Ok(unsafe { core::slice::from_raw_parts_mut(self.base as *mut u8, self.len as usize) })
    }
}

/// Copy without going through `memcpy` twice for short messages (they are tiny). `src` goes to
/// the front of `dst`; every caller passes a `dst` at least as long (nothing is copied if not).
pub fn copy(dst: &mut [u8], src: &[u8]) {
    if let Some(front) = dst.get_mut(..src.len()) {
        front.copy_from_slice(src);
    }
}

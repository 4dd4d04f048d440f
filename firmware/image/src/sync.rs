//! A cell for the image's few globals (the link, the logger state): single core, so exclusive
//! access means "interrupts off and not already borrowed". A nested borrow is refused (None)
//! instead of aliasing, so a log call made while the link is busy is dropped, never a fault.
use core::cell::{Cell, UnsafeCell};

use crate::boot::{disable_interrupts, restore_msr};

pub struct Global<T> {
    value: UnsafeCell<Option<T>>,
    borrowed: Cell<bool>,
}

// SAFETY: the 750 is single-core and `with` runs with interrupts disabled and refuses nested
// borrows, so no two `&mut T` ever exist at once.
unsafe impl<T> Sync for Global<T> {}

impl<T> Global<T> {
    pub const fn empty() -> Self {
        Self {
            value: UnsafeCell::new(None),
            borrowed: Cell::new(false),
        }
    }

    /// Install the value (boot time). Dropped silently if the cell is borrowed.
    pub fn set(&self, value: T) {
        let _ = self.with_slot(|slot| *slot = Some(value));
    }

    /// Run `f` with exclusive access; None if the cell is empty or already borrowed.
    pub fn with<R>(&self, f: impl FnOnce(&mut T) -> R) -> Option<R> {
        self.with_slot(|slot| slot.as_mut().map(f)).flatten()
    }

    fn with_slot<R>(&self, f: impl FnOnce(&mut Option<T>) -> R) -> Option<R> {
        let msr = disable_interrupts();
        if self.borrowed.replace(true) {
            restore_msr(msr);
            return None;
        }
        // SAFETY: `borrowed` was false and interrupts are off, so this is the only reference.
        let result = f(unsafe { &mut *self.value.get() });
        self.borrowed.set(false);
        restore_msr(msr);
        Some(result)
    }
}

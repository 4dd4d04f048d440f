//! The deferred code: the upper half of the shared code (`kc::DEFERRED_CODE_BASE`), where the
//! linker puts the temporal planner's and the lander's code. Nothing runs it at a warm boot or
//! in the recovery after one, so the reset stub does not check it there (it checks only the
//! lower half, everything the kernel and the recovery run); the kernel checks it against the
//! image record before it first runs:
//! - the partitions' instruction BATs leave the block out (IBAT1 invalid) until it is checked,
//!   so the first instruction fetched from it in any partition is an instruction-storage
//!   interrupt, which the kernel takes for the check ([`on_fetch_fault`]) rather than for a
//!   fault: checked and matching, IBAT1 maps it and the partition goes on with that fetch;
//! - damaged, it is a health-monitor event (the partition, `InstructionStorage`, the address)
//!   and a warm reset whose reset stub copies the whole image from ROM again, as for a damaged
//!   image at boot (`Kernel::deferred_code_damaged`);
//! - after a boot that copied the image from ROM (power-on, a repair) there is nothing to
//!   check: IBAT1 maps it from the start.
//!
//! The kernel runs with translation off and never calls the temporal planner's or the lander's
//! crates, so no code in the block runs unchecked. Reading the block as data (DBAT0) is allowed
//! throughout: what matters is what runs.
use core::sync::atomic::{AtomicBool, Ordering};

use kernel_config as kc;
use kernel_logic::image_sum::image_sums;

use super::mmu;
use crate::board::timebase;
use crate::boot::{ImageCheck, IMAGE_RECORD_DEFERRED_WORD};
use crate::warm;

extern "C" {
    static __deferred_code_start: u32;
    static __deferred_code_end: u32;
}

/// Whether the block is checked this boot (kernel .bss: false at every boot).
static CHECKED: AtomicBool = AtomicBool::new(false);

/// At boot, after `mmu::init`: a boot that copied the image from ROM has nothing to check.
pub fn boot(image: ImageCheck) {
    if image != ImageCheck::Verified {
        CHECKED.store(true, Ordering::Relaxed);
        mmu::map_deferred_code();
    }
}

/// What an instruction fetch that faulted at `address` means.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum FetchFault {
    /// Not the deferred code's first fetch: a fault as any other.
    Fault,
    /// The block was checked, matches its record and is now mapped: retry the fetch.
    Checked,
    /// The block does not match its record.
    Damaged,
}

/// An instruction-storage interrupt at `address` in a partition.
pub fn on_fetch_fault(address: u32) -> FetchFault {
    let inside = address.wrapping_sub(kc::DEFERRED_CODE_BASE) < kc::DEFERRED_CODE_SIZE;
    if !inside || CHECKED.load(Ordering::Relaxed) {
        return FetchFault::Fault;
    }
    let started = timebase::now().0;
    // SAFETY: the linker symbols bound the deferred code, a word-aligned part of the shared
    // code in RAM (its start is the block's base, checked by the linker script); the kernel
    // runs with translation off, so these are the physical addresses, and nothing writes the
    // shared code while the kernel runs.
    let words = unsafe {
        let start = core::ptr::addr_of!(__deferred_code_start);
        let end = core::ptr::addr_of!(__deferred_code_end);
        let count = (end as usize).saturating_sub(start as usize) / 4;
        core::slice::from_raw_parts(start, count)
    };
    let sums = image_sums(words);
    let recorded = (
        warm::image_record_word(IMAGE_RECORD_DEFERRED_WORD),
        warm::image_record_word(IMAGE_RECORD_DEFERRED_WORD + 1),
    );
    defmt::info!(
        "kernel: deferred code checked before its first run: {=usize} words in {=u64} ticks, {=str}",
        words.len(),
        timebase::now().0.wrapping_sub(started),
        if sums == recorded {
            "intact"
        } else {
            "damaged"
        }
    );
    if sums != recorded {
        return FetchFault::Damaged;
    }
    CHECKED.store(true, Ordering::Relaxed);
    mmu::map_deferred_code();
    FetchFault::Checked
}

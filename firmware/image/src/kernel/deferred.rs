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
use core::arch::global_asm;
use core::sync::atomic::{AtomicBool, Ordering};

use kernel_config as kc;

use super::mmu;
use crate::board::timebase;
use crate::boot::{ImageCheck, IMAGE_RECORD_DEFERRED_WORD};
use crate::warm;

extern "C" {
    static __deferred_code_start: u32;
    static __deferred_code_end: u32;
}

// The image checksum of `kernel_logic::image_sum::image_sums` (the reset stub's, `boot.rs`
// routine 40) at the stub's speed: `lmw` of 24 words while 24 are left, then of 8, and one add
// or XOR a word, about 1.17 instructions a word (the Rust loop took about 2.9, so the check of
// the block cost 2.5 times what the stub pays for the same words). r13-r31 are saved in a
// stack frame of its own; r0 and r3-r12, CTR and CR0 are volatile. Returns the chain in r3 and
// the block sum in r4 (a `u64`, high word first).
global_asm!(
    r#"
    .section .text.kernel_image_sums, "ax"
    .globl kernel_image_sums
    .type kernel_image_sums, @function
    # kernel_image_sums(words r3, count r4) -> (chain << 32) | blocks
kernel_image_sums:
    stwu %r1, -96(%r1)
    stmw %r13, 16(%r1)
    li %r6, 0
    li %r7, 0
    li %r0, 24
    divwu %r5, %r4, %r0
    mullw %r0, %r5, %r0
    subf %r4, %r0, %r4
    cmpwi %r5, 0
    beq 2f
    mtctr %r5
1:  lmw %r8, 0(%r3)
    add %r6, %r6, %r8
    xor %r6, %r6, %r9
    add %r6, %r6, %r10
    xor %r6, %r6, %r11
    add %r6, %r6, %r12
    xor %r6, %r6, %r13
    add %r6, %r6, %r14
    xor %r6, %r6, %r15
    add %r6, %r6, %r16
    xor %r6, %r6, %r17
    add %r6, %r6, %r18
    xor %r6, %r6, %r19
    add %r6, %r6, %r20
    xor %r6, %r6, %r21
    add %r6, %r6, %r22
    xor %r6, %r6, %r23
    add %r6, %r6, %r24
    xor %r6, %r6, %r25
    add %r6, %r6, %r26
    xor %r6, %r6, %r27
    add %r6, %r6, %r28
    xor %r6, %r6, %r29
    add %r6, %r6, %r30
    xor %r6, %r6, %r31
    add %r7, %r7, %r6
    addi %r3, %r3, 96
    bdnz 1b
2:  srwi. %r0, %r4, 3
    beq 4f
    mtctr %r0
3:  lmw %r24, 0(%r3)
    add %r6, %r6, %r24
    xor %r6, %r6, %r25
    add %r6, %r6, %r26
    xor %r6, %r6, %r27
    add %r6, %r6, %r28
    xor %r6, %r6, %r29
    add %r6, %r6, %r30
    xor %r6, %r6, %r31
    add %r7, %r7, %r6
    addi %r3, %r3, 32
    bdnz 3b
4:  mr %r3, %r6
    mr %r4, %r7
    lmw %r13, 16(%r1)
    addi %r1, %r1, 96
    blr
    .size kernel_image_sums, . - kernel_image_sums
"#
);

extern "C" {
    fn kernel_image_sums(words: *const u32, count: usize) -> u64;
}

/// [`kernel_logic::image_sum::image_sums`] of `words`, by `kernel_image_sums`.
fn image_sums(words: &[u32]) -> (u32, u32) {
    // SAFETY: the routine reads `count` words from `words` (whole blocks of 24, then of 8, never
    // past the end) and writes only its own stack frame and volatile registers.
    let sums = unsafe { kernel_image_sums(words.as_ptr(), words.len()) };
    ((sums >> 32) as u32, sums as u32)
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

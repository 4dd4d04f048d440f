//! Reset vector, exception vectors and the jump into Rust.
//!
//! The 750 starts at `0xfff00100` with MSR[IP]=1 and the MMU off. The reset stub (in ROM) copies
//! the RAM image from its load address to 0x0, clears `.bss`, sets up the boot stack and enters
//! [`crate::rust_start`] through `rfi` with MSR[IP]=0 (vectors at 0x0), MSR[ME] and MSR[FP] set.
//! Every exception vector saves r3, loads its vector offset and branches to a common handler
//! that calls [`crate::fatal_exception`] on the exception stack.

use core::arch::{asm, global_asm};

/// MSR bits used by the boot code and the kernel.
#[allow(dead_code)]
pub mod msr {
    pub const EE: u32 = 0x8000;
    pub const PR: u32 = 0x4000;
    pub const FP: u32 = 0x2000;
    pub const ME: u32 = 0x1000;
    pub const IP: u32 = 0x0040;
    pub const IR: u32 = 0x0020;
    pub const DR: u32 = 0x0010;
}

/// Address of the 6xx system-reset vector with MSR[IP]=1.
pub const RESET_VECTOR: u32 = 0xfff0_0100;

global_asm!(
    r#"
    .section .reset.entry, "ax"
    .globl _reset
_reset:
    # Copy the RAM image (vectors, text, rodata, data) from ROM to RAM, a word at a time.
    lis %r3, __ram_image_lma@ha
    addi %r3, %r3, __ram_image_lma@l
    lis %r4, __ram_image_start@ha
    addi %r4, %r4, __ram_image_start@l
    lis %r5, __ram_image_end@ha
    addi %r5, %r5, __ram_image_end@l
1:  cmplw %r4, %r5
    bge 2f
    lwz %r6, 0(%r3)
    stw %r6, 0(%r4)
    addi %r3, %r3, 4
    addi %r4, %r4, 4
    b 1b
    # Clear .bss.
2:  lis %r4, __bss_start@ha
    addi %r4, %r4, __bss_start@l
    lis %r5, __bss_end@ha
    addi %r5, %r5, __bss_end@l
    li %r6, 0
3:  cmplw %r4, %r5
    bge 4f
    stw %r6, 0(%r4)
    addi %r4, %r4, 4
    b 3b
4:  sync
    isync
    # Boot stack with a terminating back-chain word.
    lis %r1, __stack_top@ha
    addi %r1, %r1, __stack_top@l
    li %r0, 0
    stwu %r0, -16(%r1)
    li %r2, 0
    li %r13, 0
    # Enter Rust with MSR = ME | FP (IP cleared: exception vectors now at 0x0).
    lis %r3, rust_start@ha
    addi %r3, %r3, rust_start@l
    mtspr 26, %r3
    li %r4, 0x3000
    mtspr 27, %r4
    rfi

    .section .vectors, "ax"
    .globl __vectors
__vectors:
    .irp vec, 0x100, 0x200, 0x300, 0x400, 0x500, 0x600, 0x700, 0x800, 0x900, 0xa00, 0xb00, 0xc00, 0xd00, 0xe00, 0xf00, 0x1000, 0x1100, 0x1200, 0x1300, 0x1400, 0x1500, 0x1600, 0x1700
    .org \vec
    mtspr 273, %r3
    li %r3, \vec
    b __exception_common
    .endr

    .section .text.__exception_common, "ax"
    .globl __exception_common
__exception_common:
    # r3 = vector offset; SPRG1 = interrupted r3. Save the interrupted r1 in SPRG0 and switch
    # to the exception stack.
    mtspr 272, %r1
    lis %r1, __exc_stack_top@ha
    addi %r1, %r1, __exc_stack_top@l
    li %r0, 0
    stwu %r0, -16(%r1)
    mfspr %r4, 26
    mfspr %r5, 27
    mfspr %r6, 19
    mfspr %r7, 18
    bl fatal_exception
5:  b 5b
"#
);

/// Restart from the reset vector with RAM kept: the same path a warm reset takes.
pub fn software_reset() -> ! {
    // SAFETY:
    // 1. SRR0/SRR1 are loaded with the reset vector and an MSR with IP set and the MMU off,
    //    which is the state the hardware reset leaves; `rfi` never returns here.
    // 2. Nothing in RAM is relied on by the reset stub; the warm-restart area is not touched.
    unsafe {
        asm!(
            "mtspr 26, {pc}",
            "mtspr 27, {msr}",
            "sync",
            "rfi",
            pc = in(reg) RESET_VECTOR,
            msr = in(reg) msr::IP,
            options(noreturn)
        )
    }
}

/// Disable external and decrementer interrupts; returns the previous MSR for [`restore_msr`].
#[inline]
pub fn disable_interrupts() -> u32 {
    let saved: u32;
    // SAFETY: reading and writing the MSR in supervisor state only clears EE.
    unsafe {
        asm!("mfmsr {0}", out(reg) saved, options(nomem, nostack));
        let cleared = saved & !msr::EE;
        asm!("mtmsr {0}", "isync", in(reg) cleared, options(nostack));
    }
    saved
}

/// Restore the MSR saved by [`disable_interrupts`].
#[inline]
pub fn restore_msr(saved: u32) {
    // SAFETY: `saved` came from `disable_interrupts`, so this only restores EE.
    unsafe { asm!("mtmsr {0}", "isync", in(reg) saved, options(nostack)) }
}

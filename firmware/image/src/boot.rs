//! Reset vector, exception vectors, and the two halves of every kernel entry: saving the
//! interrupted context and resuming a context.
//!
//! The 750 starts at `0xfff00100` with MSR[IP]=1 and the MMU off. The reset stub (in ROM) reads
//! the timebase first (the start of boot to ready, passed on to [`crate::rust_start`]), copies
//! the shared code (vectors, text, rodata, `.kshared`) to 0x0 and the kernel data to its region,
//! clears `.bss` and the hashed page table, sets up the kernel stack and enters
//! [`crate::rust_start`] through `rfi` with MSR[IP]=0 (vectors at 0x0), MSR[ME] and MSR[FP].
//!
//! Every exception vector saves r3 in SPRG1, loads its vector offset and branches to
//! `__exception_common`, which stores all of the interrupted context (GPRs, CR, LR, CTR, XER,
//! SRR0, SRR1) into the save area SPRG2 points at, points SPRG2 at the kernel-fault area (so a
//! fault inside the kernel cannot overwrite a partition's context), switches to the kernel stack
//! and calls `kernel_trap` with the MMU off. `kernel_trap` returns the context to resume, which
//! `__context_resume` loads and enters with `rfi`.

use core::arch::{asm, global_asm};

/// MSR bits used by the boot code and the kernel.
#[allow(dead_code)]
pub mod msr {
    pub const POW: u32 = 0x0004_0000;
    pub const EE: u32 = 0x8000;
    pub const PR: u32 = 0x4000;
    pub const FP: u32 = 0x2000;
    pub const ME: u32 = 0x1000;
    pub const IP: u32 = 0x0040;
    pub const IR: u32 = 0x0020;
    pub const DR: u32 = 0x0010;
    /// A partition: problem state, translation on, decrementer enabled, no FPU.
    pub const PARTITION: u32 = PR | EE | ME | IR | DR;
    /// The kernel's idle loop: supervisor, MMU off, decrementer enabled.
    pub const IDLE: u32 = EE | ME;
}

/// Address of the 6xx system-reset vector with MSR[IP]=1.
pub const RESET_VECTOR: u32 = 0xfff0_0100;

global_asm!(
    r#"
    .section .reset.entry, "ax"
    .globl _reset
_reset:
    # The timebase at the reset vector in r14:r15 (upper half re-read until stable); nothing
    # below touches r14-r16 until they are handed to rust_start.
30: mftbu %r14
    mftb %r15
    mftbu %r16
    cmpw %r14, %r16
    bne 30b
    # Copy the shared code (vectors, text, rodata, .kshared) from ROM to RAM.
    lis %r3, __ram_image_lma@ha
    addi %r3, %r3, __ram_image_lma@l
    lis %r4, __ram_image_start@ha
    addi %r4, %r4, __ram_image_start@l
    lis %r5, __ram_image_end@ha
    addi %r5, %r5, __ram_image_end@l
    bl 10f
    # Copy the kernel's initialised data to its region.
    lis %r3, __kdata_lma@ha
    addi %r3, %r3, __kdata_lma@l
    lis %r4, __kdata_start@ha
    addi %r4, %r4, __kdata_start@l
    lis %r5, __kdata_end@ha
    addi %r5, %r5, __kdata_end@l
    bl 10f
    # Clear .bss and the hashed page table (every PTE invalid).
    lis %r4, __bss_start@ha
    addi %r4, %r4, __bss_start@l
    lis %r5, __bss_end@ha
    addi %r5, %r5, __bss_end@l
    bl 20f
    lis %r4, __htab_base@ha
    addi %r4, %r4, __htab_base@l
    lis %r5, __htab_size@ha
    addi %r5, %r5, __htab_size@l
    add %r5, %r5, %r4
    bl 20f
    sync
    isync
    # Kernel stack with a terminating back-chain word.
    lis %r1, __kernel_stack_top@ha
    addi %r1, %r1, __kernel_stack_top@l
    li %r0, 0
    stwu %r0, -16(%r1)
    li %r2, 0
    li %r13, 0
    # Enter Rust with MSR = ME | FP (IP cleared: exception vectors now at 0x0) and the
    # timebase at the reset vector as its arguments.
    lis %r3, rust_start@ha
    addi %r3, %r3, rust_start@l
    mtspr 26, %r3
    li %r4, 0x3000
    mtspr 27, %r4
    mr %r3, %r14
    mr %r4, %r15
    rfi
    # Copy words [r4, r5) from r3.
10: cmplw %r4, %r5
    bgelr
    lwz %r6, 0(%r3)
    stw %r6, 0(%r4)
    addi %r3, %r3, 4
    addi %r4, %r4, 4
    b 10b
    # Zero words [r4, r5).
20: li %r6, 0
21: cmplw %r4, %r5
    bgelr
    stw %r6, 0(%r4)
    addi %r4, %r4, 4
    b 21b

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
    # r3 = vector offset, SPRG1 = interrupted r3, SPRG2 = save area. MMU off, EE off.
    mtspr 272, %r4
    mfspr %r4, 274
    stw %r0, 0(%r4)
    stw %r1, 4(%r4)
    stw %r2, 8(%r4)
    mfspr %r0, 273
    stw %r0, 12(%r4)
    mfspr %r0, 272
    stw %r0, 16(%r4)
    stmw %r5, 20(%r4)
    mfcr %r0
    stw %r0, 128(%r4)
    mflr %r0
    stw %r0, 132(%r4)
    mfctr %r0
    stw %r0, 136(%r4)
    mfspr %r0, 1
    stw %r0, 140(%r4)
    mfspr %r0, 26
    stw %r0, 144(%r4)
    mfspr %r0, 27
    stw %r0, 148(%r4)
    # From here on a fault is the kernel's own: it must not overwrite this context.
    lis %r5, KERNEL_FAULT_CONTEXT@ha
    addi %r5, %r5, KERNEL_FAULT_CONTEXT@l
    mtspr 274, %r5
    lis %r1, __kernel_stack_top@ha
    addi %r1, %r1, __kernel_stack_top@l
    li %r0, 0
    stwu %r0, -16(%r1)
    mfspr %r5, 19
    mfspr %r6, 18
    bl kernel_trap
    # fall through: r3 = context to resume

    .globl __context_resume
__context_resume:
    mtspr 274, %r3
    lwz %r0, 128(%r3)
    mtcrf 255, %r0
    lwz %r0, 132(%r3)
    mtlr %r0
    lwz %r0, 136(%r3)
    mtctr %r0
    lwz %r0, 140(%r3)
    mtspr 1, %r0
    lwz %r0, 144(%r3)
    mtspr 26, %r0
    lwz %r0, 148(%r3)
    mtspr 27, %r0
    lwz %r0, 0(%r3)
    lwz %r1, 4(%r3)
    lwz %r2, 8(%r3)
    lmw %r4, 16(%r3)
    lwz %r3, 12(%r3)
    rfi

    # A partition's first instructions after a (re)start, in problem state with its BATs:
    # r3 = start of its memory, r4 = end of its statics (both 32-byte aligned),
    # r5 = entry function, r6 = stack top. Zero statics and stack, then call the entry.
    .globl __partition_start
__partition_start:
    li %r7, 0
1:  cmplw %r3, %r4
    bge 2f
    dcbz 0, %r3
    addi %r3, %r3, 32
    b 1b
2:  mr %r1, %r6
    stwu %r7, -16(%r1)
    li %r2, 0
    li %r13, 0
    mtctr %r5
    mtlr %r7
    bctr

    # The kernel's idle loop: supervisor, MMU off, EE on. MSR[POW] with HID0[DOZE] set makes
    # QEMU halt the CPU until the decrementer fires (with icount sleep=off it jumps to it).
    .globl __kernel_idle
__kernel_idle:
    mfmsr %r3
    oris %r3, %r3, 0x0004
    sync
    mtmsr %r3
    isync
    b __kernel_idle
"#
);

extern "C" {
    /// Load a saved context and enter it (see the module docs).
    pub fn __context_resume(context: *const crate::kernel::Context) -> !;
    pub fn __partition_start();
    pub fn __kernel_idle();
}

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
/// Supervisor state only (the kernel).
#[inline]
pub fn disable_interrupts() -> u32 {
    let saved: u32;
    // SAFETY:
    // 1. Called only in supervisor state (kernel code), where mfmsr/mtmsr are allowed.
    // 2. Only EE is cleared.
    unsafe {
        asm!("mfmsr {0}", out(reg) saved, options(nomem, nostack));
        let cleared = saved & !msr::EE;
        asm!("mtmsr {0}", "isync", in(reg) cleared, options(nostack));
    }
    saved
}

/// Set HID0[DOZE] so that MSR[POW] dozes until an interrupt (the idle loop).
pub fn enable_doze() {
    // SAFETY:
    // 1. Supervisor state at boot; HID0 bit 8 (DOZE) only selects what MSR[POW] does.
    unsafe {
        asm!(
            "mfspr {t}, 1008",
            "oris {t}, {t}, 0x0080",
            "mtspr 1008, {t}",
            "isync",
            t = out(reg) _,
            options(nostack)
        )
    }
}

/// Restore the MSR saved by [`disable_interrupts`].
#[inline]
pub fn restore_msr(saved: u32) {
    // SAFETY: supervisor state; `saved` came from `disable_interrupts`, so this only restores EE.
    unsafe { asm!("mtmsr {0}", "isync", in(reg) saved, options(nostack)) }
}

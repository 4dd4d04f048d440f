//! Reset vector, exception vectors, and the two halves of every kernel entry: saving the
//! interrupted context and resuming a context.
//!
//! The 750 starts at `0xfff00100` with MSR[IP]=1 and the MMU off. The reset vector (in ROM)
//! reads the timebase first (the start of boot to ready, passed on to [`crate::rust_start`])
//! and branches to the stub's body, which lies in ROM after the image. The body makes the RAM
//! image (vectors, text, rodata: everything the partitions map as shared code) good:
//! - after a warm reset RAM still holds it, so it is checked rather than copied again: the
//!   image record in the warm-restart area (after the boot record; [`IMAGE_RECORD_OFFSET`])
//!   names the ROM it was copied from (its build id) and the checksums of the image's two
//!   parts, and the stub sums the RAM copy of the part below the deferred code and compares.
//!   The deferred code (the temporal planner's and the lander's, at `DEFERRED_CODE_BASE`) is
//!   left to the kernel, which checks it against the record's second pair of sums before any
//!   of it runs (`kernel::deferred`);
//! - without a valid record for this ROM (power-on, new firmware, a damaged record), or when
//!   the sums differ (a damaged image, or the kernel found the deferred code damaged and said
//!   so in the record), it copies both parts from ROM, summing as it copies, and writes the
//!   record.
//!
//! The checksum is two 32-bit words (routine 40 in the stub): a chain that takes the image's
//! words in turn, adding one and XORing the next (both steps are bijections, so any damage
//! confined to one word changes it, and since they do not commute, so do words swapped), and
//! the sum of the chain after each 24-word block (Fletcher's second sum at block granularity:
//! blocks in the wrong order change it). It is not a CRC: a table-driven CRC-32 costs about
//! 14 instructions per word, twice a word-by-word copy from ROM, whereas the chain costs one
//! per word, the words being read 24 at a time with `lmw` (1.17 instructions per word in all).
//! On a real board the check also avoids reading the boot ROM, which is many times slower
//! than RAM (under QEMU both cost one instruction per access). Then, on every boot, the stub
//! reloads `.kshared` (the words the kernel writes at run time, so outside the checksum) and
//! the kernel data from ROM, clears `.bss` and the hashed page table (24 words per `stmw`), sets up the kernel stack and enters
//! [`crate::rust_start`] through `rfi` with MSR[IP]=0 (vectors at 0x0), MSR[ME] and MSR[FP],
//! with the timebase at the reset vector, how the image was made good ([`ImageCheck`]) and
//! the timebase after each of its two steps (the boot breakdown the host prints).
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

/// How the reset stub made the RAM image good (its r5 to [`crate::rust_start`]; the kernel
/// reports it as `metric::BOOT_IMAGE`).
#[derive(Clone, Copy, PartialEq, Eq, Debug, defmt::Format)]
pub enum ImageCheck {
    /// After a warm reset: the RAM copy matched the image record's checksum.
    Verified,
    /// Copied from ROM: no valid image record for this ROM (power-on, new firmware, a
    /// damaged record).
    Copied,
    /// Copied from ROM because the RAM copy did not match its record's checksum.
    Repaired,
}

impl ImageCheck {
    /// The stub's code (1, 2, 3); anything else is taken as a copy.
    pub fn from_stub(code: u32) -> ImageCheck {
        match code {
            1 => ImageCheck::Verified,
            3 => ImageCheck::Repaired,
            _ => ImageCheck::Copied,
        }
    }

    /// `metric::BOOT_IMAGE`'s value (`kernel_config::abi::boot_image`).
    pub fn code(self) -> u64 {
        match self {
            ImageCheck::Verified => kernel_config::abi::boot_image::VERIFIED,
            ImageCheck::Copied => kernel_config::abi::boot_image::COPIED,
            ImageCheck::Repaired => kernel_config::abi::boot_image::REPAIRED,
        }
    }
}

/// The image record's magic ("RADI"), in the warm-restart area after the boot record.
pub const IMAGE_RECORD_MAGIC: u32 = 0x5241_4449;
/// Byte offset of the image record in the warm-restart area.
pub const IMAGE_RECORD_OFFSET: usize = kernel_config::WARM_IMAGE_RECORD_OFFSET as usize;
/// Bytes of the image record: magic, ROM build id (2 words), the two sums of the part checked
/// at boot, the two sums of the deferred code ([`IMAGE_RECORD_DEFERRED_WORD`]), and a check
/// word (the complement of the XOR of the seven others). The build id fixes the layout (the
/// parts' lengths are the linker's for that ROM).
pub const IMAGE_RECORD_BYTES: usize = 32;
/// Word index in the image record of the boot part's first sum.
pub const IMAGE_RECORD_BOOT_WORD: usize = 3;
/// Word index in the image record of the deferred code's first sum (then its second).
pub const IMAGE_RECORD_DEFERRED_WORD: usize = 5;
/// Word index in the image record of its check word.
pub const IMAGE_RECORD_CHECK_WORD: usize = 7;

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
    b __reset_body

    .section .reset.body, "ax"
    .globl __reset_body
__reset_body:
    # The RAM image (vectors, text, rodata): after a warm reset RAM still holds it, so it is
    # checked against the image record rather than copied again; it is copied from ROM when
    # there is no valid record for this ROM (power-on, new firmware, record damaged: r17 = 2)
    # or when its checksum does not match (r17 = 3). r17 = 1: verified in RAM.
    lis %r20, (__warm_area_base + {record})@ha
    addi %r20, %r20, (__warm_area_base + {record})@l
    lwz %r21, 0(%r20)
    lwz %r22, 4(%r20)
    lwz %r23, 8(%r20)
    lwz %r24, 12(%r20)
    lwz %r25, 16(%r20)
    lwz %r26, 20(%r20)
    lwz %r27, 24(%r20)
    lwz %r28, 28(%r20)
    li %r17, 2
    xor %r0, %r21, %r22
    xor %r0, %r0, %r23
    xor %r0, %r0, %r24
    xor %r0, %r0, %r25
    xor %r0, %r0, %r26
    xor %r0, %r0, %r27
    not %r0, %r0
    cmpw %r0, %r28
    bne 50f
    lis %r0, ({magic} >> 16)
    ori %r0, %r0, ({magic} & 0xffff)
    cmpw %r21, %r0
    bne 50f
    lis %r3, __rom_build_id@ha
    addi %r3, %r3, __rom_build_id@l
    lwz %r0, 0(%r3)
    cmpw %r22, %r0
    bne 50f
    lwz %r0, 4(%r3)
    cmpw %r23, %r0
    bne 50f
    # The part checked at boot only (the deferred code's sums, words 5 and 6, are the
    # kernel's to check before that code first runs).
    li %r17, 3
    lis %r3, __ram_image_start@ha
    addi %r3, %r3, __ram_image_start@l
    lis %r5, __image_checked_words@ha
    addi %r5, %r5, __image_checked_words@l
    bl 40f
    cmpw %r8, %r24
    bne 50f
    cmpw %r9, %r25
    bne 50f
    li %r17, 1
    b 60f
    # Copy the image from ROM, both parts, summing what is written, and record it for the
    # next warm reset (the magic last).
50: lis %r3, __ram_image_lma@ha
    addi %r3, %r3, __ram_image_lma@l
    lis %r4, __ram_image_start@ha
    addi %r4, %r4, __ram_image_start@l
    lis %r5, __image_checked_words@ha
    addi %r5, %r5, __image_checked_words@l
    bl 45f
    stw %r8, 12(%r20)
    stw %r9, 16(%r20)
    lis %r3, __deferred_code_lma@ha
    addi %r3, %r3, __deferred_code_lma@l
    lis %r4, __deferred_code_start@ha
    addi %r4, %r4, __deferred_code_start@l
    lis %r5, __deferred_code_words@ha
    addi %r5, %r5, __deferred_code_words@l
    bl 45f
    stw %r8, 20(%r20)
    stw %r9, 24(%r20)
    lis %r3, __rom_build_id@ha
    addi %r3, %r3, __rom_build_id@l
    lwz %r22, 0(%r3)
    lwz %r23, 4(%r3)
    lis %r21, ({magic} >> 16)
    ori %r21, %r21, ({magic} & 0xffff)
    xor %r0, %r21, %r22
    xor %r0, %r0, %r23
    lwz %r6, 12(%r20)
    xor %r0, %r0, %r6
    lwz %r6, 16(%r20)
    xor %r0, %r0, %r6
    lwz %r6, 20(%r20)
    xor %r0, %r0, %r6
    lwz %r6, 24(%r20)
    xor %r0, %r0, %r6
    not %r0, %r0
    stw %r22, 4(%r20)
    stw %r23, 8(%r20)
    stw %r0, 28(%r20)
    stw %r21, 0(%r20)
    # Every boot: the words the kernel writes at run time (.kshared) and the kernel's
    # initialised data, from ROM; then the timebase after the image step in r18.
60: lis %r3, __kshared_lma@ha
    addi %r3, %r3, __kshared_lma@l
    lis %r4, __kshared_start@ha
    addi %r4, %r4, __kshared_start@l
    lis %r5, __kshared_end@ha
    addi %r5, %r5, __kshared_end@l
    bl 10f
    lis %r3, __kdata_lma@ha
    addi %r3, %r3, __kdata_lma@l
    lis %r4, __kdata_start@ha
    addi %r4, %r4, __kdata_start@l
    lis %r5, __kdata_end@ha
    addi %r5, %r5, __kdata_end@l
    bl 10f
    mftb %r18
    # Clear .bss and the hashed page table (every PTE invalid); the timebase after in r19.
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
    mftb %r19
    sync
    isync
    # Kernel stack with a terminating back-chain word.
    lis %r1, __kernel_stack_top@ha
    addi %r1, %r1, __kernel_stack_top@l
    li %r0, 0
    stwu %r0, -16(%r1)
    li %r2, 0
    li %r13, 0
    # Enter Rust with MSR = ME | FP (IP cleared: exception vectors now at 0x0), the timebase
    # at the reset vector, how the image was made good and the two timebase marks.
    lis %r3, rust_start@ha
    addi %r3, %r3, rust_start@l
    mtspr 26, %r3
    li %r4, 0x3000
    mtspr 27, %r4
    mr %r3, %r14
    mr %r4, %r15
    mr %r5, %r17
    mr %r6, %r18
    mr %r7, %r19
    rfi

    # Copy words [r4, r5) from r3 (the few words of .kshared and .kdata).
10: cmplw %r4, %r5
    bgelr
    lwz %r6, 0(%r3)
    stw %r6, 0(%r4)
    addi %r3, %r3, 4
    addi %r4, %r4, 4
    b 10b

    # Routines 20, 40 and 45 move 24 words (r8-r31) per lmw/stmw: one instruction each, where
    # a word at a time cost one per word (on a real 750 they take about a cycle per register,
    # still without the loop's per-word overhead). They save and restore r14-r31 (the stub's
    # own values) in the first 72 bytes of the kernel stack, which nothing uses yet, through r1
    # (the stack pointer is set only after them); r0-r7 are theirs.

    # Zero words [r4, r5) (both ends word-aligned): 24 words per stmw, then one at a time.
20: lis %r1, __kernel_stack_bottom@ha
    addi %r1, %r1, __kernel_stack_bottom@l
    stmw %r14, 0(%r1)
    li %r8, 0
    li %r9, 0
    li %r10, 0
    li %r11, 0
    li %r12, 0
    li %r13, 0
    li %r14, 0
    li %r15, 0
    li %r16, 0
    li %r17, 0
    li %r18, 0
    li %r19, 0
    li %r20, 0
    li %r21, 0
    li %r22, 0
    li %r23, 0
    li %r24, 0
    li %r25, 0
    li %r26, 0
    li %r27, 0
    li %r28, 0
    li %r29, 0
    li %r30, 0
    li %r31, 0
    subf %r0, %r4, %r5
    srwi %r0, %r0, 2
    li %r6, 24
    divwu %r7, %r0, %r6
    mullw %r6, %r7, %r6
    subf %r0, %r6, %r0
    cmpwi %r7, 0
    beq 22f
    mtctr %r7
21: stmw %r8, 0(%r4)
    addi %r4, %r4, 96
    bdnz 21b
22: cmpwi %r0, 0
    beq 24f
    mtctr %r0
23: stw %r8, 0(%r4)
    addi %r4, %r4, 4
    bdnz 23b
24: lmw %r14, 0(%r1)
    blr

    # One step of the image checksum per word: the chain r6 takes the words in turn, adding
    # one and XORing the next. Either step is a bijection of r6 and of the word, so any change
    # confined to one word changes the chain's end; since addition and XOR do not commute,
    # two words swapped change it too (but for rare values).
    .macro __rad_mix even, odd
    add %r6, %r6, %r\even
    xor %r6, %r6, %r\odd
    .endm

    # The image checksum of r5 words at r3 (r5 a multiple of 8): r8 = the chain's end, r9 =
    # the sum of the chain after each block (a second sum, as in Fletcher's construction:
    # blocks in the wrong order change it). Blocks of 24 words (lmw into r8-r31), then blocks
    # of 8 (into r24-r31) for the rest; routine 45 takes the same blocks.
40: lis %r1, __kernel_stack_bottom@ha
    addi %r1, %r1, __kernel_stack_bottom@l
    stmw %r14, 0(%r1)
    li %r6, 0
    li %r7, 0
    li %r0, 24
    divwu %r2, %r5, %r0
    mullw %r0, %r2, %r0
    cmpwi %r2, 0
    mtctr %r2
    subf %r2, %r0, %r5
    beq 42f
41: lmw %r8, 0(%r3)
    __rad_mix 8, 9
    __rad_mix 10, 11
    __rad_mix 12, 13
    __rad_mix 14, 15
    __rad_mix 16, 17
    __rad_mix 18, 19
    __rad_mix 20, 21
    __rad_mix 22, 23
    __rad_mix 24, 25
    __rad_mix 26, 27
    __rad_mix 28, 29
    __rad_mix 30, 31
    add %r7, %r7, %r6
    addi %r3, %r3, 96
    bdnz 41b
42: srwi. %r0, %r2, 3
    beq 44f
    mtctr %r0
43: lmw %r24, 0(%r3)
    __rad_mix 24, 25
    __rad_mix 26, 27
    __rad_mix 28, 29
    __rad_mix 30, 31
    add %r7, %r7, %r6
    addi %r3, %r3, 32
    bdnz 43b
44: lmw %r14, 0(%r1)
    mr %r8, %r6
    mr %r9, %r7
    blr

    # Copy r5 words from r3 to r4 (r5 a multiple of 8), with the checksum of 40 of what was
    # written in r8, r9; r5 is kept.
45: lis %r1, __kernel_stack_bottom@ha
    addi %r1, %r1, __kernel_stack_bottom@l
    stmw %r14, 0(%r1)
    li %r6, 0
    li %r7, 0
    li %r0, 24
    divwu %r2, %r5, %r0
    mullw %r0, %r2, %r0
    cmpwi %r2, 0
    mtctr %r2
    subf %r2, %r0, %r5
    beq 47f
46: lmw %r8, 0(%r3)
    stmw %r8, 0(%r4)
    __rad_mix 8, 9
    __rad_mix 10, 11
    __rad_mix 12, 13
    __rad_mix 14, 15
    __rad_mix 16, 17
    __rad_mix 18, 19
    __rad_mix 20, 21
    __rad_mix 22, 23
    __rad_mix 24, 25
    __rad_mix 26, 27
    __rad_mix 28, 29
    __rad_mix 30, 31
    add %r7, %r7, %r6
    addi %r3, %r3, 96
    addi %r4, %r4, 96
    bdnz 46b
47: srwi. %r0, %r2, 3
    beq 49f
    mtctr %r0
48: lmw %r24, 0(%r3)
    stmw %r24, 0(%r4)
    __rad_mix 24, 25
    __rad_mix 26, 27
    __rad_mix 28, 29
    __rad_mix 30, 31
    add %r7, %r7, %r6
    addi %r3, %r3, 32
    addi %r4, %r4, 32
    bdnz 48b
49: lmw %r14, 0(%r1)
    mr %r8, %r6
    mr %r9, %r7
    blr

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
    # r5 = entry function, r6 = stack top. Zero the statics, then call the entry.
    .globl __partition_start
__partition_start:
    # Zero [r3, r4): 768 bytes per loop turn (eight stmw of r8-r31, all zero: nothing of the
    # partition is live yet), then 32 bytes per dcbz.
    subf %r0, %r3, %r4
    li %r7, 768
    divwu %r9, %r0, %r7
    mullw %r7, %r9, %r7
    subf %r0, %r7, %r0
    cmpwi %r9, 0
    beq 3f
    mtctr %r9
    li %r8, 0
    li %r9, 0
    li %r10, 0
    li %r11, 0
    li %r12, 0
    li %r13, 0
    li %r14, 0
    li %r15, 0
    li %r16, 0
    li %r17, 0
    li %r18, 0
    li %r19, 0
    li %r20, 0
    li %r21, 0
    li %r22, 0
    li %r23, 0
    li %r24, 0
    li %r25, 0
    li %r26, 0
    li %r27, 0
    li %r28, 0
    li %r29, 0
    li %r30, 0
    li %r31, 0
1:
    stmw %r8, 0(%r3)
    stmw %r8, 96(%r3)
    stmw %r8, 192(%r3)
    stmw %r8, 288(%r3)
    stmw %r8, 384(%r3)
    stmw %r8, 480(%r3)
    stmw %r8, 576(%r3)
    stmw %r8, 672(%r3)
    addi %r3, %r3, 768
    bdnz 1b
3:  srwi. %r9, %r0, 5
    beq 2f
    mtctr %r9
4:  dcbz 0, %r3
    addi %r3, %r3, 32
    bdnz 4b
2:  li %r7, 0
    mr %r1, %r6
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
"#,
    magic = const IMAGE_RECORD_MAGIC,
    record = const IMAGE_RECORD_OFFSET,
);

extern "C" {
    /// Load a saved context and enter it (see the module docs).
    pub fn __context_resume(context: *const crate::context::Context) -> !;
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

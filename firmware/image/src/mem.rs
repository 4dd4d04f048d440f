//! `memcpy`, `memmove`, `memset`, `memcmp` and `bcmp`: libcore calls them, and nothing provides
//! them for this target. The first three are hand-written PowerPC (so the compiler can never
//! turn them back into calls to themselves) and move 32 bytes per loop turn when both pointers
//! share their alignment; they are on every hot path (struct moves in the checkpoint decode and
//! the planner, port and link copies, the warm-restart area's reads and writes). A word loop
//! took 6 instructions per word; the 32-byte loop takes 19 per 8 words. From 96 bytes on, a
//! copy moves 96 bytes per `lswx`/`stswx` pair whatever the pointers' alignment (5
//! instructions per 96 bytes; the string instructions take any alignment in big-endian mode)
//! and a fill 96 bytes per `stmw` (3 instructions); on a real 750 these take about a cycle per
//! register, still without a loop's per-word overhead. Below 96 bytes, pointers of different
//! alignment (common in the checkpoint decode, which moves values built from byte buffers)
//! are copied with aligned loads whose halves are shifted together, 6 instructions per word
//! (3 per byte, 12 per word, before): no misaligned word access, which a 750 only tolerates
//! within limits. `memcmp` and `bcmp` are rare and stay in Rust.
//!
//! Only general-purpose registers are used, so partitions, which run without the FPU, can call
//! them too: r0, r3-r12, CR0/CR1, CTR and XER (all volatile in the SysV ABI), and for the
//! 96-byte loops r14-r31, saved and restored in an 80-byte stack frame.

use core::arch::global_asm;
use core::ptr::read_volatile;

global_asm!(
    r#"
    .section .text.memcpy, "ax"
    .globl memcpy
    .type memcpy, @function
    # memcpy(dest r3, src r4, n r5) -> dest. Also memmove's forward path.
memcpy:
    mr %r6, %r3
.Lcopy_forward:
    # 96 bytes per lswx/stswx pair (into r8-r31, XER's byte count 96; string loads and stores
    # take any alignment in big-endian mode) while at least 96 are left; r14-r31 are saved
    # around the loop in a stack frame of its own. Each block is loaded whole before it is
    # stored, as memmove's forward path needs. The rest goes on below.
    cmplwi %r5, 96
    blt .Lcopy_small
    li %r0, 96
    divwu %r7, %r5, %r0
    mullw %r0, %r7, %r0
    subf %r5, %r0, %r5
    mtctr %r7
    li %r0, 96
    mtxer %r0
    stwu %r1, -80(%r1)
    stmw %r14, 8(%r1)
    # (LLVM's assembler lacks the X-form string instructions: they are spelled out.)
12: .long 0x7d00242a # lswx %r8, 0, %r4
    .long 0x7d00352a # stswx %r8, 0, %r6
    addi %r4, %r4, 96
    addi %r6, %r6, 96
    bdnz 12b
    lmw %r14, 8(%r1)
    addi %r1, %r1, 80
.Lcopy_small:
    cmplwi %r5, 16
    blt .Lcopy_bytes
    xor %r0, %r6, %r4
    andi. %r0, %r0, 3
    bne .Lcopy_shifted
    # Same alignment: bytes until dest (and so src) is word-aligned.
    andi. %r0, %r6, 3
    beq .Lcopy_aligned
    subfic %r0, %r0, 4
    sub %r5, %r5, %r0
    mtctr %r0
1:  lbz %r7, 0(%r4)
    addi %r4, %r4, 1
    stb %r7, 0(%r6)
    addi %r6, %r6, 1
    bdnz 1b
.Lcopy_aligned:
    srwi. %r0, %r5, 5
    beq .Lcopy_words
    mtctr %r0
2:  lwz %r7, 0(%r4)
    lwz %r8, 4(%r4)
    lwz %r9, 8(%r4)
    lwz %r10, 12(%r4)
    stw %r7, 0(%r6)
    stw %r8, 4(%r6)
    stw %r9, 8(%r6)
    stw %r10, 12(%r6)
    lwz %r7, 16(%r4)
    lwz %r8, 20(%r4)
    lwz %r9, 24(%r4)
    lwz %r10, 28(%r4)
    stw %r7, 16(%r6)
    stw %r8, 20(%r6)
    stw %r9, 24(%r6)
    stw %r10, 28(%r6)
    addi %r4, %r4, 32
    addi %r6, %r6, 32
    bdnz 2b
.Lcopy_words:
    rlwinm. %r0, %r5, 30, 29, 31
    beq .Lcopy_tail
    mtctr %r0
3:  lwz %r7, 0(%r4)
    addi %r4, %r4, 4
    stw %r7, 0(%r6)
    addi %r6, %r6, 4
    bdnz 3b
.Lcopy_tail:
    andi. %r5, %r5, 3
.Lcopy_bytes:
    cmpwi %r5, 0
    beqlr
    mtctr %r5
    addi %r4, %r4, -1
    addi %r6, %r6, -1
4:  lbzu %r7, 1(%r4)
    stbu %r7, 1(%r6)
    bdnz 4b
    blr
    # Different alignment: bytes until dest is word-aligned, then each dest word is put
    # together from the two aligned source words it straddles (shifted and or-ed), two words
    # per loop turn. Only aligned words holding source bytes are read.
.Lcopy_shifted:
    andi. %r0, %r6, 3
    beq 8f
    subfic %r0, %r0, 4
    sub %r5, %r5, %r0
    mtctr %r0
7:  lbz %r7, 0(%r4)
    addi %r4, %r4, 1
    stb %r7, 0(%r6)
    addi %r6, %r6, 1
    bdnz 7b
8:  rlwinm %r9, %r4, 3, 27, 28
    subfic %r10, %r9, 32
    rlwinm %r11, %r4, 0, 0, 29
    lwz %r7, 0(%r11)
    srwi. %r0, %r5, 3
    beq 10f
    mtctr %r0
9:  lwz %r8, 4(%r11)
    slw %r12, %r7, %r9
    srw %r0, %r8, %r10
    or %r12, %r12, %r0
    stw %r12, 0(%r6)
    lwzu %r7, 8(%r11)
    slw %r12, %r8, %r9
    srw %r0, %r7, %r10
    or %r12, %r12, %r0
    stw %r12, 4(%r6)
    addi %r6, %r6, 8
    bdnz 9b
10: andi. %r0, %r5, 4
    beq 11f
    lwz %r8, 4(%r11)
    slw %r12, %r7, %r9
    srw %r0, %r8, %r10
    or %r12, %r12, %r0
    stw %r12, 0(%r6)
    addi %r6, %r6, 4
11: rlwinm %r0, %r5, 0, 0, 29
    add %r4, %r4, %r0
    andi. %r5, %r5, 3
    b .Lcopy_bytes
    .size memcpy, . - memcpy

    .section .text.memmove, "ax"
    .globl memmove
    .type memmove, @function
    # memmove(dest r3, src r4, n r5) -> dest. Forward (memcpy's loop) unless dest lies inside
    # (src, src + n): a forward copy never overwrites a source byte it has not read yet when
    # dest < src, because every block is loaded before it is stored.
memmove:
    mr %r6, %r3
    cmplw %r3, %r4
    ble .Lcopy_forward
    add %r0, %r4, %r5
    cmplw %r3, %r0
    bge .Lcopy_forward
    # Backward, from the ends: words when dest, src and n are all word-aligned, else bytes.
    add %r4, %r4, %r5
    add %r6, %r6, %r5
    or %r0, %r4, %r6
    or %r0, %r0, %r5
    andi. %r0, %r0, 3
    bne 6f
    srwi. %r0, %r5, 2
    beqlr
    mtctr %r0
5:  lwzu %r7, -4(%r4)
    stwu %r7, -4(%r6)
    bdnz 5b
    blr
6:  cmpwi %r5, 0
    beqlr
    mtctr %r5
7:  lbzu %r7, -1(%r4)
    stbu %r7, -1(%r6)
    bdnz 7b
    blr
    .size memmove, . - memmove

    .section .text.memset, "ax"
    .globl memset
    .type memset, @function
    # memset(dest r3, c r4, n r5) -> dest.
memset:
    mr %r6, %r3
    rlwinm %r4, %r4, 0, 24, 31
    cmplwi %r5, 16
    blt .Lset_bytes
    # The byte in all four lanes.
    rlwimi %r4, %r4, 8, 16, 23
    rlwimi %r4, %r4, 16, 0, 15
    andi. %r0, %r6, 3
    beq .Lset_aligned
    subfic %r0, %r0, 4
    sub %r5, %r5, %r0
    mtctr %r0
1:  stb %r4, 0(%r6)
    addi %r6, %r6, 1
    bdnz 1b
.Lset_aligned:
    # 96 bytes per stmw (the word in r8-r31) while at least 192 are left; r14-r31 are saved
    # around the loop in a stack frame of its own.
    cmplwi %r5, 192
    blt .Lset_blocks
    li %r0, 96
    divwu %r7, %r5, %r0
    mullw %r0, %r7, %r0
    subf %r5, %r0, %r5
    mtctr %r7
    stwu %r1, -80(%r1)
    stmw %r14, 8(%r1)
    mr %r8, %r4
    mr %r9, %r4
    mr %r10, %r4
    mr %r11, %r4
    mr %r12, %r4
    mr %r13, %r4
    mr %r14, %r4
    mr %r15, %r4
    mr %r16, %r4
    mr %r17, %r4
    mr %r18, %r4
    mr %r19, %r4
    mr %r20, %r4
    mr %r21, %r4
    mr %r22, %r4
    mr %r23, %r4
    mr %r24, %r4
    mr %r25, %r4
    mr %r26, %r4
    mr %r27, %r4
    mr %r28, %r4
    mr %r29, %r4
    mr %r30, %r4
    mr %r31, %r4
12: stmw %r8, 0(%r6)
    addi %r6, %r6, 96
    bdnz 12b
    lmw %r14, 8(%r1)
    addi %r1, %r1, 80
.Lset_blocks:
    srwi. %r0, %r5, 5
    beq .Lset_words
    mtctr %r0
2:  stw %r4, 0(%r6)
    stw %r4, 4(%r6)
    stw %r4, 8(%r6)
    stw %r4, 12(%r6)
    stw %r4, 16(%r6)
    stw %r4, 20(%r6)
    stw %r4, 24(%r6)
    stw %r4, 28(%r6)
    addi %r6, %r6, 32
    bdnz 2b
.Lset_words:
    rlwinm. %r0, %r5, 30, 29, 31
    beq .Lset_tail
    mtctr %r0
3:  stw %r4, 0(%r6)
    addi %r6, %r6, 4
    bdnz 3b
.Lset_tail:
    andi. %r5, %r5, 3
.Lset_bytes:
    cmpwi %r5, 0
    beqlr
    mtctr %r5
    addi %r6, %r6, -1
4:  stbu %r4, 1(%r6)
    bdnz 4b
    blr
    .size memset, . - memset
"#
);

/// # Safety
/// 1. `a` and `b` are valid for `n` bytes.
#[no_mangle]
pub unsafe extern "C" fn memcmp(a: *const u8, b: *const u8, n: usize) -> i32 {
    let mut i = 0;
    while i < n {
        let (x, y) = (read_volatile(a.add(i)), read_volatile(b.add(i)));
        if x != y {
            return i32::from(x) - i32::from(y);
        }
        i += 1;
    }
    0
}

/// # Safety
/// 1. `a` and `b` are valid for `n` bytes.
#[no_mangle]
pub unsafe extern "C" fn bcmp(a: *const u8, b: *const u8, n: usize) -> i32 {
    memcmp(a, b, n)
}

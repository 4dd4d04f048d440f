//! The saved register context: what the exception entry code (`boot`) stores and the kernel
//! reads, edits and resumes. Its own module so that `boot` (the assembly that fills and loads
//! it) and `kernel` (which decides what runs) share it without importing each other: the
//! kernel uses `boot`, `boot` uses only this.

/// A saved register set. The layout is fixed: `boot`'s entry and resume code use the
/// offsets.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct Context {
    pub gpr: [u32; 32],
    pub cr: u32,
    pub lr: u32,
    pub ctr: u32,
    pub xer: u32,
    pub srr0: u32,
    pub srr1: u32,
    _pad: [u32; 2],
}

const _: () = {
    assert!(core::mem::offset_of!(Context, cr) == 128);
    assert!(core::mem::offset_of!(Context, srr0) == 144);
    assert!(core::mem::offset_of!(Context, srr1) == 148);
};

impl Context {
    pub const ZERO: Context = Context {
        gpr: [0; 32],
        cr: 0,
        lr: 0,
        ctr: 0,
        xer: 0,
        srr0: 0,
        srr1: 0,
        _pad: [0; 2],
    };
}

/// Where a fault inside the kernel saves its registers (SPRG2 points here while the kernel
/// runs), so it never overwrites a partition's context.
#[no_mangle]
pub static mut KERNEL_FAULT_CONTEXT: Context = Context::ZERO;

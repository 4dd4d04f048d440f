//! Drivers for the g3beige board as QEMU emulates it: Grackle PCI host bridge, Heathrow mac-io
//! and its interrupt controller, the ESCC (Zilog 8530) serial controller, and the 750's timebase.
pub mod escc;
pub mod heathrow;
pub mod pci;
pub mod timebase;

use core::ptr::{read_volatile, write_volatile};

/// Memory-mapped register access with the ordering barrier the 750 needs for device memory.
///
/// # Safety
/// 1. `addr` is a device register mapped (or, with the MMU off, physically present) for bytes.
#[inline]
pub unsafe fn mmio_write8(addr: usize, value: u8) {
    write_volatile(addr as *mut u8, value);
    core::arch::asm!("eieio", options(nostack));
}

/// # Safety
/// 1. `addr` is a device register mapped (or physically present) for bytes.
#[inline]
pub unsafe fn mmio_read8(addr: usize) -> u8 {
    let v = read_volatile(addr as *const u8);
    core::arch::asm!("eieio", options(nostack));
    v
}

/// # Safety
/// 1. `addr` is a 4-byte aligned device register.
#[inline]
pub unsafe fn mmio_write32(addr: usize, value: u32) {
    write_volatile(addr as *mut u32, value);
    core::arch::asm!("eieio", options(nostack));
}

/// # Safety
/// 1. `addr` is a 4-byte aligned device register.
#[inline]
pub unsafe fn mmio_read32(addr: usize) -> u32 {
    let v = read_volatile(addr as *const u32);
    core::arch::asm!("eieio", options(nostack));
    v
}

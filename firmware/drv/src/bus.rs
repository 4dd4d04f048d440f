//! Register access: what a driver needs from the machine.

/// Byte and word access to device registers at absolute addresses. Drivers compute the
/// addresses; an implementation performs the accesses in program order, each exactly once.
///
/// Multi-byte registers are accessed in the CPU's byte order (big-endian on the 750); drivers of
/// little-endian devices swap.
pub trait Bus {
    fn read8(&self, addr: usize) -> u8;
    fn write8(&self, addr: usize, value: u8);
    fn read32(&self, addr: usize) -> u32;
    fn write32(&self, addr: usize, value: u32);
}

impl<B: Bus + ?Sized> Bus for &B {
    #[inline]
    fn read8(&self, addr: usize) -> u8 {
        (**self).read8(addr)
    }
    #[inline]
    fn write8(&self, addr: usize, value: u8) {
        (**self).write8(addr, value)
    }
    #[inline]
    fn read32(&self, addr: usize) -> u32 {
        (**self).read32(addr)
    }
    #[inline]
    fn write32(&self, addr: usize, value: u32) {
        (**self).write32(addr, value)
    }
}

#[cfg(target_arch = "powerpc")]
pub use self::mmio::Mmio;

#[cfg(target_arch = "powerpc")]
mod mmio {
    use core::arch::asm;
    use core::ptr::{read_volatile, write_volatile};

    /// Memory-mapped registers, with the ordering barrier (`eieio`) the 750 needs after each
    /// access to device memory. Zero-sized: passing it around costs nothing.
    #[derive(Clone, Copy)]
    pub struct Mmio(());

    impl Mmio {
        /// # Safety
        /// 1. Every address the drivers given this value access is a device register present
        ///    at that address: the kernel runs with the MMU off (or the registers mapped 1:1),
        ///    and drivers of mac-io's devices are used only after `pci::Grackle::init_mac_io`
        ///    mapped mac-io at [`crate::pci::MAC_IO_BASE`].
        /// 2. Only the kernel uses the board's devices.
        #[inline]
        pub const unsafe fn new() -> Self {
            Self(())
        }
    }

    impl super::Bus for Mmio {
        #[inline]
        fn read8(&self, addr: usize) -> u8 {
            // SAFETY: `Mmio::new`'s contract: `addr` is a mapped device register.
            unsafe {
                let v = read_volatile(addr as *const u8);
                asm!("eieio", options(nostack));
                v
            }
        }

        #[inline]
        fn write8(&self, addr: usize, value: u8) {
            // SAFETY: as in `read8`.
            unsafe {
                write_volatile(addr as *mut u8, value);
                asm!("eieio", options(nostack));
            }
        }

        #[inline]
        fn read32(&self, addr: usize) -> u32 {
            // SAFETY: as in `read8`; the drivers' word registers are 4-byte aligned.
            unsafe {
                let v = read_volatile(addr as *const u32);
                asm!("eieio", options(nostack));
                v
            }
        }

        #[inline]
        fn write32(&self, addr: usize, value: u32) {
            // SAFETY: as in `read32`.
            unsafe {
                write_volatile(addr as *mut u32, value);
                asm!("eieio", options(nostack));
            }
        }
    }
}

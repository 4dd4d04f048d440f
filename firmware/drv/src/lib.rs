//! Drivers for the g3beige board as QEMU emulates it (Hubris's `drv/`): the Grackle PCI host
//! bridge, Heathrow mac-io's interrupt controller, the ESCC (Zilog 8530) serial controller, and
//! the 750's timebase.
//!
//! Every driver is generic over [`Bus`], the register access it needs, so that the same
//! register-level code runs on the target ([`bus::Mmio`], PowerPC only: volatile accesses
//! followed by `eieio`) and on the host against a mock (`cargo test -p drv-g3beige`). Where the
//! embedded-hal family has a trait, the driver implements it:
//!
//! - [`timebase::Delay`]: `embedded_hal::delay::DelayNs` over the timebase (exact tick
//!   arithmetic at 16.6 MHz);
//! - [`escc::Escc`]: `embedded-io`'s `Read`, `ReadReady`, `Write`, `WriteReady`, and
//!   `embedded-hal-nb`'s non-blocking `serial::Read` / `serial::Write`.
//!
//! The PIC and the PCI bridge have no embedded-hal trait; their drivers are plain types.
#![no_std]
// The kernel's lints (as firmware/autonomy and the image): no panicking path.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

pub mod bus;
pub mod escc;
pub mod heathrow;
pub mod pci;
pub mod timebase;

#[cfg(test)]
mod mock;

pub use bus::Bus;

//! The parts of the RAD750-proxy kernel and its board drivers that are plain logic: no
//! registers, no assembly, no `unsafe`. They live here, `no_std`, so that the host's test suite
//! runs them (`cargo test -p kernel-logic`); the firmware image uses them unchanged.
//!
//! - [`byte_ring`]: the fixed-capacity byte ring the kernel drains the link's UART into;
//! - [`heathrow`]: where an interrupt line's bits live in the Heathrow PIC's registers, and the
//!   lines QEMU's g3beige wires to it;
//! - [`park`]: whether the module may stop its schedule and wait for the host
//!   (`SYS_WAIT_FOR_INPUT`), and the check of that call's arguments;
//! - [`shm_link`]: the shared-memory link transport's layout and ring logic, used by the
//!   target's kernel and by the host (`hil`) alike.
#![no_std]

pub mod byte_ring;
pub mod heathrow;
pub mod park;
pub mod shm_link;

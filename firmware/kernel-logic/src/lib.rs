//! The parts of the RAD750-proxy kernel that are plain logic: no
//! registers, no assembly, no `unsafe`. They live here, `no_std`, so that the host's test suite
//! runs them (`cargo test -p kernel-logic`); the firmware image uses them unchanged. The board
//! drivers, register logic included, are in `drv-g3beige` (`firmware/drv`).
//!
//! - [`byte_ring`]: the fixed-capacity byte ring the kernel drains the link's UART into;
//! - [`event`]: the kernel's event records (health-monitor events, metrics) as the I/O
//!   partition drains them, and the message each stands for;
//! - [`image_sum`]: the RAM image's checksum as the reset stub computes it (the kernel checks
//!   the deferred code with it before that code first runs);
//! - [`park`]: whether the module may stop its schedule and wait for the host
//!   (`SYS_WAIT_FOR_INPUT`), and the check of that call's arguments;
//! - [`port_queue`]: a queuing port's ring, and the rule that drops messages sent before
//!   their sender restarted (stale generation);
//! - [`shm_link`]: the shared-memory link transport's layout and ring logic, used by the
//!   target's kernel and by the host (`hil`) alike.
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

pub mod byte_ring;
pub mod event;
pub mod image_sum;
pub mod park;
pub mod port_queue;
pub mod shm_link;

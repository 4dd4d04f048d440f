//! RAD750-proxy firmware image: boots from its own reset vector on qemu-system-ppc g3beige
//! (`-cpu 750`, `-bios`), brings up PCI, mac-io and the ESCC UART, determines the reset cause,
//! and starts the partitioning kernel, which runs the I/O, executive and planner partitions
//! (and, in the test image, a rogue one) in problem state in their windows of the major frame.
//! The partitions are crates of their own (`firmware/task-*`, on `firmware/userlib`); the image
//! links them, and its build script places each one's statics in its region.
#![no_std]
#![no_main]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod board;
mod boot;
mod config;
mod context;
mod kernel;
mod log;
mod mem;
mod shared;
mod warm;

// The partitions: linked for their entry functions, which the kernel finds by their symbols
// (`config::partition_image`, generated from the configuration).
extern crate task_executive;
extern crate task_io;
extern crate task_planner;
#[cfg(feature = "test-partitions")]
extern crate task_rogue;

use core::panic::PanicInfo;

use board::{escc, heathrow, pci, timebase};
use fsw_bridge::messages::PANIC_FILE_MAX;
use fsw_bridge::{ResetCause, TargetToHost, PROTOCOL_VERSION};
use kernel::link::SharedMemoryDevice;
use kernel_logic::shm_link;

include!(concat!(env!("OUT_DIR"), "/build_id.rs"));

/// The build id, word-aligned (the reset stub compares the ROM's with the image record's a
/// word at a time).
#[repr(C, align(4))]
pub struct BuildId(pub [u8; 8]);

/// The build id, also readable by the host from the ELF symbol table, and by the I/O
/// partition (for its Hello) by this symbol.
#[no_mangle]
#[used]
pub static FIRMWARE_BUILD_ID: BuildId = BuildId(BUILD_ID);

/// libcore is prebuilt with unwinding; with panic=abort nothing calls this.
#[no_mangle]
pub extern "C" fn rust_eh_personality() {}

fn reset_cause_name(cause: ResetCause) -> &'static str {
    match cause {
        ResetCause::PowerOn => "power-on",
        ResetCause::Warm => "warm",
        ResetCause::Watchdog => "watchdog",
        ResetCause::HealthMonitor => "health-monitor",
        ResetCause::KernelFault => "kernel-fault",
    }
}

/// Entered from the reset stub with the MMU off, vectors at 0x0, the kernel stack, and .bss
/// cleared; `reset_tb_hi:reset_tb_lo` is the timebase the stub read at the reset vector,
/// `image_check` how it made the RAM image good (`boot::ImageCheck`), and `image_done_tb`
/// and `cleared_tb` the low words of the timebase after its image step and after its clears.
#[no_mangle]
#[link_section = ".text.rust_start"]
pub extern "C" fn rust_start(
    reset_tb_hi: u32,
    reset_tb_lo: u32,
    image_check: u32,
    image_done_tb: u32,
    cleared_tb: u32,
) -> ! {
    timebase::mark_boot((u64::from(reset_tb_hi) << 32) | u64::from(reset_tb_lo));
    let stub = kernel::StubReport {
        image: boot::ImageCheck::from_stub(image_check),
        image_ticks: image_done_tb.wrapping_sub(reset_tb_lo),
        clear_ticks: cleared_tb.wrapping_sub(image_done_tb),
    };
    let (cause, boot_count) = warm::record_boot();
    if pci::init_mac_io().is_none() {
        // Without mac-io there is no UART and nobody to tell: try again from the top.
        warm::set_pending_cause(ResetCause::HealthMonitor);
        boot::software_reset();
    }
    // Nothing may interrupt before the kernel asks for it (QEMU keeps the controller's mask and
    // latched events across a warm reset).
    heathrow::init();
    // mac-io was just mapped; from now on only the kernel uses the channel (`kernel::link`).
    let _ = escc::init();
    // Goes to the kernel's log ring; the I/O partition sends it right after its Hello.
    defmt::info!(
        "boot: reset cause {=str}, boot {=u32}, protocol v{=u16}",
        reset_cause_name(cause),
        boot_count,
        PROTOCOL_VERSION
    );
    if stub.image == boot::ImageCheck::Repaired {
        defmt::warn!("boot: the RAM image failed its checksum; copied again from ROM");
    }
    // SAFETY: the link device is mapped at LINK_SHM_BASE when `is_link` is asked, and only the
    // kernel touches it.
    let link_device = unsafe { SharedMemoryDevice::at(kernel_config::LINK_SHM_BASE as usize) };
    let memories = pci::init_shared_memories(
        kernel_config::NV_BASE,
        kernel_config::LINK_SHM_BASE,
        shm_link::DEVICE_BYTES,
        || shm_link::check_header(&link_device).is_ok(),
    );
    let nv_bytes = match memories.nv_bytes {
        Some(size) => {
            defmt::info!(
                "boot: non-volatile memory, {=u32} KiB at {=u32:#x}",
                size / 1024,
                kernel_config::NV_BASE
            );
            size.min(kernel_config::NV_MAX_BYTES)
        }
        None => 0,
    };
    if memories.link {
        defmt::info!(
            "boot: link over shared memory at {=u32:#x}, the serial line as its doorbell",
            kernel_config::LINK_SHM_BASE
        );
    }
    kernel::start(
        warm::cause_code(cause),
        boot_count,
        nv_bytes,
        memories.link.then_some(link_device),
        stub,
    )
}

static mut PANICKING: bool = false;

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    let (file, line) = info
        .location()
        .map(|l| (l.file(), l.line()))
        .unwrap_or(("<unknown>", 0));
    if !shared::in_kernel() {
        // A partition: the health monitor decides (restart, halt, warm reset).
        userlib::sys::panic(file, line);
    }
    kernel_panic(file, line)
}

/// The kernel's last words: report `file:line` to the host as a panic, then warm-reset (cause
/// HealthMonitor). Reached from a panic in kernel context and from a kernel invariant that did
/// not hold ([`kernel::invariant_broken`]).
pub fn kernel_panic(file: &str, line: u32) -> ! {
    boot::disable_interrupts();
    // SAFETY: kernel context, single core, interrupts off.
    let first = unsafe { !core::mem::replace(&mut *core::ptr::addr_of_mut!(PANICKING), true) };
    if first {
        let bytes = file.as_bytes();
        let tail = bytes
            .get(bytes.len().saturating_sub(PANIC_FILE_MAX)..)
            .unwrap_or_default();
        // SAFETY: kernel context, interrupts off; whatever the kernel was doing is abandoned
        // (this ends in a reset), so no other use of its state follows.
        let k = unsafe { kernel::kernel() };
        kernel::klog::send_direct(
            &mut k.link,
            &TargetToHost::Panic {
                file: heapless::Vec::from_slice(tail).unwrap_or_default(),
                line,
            },
        );
    }
    warm::set_pending_cause(ResetCause::HealthMonitor);
    boot::software_reset()
}

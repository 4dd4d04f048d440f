//! RAD750-proxy firmware image: boots from its own reset vector on qemu-system-ppc g3beige
//! (`-cpu 750`, `-bios`), brings up PCI, mac-io and the ESCC UART, says Hello with the reset
//! cause, and serves the framed link (ping, reset request, time grants), logging through defmt.
#![no_std]
#![no_main]

mod board;
mod boot;
mod link;
mod log;
mod mem;
mod sync;
mod warm;

use core::panic::PanicInfo;

use board::escc::EsccChannelA;
use board::{pci, timebase};
use fsw_bridge::messages::PANIC_FILE_MAX;
use fsw_bridge::{
    HostToTarget, ResetCause, ResetKind, TargetToHost, TelemetryEvent, PROTOCOL_VERSION,
};

include!(concat!(env!("OUT_DIR"), "/build_id.rs"));

/// The build id, also readable by the host from the ELF symbol table.
#[no_mangle]
#[used]
pub static FIRMWARE_BUILD_ID: [u8; 8] = BUILD_ID;

/// Partition number used in health-monitor reports for the kernel itself.
const KERNEL_PARTITION: u8 = 0xff;
/// Health-monitor action code: warm-reset the module.
const ACTION_WARM_RESET: u8 = 2;

/// libcore is prebuilt with unwinding; with panic=abort nothing calls this.
#[no_mangle]
pub extern "C" fn rust_eh_personality() {}

fn reset_cause_name(cause: ResetCause) -> &'static str {
    match cause {
        ResetCause::PowerOn => "power-on",
        ResetCause::Warm => "warm",
        ResetCause::Watchdog => "watchdog",
        ResetCause::HealthMonitor => "health-monitor",
    }
}

/// Entered from the reset stub with the MMU off, vectors at 0x0, a stack, and .bss cleared.
#[no_mangle]
#[link_section = ".text.rust_start"]
pub extern "C" fn rust_start() -> ! {
    timebase::mark_boot();
    let (cause, boot_count) = warm::record_boot();
    if pci::init_mac_io().is_none() {
        // Without mac-io there is no UART and nobody to tell: try again from the top.
        warm::set_pending_cause(ResetCause::HealthMonitor);
        boot::software_reset();
    }
    // SAFETY: mac-io was just mapped at MAC_IO_BASE, and this is the only UART instance.
    let uart = unsafe { EsccChannelA::init() };
    link::LINK.set(link::Link::new(uart));
    link::send(&TargetToHost::Hello {
        protocol_version: PROTOCOL_VERSION,
        build_id: BUILD_ID,
        reset_cause: cause,
        boot_count,
    });
    defmt::info!(
        "boot: reset cause {=str}, boot {=u32}, protocol v{=u16}",
        reset_cause_name(cause),
        boot_count,
        PROTOCOL_VERSION
    );
    serve()
}

/// Serve the link: answer pings, honour reset requests, acknowledge time grants.
fn serve() -> ! {
    loop {
        let Some(next) = link::LINK.with(|l| l.poll()).flatten() else {
            continue;
        };
        match next {
            Ok(HostToTarget::Ping { seq }) => {
                let counters = link::LINK.with(|l| l.counters()).unwrap_or_default();
                link::send(&TargetToHost::Pong {
                    seq,
                    link: counters,
                });
            }
            Ok(HostToTarget::ResetRequest {
                kind: ResetKind::Warm,
            }) => {
                defmt::info!("reset requested by host: warm");
                warm::set_pending_cause(ResetCause::Warm);
                boot::software_reset();
            }
            Ok(HostToTarget::TimeGrant { frame, .. }) => {
                link::send(&TargetToHost::FrameDone {
                    frame,
                    next_wakeup: None,
                    busy_ticks: 0,
                });
            }
            Ok(_) => defmt::warn!("link: message not handled by this image"),
            Err(error) => defmt::warn!("link: frame rejected: {=str}", decode_error_name(error)),
        }
    }
}

fn decode_error_name(error: fsw_bridge::codec::DecodeError) -> &'static str {
    use fsw_bridge::codec::DecodeError::*;
    match error {
        BadCrc => "bad CRC",
        Oversize => "oversize",
        UnknownType(_) => "unknown type",
        Truncated => "truncated",
        Malformed => "malformed",
    }
}

/// Called by the common exception handler (boot.rs) for any exception the image does not
/// handle: report it to the host, then warm-reset with cause HealthMonitor.
#[no_mangle]
pub extern "C" fn fatal_exception(vector: u32, srr0: u32, srr1: u32, dar: u32, dsisr: u32) -> ! {
    boot::disable_interrupts();
    let address = if vector == 0x300 { dar } else { srr0 };
    link::send(&TargetToHost::Telemetry(TelemetryEvent::HealthMonitor {
        partition: KERNEL_PARTITION,
        kind: (vector >> 8) as u8,
        address,
        action: ACTION_WARM_RESET,
    }));
    defmt::error!(
        "kernel exception {=u32:#x} at {=u32:#x} (srr1 {=u32:#x}, dar {=u32:#x}, dsisr {=u32:#x}): warm reset",
        vector,
        srr0,
        srr1,
        dar,
        dsisr
    );
    warm::set_pending_cause(ResetCause::HealthMonitor);
    boot::software_reset()
}

static mut PANICKING: bool = false;

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    boot::disable_interrupts();
    // SAFETY: single core with interrupts off.
    let first = unsafe { !core::mem::replace(&mut *core::ptr::addr_of_mut!(PANICKING), true) };
    if first {
        let (file, line) = info
            .location()
            .map(|l| (l.file(), l.line()))
            .unwrap_or(("<unknown>", 0));
        let bytes = file.as_bytes();
        let tail = &bytes[bytes.len().saturating_sub(PANIC_FILE_MAX)..];
        let report = TargetToHost::Panic {
            file: heapless::Vec::from_slice(tail).unwrap_or_default(),
            line,
        };
        // The link may be borrowed by whoever panicked; then there is no safe way to report.
        link::send(&report);
    }
    warm::set_pending_cause(ResetCause::HealthMonitor);
    boot::software_reset()
}

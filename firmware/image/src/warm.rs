//! The warm-restart area: 64 KiB of RAM at a fixed address that the boot code never clears,
//! so it survives a warm reset (QEMU keeps RAM across `system_reset`) but not a power cycle.
//!
//! Its first bytes hold the boot record, from which the boot code derives the reset cause: no
//! valid record means RAM was not kept (power-on); a valid one means a warm reset, and a cause
//! the firmware recorded before resetting itself (health monitor, watchdog) takes precedence.
//! After it comes the reset stub's image record (`boot.rs`), and the rest of the area is for the
//! autonomy's A/B checkpoints.
use core::ptr::{addr_of_mut, read_volatile, write_volatile};

use crc::{Crc, CRC_32_ISO_HDLC};
use fsw_bridge::ResetCause;

/// Size of the whole area (must match `__warm_area_size` in linker/g3beige.ld).
pub const WARM_AREA_SIZE: usize = 0x1_0000;
/// Bytes reserved at the start of the area for the boot record (its first 16 bytes) and the
/// reset stub's image record (`boot::IMAGE_RECORD_OFFSET`).
const BOOT_RECORD_SIZE: usize = kernel_config::WARM_BOOT_RECORD_SIZE as usize;
const _: () = assert!(
    crate::boot::IMAGE_RECORD_OFFSET >= 16
        && crate::boot::IMAGE_RECORD_OFFSET + crate::boot::IMAGE_RECORD_BYTES <= BOOT_RECORD_SIZE
);

#[link_section = ".warm_restart"]
static mut WARM_AREA: [u8; WARM_AREA_SIZE] = [0; WARM_AREA_SIZE];

const MAGIC: u32 = 0x5241_4457; // "RADW"
const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

#[derive(Clone, Copy)]
struct BootRecord {
    magic: u32,
    boot_count: u32,
    pending_cause: u32,
    crc: u32,
}

const NO_PENDING_CAUSE: u32 = 0;

/// The code the kernel hands the I/O partition (SYS_BOOT_INFO): 1 power-on, 2 warm, 3 watchdog,
/// 4 health monitor.
pub fn cause_code(cause: ResetCause) -> u32 {
    match cause {
        ResetCause::PowerOn => 1,
        ResetCause::Warm => 2,
        ResetCause::Watchdog => 3,
        ResetCause::HealthMonitor => 4,
    }
}

fn cause_from_code(code: u32) -> Option<ResetCause> {
    Some(match code {
        1 => ResetCause::PowerOn,
        2 => ResetCause::Warm,
        3 => ResetCause::Watchdog,
        4 => ResetCause::HealthMonitor,
        _ => return None,
    })
}

impl BootRecord {
    fn checksum(&self) -> u32 {
        let mut bytes = [0u8; 12];
        bytes[0..4].copy_from_slice(&self.magic.to_be_bytes());
        bytes[4..8].copy_from_slice(&self.boot_count.to_be_bytes());
        bytes[8..12].copy_from_slice(&self.pending_cause.to_be_bytes());
        CRC32.checksum(&bytes)
    }

    fn is_valid(&self) -> bool {
        self.magic == MAGIC && self.crc == self.checksum()
    }
}

fn record_ptr() -> *mut u32 {
    addr_of_mut!(WARM_AREA) as *mut u32
}

fn read_record() -> BootRecord {
    let p = record_ptr();
    // SAFETY: the area is 4-byte aligned RAM reserved for this module; volatile because its
    // contents come from before the reset, not from anything the compiler saw.
    unsafe {
        BootRecord {
            magic: read_volatile(p),
            boot_count: read_volatile(p.add(1)),
            pending_cause: read_volatile(p.add(2)),
            crc: read_volatile(p.add(3)),
        }
    }
}

fn write_record(mut record: BootRecord) {
    record.crc = record.checksum();
    let p = record_ptr();
    // SAFETY: as in `read_record`.
    unsafe {
        write_volatile(p, record.magic);
        write_volatile(p.add(1), record.boot_count);
        write_volatile(p.add(2), record.pending_cause);
        write_volatile(p.add(3), record.crc);
    }
}

/// Decide the reset cause from the boot record, then record this boot. Returns the cause and
/// the number of boots since the area was last initialised (power-on counts as 1).
pub fn record_boot() -> (ResetCause, u32) {
    let old = read_record();
    let (cause, boot_count) = if old.is_valid() {
        let cause = cause_from_code(old.pending_cause).unwrap_or(ResetCause::Warm);
        (cause, old.boot_count.wrapping_add(1))
    } else {
        (ResetCause::PowerOn, 1)
    };
    write_record(BootRecord {
        magic: MAGIC,
        boot_count,
        pending_cause: NO_PENDING_CAUSE,
        crc: 0,
    });
    (cause, boot_count)
}

/// Record why the firmware is about to reset itself, for the next boot's Hello.
pub fn set_pending_cause(cause: ResetCause) {
    let mut record = read_record();
    if !record.is_valid() {
        record = BootRecord {
            magic: MAGIC,
            boot_count: 0,
            pending_cause: 0,
            crc: 0,
        };
    }
    record.pending_cause = cause_code(cause);
    write_record(record);
}

/// Bytes of the area available after the boot record (for A/B checkpoints).
#[allow(dead_code)]
pub const CHECKPOINT_REGION_SIZE: usize = WARM_AREA_SIZE - BOOT_RECORD_SIZE;

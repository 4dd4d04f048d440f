//! The warm-restart area: 64 KiB of RAM at a fixed address that the boot code never clears,
//! so it survives a warm reset (QEMU keeps RAM across `system_reset`) but not a power cycle.
//!
//! Its first bytes hold the boot record, from which the boot code derives the reset cause: no
//! valid record means RAM was not kept (power-on); a valid one means a warm reset, and a cause
//! the firmware recorded before resetting itself (health monitor, watchdog) takes precedence.
//! A kernel fault (an exception in the kernel itself) also leaves its record after the boot
//! record (bytes 16..32: vector, SRR0, DAR, CRC), which the next boot takes for its Hello and
//! clears. After them comes the reset stub's image record (`boot.rs`), and the rest of the area
//! is for the autonomy's A/B checkpoints.
use core::ptr::{addr_of_mut, read_volatile, write_volatile};
use core::sync::atomic::{AtomicU32, Ordering};

use crc::{Crc, CRC_32_ISO_HDLC};
use fsw_bridge::{KernelFault, ResetCause};

/// Size of the whole area (must match `__warm_area_size` in linker/g3beige.ld).
pub const WARM_AREA_SIZE: usize = 0x1_0000;
/// Bytes reserved at the start of the area for the boot record (its first 16 bytes) and the
/// reset stub's image record (`boot::IMAGE_RECORD_OFFSET`).
const BOOT_RECORD_SIZE: usize = kernel_config::WARM_BOOT_RECORD_SIZE as usize;
/// Where the kernel-fault record lies (word index: bytes 16..32, between the boot record and
/// the image record).
const FAULT_RECORD_WORD: usize = 4;
const _: () = assert!(
    crate::boot::IMAGE_RECORD_OFFSET >= 32
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
/// 4 health monitor, 5 kernel fault.
pub fn cause_code(cause: ResetCause) -> u32 {
    match cause {
        ResetCause::PowerOn => 1,
        ResetCause::Warm => 2,
        ResetCause::Watchdog => 3,
        ResetCause::HealthMonitor => 4,
        ResetCause::KernelFault => 5,
    }
}

fn cause_from_code(code: u32) -> Option<ResetCause> {
    Some(match code {
        1 => ResetCause::PowerOn,
        2 => ResetCause::Warm,
        3 => ResetCause::Watchdog,
        4 => ResetCause::HealthMonitor,
        5 => ResetCause::KernelFault,
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
/// the number of boots since the area was last initialised (power-on counts as 1). After a
/// kernel fault, its record is taken (see [`boot_kernel_fault`]) and cleared.
pub fn record_boot() -> (ResetCause, u32) {
    let old = read_record();
    let (cause, boot_count) = if old.is_valid() {
        let cause = cause_from_code(old.pending_cause).unwrap_or(ResetCause::Warm);
        (cause, old.boot_count.wrapping_add(1))
    } else {
        (ResetCause::PowerOn, 1)
    };
    // Only a kernel fault's reset has a record to take (its CRC is not worth checking on every
    // boot); any other leaves whatever is there unread, bound to an older boot count.
    if cause == ResetCause::KernelFault {
        if let Some(fault) = take_fault_record() {
            BOOT_FAULT[0].store(fault.vector, Ordering::Relaxed);
            BOOT_FAULT[1].store(fault.pc, Ordering::Relaxed);
            BOOT_FAULT[2].store(fault.dar, Ordering::Relaxed);
        }
    }
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

/// This boot's kernel fault (vector, SRR0, DAR; vector 0: none), taken from the warm area by
/// [`record_boot`]. Kernel RAM, cleared at every boot.
static BOOT_FAULT: [AtomicU32; 3] = [AtomicU32::new(0), AtomicU32::new(0), AtomicU32::new(0)];

fn fault_checksum(words: [u32; 3], boot_count: u32) -> u32 {
    let mut bytes = [0u8; 16];
    let words = words.iter().chain(core::iter::once(&boot_count));
    for (chunk, w) in bytes.as_chunks_mut::<4>().0.iter_mut().zip(words) {
        *chunk = w.to_be_bytes();
    }
    CRC32.checksum(&bytes) ^ MAGIC
}

/// Record a fault inside the kernel (before the warm reset it causes, with the pending cause
/// KernelFault): it is reported in the next boot's Hello. Bound to the boot record's boot
/// count, so a record left by an earlier boot is never taken for a later one's.
pub fn set_kernel_fault(fault: KernelFault) {
    let words = [fault.vector, fault.pc, fault.dar];
    let crc = fault_checksum(words, read_record().boot_count);
    // SAFETY: as in `read_record`; words 4..8 of the area are this record's.
    unsafe {
        let p = record_ptr().add(FAULT_RECORD_WORD);
        for (i, w) in words.iter().chain([crc].iter()).enumerate() {
            write_volatile(p.add(i), *w);
        }
    }
}

/// The kernel-fault record if a valid one for the boot that wrote the boot record is there;
/// the record is cleared either way. Called before the boot record is rewritten, only when the
/// pending cause was KernelFault.
fn take_fault_record() -> Option<KernelFault> {
    let boot_count = read_record().boot_count;
    // SAFETY: as in `set_kernel_fault`.
    let (words, crc) = unsafe {
        let p = record_ptr().add(FAULT_RECORD_WORD);
        let words = [
            read_volatile(p),
            read_volatile(p.add(1)),
            read_volatile(p.add(2)),
        ];
        let crc = read_volatile(p.add(3));
        for i in 0..4 {
            write_volatile(p.add(i), 0);
        }
        (words, crc)
    };
    (crc == fault_checksum(words, boot_count) && words[0] != 0).then_some(KernelFault {
        vector: words[0],
        pc: words[1],
        dar: words[2],
    })
}

/// The kernel fault that caused this boot's reset (cause KernelFault), if its record was good.
pub fn boot_kernel_fault() -> Option<KernelFault> {
    let vector = BOOT_FAULT[0].load(Ordering::Relaxed);
    (vector != 0).then(|| KernelFault {
        vector,
        pc: BOOT_FAULT[1].load(Ordering::Relaxed),
        dar: BOOT_FAULT[2].load(Ordering::Relaxed),
    })
}

/// Bytes of the area available after the boot record (for A/B checkpoints).
#[allow(dead_code)]
pub const CHECKPOINT_REGION_SIZE: usize = WARM_AREA_SIZE - BOOT_RECORD_SIZE;

/// Word `index` of the reset stub's image record (`boot::IMAGE_RECORD_*`).
pub fn image_record_word(index: usize) -> u32 {
    debug_assert!(index < crate::boot::IMAGE_RECORD_BYTES / 4);
    // SAFETY: as in `read_record`; the image record lies inside the area's reserved first
    // bytes (checked at compile time above), word-aligned.
    unsafe { read_volatile(record_ptr().add(crate::boot::IMAGE_RECORD_OFFSET / 4 + index)) }
}

/// Make the image record say that the part checked at boot does not match (its first sum
/// flipped, the check word with it, so the record stays valid for this ROM): the next boot's
/// reset stub copies the whole image from ROM again and reports it repaired.
pub fn image_record_fail() {
    for index in [
        crate::boot::IMAGE_RECORD_BOOT_WORD,
        crate::boot::IMAGE_RECORD_CHECK_WORD,
    ] {
        let word = image_record_word(index) ^ 1;
        // SAFETY: as in `image_record_word`.
        unsafe {
            write_volatile(
                record_ptr().add(crate::boot::IMAGE_RECORD_OFFSET / 4 + index),
                word,
            )
        }
    }
}

//! The defmt global logger, for the kernel and for partitions alike. Each log call is encoded
//! into a whole frame first: in the kernel into the kernel's buffer, then into the kernel's log
//! ring; in a partition into the partition's own header (in its region, right above its stack),
//! then handed to the kernel with SYS_LOG. Whole frames never interleave, so the host decodes
//! one defmt stream (carried in Log frames by the I/O partition) against this ELF.
//! Timestamps are guest microseconds since this boot (timebase).
use core::cell::UnsafeCell;
use core::ptr::addr_of_mut;

use crate::config::partition_image;
use crate::shared;

/// Largest encoded log frame; longer ones are dropped whole.
pub const LOG_FRAME_MAX: usize = 256;

struct Sink {
    bytes: [u8; LOG_FRAME_MAX],
    len: usize,
    overflow: bool,
}

impl Sink {
    fn push(&mut self, bytes: &[u8]) {
        let end = self.len + bytes.len();
        match self.bytes.get_mut(self.len..end) {
            Some(free) => free.copy_from_slice(bytes),
            None => {
                self.overflow = true;
                return;
            }
        }
        self.len = end;
    }
}

/// A logger's state: in the kernel's RAM for the kernel, in each partition's header for it.
#[repr(C)]
pub struct LogFrame {
    encoder: defmt::Encoder,
    sink: Sink,
    /// Nesting depth of acquire; only depth 1 writes, deeper messages are dropped.
    depth: u32,
    saved_msr: u32,
}

const _: () = assert!(
    core::mem::size_of::<LogFrame>() <= kernel_config::PARTITION_HEADER_SIZE as usize,
    "the partition header must hold a LogFrame"
);

struct KernelFrame(UnsafeCell<LogFrame>);

// SAFETY: used only in kernel context, with interrupts off, on the single core.
unsafe impl Sync for KernelFrame {}

static KERNEL_FRAME: KernelFrame = KernelFrame(UnsafeCell::new(LogFrame {
    encoder: defmt::Encoder::new(),
    sink: Sink {
        bytes: [0; LOG_FRAME_MAX],
        len: 0,
        overflow: false,
    },
    depth: 0,
    saved_msr: 0,
}));

/// This context's logger state.
fn frame() -> *mut LogFrame {
    if shared::in_kernel() {
        KERNEL_FRAME.0.get()
    } else {
        partition_image(shared::current_partition()).header() as *mut LogFrame
    }
}

#[defmt::global_logger]
struct Logger;

// SAFETY: every write happens between acquire and release; the kernel's state is used with
// interrupts off, a partition's only by that partition (which is single-threaded; preemption
// does not touch its header), and nested use is dropped.
unsafe impl defmt::Logger for Logger {
    fn acquire() {
        let kernel = shared::in_kernel();
        let msr = if kernel {
            crate::boot::disable_interrupts()
        } else {
            0
        };
        let f = frame();
        // SAFETY:
        // 1. `f` is this context's own LogFrame (see `frame`); in a partition it is in the
        //    partition's header, which the partition start zeroed (integers and bool: valid).
        // 2. The encoder is written before any reference to it is formed.
        unsafe {
            let depth = (*f).depth;
            (*f).depth = depth + 1;
            if depth == 0 {
                (*f).saved_msr = msr;
                addr_of_mut!((*f).encoder).write(defmt::Encoder::new());
                (*f).sink.len = 0;
                (*f).sink.overflow = false;
                let LogFrame { encoder, sink, .. } = &mut *f;
                encoder.start_frame(|b| sink.push(b));
            }
        }
    }

    unsafe fn flush() {}

    unsafe fn release() {
        let f = frame();
        let depth = (*f).depth;
        if depth != 1 {
            (*f).depth = depth.saturating_sub(1);
            return;
        }
        let LogFrame {
            encoder,
            sink,
            depth,
            ..
        } = &mut *f;
        encoder.end_frame(|b| sink.push(b));
        *depth = 0;
        if let Some(bytes) = sink.bytes.get(..sink.len).filter(|_| !sink.overflow) {
            if shared::in_kernel() {
                crate::kernel::klog::with_ring(|ring| ring.push_frame(bytes));
            } else {
                let _ = userlib::sys::log(bytes);
            }
        }
        if shared::in_kernel() {
            crate::boot::restore_msr((*f).saved_msr);
        }
    }

    unsafe fn write(bytes: &[u8]) {
        let f = frame();
        if (*f).depth == 1 {
            let LogFrame { encoder, sink, .. } = &mut *f;
            encoder.write(bytes, |b| sink.push(b));
        }
    }
}

defmt::timestamp!("{=u64:us}", crate::board::timebase::micros_since_boot());

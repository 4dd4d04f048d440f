//! defmt global logger: encoded log bytes travel to the host in Log frames and are decoded there
//! against this ELF. Timestamps are guest microseconds since this boot (timebase).
use core::cell::{Cell, UnsafeCell};

use fsw_bridge::messages::LOG_CHUNK_MAX;
use fsw_bridge::TargetToHost;
use heapless::Vec;

use crate::boot::{disable_interrupts, restore_msr};

struct LoggerState {
    encoder: UnsafeCell<defmt::Encoder>,
    chunk: UnsafeCell<Vec<u8, LOG_CHUNK_MAX>>,
    /// Nesting depth of acquire; only depth 1 writes, deeper messages are dropped.
    depth: Cell<u32>,
    saved_msr: Cell<u32>,
}

// SAFETY: single core; every access happens between acquire and release with interrupts off.
unsafe impl Sync for LoggerState {}

static STATE: LoggerState = LoggerState {
    encoder: UnsafeCell::new(defmt::Encoder::new()),
    chunk: UnsafeCell::new(Vec::new()),
    depth: Cell::new(0),
    saved_msr: Cell::new(0),
};

fn flush_chunk() {
    // SAFETY: called only while the logger is held at depth 1 (see `Logger` impl).
    let chunk = unsafe { &mut *STATE.chunk.get() };
    if !chunk.is_empty() {
        crate::link::send(&TargetToHost::Log {
            bytes: chunk.clone(),
        });
        chunk.clear();
    }
}

fn emit(bytes: &[u8]) {
    for &b in bytes {
        // SAFETY: as in `flush_chunk`.
        let chunk = unsafe { &mut *STATE.chunk.get() };
        if chunk.push(b).is_err() {
            flush_chunk();
            // SAFETY: as above; the chunk is empty now, so the push succeeds.
            let _ = unsafe { &mut *STATE.chunk.get() }.push(b);
        }
    }
}

#[defmt::global_logger]
struct LinkLogger;

// SAFETY: acquire/release bracket every write with interrupts off; nested use is dropped.
unsafe impl defmt::Logger for LinkLogger {
    fn acquire() {
        let msr = disable_interrupts();
        let depth = STATE.depth.get();
        STATE.depth.set(depth + 1);
        if depth == 0 {
            STATE.saved_msr.set(msr);
            // SAFETY: depth 0 -> 1: we are the only user of the encoder.
            unsafe { (*STATE.encoder.get()).start_frame(emit) }
        }
    }

    unsafe fn flush() {}

    unsafe fn release() {
        let depth = STATE.depth.get();
        if depth == 1 {
            (*STATE.encoder.get()).end_frame(emit);
            flush_chunk();
            STATE.depth.set(0);
            restore_msr(STATE.saved_msr.get());
        } else {
            STATE.depth.set(depth.saturating_sub(1));
        }
    }

    unsafe fn write(bytes: &[u8]) {
        if STATE.depth.get() == 1 {
            (*STATE.encoder.get()).write(bytes, emit);
        }
    }
}

defmt::timestamp!("{=u64:us}", crate::board::timebase::micros_since_boot());

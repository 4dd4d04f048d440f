//! The partitions' side of the system calls: thin wrappers over `sc` (see
//! `kernel_config::abi` for numbers and error codes). Everything here runs in problem state.
//! Calls are named by [`Sysnum`] and their r3 is decoded once, by [`decode_result`], into a
//! value or a [`SysError`].
use core::arch::asm;

use kernel_config::abi::*;
use kernel_logic::event::{record_from_bytes, EventRecord};

/// System call `call` with up to five arguments; returns (r3, r4, r5). The kernel restores
/// every other register.
#[inline(always)]
pub fn raw(call: Sysnum, a: [u32; 5]) -> (u32, u32, u32) {
    raw_number(call.number(), a)
}

/// A system call by number, assigned or not (the rogue partition's bad calls).
#[inline(always)]
pub fn raw_number(call: u32, a: [u32; 5]) -> (u32, u32, u32) {
    let (r3, r4, r5): (u32, u32, u32);
    // SAFETY:
    // 1. `sc` enters the kernel, which saves and restores the whole register set except r3-r5
    //    (the results) and checks every argument; the worst a bad argument does is an error.
    // 2. The kernel may write memory the arguments point at (receive buffers): no `nomem`.
    unsafe {
        asm!(
            "sc",
            in("r0") call,
            inlateout("r3") a[0] => r3,
            inlateout("r4") a[1] => r4,
            inlateout("r5") a[2] => r5,
            in("r6") a[3],
            in("r7") a[4],
            options(nostack)
        );
    }
    (r3, r4, r5)
}

#[inline]
fn result(r3: u32) -> Result<u32, SysError> {
    decode_result(r3)
}

/// Give up the rest of this window; returns at the start of the next one.
#[inline]
pub fn wait_next_window() {
    raw(Sysnum::WaitNextWindow, [wait::NEXT_WINDOW, 0, 0, 0, 0]);
}

/// Give up the rest of this window with nothing to do until a message arrives on one of this
/// partition's ports (the module may stop its schedule meanwhile); returns at a window start.
#[inline]
pub fn wait_idle() {
    raw(Sysnum::WaitNextWindow, [wait::IDLE, 0, 0, 0, 0]);
}

/// Link owner: move received link bytes into `buffer`; how many (the kernel reports bytes its
/// receiver lost in its accounting reports).
#[inline]
pub fn link_read(buffer: &mut [u8]) -> usize {
    let (r3, _, _) = raw(
        Sysnum::LinkRead,
        [buffer.as_mut_ptr() as u32, buffer.len() as u32, 0, 0, 0],
    );
    result(r3).unwrap_or(0) as usize
}

/// Link owner: send bytes to the host; how many the kernel took (0: no room yet).
#[inline]
pub fn link_write(data: &[u8]) -> usize {
    let (r3, _, _) = raw(
        Sysnum::LinkWrite,
        [data.as_ptr() as u32, data.len() as u32, 0, 0, 0],
    );
    result(r3).unwrap_or(0) as usize
}

/// What [`wait_for_input`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputWait {
    /// The module stopped its schedule until input arrived; this is a fresh major frame.
    Parked,
    /// Input was already waiting.
    InputPending,
    /// Something else had work; this is the caller's next window. `reasons` are
    /// `abi::wait_input` bits, `busy` the busy partitions.
    NextWindow { reasons: u32, busy: u32 },
}

/// Link owner: everything is sent and the caller waits for the host (see
/// `abi::SYS_WAIT_FOR_INPUT`).
#[inline]
pub fn wait_for_input() -> InputWait {
    let (r3, reasons, busy) = raw(Sysnum::WaitForInput, [0; 5]);
    match r3 {
        wait_input::PARKED => InputWait::Parked,
        wait_input::INPUT_PENDING => InputWait::InputPending,
        _ => InputWait::NextWindow { reasons, busy },
    }
}

/// Link owner: why the module could not park now (`abi::wait_input` reason bits, 0: everyone
/// else is done and nothing is in flight) and which partitions are busy, without waiting.
#[inline]
pub fn link_quiet() -> (u32, u32) {
    let (_, reasons, busy) = raw(Sysnum::WaitForInput, [wait_input::QUERY, 0, 0, 0, 0]);
    (reasons, busy)
}

#[inline]
pub fn port_send(port: usize, message: &[u8]) -> Result<(), SysError> {
    let (r3, _, _) = raw(
        Sysnum::PortSend,
        [
            port as u32,
            message.as_ptr() as u32,
            message.len() as u32,
            0,
            0,
        ],
    );
    result(r3).map(|_| ())
}

/// A message taken from a port.
pub struct Received {
    pub len: usize,
    /// The sender's generation when it sent the message.
    pub generation: u32,
    /// Ticks since it was sent.
    pub age: u32,
}

#[inline]
pub fn port_receive(port: usize, buffer: &mut [u8]) -> Result<Received, SysError> {
    let (r3, generation, age) = raw(
        Sysnum::PortReceive,
        [
            port as u32,
            buffer.as_mut_ptr() as u32,
            buffer.len() as u32,
            0,
            0,
        ],
    );
    result(r3).map(|len| Received {
        len: len as usize,
        generation,
        age,
    })
}

/// Mission time in µs (as last granted by the host).
#[inline]
pub fn mission_time_us() -> u64 {
    let (hi, lo, _) = raw(Sysnum::MissionTime, [0; 5]);
    (u64::from(hi) << 32) | u64::from(lo)
}

/// (ticks used since boot, ticks used in this window so far).
#[inline]
pub fn cpu_time() -> (u64, u32) {
    let (hi, lo, window) = raw(Sysnum::CpuTime, [0; 5]);
    ((u64::from(hi) << 32) | u64::from(lo), window)
}

/// (ticks since the reset vector, ticks the kernel's boot took: reset vector to the start of
/// the schedule).
#[inline]
pub fn uptime() -> (u64, u64) {
    let (hi, lo, boot) = raw(Sysnum::Uptime, [0; 5]);
    ((u64::from(hi) << 32) | u64::from(lo), u64::from(boot))
}

/// One whole defmt frame.
#[inline]
pub fn log(frame: &[u8]) -> Result<(), SysError> {
    let (r3, _, _) = raw(
        Sysnum::Log,
        [frame.as_ptr() as u32, frame.len() as u32, 0, 0, 0],
    );
    result(r3).map(|_| ())
}

#[inline]
pub fn warm_read(offset: u32, buffer: &mut [u8]) -> Result<(), SysError> {
    let (r3, _, _) = raw(
        Sysnum::WarmRead,
        [
            offset,
            buffer.as_mut_ptr() as u32,
            buffer.len() as u32,
            0,
            0,
        ],
    );
    result(r3).map(|_| ())
}

#[inline]
pub fn warm_write(offset: u32, data: &[u8]) -> Result<(), SysError> {
    let (r3, _, _) = raw(
        Sysnum::WarmWrite,
        [offset, data.as_ptr() as u32, data.len() as u32, 0, 0],
    );
    result(r3).map(|_| ())
}

/// Read non-volatile memory at `offset`; Ok(size of the memory offered), Err(SysError::NoDevice)
/// when the board has none.
#[inline]
pub fn nv_read(offset: u32, buffer: &mut [u8]) -> Result<u32, SysError> {
    let (r3, _, _) = raw(
        Sysnum::NvRead,
        [
            offset,
            buffer.as_mut_ptr() as u32,
            buffer.len() as u32,
            0,
            0,
        ],
    );
    result(r3)
}

#[inline]
pub fn nv_write(offset: u32, data: &[u8]) -> Result<(), SysError> {
    let (r3, _, _) = raw(
        Sysnum::NvWrite,
        [offset, data.as_ptr() as u32, data.len() as u32, 0, 0],
    );
    result(r3).map(|_| ())
}

/// (partition index, generation).
#[inline]
pub fn identity() -> (usize, u32) {
    let (p, generation, _) = raw(Sysnum::Identity, [0; 5]);
    (p as usize, generation)
}

/// Report a panic; the health monitor acts and this never returns.
pub fn panic(file: &str, line: u32) -> ! {
    raw(
        Sysnum::Panic,
        [file.as_ptr() as u32, file.len() as u32, line, 0, 0],
    );
    // The kernel never resumes a partition after SYS_PANIC; should it ever, wait for good.
    loop {
        wait_next_window();
    }
}

/// Link owner: (reset cause code, boot count).
#[inline]
pub fn boot_info() -> (u32, u32) {
    let (cause, count, _) = raw(Sysnum::BootInfo, [BOOT_INFO_CAUSE, 0, 0, 0, 0]);
    (cause, count)
}

/// Link owner: the kernel fault that caused this boot's reset, if any.
#[inline]
pub fn boot_kernel_fault() -> Option<fsw_bridge::KernelFault> {
    let (r3, pc, dar) = raw(Sysnum::BootInfo, [BOOT_INFO_KERNEL_FAULT, 0, 0, 0, 0]);
    match result(r3) {
        Ok(vector) if vector != 0 => Some(fsw_bridge::KernelFault { vector, pc, dar }),
        _ => None,
    }
}

/// Link owner: move kernel log bytes into `buffer`.
#[inline]
pub fn log_drain(buffer: &mut [u8]) -> usize {
    let (r3, _, _) = raw(
        Sysnum::LogDrain,
        [buffer.as_mut_ptr() as u32, buffer.len() as u32, 0, 0, 0],
    );
    result(r3).unwrap_or(0) as usize
}

/// Link owner: kernel event records (`kernel_logic::event`), oldest first, into `records`; how
/// many were written (0: none waiting).
#[inline]
pub fn event_drain(records: &mut [EventRecord]) -> usize {
    let mut bytes = [0u8; EVENT_RECORD_SIZE * EVENT_DRAIN_BATCH];
    let batch = records.len().min(EVENT_DRAIN_BATCH);
    let (r3, _, _) = raw(
        Sysnum::EventDrain,
        [bytes.as_mut_ptr() as u32, batch as u32, 0, 0, 0],
    );
    let n = result(r3).unwrap_or(0) as usize;
    for (record, raw) in records
        .iter_mut()
        .zip(bytes.as_chunks::<EVENT_RECORD_SIZE>().0)
        .take(n)
    {
        *record = record_from_bytes(raw);
    }
    n
}

/// Event records taken per SYS_EVENT_DRAIN (a kernel report is about 30).
pub const EVENT_DRAIN_BATCH: usize = 16;

/// Link owner: the host granted mission time `us`.
#[inline]
pub fn set_mission_time(us: u64) {
    raw(
        Sysnum::SetMissionTime,
        [(us >> 32) as u32, us as u32, 0, 0, 0],
    );
}

/// Link owner: warm-reset the module (reset cause Warm).
pub fn reset_module() -> ! {
    raw(Sysnum::ResetModule, [reset_at::NOW, 0, 0, 0, 0]);
    loop {
        wait_next_window();
    }
}

/// Link owner: warm-reset the module at a point inside the work the destination partition of
/// `port` does on the message last queued there (`mode`: `reset_at::AFTER_TICKS` with `value`
/// ticks, or `reset_at::IN_WARM_WRITE` with `value` permille of its next warm-area write).
///
/// With `chain`, a port from that destination partition: the point is in the work of
/// `chain`'s destination on the first message sent there after the anchor, counted from its
/// receipt.
#[inline]
pub fn arm_reset(mode: u32, value: u32, port: usize, chain: Option<usize>) -> Result<(), SysError> {
    let chain = chain.map_or(reset_at::NO_CHAIN, |c| c as u32);
    let (r3, _, _) = raw(Sysnum::ResetModule, [mode, value, port as u32, chain, 0]);
    result(r3).map(|_| ())
}

/// Link owner: have the kernel queue its accounting metrics now (0), every `period` frames,
/// or stop (REPORT_OFF).
#[inline]
pub fn request_metrics(period: u32) {
    raw(Sysnum::RequestMetrics, [period, 0, 0, 0, 0]);
}

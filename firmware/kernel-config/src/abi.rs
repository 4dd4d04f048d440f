//! The numbers partitions, the kernel and the host agree on: system-call numbers and error
//! codes, the kernel-event records the I/O partition drains, telemetry metric ids, and the
//! reserved state keys the harness uses to ask the target for measurements and (in the test
//! image) to steer the rogue partition.
//!
//! System calls: `sc` with the call number in r0 and arguments in r3..r7; the result comes back
//! in r3 (negative: one of the `E_*` codes), secondary results in r4 and r5. Pointers and
//! lengths are checked against the caller's regions before the kernel touches them. The numbers
//! and codes are the ABI; both sides decode them once at the boundary, into [`Sysnum`] (the
//! kernel's dispatch) and [`SysError`] (the kernel's return path and the partitions' wrappers,
//! [`decode_result`]), which separates recoverable errors from faults ([`ErrorClass`]).

/// (until) -> 0: give up the rest of this window; returns at the start of the partition's next
/// window. `until` is [`wait::NEXT_WINDOW`] (0: the partition has more to do) or
/// [`wait::IDLE`] (it has nothing to do until a message arrives on one of its ports: the
/// module may then stop its schedule while it waits for the host, see
/// [`SYS_WAIT_FOR_INPUT`]; the partition still resumes at a window start). Any other value:
/// E_RANGE, and the call does not wait.
pub const SYS_WAIT_NEXT_WINDOW: u32 = 0;
/// (port, ptr, len) -> 0. Sampling: replaces the value; queuing: appends (E_FULL when full).
pub const SYS_PORT_SEND: u32 = 1;
/// (port, ptr, cap) -> length; r4 = sender's generation, r5 = age in ticks (saturated).
/// E_EMPTY when a queue is empty or a sampling port was never written.
pub const SYS_PORT_RECEIVE: u32 = 2;
/// () -> mission time in µs: r3 = high word, r4 = low word (last time granted by the host).
pub const SYS_MISSION_TIME: u32 = 3;
/// () -> CPU ticks the caller used since boot: r3 = high, r4 = low; r5 = ticks in this window.
pub const SYS_CPU_TIME: u32 = 4;
/// (ptr, len) -> 0: one whole defmt frame for the host.
pub const SYS_LOG: u32 = 5;
/// (offset, ptr, len) -> 0: read the warm area's checkpoint part (warm-area owner only).
pub const SYS_WARM_READ: u32 = 6;
/// (offset, ptr, len) -> 0: write the warm area's checkpoint part (warm-area owner only).
pub const SYS_WARM_WRITE: u32 = 7;
/// () -> r3 = partition index, r4 = generation. Also the null call of the benchmarks.
pub const SYS_IDENTITY: u32 = 8;
/// (file ptr, len, line): the partition panicked; the health monitor acts; never returns.
pub const SYS_PANIC: u32 = 9;
/// (BOOT_INFO_CAUSE) -> r3 = reset cause code (1 power-on, 2 warm, 3 watchdog, 4 health
/// monitor, 5 kernel fault), r4 = boot count; (BOOT_INFO_KERNEL_FAULT) -> r3 = vector, r4 = SRR0,
/// r5 = DAR of the kernel fault that caused this boot's reset (all 0: none). Link owner only.
pub const SYS_BOOT_INFO: u32 = 10;
/// SYS_BOOT_INFO's modes.
pub const BOOT_INFO_CAUSE: u32 = 0;
pub const BOOT_INFO_KERNEL_FAULT: u32 = 1;
/// (ptr, cap) -> bytes of the kernel's defmt stream moved into the buffer. Link owner only.
pub const SYS_LOG_DRAIN: u32 = 11;
/// (ptr, records) -> kernel events written into the buffer, up to `records` of
/// EVENT_RECORD_SIZE bytes each (0 counts as 1), oldest first; 0 if none. Link owner.
pub const SYS_EVENT_DRAIN: u32 = 12;
/// (high, low): mission time granted by the host, in µs. Link owner only.
pub const SYS_SET_MISSION_TIME: u32 = 13;
/// (mode, value, port): warm-reset the module with reset cause Warm (the host asked). Link
/// owner only. `mode` is one of [`reset_at`]: NOW resets at once (value and port unused);
/// AFTER_TICKS and IN_WARM_WRITE arm a reset inside the work the destination partition of the
/// queuing `port` (the caller must be its source, the port must have one destination) does on
/// the message now last in that port: the count starts at that partition's first window after
/// it received the message (the executive starts a granted frame's work there).
/// AFTER_TICKS: once the partition has run `value` ticks of CPU (its system calls included).
/// IN_WARM_WRITE: in its next warm-area write, after `value`/1000 of the bytes. Either way, if
/// the partition gives up its window (has finished that work) or is stopped by the health
/// monitor first, the reset happens then. An armed reset returns 0 (E_EMPTY if the port holds
/// no message, E_RANGE for a bad mode or permille, E_BAD_PORT for a port that does not qualify);
/// the kernel reports where it landed in metrics (`metric::ARMED_RESET_*`) just before the reset.
pub const SYS_RESET_MODULE: u32 = 14;

/// SYS_RESET_MODULE modes and where an armed reset landed.
pub mod reset_at {
    /// Reset now.
    pub const NOW: u32 = 0;
    /// After `value` ticks of the partition's work on the anchor message.
    pub const AFTER_TICKS: u32 = 1;
    /// In the partition's next warm-area write, after `value` permille of its bytes.
    pub const IN_WARM_WRITE: u32 = 2;
    /// The fourth argument when the point is in the destination partition's own work (no
    /// next stage). Otherwise it names a port from that partition: the point is then in the
    /// work of that port's destination on the first message sent there after the anchor,
    /// counted from its receipt (the planner partition's work on the executive's frame).
    pub const NO_CHAIN: u32 = u32::MAX;

    use fsw_bridge::dictionary::armed_reset_point;

    /// `metric::ARMED_RESET_POINT`: the count ran out while the partition ran its own code (or
    /// in a system call other than a warm-area write, the reset then following that call).
    pub const LANDED_IN_CODE: u64 = armed_reset_point::IN_CODE;
    /// Inside a warm-area write: part of its bytes copied (`metric::ARMED_RESET_WARM_COPIED`).
    pub const LANDED_IN_WARM_WRITE: u64 = armed_reset_point::IN_WARM_WRITE;
    /// The partition finished first (gave up its window); the reset followed at once.
    pub const LANDED_AFTER_WORK: u64 = armed_reset_point::AFTER_WORK;
    /// The health monitor stopped or restarted the partition first; the reset followed.
    pub const LANDED_PARTITION_STOPPED: u64 = armed_reset_point::PARTITION_STOPPED;
}
/// (period): 0 = queue the kernel's accounting metrics now; n = queue them every n major
/// frames from now on; REPORT_OFF = stop the periodic reports (the default: nothing is sent
/// unasked). Link owner only.
pub const SYS_REQUEST_METRICS: u32 = 15;
/// SYS_REQUEST_METRICS argument that stops periodic reports.
pub const REPORT_OFF: u32 = u32::MAX;
/// (offset, ptr, len) -> r3 = size of the non-volatile memory offered (NV owner only):
/// read `len` bytes at `offset`. E_NO_DEVICE when the board has no non-volatile memory
/// (`len` 0 probes the size).
pub const SYS_NV_READ: u32 = 16;
/// (offset, ptr, len) -> 0: write the non-volatile memory (NV owner only; E_NO_DEVICE as above).
pub const SYS_NV_WRITE: u32 = 17;
/// () -> ticks since the reset vector: r3 = high, r4 = low; r5 = ticks the kernel's boot took,
/// from the reset vector to the start of the schedule (reset stub, board bring-up, kernel set-up:
/// the same every boot of the same kind, unlike the uptime, which includes every other
/// partition's windows and the idle time spent waiting for the host).
pub const SYS_UPTIME: u32 = 18;
/// (ptr, cap) -> bytes received from the host moved into the buffer (0: nothing received);
/// r4 = bytes the receiver lost since boot (UART overruns). The kernel is the link's byte pipe
/// over the board's transport (the serial line, or shared memory on the emulated target: see
/// `kernel_logic::shm_link`). Link owner only.
pub const SYS_LINK_READ: u32 = 19;
/// () -> r3 = one of [`wait_input`]: the caller (the link owner) has sent everything and waits
/// for the host. If the whole module has nothing to do until input arrives (see
/// [`wait_input`]'s reasons), the kernel stops the schedule and waits for the link's receive
/// interrupt without running anything (an emulated target then costs no host CPU), and restarts
/// the schedule at a fresh major frame when input arrives: r3 = PARKED, returned in the
/// caller's first window. Input already waiting: r3 = INPUT_PENDING at once. Otherwise it acts
/// as SYS_WAIT_NEXT_WINDOW: r3 = NOT_PARKED at the caller's next window start, r4 = the
/// reasons (`wait_input::*` bits), r5 = the partitions that were busy (bit p). With
/// r3 = [`wait_input::QUERY`] it does not wait at all: it returns at once with r3 =
/// [`wait_input::NOT_PARKED`], r4 = the reasons the module could not park now (0: quiet) and
/// r5 = the busy partitions (the reliable link's end of round: answer when everyone else is
/// done). Every other argument register must be 0 (E_RANGE otherwise). Link owner only.
pub const SYS_WAIT_FOR_INPUT: u32 = 20;
/// (ptr, len) -> bytes taken for the host: all of them over the serial line (the call waits for
/// the UART); over shared memory what fits in the ring (0 while the host has not read; the
/// caller tries again later). Link owner only.
pub const SYS_LINK_WRITE: u32 = 21;
/// Number of system calls (one past the highest number; unassigned numbers get E_UNKNOWN_CALL).
pub const SYSCALL_COUNT: u32 = 22;

/// SYS_WAIT_NEXT_WINDOW's argument.
pub mod wait {
    /// The partition has more to do in its next window.
    pub const NEXT_WINDOW: u32 = 0;
    /// The partition has nothing to do until a message arrives on one of its ports.
    pub const IDLE: u32 = 1;
}

/// SYS_WAIT_FOR_INPUT's results (r3) and the reasons it did not stop the schedule (r4 bits).
pub mod wait_input {
    /// Not parked: returned at the caller's next window start (r4: why).
    pub const NOT_PARKED: u32 = 0;
    /// Parked until input arrived; returned in the caller's first window of a fresh frame.
    pub const PARKED: u32 = 1;
    /// Input was already waiting; returned at once.
    pub const INPUT_PENDING: u32 = 2;

    /// The argument that asks without waiting (see `SYS_WAIT_FOR_INPUT`).
    pub const QUERY: u32 = 1;

    /// Another partition has work (it has not declared itself idle since it last ran; r5 says
    /// which).
    pub const PARTITION_BUSY: u32 = 1 << 0;
    /// A queuing port holds a message its destination has not taken.
    pub const MESSAGE_IN_FLIGHT: u32 = 1 << 1;
    /// The kernel's log ring holds bytes for the host.
    pub const LOG_PENDING: u32 = 1 << 2;
    /// The kernel's event queue holds events for the host.
    pub const EVENTS_PENDING: u32 = 1 << 3;
    /// The host asked for periodic accounting reports (the schedule must keep running).
    pub const PERIODIC_REPORTS: u32 = 1 << 4;
    /// A warm reset is armed inside a partition's work.
    pub const RESET_ARMED: u32 = 1 << 5;
}

/// Unknown system-call number.
pub const E_UNKNOWN_CALL: i32 = -1;
/// A pointer/length outside the caller's regions, misaligned, or wrapping around.
pub const E_BAD_POINTER: i32 = -2;
/// No such port, or the caller is not its source (send) / a destination (receive).
pub const E_BAD_PORT: i32 = -3;
/// Message larger than the port's size, or receive buffer smaller than the message.
pub const E_TOO_BIG: i32 = -4;
/// Nothing to receive (not a fault).
pub const E_EMPTY: i32 = -5;
/// Queue full (not a fault).
pub const E_FULL: i32 = -6;
/// The caller lacks the capability for this service.
pub const E_DENIED: i32 = -7;
/// Warm-area (or non-volatile memory) offset or length outside its usable part.
pub const E_RANGE: i32 = -8;
/// The board has no such device (non-volatile memory). Not a fault: the caller copes.
pub const E_NO_DEVICE: i32 = -9;

/// A system-call number, decoded once at the kernel's boundary (and named by the partitions'
/// wrappers): the numeric ABI is the `SYS_*` constants, which the variants take as their values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Sysnum {
    WaitNextWindow = SYS_WAIT_NEXT_WINDOW,
    PortSend = SYS_PORT_SEND,
    PortReceive = SYS_PORT_RECEIVE,
    MissionTime = SYS_MISSION_TIME,
    CpuTime = SYS_CPU_TIME,
    Log = SYS_LOG,
    WarmRead = SYS_WARM_READ,
    WarmWrite = SYS_WARM_WRITE,
    Identity = SYS_IDENTITY,
    Panic = SYS_PANIC,
    BootInfo = SYS_BOOT_INFO,
    LogDrain = SYS_LOG_DRAIN,
    EventDrain = SYS_EVENT_DRAIN,
    SetMissionTime = SYS_SET_MISSION_TIME,
    ResetModule = SYS_RESET_MODULE,
    RequestMetrics = SYS_REQUEST_METRICS,
    NvRead = SYS_NV_READ,
    NvWrite = SYS_NV_WRITE,
    Uptime = SYS_UPTIME,
    LinkRead = SYS_LINK_READ,
    WaitForInput = SYS_WAIT_FOR_INPUT,
    LinkWrite = SYS_LINK_WRITE,
}

impl Sysnum {
    /// Every system call, in number order (`ALL[n]` is number n).
    pub const ALL: [Sysnum; SYSCALL_COUNT as usize] = [
        Sysnum::WaitNextWindow,
        Sysnum::PortSend,
        Sysnum::PortReceive,
        Sysnum::MissionTime,
        Sysnum::CpuTime,
        Sysnum::Log,
        Sysnum::WarmRead,
        Sysnum::WarmWrite,
        Sysnum::Identity,
        Sysnum::Panic,
        Sysnum::BootInfo,
        Sysnum::LogDrain,
        Sysnum::EventDrain,
        Sysnum::SetMissionTime,
        Sysnum::ResetModule,
        Sysnum::RequestMetrics,
        Sysnum::NvRead,
        Sysnum::NvWrite,
        Sysnum::Uptime,
        Sysnum::LinkRead,
        Sysnum::WaitForInput,
        Sysnum::LinkWrite,
    ];

    /// The number in r0.
    pub const fn number(self) -> u32 {
        self as u32
    }

    /// The call numbered `number`, if there is one.
    pub const fn from_number(number: u32) -> Option<Sysnum> {
        if number < SYSCALL_COUNT {
            Some(Sysnum::ALL[number as usize])
        } else {
            None
        }
    }
}

impl TryFrom<u32> for Sysnum {
    /// An unassigned number: [`SysError::UnknownCall`], a fault.
    type Error = SysError;

    fn try_from(number: u32) -> Result<Self, SysError> {
        Sysnum::from_number(number).ok_or(SysError::UnknownCall)
    }
}

/// Whether a system call's error is the caller's to handle or a fault.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ErrorClass {
    /// The call could not be done now or here, and the caller copes (nothing to receive, a
    /// full queue, no such device): the kernel only returns the code.
    Recoverable,
    /// The caller broke the ABI (a bad pointer, a port that is not its own, a call it has no
    /// capability for, an argument out of range): the kernel returns the code and reports the
    /// call to the health monitor, which applies the partition's IllegalSyscall action.
    Fault,
}

/// A system call's error, decoded once at the boundary: the kernel returns
/// [`SysError::code`] in r3, and the partitions' wrappers decode r3 with [`decode_result`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SysError {
    /// [`E_UNKNOWN_CALL`].
    UnknownCall,
    /// [`E_BAD_POINTER`].
    BadPointer,
    /// [`E_BAD_PORT`].
    BadPort,
    /// [`E_TOO_BIG`].
    TooBig,
    /// [`E_EMPTY`].
    Empty,
    /// [`E_FULL`].
    Full,
    /// [`E_DENIED`].
    Denied,
    /// [`E_RANGE`].
    Range,
    /// [`E_NO_DEVICE`].
    NoDevice,
}

impl SysError {
    /// Every error, in code order (-1, -2, ...).
    pub const ALL: [SysError; 9] = [
        SysError::UnknownCall,
        SysError::BadPointer,
        SysError::BadPort,
        SysError::TooBig,
        SysError::Empty,
        SysError::Full,
        SysError::Denied,
        SysError::Range,
        SysError::NoDevice,
    ];

    /// The code in r3 (negative).
    pub const fn code(self) -> i32 {
        match self {
            SysError::UnknownCall => E_UNKNOWN_CALL,
            SysError::BadPointer => E_BAD_POINTER,
            SysError::BadPort => E_BAD_PORT,
            SysError::TooBig => E_TOO_BIG,
            SysError::Empty => E_EMPTY,
            SysError::Full => E_FULL,
            SysError::Denied => E_DENIED,
            SysError::Range => E_RANGE,
            SysError::NoDevice => E_NO_DEVICE,
        }
    }

    /// The error whose code is `code`, if it is one.
    pub const fn from_code(code: i32) -> Option<SysError> {
        if code < 0 && code >= -(SysError::ALL.len() as i32) {
            Some(SysError::ALL[(-code - 1) as usize])
        } else {
            None
        }
    }

    /// Recoverable or a fault (see [`ErrorClass`]).
    pub const fn class(self) -> ErrorClass {
        match self {
            SysError::Empty | SysError::Full | SysError::NoDevice => ErrorClass::Recoverable,
            SysError::UnknownCall
            | SysError::BadPointer
            | SysError::BadPort
            | SysError::TooBig
            | SysError::Denied
            | SysError::Range => ErrorClass::Fault,
        }
    }

    /// A fault for the health monitor.
    pub const fn is_fault(self) -> bool {
        matches!(self.class(), ErrorClass::Fault)
    }
}

impl From<SysError> for i32 {
    fn from(error: SysError) -> i32 {
        error.code()
    }
}

/// A system call's r3 as the partitions' wrappers see it: one of the error codes, or the call's
/// value (a length, a size, 0). Values never reach the codes' range (-9..-1 as i32): lengths and
/// sizes stay below 2 GiB.
pub const fn decode_result(r3: u32) -> Result<u32, SysError> {
    match SysError::from_code(r3 as i32) {
        Some(error) => Err(error),
        None => Ok(r3),
    }
}

/// The r3 the kernel returns for `result`.
pub const fn encode_result(result: Result<u32, SysError>) -> u32 {
    match result {
        Ok(value) => value,
        Err(error) => error.code() as u32,
    }
}

/// Size of one kernel-event record (SYS_EVENT_DRAIN): four big-endian words.
/// Health monitor: [EVENT_HEALTH_MONITOR, partition | kind << 8 | action << 16, address, 0].
/// Metric: [EVENT_METRIC, id, value high, value low].
pub const EVENT_RECORD_SIZE: usize = 16;
pub const EVENT_HEALTH_MONITOR: u32 = 1;
pub const EVENT_METRIC: u32 = 2;

/// Telemetry `Metric` ids of the kernel and the partitions' instrumentation: the telemetry
/// dictionary's platform table (`fsw_bridge::dictionary::platform`), where each id's name,
/// unit, kind and channel are declared. Per-partition ids add the partition index.
pub mod metric {
    pub use fsw_bridge::dictionary::platform::*;
}

/// `metric::BOOT_IMAGE` values: how the reset stub made the RAM image good.
pub use fsw_bridge::dictionary::boot_image;

/// Bound on window-start jitter (switch-in minus scheduled start), in timebase ticks, that the
/// kernel tests hold every window of every frame to. Measured under `-icount shift=2`; see
/// the README's kernel section. A window's budget is its length less this bound (rounded down
/// to a multiple of 83 ticks), so a partition switched in within the bound ends its window
/// before the next one starts.
pub const JITTER_BOUND_TICKS: u64 = 100;

/// Null system calls timed by the syscall benchmark.
pub const SYSCALL_BENCH_CALLS: u32 = 1000;

/// Reserved `StateKey`s (0xff00..): control messages from the harness, routed by the I/O
/// partition instead of being treated as spacecraft state.
pub mod control {
    /// Ask the kernel for its accounting metrics (handled by the I/O partition): value
    /// `Int(0)` once now, `Int(n)` every n major frames, `Int(-1)` stop periodic reports.
    pub const REQUEST_METRICS: u16 = 0xff00;
    /// Ask the planner for the checksum of its search table.
    pub const PLANNER_CHECKSUM: u16 = 0xff01;
    /// Ask the executive to time SYSCALL_BENCH_CALLS null system calls.
    pub const SYSCALL_BENCH: u16 = 0xff02;
    /// Set the planner partition's budget, in validity checks per window (value `Int(n)`,
    /// n >= 1; anything else restores the default). Lasts until the next boot.
    pub const PLANNER_BUDGET: u16 = 0xff03;
    /// Test image: tell the rogue partition what to do (value `Enum(ROGUE_*)`).
    pub const ROGUE_MODE: u16 = 0xff10;
    /// First reserved key.
    pub const FIRST: u16 = 0xff00;
}

/// Rogue behaviours (test image).
pub mod rogue {
    /// Store into the planner's region (expect a DSI and a restart).
    pub const WRITE_PLANNER: u16 = 1;
    /// Spin forever (expect preemption at every window end; nobody else delayed).
    pub const ENDLESS_LOOP: u16 = 2;
    /// Pass bad pointers to every system call (expect errors and log-and-continue events).
    pub const BAD_POINTERS: u16 = 3;
    /// Panic (expect a restart).
    pub const PANIC: u16 = 4;
    /// Execute a privileged instruction (expect a program exception and a restart).
    pub const PRIVILEGED: u16 = 5;
    /// Send a probe (a Telemetry metric `PROBE_METRIC`, value: the rogue's generation) to the
    /// host through `rogue_to_io`, then panic: restarted before the I/O partition's window,
    /// the probe is stale (expect it dropped, `metric::PORT_STALE_DROPPED` up by one).
    pub const SEND_THEN_RESTART: u16 = 6;
    /// Send the probe and carry on (expect it at the host).
    pub const SEND: u16 = 7;
    /// Make the kernel fault: the system call `KERNEL_FAULT_CALL`, which the test image's
    /// kernel answers with a `trap` in supervisor state (expect a warm reset with cause
    /// KernelFault, and the fault in the next Hello).
    pub const KERNEL_FAULT: u16 = 8;
    /// The probe's metric id (the dictionary's `rogue_probe`).
    pub const PROBE_METRIC: u16 = super::metric::ROGUE_PROBE;
    /// The test image's system call that makes the kernel fault (rogue partition only; any
    /// other image or partition gets E_UNKNOWN_CALL).
    pub const KERNEL_FAULT_CALL: u32 = 0x7e57_0001;
}

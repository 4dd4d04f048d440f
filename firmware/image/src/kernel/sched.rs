//! Time partitioning: the major frame's windows, driven by the decrementer, and the per-partition
//! CPU accounting. A partition runs from its window's start until it waits for its next window
//! or the window ends, whichever comes first; at the end it is preempted (an overrun) and
//! resumes where it was in its next window. Windows start at fixed offsets in the frame whatever
//! anyone did before; the gaps between windows are idle.
//!
//! Accounting is in timebase ticks: a partition is charged from the moment the kernel switches
//! it in until the kernel is entered to switch it out (its system calls included). Window-start
//! jitter is the switch-in time minus the scheduled start.
//!
//! Window starts follow the timebase; what a partition gets of its window, and its CPU time, are
//! counted with the decrementer, so that they are the same on every run. Under `-icount` the
//! timebase reads `floor(virtual ns * 16.6 MHz)`: the difference of two readings a fixed number
//! of instructions apart is off by one tick or not depending on where within a tick the first
//! one fell, which depends on how long the guest idled waiting for the host, and a window end
//! taken from the timebase falls a few instructions earlier or later in the partition's work
//! from one run to the next. A decrementer value that is a multiple of [`DEC_EXACT_TICKS`]
//! instead expires an exact number of instructions after the instruction that wrote it, and
//! reading it back counts from that write. So the last thing the kernel does before it enters a
//! partition at its window start is to write the window's budget into DEC: the window's length
//! less the jitter bound, rounded down to such a multiple (the window ends that much before its
//! scheduled end; a late switch-in gets what is left before it). The partition's CPU time in the
//! stint is the value written minus DEC at the next kernel entry: the instructions it ran
//! (through fixed code paths), the same on every run for the same work.
//!
//! The schedule can be stopped ("parked", see `SYS_WAIT_FOR_INPUT`) when the module has nothing
//! to do until the host sends something: the frame in progress is cut short there, no
//! decrementer deadline is set again, and the CPU dozes until the link's receive interrupt;
//! input then restarts the schedule at a fresh major frame that starts at once. Frame offsets are relative
//! to the frame's start and CPU time is counted with the decrementer, so a frame's costs do not
//! depend on how long the module was parked. Under `-icount sleep=off` virtual time stands still
//! while the CPU dozes with no deadline pending (QEMU warns once "icount sleep disabled and no
//! active timers"), so the guest neither runs nor costs host CPU while the host thinks.
//!
//! A decrementer interrupt can outlive the deadline that raised it: if it fires while the kernel
//! runs with interrupts off and the kernel then writes a new deadline, QEMU keeps the interrupt
//! pending (the 750's decrementer is edge-triggered; a write does not lower it), and it would be
//! taken as soon as interrupts are on again, e.g. right after a parked schedule restarts, ending
//! the new window at once. Such an interrupt finds the decrementer still far from zero and is
//! ignored ([`is_stale_decrementer_interrupt`]). For that test to hold, the kernel never writes a
//! value below [`MIN_DEC_TICKS`]: QEMU 7.2 as released raises the interrupt at once for values
//! below 3 without moving its deadline (a later stable fix removed that special case), so the
//! decrementer would then read from the previous deadline.
use core::arch::asm;

use kernel_config::abi::{metric, JITTER_BOUND_TICKS};
use kernel_config::ErrorKind;

use super::{at, at_mut, Kernel, Next, RunState};
use crate::board::timebase;
use crate::config::{LINK_OWNER, SYSTEM, WINDOW_COUNT};

/// Lead time from the kernel's start to the first frame.
const START_LEAD_TICKS: u64 = 1_000;

#[derive(Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Idle before window `w` starts.
    Gap(usize),
    /// Inside window `w`.
    Window(usize),
    /// Stopped until input arrives (no deadline set).
    Parked,
}

pub struct Scheduler {
    phase: Phase,
    /// Scheduled start of the current major frame (timebase).
    frame_start: u64,
    /// The partition switched in, if any (None: idle).
    pub running: Option<usize>,
    /// The decrementer written when `running` was switched in (its CPU time counts down from
    /// here).
    stint_dec: i32,
    /// The decrementer at the last kernel entry.
    pub entry_dec: i32,
    /// Timebase end of the current window (scheduled).
    window_end: u64,
    /// The kernel entry that led to the last window-start switch, and when that switch
    /// finished (just before the partition resumed): accounted at its switch-out, so that
    /// nothing data-dependent runs between the decrementer write and the partition.
    switch_entry: Option<u64>,
    switch_end: u64,
    /// The window whose start the next switch-in measures: (partition, scheduled start).
    pending_start: Option<(usize, u64)>,
    pub frames: u32,
    pub switches: u32,
    pub switch_ticks_total: u64,
    pub switch_max_ticks: u32,
    pub max_jitter: u32,
    /// Major frames between accounting reports; 0 = only on request.
    pub report_period: u32,
}

/// Decrementer values that are multiples of this expire an exact number of nanoseconds after
/// their write: 83 ticks at 16.6 MHz are exactly 5 µs (1250 instructions under icount shift=2).
/// QEMU turns a DEC value into a deadline in whole nanoseconds, rounding down, so any other
/// value expires up to a nanosecond early, by an amount that depends on the value.
pub const DEC_EXACT_TICKS: u32 = 83;

/// The smallest decrementer value the kernel writes (see the module docs).
pub const MIN_DEC_TICKS: i32 = 3;

/// True for a decrementer interrupt whose deadline is not the current one: the decrementer,
/// read at the kernel's entry, has not run out. A current deadline reads 0 or less by then (the
/// interrupt is raised when it runs out, and every write is at least MIN_DEC_TICKS).
#[inline]
pub fn is_stale_decrementer_interrupt(entry_dec: i32) -> bool {
    entry_dec >= MIN_DEC_TICKS
}

/// The decrementer (counts down; negative once expired). Also a compiler barrier: the kernel
/// reads it at fixed points (its entry), and the code around must not move across the read.
#[inline]
pub fn read_dec() -> i32 {
    let value: u32;
    // SAFETY: supervisor state; reading DEC has no side effects (no `nomem`: a barrier).
    unsafe { asm!("mfspr {0}, 22", out(reg) value, options(nostack)) }
    value as i32
}

/// Schedule the next decrementer interrupt `ticks` from now. Also a compiler barrier: what the
/// kernel does after the write to a partition's window budget counts as the partition's time,
/// so nothing data-dependent may be moved after it.
#[inline]
pub fn write_dec(ticks: i32) {
    // SAFETY: supervisor state; writing DEC only schedules the next decrementer interrupt,
    // which stays masked until the kernel returns with MSR[EE] set (no `nomem`: a barrier).
    unsafe { asm!("mtspr 22, {0}", in(reg) ticks as u32, options(nostack)) }
}

fn set_decrementer_at(deadline: u64) {
    let now = timebase::now().0;
    write_dec(
        deadline
            .saturating_sub(now)
            .clamp(MIN_DEC_TICKS as u64, 0x7fff_ffff) as i32,
    );
}

/// Decrementer value for window `w` whose scheduled end is `deadline`, entered at `now`: its
/// budget, or the last multiple of DEC_EXACT_TICKS ticks before the end if less is left (at
/// least one multiple).
fn window_end_dec(w: usize, deadline: u64, now: u64) -> i32 {
    let left = deadline.saturating_sub(now).clamp(1, 0x7fff_ffff) as u32;
    let left = (left / DEC_EXACT_TICKS).max(1) * DEC_EXACT_TICKS;
    (*at(&WINDOW_BUDGETS, w)).min(left) as i32
}

/// Ticks a partition runs in each window when it is switched in on time: the window's length
/// less the jitter bound, rounded down to a multiple of DEC_EXACT_TICKS.
// Evaluated at compile time: an index out of range is a build error, not a panic.
#[allow(clippy::indexing_slicing)]
const WINDOW_BUDGETS: [u32; WINDOW_COUNT] = {
    let mut budgets = [0; WINDOW_COUNT];
    let mut w = 0;
    while w < WINDOW_COUNT {
        let usable = SYSTEM.schedule.windows[w].duration - JITTER_BOUND_TICKS as u32;
        budgets[w] = usable / DEC_EXACT_TICKS * DEC_EXACT_TICKS;
        assert!(budgets[w] > 0, "a window shorter than the jitter bound");
        w += 1;
    }
    budgets
};

impl Scheduler {
    pub const fn new() -> Self {
        Self {
            phase: Phase::Gap(0),
            frame_start: 0,
            running: None,
            stint_dec: 0,
            entry_dec: 0,
            window_end: 0,
            switch_entry: None,
            switch_end: 0,
            pending_start: None,
            frames: 0,
            switches: 0,
            switch_ticks_total: 0,
            switch_max_ticks: 0,
            max_jitter: 0,
            report_period: 0,
        }
    }
}

impl Kernel {
    /// Plan the first frame shortly after `now`.
    pub fn sched_start(&mut self, now: u64) -> Next {
        self.sched.frame_start = now + START_LEAD_TICKS;
        self.enter_gap_or_window(0, now)
    }

    fn window_start(&self, w: usize) -> u64 {
        self.sched.frame_start + u64::from(at(SYSTEM.schedule.windows, w).offset)
    }

    /// Ticks the running partition has used since it was switched in, up to the last kernel
    /// entry.
    pub fn stint_ticks(&self) -> u32 {
        self.sched
            .stint_dec
            .wrapping_sub(self.sched.entry_dec)
            .max(0) as u32
    }

    /// CPU ticks `p` (running) has used since boot, up to this instruction.
    /// Points the decrementer at `ticks` from now inside the running partition's stint (an
    /// armed reset point that came before its window end), keeping the stint's accounting:
    /// what it used so far stays charged.
    pub fn repoint_stint(&mut self, ticks: i32) {
        let used = self.sched.stint_dec.wrapping_sub(read_dec());
        let ticks = ticks.max(MIN_DEC_TICKS);
        self.sched.stint_dec = used.wrapping_add(ticks);
        write_dec(ticks);
    }

    pub fn cpu_now(&self, p: usize) -> u64 {
        let stint = self.sched.stint_dec.wrapping_sub(read_dec()).max(0) as u64;
        at(&self.parts, p).cpu_total + stint
    }

    /// Stop charging `p` (switch-out; the time up to the kernel entry). When `p` is the link
    /// owner, what it wrote for the host since it last gave up the CPU is announced (the
    /// shared-memory link's doorbell): every way it stops running passes here.
    pub fn charge(&mut self, p: usize, _now: u64) {
        if p == LINK_OWNER {
            self.link.ring_doorbell();
        }
        let used = u64::from(self.stint_ticks());
        let state = at_mut(&mut self.parts, p);
        state.cpu_total += used;
        state.window_ticks = state.window_ticks.saturating_add(used as u32);
        state.frame_ticks = state.frame_ticks.saturating_add(used as u32);
        self.sched.running = None;
        if let Some(entry) = self.sched.switch_entry.take() {
            let cost = self.sched.switch_end.saturating_sub(entry) as u32;
            self.sched.switches = self.sched.switches.wrapping_add(1);
            self.sched.switch_ticks_total += u64::from(cost);
            self.sched.switch_max_ticks = self.sched.switch_max_ticks.max(cost);
        }
    }

    /// Called by `resume` when `p` is about to run: the window-start bookkeeping, then the
    /// window end (or an armed reset point) into DEC, last.
    pub fn switched_in(&mut self, p: usize, entry: u64, now: u64) {
        if let Some((q, scheduled)) = self.sched.pending_start.take() {
            if q == p {
                let jitter = now.saturating_sub(scheduled) as u32;
                let state = at_mut(&mut self.parts, p);
                state.max_jitter = state.max_jitter.max(jitter);
                self.sched.max_jitter = self.sched.max_jitter.max(jitter);
                self.sched.switch_entry = Some(entry);
            }
        }
        self.sched.running = Some(p);
        let w = match self.sched.phase {
            Phase::Window(w) | Phase::Gap(w) => w,
            // Nothing is switched in while parked (a restart enters window 0 first).
            Phase::Parked => 0,
        };
        let mut dec = window_end_dec(w, self.sched.window_end, now);
        if self.armed.counts_stint(p) {
            dec = self.armed_reset_stint(p, dec).max(MIN_DEC_TICKS);
        }
        self.idle_declared.withdraw(p);
        write_dec(dec);
        self.sched.stint_dec = dec;
        self.sched.switch_end = timebase::now().0;
    }

    /// The decrementer fired: a window ended or a gap did.
    pub fn on_timer(&mut self, now: u64) -> Next {
        match self.sched.phase {
            Phase::Window(w) => {
                if let Some(p) = self.sched.running {
                    // An armed reset point, or the count pauses at the window end.
                    self.armed_reset_on_timer(p);
                    self.charge(p, now);
                    let state = at_mut(&mut self.parts, p);
                    state.overruns = state.overruns.wrapping_add(1);
                    self.overrun(p);
                }
                self.after_window(w, now)
            }
            Phase::Gap(w) => self.begin_window(w, now),
            // The deadline of the window in which the schedule stopped: nothing to start.
            Phase::Parked => Next::Idle,
        }
    }

    /// The link owner `p` (running) waits for input and nothing else has work: end the frame
    /// (cut short: it counts as a frame, with what its windows used) and stop the schedule until
    /// input arrives ([`Kernel::on_input_while_idle`]).
    pub fn park(&mut self, p: usize, now: u64) -> Next {
        self.charge(p, now);
        at_mut(&mut self.parts, p).run = RunState::Waiting;
        self.end_frame();
        self.sched.phase = Phase::Parked;
        self.sched.pending_start = None;
        self.parks = self.parks.wrapping_add(1);
        Next::Idle
    }

    /// True while the schedule is stopped waiting for input.
    pub fn is_parked(&self) -> bool {
        self.sched.phase == Phase::Parked
    }

    /// The receive interrupt came while the kernel idled (the UART is drained): if the
    /// schedule is parked and a whole frame has arrived (see `link`), restart it with a major
    /// frame that starts now; otherwise keep idling.
    pub fn on_input_while_idle(&mut self, now: u64) -> Next {
        if self.sched.phase != Phase::Parked || !self.link.holds_frame_end() {
            return Next::Idle;
        }
        self.sched.frame_start = now;
        self.enter_gap_or_window(0, now)
    }

    /// The running partition `p` gave up the rest of its window.
    pub fn wait_next_window(&mut self, p: usize, now: u64) -> Next {
        self.armed_reset_on_wait(p);
        self.charge(p, now);
        at_mut(&mut self.parts, p).run = RunState::Waiting;
        Next::Idle
    }

    fn after_window(&mut self, w: usize, now: u64) -> Next {
        let next = if w + 1 < WINDOW_COUNT {
            w + 1
        } else {
            self.end_frame();
            self.sched.frame_start += u64::from(SYSTEM.schedule.major_frame);
            // Far behind (a debugger, a very long kernel path): skip whole frames rather than
            // running every window late.
            let major = u64::from(SYSTEM.schedule.major_frame);
            while self.sched.frame_start + major < now {
                self.sched.frame_start += major;
            }
            0
        };
        self.enter_gap_or_window(next, now)
    }

    fn enter_gap_or_window(&mut self, w: usize, now: u64) -> Next {
        let start = self.window_start(w);
        if now < start {
            self.sched.phase = Phase::Gap(w);
            set_decrementer_at(start);
            Next::Idle
        } else {
            self.begin_window(w, now)
        }
    }

    fn begin_window(&mut self, w: usize, _now: u64) -> Next {
        let window = at(SYSTEM.schedule.windows, w);
        let scheduled = self.window_start(w);
        self.sched.phase = Phase::Window(w);
        // DEC gets the window end when the partition is switched in (`switched_in`).
        self.sched.window_end = scheduled + u64::from(window.duration);
        let p = window.partition;
        at_mut(&mut self.parts, p).window_ticks = 0;
        match at(&self.parts, p).run {
            RunState::Halted => {
                set_decrementer_at(self.sched.window_end);
                Next::Idle
            }
            RunState::Ready | RunState::Waiting => {
                at_mut(&mut self.parts, p).run = RunState::Ready;
                self.sched.pending_start = Some((p, scheduled));
                Next::Partition(p)
            }
        }
    }

    fn end_frame(&mut self) {
        for state in self.parts.iter_mut() {
            state.last_frame_ticks = state.frame_ticks;
            state.worst_frame_ticks = state.worst_frame_ticks.max(state.frame_ticks);
            state.frame_ticks = 0;
        }
        self.sched.frames = self.sched.frames.wrapping_add(1);
        let period = self.sched.report_period;
        if period != 0 && self.sched.frames.is_multiple_of(period) {
            self.report_metrics();
        }
    }

    /// Queue the accounting metrics for the host (on request, or every `report_period` frames
    /// once the host asked for that).
    pub fn report_metrics(&mut self) {
        self.events
            .metric(metric::FRAME_NUMBER, u64::from(self.sched.frames));
        for (p, s) in self.parts.iter().enumerate() {
            let id = p as u16;
            self.events
                .metric(metric::FRAME_TICKS + id, u64::from(s.last_frame_ticks));
            self.events.metric(
                metric::WORST_FRAME_TICKS + id,
                u64::from(s.worst_frame_ticks),
            );
            self.events
                .metric(metric::OVERRUNS + id, u64::from(s.overruns));
            self.events
                .metric(metric::MAX_JITTER + id, u64::from(s.max_jitter));
            self.events
                .metric(metric::GENERATION + id, u64::from(s.generation));
        }
        let switches = u64::from(self.sched.switches.max(1));
        self.events
            .metric(metric::MAX_JITTER_ALL, u64::from(self.sched.max_jitter));
        self.events.metric(
            metric::SWITCH_MILLITICKS,
            self.sched.switch_ticks_total * 1000 / switches,
        );
        self.events
            .metric(metric::SWITCHES, u64::from(self.sched.switches));
        self.events.metric(
            metric::SWITCH_MAX_TICKS,
            u64::from(self.sched.switch_max_ticks),
        );
        let link = &self.link;
        for (id, value) in [
            (metric::LINK_RX_BYTES, link.received),
            (metric::LINK_RX_LOST, link.lost),
            (metric::LINK_RX_RING_FULL, link.ring_full),
            (metric::PARKS, self.parks),
            (metric::LINK_TRANSPORT, u32::from(link.over_shared_memory())),
            (metric::LINK_RING_ERRORS, link.ring_errors),
            (metric::PORT_STALE_DROPPED, self.ports.stale_dropped),
        ] {
            self.events.metric(id, u64::from(value));
        }
        self.events.metric(
            metric::LOG_BYTES_DROPPED,
            u64::from(super::klog::with_ring(|ring| ring.dropped)),
        );
        let dropped = self.events.dropped;
        self.events
            .metric(metric::EVENTS_DROPPED, u64::from(dropped));
    }

    /// `p` was still running when its window ended (it has been charged and is preempted).
    fn overrun(&mut self, p: usize) {
        let action = at(SYSTEM.partitions, p).health.action(ErrorKind::Overrun);
        self.overrun_action(p, action);
    }
}

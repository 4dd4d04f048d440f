//! Time partitioning: the major frame's windows, driven by the decrementer, and the per-partition
//! CPU accounting. A partition runs from its window's start until it waits for its next window
//! or the window ends, whichever comes first; at the end it is preempted (an overrun) and
//! resumes where it was in its next window. Windows start at fixed offsets in the frame whatever
//! anyone did before; the gaps between windows are idle.
//!
//! Accounting is in timebase ticks: a partition is charged from the moment the kernel switches
//! it in until the kernel is entered to switch it out (its system calls included). Window-start
//! jitter is the switch-in time minus the scheduled start.
use core::arch::asm;

use kernel_config::abi::metric;
use kernel_config::ErrorKind;

use super::{Kernel, Next, RunState};
use crate::board::timebase;
use crate::config::{PARTITION_COUNT, SYSTEM, WINDOW_COUNT};

/// Lead time from the kernel's start to the first frame.
const START_LEAD_TICKS: u64 = 1_000;

#[derive(Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Idle before window `w` starts.
    Gap(usize),
    /// Inside window `w`.
    Window(usize),
}

pub struct Scheduler {
    phase: Phase,
    /// Scheduled start of the current major frame (timebase).
    frame_start: u64,
    /// The partition switched in, if any (None: idle).
    pub running: Option<usize>,
    /// When `running` was switched in.
    run_since: u64,
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

fn set_decrementer_at(deadline: u64) {
    let now = timebase::now().0;
    let ticks = deadline.saturating_sub(now).clamp(1, 0x7fff_ffff) as u32;
    // SAFETY: supervisor state; writing DEC only schedules the next decrementer interrupt,
    // which stays masked until the kernel returns with MSR[EE] set.
    unsafe { asm!("mtspr 22, {0}", in(reg) ticks, options(nostack, nomem)) }
}

impl Scheduler {
    pub const fn new() -> Self {
        Self {
            phase: Phase::Gap(0),
            frame_start: 0,
            running: None,
            run_since: 0,
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
        self.sched.frame_start + u64::from(SYSTEM.schedule.windows[w].offset)
    }

    /// When the running partition was switched in.
    pub fn sched_run_since(&self) -> u64 {
        self.sched.run_since
    }

    /// Stop charging `p` (switch-out at `now`).
    pub fn charge(&mut self, p: usize, now: u64) {
        let used = now.saturating_sub(self.sched.run_since);
        let state = &mut self.parts[p];
        state.cpu_total += used;
        state.window_ticks = state.window_ticks.saturating_add(used as u32);
        state.frame_ticks = state.frame_ticks.saturating_add(used as u32);
        self.sched.running = None;
    }

    /// Called by `resume` when `p` is about to run.
    pub fn switched_in(&mut self, p: usize, entry: u64, now: u64) {
        if let Some((q, scheduled)) = self.sched.pending_start.take() {
            if q == p {
                let jitter = now.saturating_sub(scheduled) as u32;
                let state = &mut self.parts[p];
                state.max_jitter = state.max_jitter.max(jitter);
                self.sched.max_jitter = self.sched.max_jitter.max(jitter);
                let cost = now.saturating_sub(entry) as u32;
                self.sched.switches = self.sched.switches.wrapping_add(1);
                self.sched.switch_ticks_total += u64::from(cost);
                self.sched.switch_max_ticks = self.sched.switch_max_ticks.max(cost);
            }
        }
        self.sched.running = Some(p);
        self.sched.run_since = now;
    }

    /// The decrementer fired: a window ended or a gap did.
    pub fn on_timer(&mut self, now: u64) -> Next {
        match self.sched.phase {
            Phase::Window(w) => {
                if let Some(p) = self.sched.running {
                    self.charge(p, now);
                    self.parts[p].overruns = self.parts[p].overruns.wrapping_add(1);
                    self.overrun(p);
                }
                self.after_window(w, now)
            }
            Phase::Gap(w) => self.begin_window(w, now),
        }
    }

    /// The running partition `p` gave up the rest of its window.
    pub fn wait_next_window(&mut self, p: usize, now: u64) -> Next {
        self.charge(p, now);
        self.parts[p].run = RunState::Waiting;
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
        let window = &SYSTEM.schedule.windows[w];
        let scheduled = self.window_start(w);
        self.sched.phase = Phase::Window(w);
        set_decrementer_at(scheduled + u64::from(window.duration));
        let p = window.partition;
        self.parts[p].window_ticks = 0;
        match self.parts[p].run {
            RunState::Halted => Next::Idle,
            RunState::Ready | RunState::Waiting => {
                self.parts[p].run = RunState::Ready;
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
        for p in 0..PARTITION_COUNT {
            let s = self.parts[p];
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
        let action = SYSTEM.partitions[p].health.action(ErrorKind::Overrun);
        self.overrun_action(p, action);
    }
}

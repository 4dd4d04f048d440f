//! A warm reset the host armed to land at a chosen point inside the work one partition does on
//! one message (the executive on the next time grant): after so many ticks of that partition's
//! CPU, or part-way through its next warm-area write. Campaigns use it to reset the emulated
//! target at seeded points inside a frame, the same point on every run.
//!
//! The point is counted in the partition's own CPU time (see [`super::sched`]: counted with the
//! decrementer, so the same instructions give the same count on every run), from the start of
//! its first window after it received the anchor message: the executive takes a time grant in
//! one window and starts that frame's work at the start of its next one, so its work on the
//! frame starts at the same instruction of that window on every run, whatever part of its
//! window the host's bytes arrived in. While the counted partition runs and the point comes
//! before its window end, the decrementer is pointed at the reset point instead; a window end
//! in between pauses the count until the partition's next window. The kernel runs with interrupts off, so a point
//! inside a warm-area write (a system call) is found by the copy loop, which looks at the
//! decrementer between chunks: the reset then tears that write.
//!
//! If the partition gives up its window first (it finished its work on the message) or the
//! health monitor stops it, the reset happens right then. Just before resetting, the kernel
//! queues where the reset landed (`metric::ARMED_RESET_*`); `warm_reset` sends the queue
//! straight to the host, ahead of the next boot's Hello.
use fsw_bridge::ResetCause;
use kernel_config::abi::{metric, reset_at, SysError};
use kernel_config::PortKind;

use super::sched::{read_dec, DEC_EXACT_TICKS};
use super::umem::copy;
use super::{at, Kernel};
use crate::config::SYSTEM;

/// Bytes a watched warm-area write copies between two looks at the decrementer (a few ticks of
/// copying: the tear lands within 32 bytes of the reset point).
const WATCHED_COPY_CHUNK: usize = 32;

#[derive(Clone, Copy, PartialEq, Eq)]
enum Point {
    /// After this many ticks of the partition's CPU from its receipt of the anchor message.
    AfterTicks(u32),
    /// In its next warm-area write, after `permille`/1000 of the bytes.
    InWarmWrite { permille: u32 },
}

#[derive(Clone, Copy)]
enum State {
    Off,
    /// `partition` has `messages` more to receive from `port`; the last one is the anchor.
    /// With `chain`, the anchor arms the next stage instead: the destination of port `chain`,
    /// anchored on the first message sent there after it (the planner partition's work on
    /// the executive's first message of the frame). `from_receipt`: the count starts at the
    /// anchor's receipt (a partition that works on a message in the window it receives it),
    /// not at the partition's next window.
    Armed {
        partition: usize,
        port: usize,
        messages: u16,
        chain: Option<usize>,
        from_receipt: bool,
    },
    /// `partition` received the anchor; the count starts at its next switch-in.
    Received {
        partition: usize,
    },
    /// Counting `partition`'s CPU time from `anchor` (its CPU time at the receipt).
    Counting {
        partition: usize,
        anchor: u64,
        /// The decrementer runs out at the reset point (not at the window end).
        to_point: bool,
    },
}

/// A warm-area write the counted partition made.
#[derive(Clone, Copy)]
struct WarmWrite {
    offset: u32,
    len: u32,
    copied: u32,
    /// Ticks since the anchor at its start and at its end (or tear).
    start: u32,
    end: u32,
}

pub struct ArmedReset {
    state: State,
    point: Point,
    last_write: Option<WarmWrite>,
}

impl ArmedReset {
    pub const fn new() -> Self {
        Self {
            state: State::Off,
            point: Point::AfterTicks(0),
            last_write: None,
        }
    }

    /// True when no reset is armed.
    #[inline]
    pub fn is_off(&self) -> bool {
        matches!(self.state, State::Off)
    }

    /// True while `p`'s ticks are being counted.
    #[inline]
    pub fn counting(&self, p: usize) -> bool {
        matches!(self.state, State::Counting { partition, .. } if partition == p)
    }

    /// True if `p`'s next stint counts (asked on every switch-in: keep it cheap).
    #[inline]
    pub fn counts_stint(&self, p: usize) -> bool {
        matches!(
            self.state,
            State::Counting { partition, .. } | State::Received { partition } if partition == p
        )
    }

    /// The decrementer is pointed at the reset point and has run out.
    fn point_passed(&self) -> bool {
        matches!(self.state, State::Counting { to_point: true, .. }) && read_dec() <= 0
    }
}

impl Kernel {
    /// SYS_RESET_MODULE with a point (`mode` is not NOW), from `caller`.
    pub fn arm_reset(
        &mut self,
        caller: usize,
        mode: u32,
        value: u32,
        port: usize,
        chain: Option<usize>,
    ) -> Result<(), SysError> {
        let point = match mode {
            reset_at::AFTER_TICKS => Point::AfterTicks(value),
            reset_at::IN_WARM_WRITE if value <= 1000 => Point::InWarmWrite { permille: value },
            _ => return Err(SysError::Range),
        };
        let config = SYSTEM.ports.get(port).ok_or(SysError::BadPort)?;
        let &[partition] = config.destinations else {
            return Err(SysError::BadPort);
        };
        if config.kind != PortKind::Queuing || config.source != caller {
            return Err(SysError::BadPort);
        }
        let messages = self.ports.queued(port);
        if messages == 0 {
            return Err(SysError::Empty);
        }
        if let Some(chain) = chain {
            // The next stage's port: a queuing port from the first stage's partition to one
            // other.
            let next = SYSTEM.ports.get(chain).ok_or(SysError::BadPort)?;
            if next.kind != PortKind::Queuing
                || next.source != partition
                || next.destinations.len() != 1
            {
                return Err(SysError::BadPort);
            }
        }
        // The counted partition is not running (the caller is), so the decrementer is not
        // pointed at an earlier reset point.
        self.armed = ArmedReset {
            state: State::Armed {
                partition,
                port,
                messages,
                chain,
                from_receipt: false,
            },
            point,
            last_write: None,
        };
        defmt::info!(
            "reset armed in {=str}'s work on message {=u16} of port {=usize}",
            at(SYSTEM.partitions, partition).name,
            messages,
            port
        );
        Ok(())
    }

    /// `p` (running, in SYS_PORT_RECEIVE) took a message from `port`: after the anchor, the
    /// count starts with its next window.
    pub fn armed_reset_on_receive(&mut self, p: usize, port: usize) {
        let State::Armed {
            partition,
            port: anchor_port,
            messages,
            chain,
            from_receipt,
        } = self.armed.state
        else {
            return;
        };
        if partition != p || anchor_port != port {
            return;
        }
        if messages > 1 {
            self.armed.state = State::Armed {
                partition,
                port,
                messages: messages - 1,
                chain,
                from_receipt,
            };
            return;
        }
        match chain {
            Some(next) => {
                // The next stage: the first message `p` sends on `next` from here on is the
                // anchor of its destination's work.
                let Some(&[destination]) = SYSTEM.ports.get(next).map(|c| c.destinations) else {
                    self.armed.state = State::Off;
                    return;
                };
                let queued = self.ports.queued(next).saturating_add(1);
                self.armed.state = State::Armed {
                    partition: destination,
                    port: next,
                    messages: queued,
                    chain: None,
                    from_receipt: true,
                };
            }
            None if from_receipt => self.armed_count_from_now(p),
            None => self.armed.state = State::Received { partition },
        }
    }

    /// Starts counting the running partition `p`'s CPU from now (inside its stint): the
    /// decrementer is pointed at the reset point if that comes before the window end, the
    /// stint's accounting kept (what it used so far stays charged).
    fn armed_count_from_now(&mut self, p: usize) {
        let anchor = self.cpu_now(p);
        self.armed.state = State::Counting {
            partition: p,
            anchor,
            to_point: false,
        };
        let Point::AfterTicks(ticks) = self.armed.point else {
            return;
        };
        let window_dec = read_dec();
        // An exact count (see `sched`): a multiple of DEC_EXACT_TICKS, written at the same
        // instruction of the partition's work on every run.
        let exact = (ticks / DEC_EXACT_TICKS).max(1) * DEC_EXACT_TICKS;
        let Ok(to_point) = i32::try_from(exact) else {
            return;
        };
        if to_point < window_dec {
            self.repoint_stint(to_point);
            self.armed.state = State::Counting {
                partition: p,
                anchor,
                to_point: true,
            };
        }
    }

    /// Ticks the counted partition `p` (running) has used since the anchor.
    fn armed_used(&self, p: usize) -> u32 {
        match self.armed.state {
            State::Counting { anchor, .. } => self
                .cpu_now(p)
                .saturating_sub(anchor)
                .min(u64::from(u32::MAX)) as u32,
            _ => 0,
        }
    }

    /// The counted partition `p` starts a stint (switch-in, or the start of the count) whose
    /// window end is `window_dec` ticks away: the decrementer value to write, the reset point
    /// if that comes first.
    pub fn armed_reset_stint(&mut self, p: usize, window_dec: i32) -> i32 {
        // Between stints `cpu_total` is the partition's whole CPU time.
        let (partition, anchor) = match self.armed.state {
            State::Received { partition } => (partition, at(&self.parts, p).cpu_total),
            State::Counting {
                partition, anchor, ..
            } => (partition, anchor),
            _ => return window_dec,
        };
        self.armed.state = State::Counting {
            partition,
            anchor,
            to_point: false,
        };
        let Point::AfterTicks(ticks) = self.armed.point else {
            return window_dec;
        };
        let used = at(&self.parts, p).cpu_total - anchor;
        let Some(to_point) = u64::from(ticks).checked_sub(used).filter(|left| *left > 0) else {
            // Passed while the kernel worked for it past its window end.
            self.armed_reset_now(
                p,
                used.min(u64::from(u32::MAX)) as u32,
                reset_at::LANDED_IN_CODE,
            );
        };
        let to_point = to_point.min(i32::MAX as u64) as i32;
        self.armed.state = State::Counting {
            partition,
            anchor,
            to_point: to_point < window_dec,
        };
        to_point.min(window_dec)
    }

    /// The decrementer fired while `p` ran: the reset point (never returns), or its window end
    /// (the count pauses until its next window).
    pub fn armed_reset_on_timer(&mut self, p: usize) {
        if let State::Counting {
            partition,
            to_point: true,
            ..
        } = self.armed.state
        {
            if partition == p {
                self.armed_reset_now(p, self.armed_used(p), reset_at::LANDED_IN_CODE);
            }
        }
    }

    /// `p` gave up its window: if it is the counted partition, it finished its work first.
    pub fn armed_reset_on_wait(&mut self, p: usize) {
        if self.armed.counting(p) {
            let landed = if self.armed.point_passed() {
                reset_at::LANDED_IN_CODE
            } else {
                reset_at::LANDED_AFTER_WORK
            };
            self.armed_reset_now(p, self.armed_used(p), landed);
        }
    }

    /// The health monitor is stopping or restarting `p`.
    pub fn armed_reset_on_stop(&mut self, p: usize) {
        if self.armed.counting(p) {
            self.armed_reset_now(p, self.armed_used(p), reset_at::LANDED_PARTITION_STOPPED);
        }
    }

    /// SYS_WARM_WRITE from the counted partition `p`: copy `data` into `area` (at `offset` of
    /// the checkpoint part), watching for the reset point; if it falls inside, the write is
    /// torn there and the module resets.
    pub fn armed_warm_write(&mut self, p: usize, offset: u32, area: &mut [u8], data: &[u8]) {
        let start = self.armed_used(p);
        let len = data.len();
        let torn_at = match self.armed.point {
            Point::InWarmWrite { permille } => {
                let n = len * permille as usize / 1000;
                copy(area, data.get(..n).unwrap_or_default());
                Some(n)
            }
            Point::AfterTicks(_)
                if matches!(self.armed.state, State::Counting { to_point: true, .. }) =>
            {
                let mut torn_at = None;
                let chunks = area
                    .chunks_mut(WATCHED_COPY_CHUNK)
                    .zip(data.chunks(WATCHED_COPY_CHUNK));
                for (i, (to, from)) in chunks.enumerate() {
                    if read_dec() <= 0 {
                        torn_at = Some(i * WATCHED_COPY_CHUNK);
                        break;
                    }
                    copy(to, from);
                }
                torn_at
            }
            Point::AfterTicks(_) => {
                copy(area, data);
                None
            }
        };
        self.armed.last_write = Some(WarmWrite {
            offset,
            len: len as u32,
            copied: torn_at.unwrap_or(len) as u32,
            start,
            end: self.armed_used(p),
        });
        if torn_at.is_some() {
            self.armed_reset_now(p, self.armed_used(p), reset_at::LANDED_IN_WARM_WRITE);
        }
    }

    /// Report where the armed reset landed in `p`'s work (`used` ticks into it), then reset
    /// (cause Warm).
    fn armed_reset_now(&mut self, p: usize, used: u32, landed: u64) -> ! {
        self.events.metric(metric::ARMED_RESET_POINT, landed);
        self.events
            .metric(metric::ARMED_RESET_TICKS, u64::from(used));
        if let Some(w) = self.armed.last_write {
            self.events.metric(
                metric::ARMED_RESET_WARM_WRITE,
                u64::from(w.offset) << 32 | u64::from(w.len),
            );
            self.events
                .metric(metric::ARMED_RESET_WARM_COPIED, u64::from(w.copied));
            self.events.metric(
                metric::ARMED_RESET_WARM_WRITE_TICKS,
                u64::from(w.start) << 32 | u64::from(w.end),
            );
        }
        defmt::info!(
            "armed reset: landed {=u64} after {=u32} ticks of {=str}'s work",
            landed,
            used,
            at(SYSTEM.partitions, p).name
        );
        self.armed = ArmedReset::new();
        self.warm_reset(ResetCause::Warm)
    }
}

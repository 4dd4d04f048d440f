//! Both partitions' applications in one place, for a target without partitions (`hil`'s native
//! target, tests).
use super::*;

/// Rounds of the planner's and the executive's windows one grant may take in [`FlightApp`]: one,
/// and one more when the planner must be brought up to date first.
pub(crate) const MAX_ROUNDS_PER_FRAME: usize = 2;

/// Bytes of the warm memory and of non-volatile memory's checkpoint part that
/// [`FlightApp`] gives the executive's side (the rest is the planner's), as the kernel
/// gives each partition its slice.
pub const fn executive_share(len: usize) -> usize {
    len / 2
}

/// Offsets a [`MemoryFetch`] by the start of one side's share of the memories.
pub(crate) struct ShareFetch<'f, 'g> {
    fetch: &'f mut (dyn MemoryFetch + 'g),
    warm_offset: usize,
    nv_offset: usize,
}

impl MemoryFetch for ShareFetch<'_, '_> {
    fn fetch(
        &mut self,
        memory: MemoryKind,
        offset: usize,
        bytes: &mut [u8],
    ) -> Result<(), StoreError> {
        let base = match memory {
            MemoryKind::Warm => self.warm_offset,
            MemoryKind::Nv => self.nv_offset,
        };
        self.fetch.fetch(memory, base + offset, bytes)
    }
}

/// The whole flight software in one place, for a target without partitions (`hil`'s native
/// target, tests): the executive's and the planner's applications with the ports between them
/// as direct calls, each with its share of the memories ([`executive_share`]). A time grant
/// runs the executive's first window, the planner's window and the executive's second window,
/// as the partitions' windows run in one major frame of the target.
pub struct FlightApp {
    pub(crate) executive: ExecutiveApp,
    pub(crate) planner: PlannerApp,
    /// Bytes of each memory's checkpoint part that are the executive's (the rest is the
    /// planner's); None: half of each ([`executive_share`]).
    pub(crate) executive_bytes: Option<usize>,
    /// The lengths of the warm memory and of non-volatile memory's checkpoint part last seen.
    pub(crate) lens: (usize, usize),
}

impl Default for FlightApp {
    fn default() -> Self {
        Self::new()
    }
}

impl FlightApp {
    pub const fn new() -> Self {
        let mut planner = PlannerApp::new();
        // The unthrottled reference: the planner's cycle runs to its end in every frame.
        planner.budget = u32::MAX;
        Self {
            executive: ExecutiveApp::new(),
            planner,
            executive_bytes: None,
            lens: (0, 0),
        }
    }

    /// As [`FlightApp::new`], with the memories split as the kernel splits them: the first
    /// `executive_bytes` of each memory's checkpoint part are the executive partition's slice,
    /// the rest the planner's (`kernel_config::system::EXECUTIVE_WARM`).
    pub const fn with_executive_share(executive_bytes: usize) -> Self {
        let mut app = Self::new();
        app.executive_bytes = Some(executive_bytes);
        app
    }

    /// Makes this application what [`FlightApp::new`] makes, in place (the memories' split
    /// and the planner's budget are kept).
    pub fn reset(&mut self) {
        let budget = self.planner.budget;
        self.executive.reset();
        self.planner.reset();
        self.planner.budget = budget;
    }

    /// The executive's bytes of a memory part of `len` bytes.
    fn share(&self, len: usize) -> usize {
        self.executive_bytes
            .map_or(executive_share(len), |b| b.min(len))
    }

    /// Where the planner's shares of `memories` start (warm, non-volatile), remembered for
    /// [`FlightApp::take_warm_write`].
    fn shares(&mut self, memories: &Memories<'_>) -> (usize, usize) {
        self.lens = (
            memories.warm.len(),
            memories.nv.as_deref().map_or(0, <[u8]>::len),
        );
        (self.share(self.lens.0), self.share(self.lens.1))
    }

    pub fn executive(&self) -> &ExecutiveApp {
        &self.executive
    }

    pub fn planner(&self) -> &PlannerApp {
        &self.planner
    }

    /// Both sides' whole states, the executive's then the planner's, as their checkpoints
    /// hold them (tests compare them to show that something left the state untouched).
    pub fn encode_state(&self, buf: &mut [u8]) -> Option<usize> {
        let n = self.executive.executive().encode_state(buf)?;
        let m = self.planner.partition().encode_state(buf.get_mut(n..)?)?;
        Some(n + m)
    }

    /// The executive's network (the one loaded last).
    pub fn network(&self) -> &autonomy::TaskNetwork {
        self.executive.executive().network()
    }

    /// Validity checks per planner window.
    pub fn set_planner_budget(&mut self, checks: u32) {
        self.planner.set_budget(checks);
    }

    /// The security association read at boot and updated by every accepted message.
    pub fn security(&self) -> &SecurityAssociation {
        self.executive.security()
    }

    /// Refusals by the security checks since boot for `reason`.
    pub fn security_refusals(&self, reason: SecurityRefusal) -> u32 {
        self.executive.security_refusals(reason)
    }

    /// The ranges the checkpoints since the last call wrote into the warm memory, in the whole
    /// memory's offsets: the executive's, then the planner's.
    pub fn take_warm_writes(&mut self) -> heapless::Vec<(usize, usize), 8> {
        let base = self.share(self.lens.0);
        both_writes(
            self.executive.take_warm_writes(),
            self.planner.take_warm_writes(),
            base,
        )
    }

    /// The same for non-volatile memory's checkpoint part.
    pub fn take_nv_writes(&mut self) -> heapless::Vec<(usize, usize), 8> {
        let base = self.share(self.lens.1);
        both_writes(
            self.executive.take_nv_writes(),
            self.planner.take_nv_writes(),
            base,
        )
    }

    /// The range the last checkpoint since the last call wrote into the warm memory, in the
    /// whole memory's offsets: the executive's last one if it wrote any (after a frame, its
    /// second window's), else the planner's. What a reset right after could have torn. The
    /// others are forgotten.
    pub fn take_warm_write(&mut self) -> Option<(usize, usize)> {
        let base = self.share(self.lens.0);
        last_write(
            &self.executive.take_warm_writes(),
            &self.planner.take_warm_writes(),
            base,
        )
    }

    /// The same for non-volatile memory's checkpoint part.
    pub fn take_nv_write(&mut self) -> Option<(usize, usize)> {
        let base = self.share(self.lens.1);
        last_write(
            &self.executive.take_nv_writes(),
            &self.planner.take_nv_writes(),
            base,
        )
    }

    /// Come up after a (re)boot: each side restores its newest whole checkpoint from its share
    /// of the memories. The executive's outcome is the application's.
    pub fn boot(
        &mut self,
        memories: &mut Memories<'_>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> BootOutcome {
        self.boot_fetching(memories, None, clock, downlink)
    }

    /// As [`FlightApp::boot`], with copies filled by `fetch` on demand.
    pub fn boot_fetching(
        &mut self,
        memories: &mut Memories<'_>,
        mut fetch: Option<&mut (dyn MemoryFetch + '_)>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> BootOutcome {
        let at = self.shares(memories);
        let outcome = {
            let (mut mem, _) = split(memories, at);
            let mut fetch = fetch.as_deref_mut().map(|f| ShareFetch {
                fetch: f,
                warm_offset: 0,
                nv_offset: 0,
            });
            self.executive.boot_fetching(
                &mut mem,
                fetch.as_mut().map(|f| f as &mut dyn MemoryFetch),
                clock,
                downlink,
            )
        };
        let (_, mut mem) = split(memories, at);
        let mut fetch = fetch.map(|f| ShareFetch {
            fetch: f,
            warm_offset: at.0,
            nv_offset: at.1,
        });
        self.planner.boot_fetching(
            &mut mem,
            fetch.as_mut().map(|f| f as &mut dyn MemoryFetch),
            clock,
            downlink,
        );
        outcome
    }

    /// Handle one message from the host (see [`ExecutiveApp::handle`]); a time grant runs the
    /// whole frame, both partitions.
    pub fn handle(
        &mut self,
        msg: &HostToTarget,
        memories: &mut Memories<'_>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> bool {
        self.handle_fetching(msg, memories, None, clock, downlink)
    }

    /// As [`FlightApp::handle`], for copies filled by `fetch` on demand.
    pub fn handle_fetching(
        &mut self,
        msg: &HostToTarget,
        memories: &mut Memories<'_>,
        mut fetch: Option<&mut (dyn MemoryFetch + '_)>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> bool {
        let at = self.shares(memories);
        let share = |planner: bool| if planner { at } else { (0, 0) };
        let handled = {
            let (mut mem, _) = split(memories, at);
            let mut f = share_fetch(fetch.as_deref_mut(), share(false));
            self.executive.handle_fetching(
                msg,
                &mut mem,
                f.as_mut().map(|f| f as &mut dyn MemoryFetch),
                clock,
                downlink,
            )
        };
        // The rest of the frame: the planner's window, then the executive's second. A second
        // round (a major frame more on the target) when the planner had to be brought up to
        // date first; never more.
        if !self.executive.awaiting_planner() {
            return handled;
        }
        let Self {
            executive, planner, ..
        } = self;
        for _ in 0..MAX_ROUNDS_PER_FRAME {
            if !executive.awaiting_planner() {
                break;
            }
            {
                let (mut mem, _) = split(memories, at);
                let mut f = share_fetch(fetch.as_deref_mut(), share(false));
                executive.checkpoint_if_needed(
                    &mut mem,
                    f.as_mut().map(|f| f as &mut dyn MemoryFetch),
                    downlink,
                );
            }
            executive.transmit(&mut |w| {
                planner.receive(w);
                true
            });
            {
                let (_, mut mem) = split(memories, at);
                let mut f = share_fetch(fetch.as_deref_mut(), share(true));
                planner.window(
                    &mut mem,
                    f.as_mut().map(|f| f as &mut dyn MemoryFetch),
                    clock,
                    downlink,
                );
            }
            planner.transmit(&mut |w| {
                executive.receive(w);
                true
            });
            let (mut mem, _) = split(memories, at);
            let mut f = share_fetch(fetch.as_deref_mut(), share(false));
            executive.second_window(
                &mut mem,
                f.as_mut().map(|f| f as &mut dyn MemoryFetch),
                clock,
                downlink,
            );
        }
        executive.transmit(&mut |w| {
            planner.receive(w);
            true
        });
        handled
    }
}

/// Both sides' write ranges in the whole memory's offsets: the executive's, then the
/// planner's (whose share starts at `base`).
pub(crate) fn both_writes(
    executive: Writes,
    planner: Writes,
    base: usize,
) -> heapless::Vec<(usize, usize), 8> {
    executive
        .into_iter()
        .chain(planner.into_iter().map(|(s, e)| (s + base, e + base)))
        .collect()
}

/// `fetch` for one side's share, which starts at `(warm, nv)` offsets.
pub(crate) fn share_fetch<'f, 'g>(
    fetch: Option<&'f mut (dyn MemoryFetch + 'g)>,
    (warm_offset, nv_offset): (usize, usize),
) -> Option<ShareFetch<'f, 'g>> {
    fetch.map(|fetch| ShareFetch {
        fetch,
        warm_offset,
        nv_offset,
    })
}

/// The executive's and the planner's shares of `memories` (the security area is the
/// executive's).
pub(crate) fn split<'m, 'a: 'm>(
    memories: &'m mut Memories<'a>,
    (warm_at, nv_at): (usize, usize),
) -> (Memories<'m>, Memories<'m>) {
    let (exec_warm, planner_warm) = memories.warm.split_at_mut(warm_at);
    let (exec_nv, planner_nv) = match memories.nv.as_deref_mut() {
        Some(nv) => {
            let (a, b) = nv.split_at_mut(nv_at);
            (Some(a), Some(b))
        }
        None => (None, None),
    };
    (
        Memories {
            warm: exec_warm,
            nv: exec_nv,
            security: match memories.security.as_mut() {
                Some(s) => Some(&mut **s),
                None => None,
            },
        },
        Memories {
            warm: planner_warm,
            nv: planner_nv,
            security: None,
        },
    )
}

/// The executive's last write if it made any, else the planner's (whose share starts at
/// `base`), in the whole memory's offsets.
fn last_write(executive: &Writes, planner: &Writes, base: usize) -> Option<(usize, usize)> {
    executive
        .last()
        .copied()
        .or_else(|| planner.last().map(|&(s, e)| (s + base, e + base)))
}

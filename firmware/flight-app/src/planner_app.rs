//! The planner partition's application: the planning loop, its budget per window, its
//! checkpoints.
use super::*;

/// The planner's budget in one window: validity checks, and CPU up to a clock reading.
pub(crate) struct WindowBudget<'c, C: CpuClock> {
    checks: u32,
    until: Option<u64>,
    clock: &'c mut C,
}

impl<C: CpuClock> autonomy::planner::Budget for WindowBudget<'_, C> {
    fn exhausted(&mut self, checks_spent: u32) -> bool {
        checks_spent >= self.checks || self.until.is_some_and(|t| self.clock.ticks() >= t)
    }
}

/// The planner partition's application: the planning loop (`autonomy::partitioned`'s planner
/// side) with its own checkpoints in its own slices of the two memories. It plans once per
/// frame, in its window after the executive's first window ([`PlannerApp::window`]), within a
/// budget of validity checks, and sends the executive its commits, decisions and status.
pub struct PlannerApp {
    pub(crate) partition: PlannerPartition,
    pub(crate) persist: Persistence,
    /// Validity checks per window.
    pub(crate) budget: u32,
    /// CPU ticks the planning may take per window (None: no limit): the planner stops before
    /// the next job once its window's share is spent, so that it yields at its window's end
    /// instead of being preempted there, and its cycle goes on in the next frame's window.
    pub(crate) cpu_budget: Option<u64>,
    /// Set at a restore until the first window with no planning pending: the CPU spent so
    /// far, the restore included ([`metric::PLANNER_RECOVERY_TICKS`]).
    pub(crate) recovering: Option<u64>,
    /// The CPU clock's reading at the start of the last window: other plug-ins of the
    /// partition share the window's planning CPU from there.
    pub(crate) window_started: u64,
    /// The channel's refusal count last reported ([`metric::CHANNEL_REFUSED_TO_EXECUTIVE`]).
    pub(crate) reported_refused: u32,
}

impl Default for PlannerApp {
    fn default() -> Self {
        Self::new()
    }
}

impl PlannerApp {
    pub const fn new() -> Self {
        Self {
            partition: PlannerPartition::new(),
            persist: Persistence::NEW,
            budget: DEFAULT_PLANNER_BUDGET,
            cpu_budget: None,
            recovering: None,
            window_started: 0,
            reported_refused: 0,
        }
    }

    /// Makes this application what [`PlannerApp::new`] makes, in place.
    pub fn reset(&mut self) {
        self.partition.reset();
        self.persist = Persistence::NEW;
        self.budget = DEFAULT_PLANNER_BUDGET;
        self.cpu_budget = None;
        self.recovering = None;
        self.window_started = 0;
        self.reported_refused = 0;
    }

    /// The CPU clock's reading at the start of the last window ([`PlannerApp::window`]).
    pub fn window_started(&self) -> u64 {
        self.window_started
    }

    /// The planning loop's side of the core.
    pub fn partition(&self) -> &PlannerPartition {
        &self.partition
    }

    /// Validity checks per window (see [`DEFAULT_PLANNER_BUDGET`]).
    pub fn set_budget(&mut self, checks: u32) {
        self.budget = checks;
    }

    /// CPU ticks the planning may take per window (None: no limit; see the field).
    pub fn set_cpu_budget(&mut self, ticks: Option<u64>) {
        self.cpu_budget = ticks;
    }

    /// The ranges of warm memory written by the checkpoints since the last call, in order.
    pub fn take_warm_writes(&mut self) -> Writes {
        core::mem::take(&mut self.persist.last_warm_write)
    }

    /// The same for non-volatile memory.
    pub fn take_nv_writes(&mut self) -> Writes {
        core::mem::take(&mut self.persist.last_nv_write)
    }

    /// Come up after a (re)boot: restore the newest whole checkpoint of this partition's two
    /// memories (copies filled by `fetch` on demand, or complete ones).
    pub fn boot_fetching(
        &mut self,
        memories: &mut Memories<'_>,
        mut fetch: Option<&mut (dyn MemoryFetch + '_)>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> BootOutcome {
        let t0 = clock.ticks();
        self.persist.start(memories, fetch.as_deref_mut());
        let (outcome, _) = self
            .persist
            .restore_newest(&mut self.partition, memories, fetch, clock);
        let t1 = clock.ticks();
        // Restored or not, the planner's CPU counts towards the repaired plan until its first
        // window with nothing pending: a planner that lost its checkpoint plans afresh.
        self.recovering = Some(t1.wrapping_sub(t0));
        if let BootOutcome::RestoredWarm(_) | BootOutcome::RestoredNv(_) = outcome {
            if t1 != t0 {
                downlink.send(metric_event(
                    metric::PLANNER_RESTORE_TICKS,
                    t1.wrapping_sub(t0),
                ));
            }
        }
        outcome
    }

    /// Takes one message from the executive partition.
    pub fn receive(&mut self, wire: Wire<PlannerInput>) {
        self.partition.receive(wire);
    }

    /// Whether the executive's frame has come and the window has not run for it.
    pub fn frame_pending(&self) -> bool {
        self.partition.frame_pending()
    }

    /// Messages for the executive not sent yet (the port was full).
    pub fn unsent(&self) -> usize {
        self.partition.unsent()
    }

    /// The window for the frame the executive announced, if one came: planning within the
    /// budget, then the checkpoint (after which [`PlannerApp::transmit`] may send the
    /// commits, decisions and status). Its costs go to `downlink` as metrics.
    pub fn window(
        &mut self,
        memories: &mut Memories<'_>,
        fetch: Option<&mut (dyn MemoryFetch + '_)>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> Option<PlannerStatus> {
        let t0 = clock.ticks();
        self.window_started = t0;
        let budget = WindowBudget {
            checks: self.budget,
            until: self.cpu_budget.map(|ticks| t0.saturating_add(ticks)),
            clock: &mut *clock,
        };
        let status = self.partition.window(budget)?;
        let t1 = clock.ticks();
        let failures = self
            .persist
            .checkpoint_all(&mut self.partition, memories, fetch);
        let t2 = clock.ticks();
        if failures > 0 {
            downlink.send(metric_event(
                metric::PLANNER_CHECKPOINT_WRITE_FAILURES,
                failures,
            ));
        }
        if let Some(spent) = self.recovering.as_mut() {
            *spent = spent.wrapping_add(t2.wrapping_sub(t0));
            if !status.pending {
                if t2 != t0 {
                    downlink.send(metric_event(metric::PLANNER_RECOVERY_TICKS, *spent));
                }
                self.recovering = None;
            }
        }
        if t2 != t0 {
            downlink.send(metric_event(metric::PLANNER_TICKS, t1.wrapping_sub(t0)));
            downlink.send(metric_event(
                metric::PLANNER_CHECKPOINT_TICKS,
                t2.wrapping_sub(t1),
            ));
        }
        let refused = self.partition.to_executive().refused;
        if refused != self.reported_refused {
            downlink.send(metric_event(
                metric::CHANNEL_REFUSED_TO_EXECUTIVE,
                u64::from(refused),
            ));
            self.reported_refused = refused;
        }
        Some(status)
    }

    /// Hands the executive partition what the last checkpoint holds, until `send` refuses one.
    pub fn transmit(&mut self, send: &mut impl FnMut(Wire<ExecutiveInput>) -> bool) {
        self.partition.transmit(send);
    }
}

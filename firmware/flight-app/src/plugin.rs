//! The planner partition's plug-in interface: the planners it runs (the MEXEC planner,
//! [`PlannerApp`]; the temporal PDDL planner, [`crate::TemporalApp`]) each take their input,
//! plan anytime within the window's CPU share, and report, behind one trait.
use super::*;

/// One planner window, as the partition hands it to a plug-in.
pub struct PluginWindow<'w, 'm> {
    /// The partition's copies of its slices of the two memories (for checkpoints).
    pub memories: &'w mut Memories<'m>,
    /// Fills those copies on demand (None: the copies are complete).
    pub fetch: Option<&'w mut (dyn MemoryFetch + 'w)>,
    /// The partition's CPU clock.
    pub clock: &'w mut dyn CpuClock,
    /// Where messages for the host go.
    pub downlink: &'w mut dyn Downlink,
    /// The clock reading at which the window's planning share ends (None: no limit, the
    /// native reference). A plug-in stops before its next unit of work once it is reached,
    /// keeps its search, and goes on in the next granted frame's window.
    pub until: Option<u64>,
    /// The reading by which the window's work must be done (its end, less what the partition
    /// does after its plug-ins). A plug-in whose unit of work does not fit the share may
    /// still start one if it fits before this; one that does not fit a window at all runs
    /// anyway when it ran nothing in the window before (and overruns: the kernel preempts it
    /// and its health monitor reports it).
    pub hard_until: Option<u64>,
}

/// A planner the planner partition runs.
/// Whether the next piece of a plug-in's work (a search call, an expansion, a set-up piece),
/// costing up to `most` ticks going by the costliest so far, may start at `now` in a window
/// whose share ends at `until`: the window's `first` piece may use the rest of the window (up to
/// `hard_until`, the share's end when None), and runs whatever it costs after a window that ran
/// none (`stalled`: progress); any later piece must end within the share.
pub fn piece_fits(
    now: u64,
    most: u64,
    first: bool,
    stalled: bool,
    until: u64,
    hard_until: Option<u64>,
) -> bool {
    let end = now.saturating_add(most);
    if first {
        now < until && (end <= hard_until.unwrap_or(until) || stalled)
    } else {
        end <= until
    }
}

pub trait PlannerPlugin {
    /// Its name, for logs.
    fn name(&self) -> &'static str;
    /// Take a host message routed to the planner partition; false if it is not this
    /// plug-in's. Answers (acceptances, refusals) go to `downlink`.
    fn handle(&mut self, msg: &HostToTarget, downlink: &mut dyn Downlink) -> bool;
    /// Planning waits for the next granted frame's window.
    fn planning_pending(&self) -> bool;
    /// It has messages to hand out whatever the frames do: the partition must keep its
    /// windows (not declare itself idle) until they are out.
    fn busy(&self) -> bool;
    /// One granted frame's window: plan within `w.until`.
    fn window(&mut self, w: &mut PluginWindow<'_, '_>);
    /// Hand out what is ready, at most `room` messages (the room left in the partition's
    /// queue for the host).
    fn report(&mut self, room: usize, downlink: &mut dyn Downlink) {
        let _ = (room, downlink);
    }
}

impl<C: CpuClock + ?Sized> CpuClock for &mut C {
    fn ticks(&mut self) -> u64 {
        (**self).ticks()
    }
}

/// The MEXEC planner: its input comes from the executive partition's channel
/// ([`PlannerApp::receive`]), its commits go back there ([`PlannerApp::transmit`]); as a
/// plug-in it plans in the frames the executive announces, within its own budget of validity
/// checks and CPU ([`PlannerApp::set_cpu_budget`]).
impl PlannerPlugin for PlannerApp {
    fn name(&self) -> &'static str {
        "mexec"
    }

    fn handle(&mut self, _msg: &HostToTarget, _downlink: &mut dyn Downlink) -> bool {
        false
    }

    fn planning_pending(&self) -> bool {
        self.frame_pending()
    }

    fn busy(&self) -> bool {
        self.unsent() > 0
    }

    fn window(&mut self, w: &mut PluginWindow<'_, '_>) {
        let PluginWindow {
            memories,
            fetch,
            clock,
            downlink,
            ..
        } = w;
        let fetch = fetch.as_deref_mut().map(|f| f as &mut dyn MemoryFetch);
        PlannerApp::window(self, memories, fetch, clock, &mut |m| downlink.send(m));
    }
}

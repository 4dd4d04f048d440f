//! The planner partition's side of a [`PlannerPlugin`] window and report, the same for every
//! plug-in it runs (the temporal planner, the lander's executor).
use flight_app::{PlannerPlugin, PluginWindow};
use kernel_config::system::PLANNER_WINDOW_TICKS;
use userlib::{HostOutbox, PartitionClock};

/// Ticks of the planner window kept for what follows the plug-ins (the messages for the
/// executive and the host) and for what preceded the MEXEC window's clock reading (the
/// messages taken in).
const WINDOW_RESERVE_TICKS: u64 = 2_000;

/// Messages for the host a plug-in leaves free in the partition's queue (its other messages:
/// the MEXEC planner's metrics).
const OUTBOX_RESERVE: usize = 8;

/// One granted frame's window for `app`, if it has planning pending: plan until
/// `window_started + share_ticks`, and never past the window less its reserve.
pub fn window<P: PlannerPlugin, const N: usize>(
    app: &mut P,
    window_started: u64,
    share_ticks: u64,
    memories: &mut flight_app::Memories<'_>,
    outbox: &mut HostOutbox<N>,
) {
    let mut clock = PartitionClock;
    let mut w =
        PluginWindow {
            memories,
            fetch: None,
            clock: &mut clock,
            downlink: outbox,
            until: Some(window_started.saturating_add(share_ticks)),
            hard_until: Some(window_started.saturating_add(
                u64::from(PLANNER_WINDOW_TICKS).saturating_sub(WINDOW_RESERVE_TICKS),
            )),
        };
    app.window(&mut w);
}

/// What `app` has ready for the host, as far as the queue has room.
pub fn report<P: PlannerPlugin, const N: usize>(app: &mut P, outbox: &mut HostOutbox<N>) {
    if !app.busy() {
        return;
    }
    let room = N.saturating_sub(outbox.queue.len() + OUTBOX_RESERVE);
    app.report(room, outbox);
}

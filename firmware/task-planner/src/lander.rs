//! The Europa Lander's executor in the planner partition (issues 11 and 12): the memory of its
//! plug-in (`flight_app::LanderApp`) and the calls the partition's loop makes.
//!
//! The setup's bytes (64 KiB), the decoded setup, the executor and a downlink manager (for
//! the measure of its cost on a problem uplinked the same way) are statics in
//! `.bss.noinit.planner`, like the temporal planner's arena: in the partition's region, after
//! its zeroed statics, never zeroed by the partition's start, so they cost no boot or recovery
//! time. The plug-in zeroes the setup and the executor once, when the first lander message
//! arrives (all-zero bytes are a valid, empty value of each), and builds the executor in place
//! from each accepted setup (`Executor::reset`): it never passes through the 64 KiB stack.
use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use flight_app::{LanderApp, LanderStorage, PlannerPlugin, MAX_LANDER_SETUP_BYTES};
use fsw_bridge::HostToTarget;
use lander::downlink::DownlinkManager;
use lander::executor::Executor;
use lander::setup::LanderSetup;

use userlib::{HostOutbox, PartitionClock};

#[link_section = ".bss.noinit.planner"]
static mut SETUP_BYTES: MaybeUninit<[u8; MAX_LANDER_SETUP_BYTES]> = MaybeUninit::uninit();

#[link_section = ".bss.noinit.planner"]
static mut SETUP: MaybeUninit<LanderSetup> = MaybeUninit::uninit();

#[link_section = ".bss.noinit.planner"]
static mut EXECUTOR: MaybeUninit<Executor> = MaybeUninit::uninit();

#[link_section = ".bss.noinit.planner"]
static mut DOWNLINK: MaybeUninit<DownlinkManager> = MaybeUninit::uninit();

#[link_section = ".bss.part.planner"]
static mut APP: MaybeUninit<LanderApp<'static>> = MaybeUninit::uninit();

/// The plug-in, made at the partition's (re)start without its memory (an executor in force is
/// lost with a restart: the host uplinks its setup again).
pub fn start() -> &'static mut LanderApp<'static> {
    // SAFETY: APP is this partition's static; the entry runs once per (re)start, so nothing
    // else refers to it.
    unsafe { (*addr_of_mut!(APP)).write(LanderApp::new()) }
}

/// Hands the plug-in its memory at its first message.
fn give_storage(app: &mut LanderApp<'static>) {
    if app.has_storage() {
        return;
    }
    // SAFETY: the plug-in holds no reference into these statics (it has no storage), and
    // nothing else in the partition refers to them, so these are the only references. The
    // setup and the executor are zeroed first: every field of each, down to the leaves, is an
    // integer, a bool, an array of them, a fieldless enum whose first variant is 0, an Option
    // of these, an enum with a data-carrying variant that has no niche (tagged: tag 0 is its
    // first, dataless variant: the executor's mode Ready, the search's stage Idle), or a
    // heapless Vec (a length and MaybeUninit storage: empty when zero); no reference, NonZero
    // or function pointer. So all-zero bytes are a valid LanderSetup, Executor and
    // DownlinkManager, which the plug-in overwrites (`decode_into`, `Executor::reset`,
    // `DownlinkManager::load`) before using them. The bytes'
    // buffer holds whatever the RAM held (defined bytes); only bytes received are read.
    let storage = unsafe {
        let setup = addr_of_mut!(SETUP) as *mut LanderSetup;
        let executor = addr_of_mut!(EXECUTOR) as *mut Executor;
        core::ptr::write_bytes(setup, 0, 1);
        core::ptr::write_bytes(executor, 0, 1);
        let manager = addr_of_mut!(DOWNLINK) as *mut DownlinkManager;
        core::ptr::write_bytes(manager, 0, 1);
        LanderStorage {
            bytes: &mut *(addr_of_mut!(SETUP_BYTES) as *mut [u8; MAX_LANDER_SETUP_BYTES]),
            setup: &mut *setup,
            executor: &mut *executor,
            downlink: &mut *manager,
        }
    };
    app.give_storage(storage);
}

/// A host message routed to the planner partition: true if it was the plug-in's.
pub fn handle<const N: usize>(
    app: &mut LanderApp<'static>,
    msg: &HostToTarget,
    outbox: &mut HostOutbox<N>,
) -> bool {
    if !matches!(
        msg,
        HostToTarget::LanderBegin { .. }
            | HostToTarget::LanderChunk { .. }
            | HostToTarget::LanderStep { .. }
            | HostToTarget::LanderInput { .. }
    ) {
        return false;
    }
    deferred_handle(app, msg, outbox)
}

/// The plug-in's part of [`handle`], in the deferred code (see the crate's
/// `mod` lines).
#[inline(never)]
fn deferred_handle<const N: usize>(
    app: &mut LanderApp<'static>,
    msg: &HostToTarget,
    outbox: &mut HostOutbox<N>,
) -> bool {
    give_storage(app);
    app.handle_with_clock(msg, &mut PartitionClock, outbox)
}

/// The granted frame's window, after the other planners: the pending step runs until the
/// window's planning share, counted from the window's start (`window_started`), is spent.
pub fn window<const N: usize>(
    app: &mut LanderApp<'static>,
    window_started: u64,
    share_ticks: u64,
    memories: &mut flight_app::Memories<'_>,
    outbox: &mut HostOutbox<N>,
) {
    if !app.planning_pending() {
        return;
    }
    deferred_window(app, window_started, share_ticks, memories, outbox);
}

/// The plug-in's part of [`window`], in the deferred code (see the crate's
/// `mod` lines).
#[inline(never)]
fn deferred_window<const N: usize>(
    app: &mut LanderApp<'static>,
    window_started: u64,
    share_ticks: u64,
    memories: &mut flight_app::Memories<'_>,
    outbox: &mut HostOutbox<N>,
) {
    crate::plugin_glue::window(app, window_started, share_ticks, memories, outbox);
}

/// What the plug-in has ready for the host, as far as the queue has room.
pub fn report<const N: usize>(app: &mut LanderApp<'static>, outbox: &mut HostOutbox<N>) {
    crate::plugin_glue::report(app, outbox);
}

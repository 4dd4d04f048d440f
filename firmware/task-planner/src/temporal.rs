//! The temporal PDDL planner in the planner partition (issue 13): the memory of its plug-in
//! (`flight_app::TemporalApp`) and the calls the partition's loop makes.
//!
//! The task buffer (2 MiB) and the search arena (8 MiB) are statics in `.bss.noinit.planner`:
//! in the partition's region, after its zeroed statics, and never zeroed, neither at a
//! partition start nor at boot (the warm boot's image check covers the RAM image only), so
//! they cost no boot time. The planner writes every arena word it reads; the task buffer is
//! read only up to the bytes a job received. The plan buffer is small and zeroed with the
//! partition's other statics.
//!
//! Temporal uplinks are authenticated here (see `flight_app::TemporalApp`'s documentation for
//! why here and not in the executive): the key and the anti-replay counter are in the
//! partition's own security area, at `PLANNER_NV_SECURITY_OFFSET` of its slice of non-volatile
//! memory (`hil` provisions the same key there as in the executive's), read and written through
//! the kernel ([`PlannerSecurityStore`]).
use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use flight_app::rover_mission::checkpoint::RoverCheckpoint;
use flight_app::rover_mission::RoverMission;
use flight_app::{
    PlannerPlugin, TemporalApp, TemporalStorage, MAX_TEMPORAL_PLAN_ACTIONS,
    MAX_TEMPORAL_TASK_BYTES, TEMPORAL_ARENA_BYTES, TEMPORAL_RESUME_RECORD_WORDS,
};
use flight_app::{SecurityStore, StoreError};
use fsw_bridge::HostToTarget;
use temporal::PlannedAction;

use kernel_config::system::PLANNER_NV_SECURITY_OFFSET;

use userlib::{sys, HostOutbox};

const ARENA_WORDS: usize = TEMPORAL_ARENA_BYTES / 4;
#[link_section = ".bss.noinit.planner"]
static mut TASK: MaybeUninit<[u8; MAX_TEMPORAL_TASK_BYTES]> = MaybeUninit::uninit();

#[link_section = ".bss.noinit.planner"]
static mut ARENA: MaybeUninit<[u32; ARENA_WORDS]> = MaybeUninit::uninit();

/// The record of the accepted job, beside its task: what a warm reset keeps of the job
/// (`flight_app::TemporalApp::resume` checks it; after a cold boot it holds whatever the RAM
/// holds, which fails its magic or its CRC).
#[link_section = ".bss.noinit.planner"]
static mut RECORD: MaybeUninit<[u32; TEMPORAL_RESUME_RECORD_WORDS]> = MaybeUninit::uninit();

#[link_section = ".bss.part.planner"]
static mut PLAN: MaybeUninit<[PlannedAction; MAX_TEMPORAL_PLAN_ACTIONS]> = MaybeUninit::uninit();

#[link_section = ".bss.part.planner"]
static mut APP: MaybeUninit<TemporalApp<'static>> = MaybeUninit::uninit();

/// The onboard rover mission's memory (`flight_app::rover_mission`, about 51 KB): not zeroed at
/// a partition start, zero-filled at the mission's first `Start` ([`rover_memory`]).
#[link_section = ".bss.noinit.planner"]
static mut MISSION: MaybeUninit<RoverMission> = MaybeUninit::uninit();

/// The rover mission's checkpoint (`flight_app::rover_mission::checkpoint`, 65,696 bytes): kept
/// across a warm reset and a restart of the partition, checked before it is believed.
#[link_section = ".bss.noinit.planner"]
static mut ROVER_CHECKPOINT: MaybeUninit<RoverCheckpoint> = MaybeUninit::uninit();

/// The rover mission's memory, zero-filled: called once per partition (re)start, by the
/// plug-in, at the first rover `Start`.
fn rover_memory() -> &'static mut RoverMission {
    // SAFETY: MISSION is this partition's static, referred to by nothing else (the plug-in
    // calls this once per (re)start and keeps the one reference). Every field of a
    // RoverMission is an integer, a bool, or an array or plain struct of them (its dispatcher
    // too), so all-zero bytes, written over the whole value here, are a valid idle mission.
    unsafe {
        let p = addr_of_mut!(MISSION) as *mut RoverMission;
        core::ptr::write_bytes(p, 0, 1);
        &mut *p
    }
}

/// The security area of temporal uplinks in the planner's slice of non-volatile memory,
/// through the kernel (this partition owns the slice).
pub struct PlannerSecurityStore;

impl SecurityStore for PlannerSecurityStore {
    fn read(&mut self, area: &mut [u8; sdls::nv::SECURITY_AREA_BYTES]) -> Result<(), StoreError> {
        sys::nv_read(PLANNER_NV_SECURITY_OFFSET, area)
            .map(|_| ())
            .map_err(|_| StoreError)
    }

    /// Returns once the kernel has copied the bytes into the device.
    fn write(&mut self, offset: usize, bytes: &[u8]) -> Result<(), StoreError> {
        let at = (PLANNER_NV_SECURITY_OFFSET as usize)
            .checked_add(offset)
            .and_then(|at| u32::try_from(at).ok())
            .ok_or(StoreError)?;
        sys::nv_write(at, bytes).map_err(|_| StoreError)
    }
}

#[link_section = ".bss.part.planner"]
static mut STORE: PlannerSecurityStore = PlannerSecurityStore;

/// The plug-in, made at the partition's (re)start. A job accepted before a warm reset (or a
/// restart of the partition) is taken up again: its record and its task are in memory the
/// reset keeps; the task is checked again in the next windows and planned from the start.
/// `has_security_area`: the partition's slice of non-volatile memory holds the security
/// area (without it every temporal uplink is refused with `NoKey`).
pub fn start(has_security_area: bool) -> &'static mut TemporalApp<'static> {
    // SAFETY: PLAN is this partition's static, zeroed by the partition start, and all-zero
    // bytes are a valid array of PlannedAction (integers). APP and STORE (a unit struct) are
    // this partition's statics. The entry runs once per (re)start, so nothing else refers to
    // any of them.
    unsafe {
        let plan = &mut *(addr_of_mut!(PLAN) as *mut [PlannedAction; MAX_TEMPORAL_PLAN_ACTIONS]);
        let app = (*addr_of_mut!(APP)).write(TemporalApp::new(plan));
        let store = &mut *addr_of_mut!(STORE);
        app.secure(has_security_area.then_some(store as &mut dyn SecurityStore));
        app.set_receive_clock(|| sys::cpu_time().0);
        app.fly_rover_in(rover_memory);
        // SAFETY: RECORD is this partition's static in `.bss.noinit.planner`, referred to by
        // nothing else; every bit pattern is a valid array of u32 (the RAM holds defined
        // bytes, and the record is checked before it is believed).
        let record = &mut *(addr_of_mut!(RECORD) as *mut [u32; TEMPORAL_RESUME_RECORD_WORDS]);
        app.keep_jobs_in(record);
        give_storage(app);
        if app.resume() {
            defmt::info!(
                "temporal: job {=u16} resumed after a restart; its task is checked again",
                app.job().unwrap_or(0)
            );
        }
        // SAFETY: ROVER_CHECKPOINT is this partition's static in `.bss.noinit.planner`,
        // referred to by nothing else; it is words only, so every bit pattern is valid, and its
        // records are checked (magic, version, length, CRC-32, every field) before use.
        let checkpoint = &mut *(addr_of_mut!(ROVER_CHECKPOINT) as *mut RoverCheckpoint);
        app.keep_rover_in(checkpoint);
        if app.resume_rover() {
            defmt::info!(
                "temporal: a rover mission's checkpoint found; taken up in the next window"
            );
        }
        app
    }
}

/// Hands the plug-in its task buffer and arena again when no job holds them.
fn give_storage(app: &mut TemporalApp<'static>) {
    if !app.needs_storage() {
        return;
    }
    // SAFETY: `needs_storage` says the plug-in holds no reference into TASK or ARENA (the
    // search that borrowed them ended with its job), and nothing else in the partition refers
    // to them, so these are the only references. Every bit pattern is a valid u8 and u32, and
    // the RAM holds whatever it held (defined bytes): nothing reads a value it did not write.
    let storage = unsafe {
        TemporalStorage {
            task: &mut *(addr_of_mut!(TASK) as *mut [u8; MAX_TEMPORAL_TASK_BYTES]),
            arena: &mut *(addr_of_mut!(ARENA) as *mut [u32; ARENA_WORDS]),
        }
    };
    app.give_storage(storage);
}

/// A host message routed to the planner partition: true if it was the plug-in's.
pub fn handle<const N: usize>(
    app: &mut TemporalApp<'static>,
    msg: &HostToTarget,
    outbox: &mut HostOutbox<N>,
) -> bool {
    if !matches!(
        msg,
        HostToTarget::TemporalBegin { .. }
            | HostToTarget::TemporalChunk { .. }
            | HostToTarget::Rover { .. }
    ) {
        return false;
    }
    deferred_handle(app, msg, outbox)
}

/// The plug-in's part of [`handle`], in the deferred code (see the crate's
/// `mod` lines).
#[inline(never)]
fn deferred_handle<const N: usize>(
    app: &mut TemporalApp<'static>,
    msg: &HostToTarget,
    outbox: &mut HostOutbox<N>,
) -> bool {
    give_storage(app);
    app.handle(msg, outbox)
}

/// The granted frame's window, after the MEXEC planner's: the search goes on until the
/// window's planning share, counted from the window's start (`window_started`), is spent.
pub fn window<const N: usize>(
    app: &mut TemporalApp<'static>,
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
    app: &mut TemporalApp<'static>,
    window_started: u64,
    share_ticks: u64,
    memories: &mut flight_app::Memories<'_>,
    outbox: &mut HostOutbox<N>,
) {
    give_storage(app);
    crate::plugin_glue::window(app, window_started, share_ticks, memories, outbox);
}

/// What the plug-in has ready for the host, as far as the queue has room.
pub fn report<const N: usize>(app: &mut TemporalApp<'static>, outbox: &mut HostOutbox<N>) {
    crate::plugin_glue::report(app, outbox);
}

//! The flight application's metrics (ids from 0x1000): sent on every target, the native one
//! included. Values travel on the Mission channel (identical on every target); measured costs
//! on the Instrument channel (the native target counts no cycles).

use super::restored_from;
use crate::security::SecurityRefusal;

metric_table! {
    APP_METRICS;
    /// Ticks the autonomy step of one frame took (planner and executive, and the clock
    /// reads that split them: at least PLANNER_TICKS + EXECUTIVE_TICKS of the same frame).
    STEP_TICKS = 0x1000,
        "step_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
    /// Ticks one checkpoint write took (both areas).
    CHECKPOINT_TICKS = 0x1001,
        "checkpoint_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
    /// Ticks the restore at boot took.
    RESTORE_TICKS = 0x1002,
        "restore_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
    /// Ticks the application spent recovering after a restore, from the end of its boot to
    /// the end of the step that committed the repaired plan: the host's inputs in between
    /// (the state buffer published again, command responses) and the step(s) of the
    /// granted frames until the planner has no work pending (violations detected, aborts,
    /// contingencies, repair, commits); checkpoint writes of the frames before that one
    /// are included, the last frame's is not. Sent once per restore.
    RECOVERY_TICKS = 0x1003,
        "recovery_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
    /// Sequence number of the checkpoint restored at boot.
    RESTORED_SEQUENCE = 0x1004,
        "restored_sequence", Sequence, Value, FlightApp, Mission;
    /// Checkpoint writes that failed in one frame (a plan image larger than an area's
    /// slot).
    CHECKPOINT_WRITE_FAILURES = 0x1005,
        "checkpoint_write_failures", Count, Value, FlightApp, Mission;
    /// Ticks the planner's part of one frame's step took (reports and contingencies, its
    /// anytime cycle within the step budget, commits).
    PLANNER_TICKS = 0x1006,
        "planner_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
    /// Ticks the executive's part of one frame's step took (both executive passes).
    EXECUTIVE_TICKS = 0x1007,
        "executive_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
    /// Where the checkpoint restored at boot came from: one of [`restored_from`].
    RESTORED_FROM = 0x1008,
        "restored_from", Code, Value, FlightApp, Mission,
        values &[
            (restored_from::WARM, "warm-restart area"),
            (restored_from::NV, "non-volatile memory"),
        ];
    /// Slot of the checkpoint restored at boot, in the memory it came from: 0 = A (first
    /// half), 1 = B (second half).
    RESTORED_SLOT = 0x1009,
        "restored_slot", Code, Value, FlightApp, Mission,
        values &[(0, "A"), (1, "B")];
    /// State-buffer updates so far whose value was not of the type their timeline takes (an
    /// integer for a state timeline, an enumeration value beyond its values, ...): each was
    /// taken as unknown (`autonomy::Autonomy::state_type_mismatches`; the types are in
    /// `TaskNetwork::measured_timelines`). Sent with the frame's FrameDone the first time
    /// it is not zero and in every frame it changed (after a restore: in the first frame),
    /// so a host can fail the run naming it. A count, not a cost.
    STATE_TYPE_MISMATCHES = 0x100A,
        "state_type_mismatches", Count, Value, FlightApp, Mission;
    /// The state key of the last such update; sent right after STATE_TYPE_MISMATCHES.
    STATE_TYPE_MISMATCH_KEY = 0x100B,
        "state_type_mismatch_key", StateKey, Value, FlightApp, Mission;
    /// Ticks the whole frame's work took (the step and the checkpoint writes): what
    /// FrameDone carried in protocol v1. A measured cost, so it travels on the link's
    /// Instrument channel and FrameDone stays the same on every target.
    FRAME_BUSY_TICKS = 0x100C,
        "frame_busy_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
    /// Ground holds after an accepted SetHold or ReleaseHold (bit h: hold h), and at boot
    /// when any is set. A mask, not a cost.
    GROUND_HOLDS = 0x100D,
        "ground_holds", Mask, Value, FlightApp, Mission;
    /// Ticks the security checks of a reassembled uplink took (header, HMAC-SHA-256 over
    /// the whole image, sequence number), from the last chunk's receipt to the verdict; the
    /// counter write and the loading are not included. A measured cost.
    UPLINK_VERIFY_TICKS = 0x100E,
        "uplink_verify_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
    /// Ground commands refused since boot although authentic (their sequence number is
    /// spent): a hold number out of range. Sent after each.
    GROUND_COMMANDS_NOT_CARRIED_OUT = 0x100F,
        "ground_commands_not_carried_out", Count, Value, FlightApp, Mission;
    /// Uplinks and ground commands refused by the security checks since boot, one metric
    /// per reason: id `SECURITY_REFUSALS_FIRST + SecurityRefusal::index()` (0x1010 NoKey,
    /// 0x1011 UnknownKey, 0x1012 Truncated, 0x1013 BadMac, 0x1014 Replay, 0x1015
    /// BadLength, 0x1016 CounterNotStored), value the count for that reason; sent after
    /// each refusal.
    SECURITY_REFUSALS_FIRST = 0x1010 * SecurityRefusal::COUNT as u16,
        "security_refusals", Count, Value, FlightApp, Mission;
    /// The parts of the application's boot (the boot breakdown; sent at every boot,
    /// whereas RESTORE_TICKS, their sum, only when a checkpoint was restored): the security
    /// area read and its key checked.
    BOOT_SECURITY_TICKS = 0x1020,
        "boot_security_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
    /// Finding the checkpoint to restore: the records' headers and the records needed read
    /// in (on a target whose memories sit behind system calls), their CRCs checked, and the
    /// memory chosen.
    RESTORE_CHECK_TICKS = 0x1021,
        "boot_restore_check_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
    /// Decoding and validating the chosen checkpoint and the restart adjustments (a few
    /// ticks when there is nothing to restore).
    RESTORE_DECODE_TICKS = 0x1022,
        "boot_restore_decode_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
    /// The planner partition: ticks its restore at boot took (finding, decoding and
    /// validating its checkpoint). Sent when it restored one.
    PLANNER_RESTORE_TICKS = 0x1023,
        "planner_restore_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
    /// The planner partition's CPU from the start of its restore to the end of the first
    /// window with no planning pending (the repaired plan committed), its checkpoints
    /// included. Sent once per restore.
    PLANNER_RECOVERY_TICKS = 0x1024,
        "planner_recovery_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
    /// Ticks the planner partition's checkpoint write took (both areas).
    PLANNER_CHECKPOINT_TICKS = 0x1025,
        "planner_checkpoint_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
    /// Checkpoint writes of the planner partition that failed in one window.
    PLANNER_CHECKPOINT_WRITE_FAILURES = 0x1026,
        "planner_checkpoint_write_failures", Count, Value, FlightApp, Mission;
    /// Mission time (µs) from the frame that started a planner cycle to the frame whose
    /// window finished it, when that is more than one frame (a throttled planner: it
    /// committed its plan that much later). A value, not a cost: the same on every target
    /// with the same planner budget.
    PLANNING_LATENCY_US = 0x1027,
        "planning_latency_us", Micros, Value, FlightApp, Mission;
    /// Commits the executive dropped since boot because they were planned for a network
    /// that is no longer loaded; sent when it changes.
    STALE_COMMITS = 0x1028,
        "stale_commits", Count, Value, FlightApp, Mission;
    /// Frames in which the planner's cycle stopped on its budget and went on in the next
    /// frame's window (the planner was throttled), since boot; sent when it changes.
    PLANNER_PENDING_FRAMES = 0x1029,
        "planner_pending_frames", Count, Value, FlightApp, Mission;
    /// Messages the executive partition could not put in its channel to the planner (the
    /// channel's log full of messages not yet acknowledged; its last place is kept for the
    /// frame's own message): a total kept by the checkpoints, sent when it changes. Each is a
    /// report, state update or note the planner did not get.
    CHANNEL_REFUSED_TO_PLANNER = 0x102A,
        "channel_refused_to_planner", Count, Value, FlightApp, Mission;
    /// The same for the planner partition's channel to the executive (telemetry refused; the
    /// last place is kept for the window's status). Sent by the planner partition.
    CHANNEL_REFUSED_TO_EXECUTIVE = 0x102B,
        "channel_refused_to_executive", Count, Value, FlightApp, Mission;
    /// Planner telemetry the executive received but could not keep for the host (its
    /// forwarding buffer full): a total kept by the checkpoints, sent when it changes.
    PLANNER_TELEMETRY_DROPPED = 0x102C,
        "planner_telemetry_dropped", Count, Value, FlightApp, Mission;
}

/// The per-reason refusal count metric of `reason`.
pub const fn security_refusals(reason: SecurityRefusal) -> u16 {
    SECURITY_REFUSALS_FIRST + reason.index() as u16
}

/// The reason a refusal count metric counts, if `id` is one.
pub fn security_refusal_of(id: u16) -> Option<SecurityRefusal> {
    let index = id.checked_sub(SECURITY_REFUSALS_FIRST)?;
    SecurityRefusal::ALL.get(usize::from(index)).copied()
}

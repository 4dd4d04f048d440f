//! Shared by the integration tests: proptest strategies for every message variant, an
//! independent reference framer, and helpers to run a byte stream through a decoder.
#![allow(dead_code)] // Each test binary uses a different subset.

pub mod largest;
pub mod link_sim;
pub mod link_strategies;

use fsw_bridge::codec::{encode, DecodeError, FrameDecoder, WireMessage, LINK_CRC, MAX_FRAME_LEN};
use fsw_bridge::messages::{LOG_CHUNK_MAX, PANIC_FILE_MAX, UPLINK_CHUNK_MAX};
use fsw_bridge::{
    CommandArgs, CommandStatus, HostToTarget, MissionTimeUs, Opcode, ResetCause, ResetKind,
    StateKey, StateValue, TargetToHost, TelemetryEvent, MAX_COMMAND_ARGS,
};
use proptest::collection::vec;
use proptest::prelude::*;

// ---------------------------------------------------------------------------------------------
// Strategies. Integers mix small values (one-byte varints), the extremes and anything, so that
// every varint length shows up.

pub fn u16s() -> impl Strategy<Value = u16> {
    prop_oneof![0u16..128, Just(u16::MAX), any::<u16>()]
}

pub fn u32s() -> impl Strategy<Value = u32> {
    prop_oneof![0u32..128, Just(u32::MAX), any::<u32>()]
}

pub fn u64s() -> impl Strategy<Value = u64> {
    prop_oneof![0u64..128, Just(u64::MAX), any::<u64>()]
}

pub fn i32s() -> impl Strategy<Value = i32> {
    prop_oneof![-64i32..64, Just(i32::MIN), Just(i32::MAX), any::<i32>()]
}

pub fn i64s() -> impl Strategy<Value = i64> {
    prop_oneof![-64i64..64, Just(i64::MIN), Just(i64::MAX), any::<i64>()]
}

pub fn times() -> impl Strategy<Value = MissionTimeUs> {
    u64s().prop_map(MissionTimeUs)
}

/// A heapless Vec of any length up to its capacity, full capacity often.
pub fn hvec<T, S, const N: usize>(element: fn() -> S) -> impl Strategy<Value = heapless::Vec<T, N>>
where
    T: Clone + core::fmt::Debug,
    S: Strategy<Value = T>,
{
    prop_oneof![vec(element(), 0..=N), vec(element(), N..=N)]
        .prop_map(|v| heapless::Vec::from_slice(&v).expect("length within capacity"))
}

pub fn state_values() -> impl Strategy<Value = StateValue> {
    prop_oneof![
        Just(StateValue::Unknown),
        any::<bool>().prop_map(StateValue::Bool),
        u16s().prop_map(StateValue::Enum),
        i64s().prop_map(StateValue::Int),
    ]
}

pub fn command_statuses() -> impl Strategy<Value = CommandStatus> {
    prop_oneof![
        Just(CommandStatus::Ok),
        u16s().prop_map(CommandStatus::Failed),
        Just(CommandStatus::Rejected),
    ]
}

pub fn reset_causes() -> impl Strategy<Value = ResetCause> {
    prop_oneof![
        Just(ResetCause::PowerOn),
        Just(ResetCause::Warm),
        Just(ResetCause::Watchdog),
        Just(ResetCause::HealthMonitor),
        Just(ResetCause::KernelFault),
    ]
}

pub fn kernel_faults() -> impl Strategy<Value = Option<fsw_bridge::KernelFault>> {
    proptest::option::of(
        (u32s(), u32s(), u32s()).prop_map(|(vector, pc, dar)| fsw_bridge::KernelFault {
            vector,
            pc,
            dar,
        }),
    )
}

pub fn link_counters() -> impl Strategy<Value = fsw_bridge::LinkCounters> {
    (u32s(), u32s(), u32s(), u32s(), u32s(), u32s()).prop_map(|(a, b, c, d, e, f)| {
        fsw_bridge::LinkCounters {
            frames_ok: a,
            crc_errors: b,
            oversize: c,
            unknown_type: d,
            truncated: e,
            malformed: f,
        }
    })
}

pub fn telemetry_events() -> impl Strategy<Value = TelemetryEvent> {
    prop_oneof![
        (u16s(), any::<u8>(), any::<u8>(), times())
            .prop_map(|(task, from, to, at)| TelemetryEvent::TaskTransition { task, from, to, at }),
        (any::<u8>(), u16s(), u16s(), times()).prop_map(|(kind, task, template, at)| {
            TelemetryEvent::PlanModification {
                kind,
                task,
                template,
                at,
            }
        }),
        (any::<u8>(), any::<u8>(), u32s(), any::<u8>()).prop_map(
            |(partition, kind, address, action)| TelemetryEvent::HealthMonitor {
                partition,
                kind,
                address,
                action,
            }
        ),
        (u16s(), u64s()).prop_map(|(id, value)| TelemetryEvent::Metric { id, value }),
        (u16s(), times(), times()).prop_map(|(key, measured_at, at)| {
            TelemetryEvent::StateStale {
                key: StateKey(key),
                measured_at,
                at,
            }
        }),
    ]
}

// One strategy per variant, so that each variant gets its own round-trip property.

pub fn ping() -> impl Strategy<Value = HostToTarget> {
    u32s().prop_map(|seq| HostToTarget::Ping { seq })
}
pub fn time_grant() -> impl Strategy<Value = HostToTarget> {
    (u32s(), times(), times()).prop_map(|(frame, now, until)| HostToTarget::TimeGrant {
        frame,
        now,
        until,
    })
}
pub fn state_update() -> impl Strategy<Value = HostToTarget> {
    (u16s(), state_values(), times()).prop_map(|(key, value, timestamp)| {
        HostToTarget::StateUpdate {
            key: StateKey(key),
            value,
            timestamp,
        }
    })
}
pub fn command_response() -> impl Strategy<Value = HostToTarget> {
    (u32s(), command_statuses(), proptest::option::of(i64s()))
        .prop_map(|(id, status, data)| HostToTarget::CommandResponse { id, status, data })
}
pub fn uplink_chunk() -> impl Strategy<Value = HostToTarget> {
    (u16s(), u16s(), hvec::<u8, _, UPLINK_CHUNK_MAX>(any::<u8>))
        .prop_map(|(seq, total, bytes)| HostToTarget::UplinkChunk { seq, total, bytes })
}
pub fn reset_kinds() -> impl Strategy<Value = ResetKind> {
    prop_oneof![
        Just(ResetKind::Warm),
        u32s().prop_map(|ticks| ResetKind::WarmAfterTicks { ticks }),
        u16s().prop_map(|permille| ResetKind::WarmDuringCheckpointWrite { permille }),
        u32s().prop_map(|ticks| ResetKind::PlannerAfterTicks { ticks }),
        u16s().prop_map(|permille| ResetKind::PlannerDuringCheckpointWrite { permille }),
    ]
}
pub fn reset_request() -> impl Strategy<Value = HostToTarget> {
    reset_kinds().prop_map(|kind| HostToTarget::ResetRequest { kind })
}

pub fn ground_commands() -> impl Strategy<Value = fsw_bridge::GroundCommand> {
    use fsw_bridge::GroundCommand;
    prop_oneof![
        Just(GroundCommand::NoOp),
        any::<u8>().prop_map(GroundCommand::SetHold),
        any::<u8>().prop_map(GroundCommand::ReleaseHold),
    ]
}
pub fn ground_command() -> impl Strategy<Value = HostToTarget> {
    (
        u16s(),
        u32s(),
        ground_commands(),
        hvec::<u8, _, { fsw_bridge::security::MAC_LEN }>(any::<u8>),
    )
        .prop_map(
            |(spi, sequence, command, mac)| HostToTarget::GroundCommand {
                header: fsw_bridge::SecurityHeader { spi, sequence },
                command,
                mac,
            },
        )
}

pub fn host_to_target() -> impl Strategy<Value = HostToTarget> {
    prop_oneof![
        ping(),
        time_grant(),
        state_update(),
        command_response(),
        uplink_chunk(),
        reset_request(),
        ground_command(),
        temporal_begin(),
        temporal_chunk(),
    ]
}

pub fn temporal_configs() -> impl Strategy<Value = fsw_bridge::temporal::TemporalConfig> {
    use fsw_bridge::temporal::{TemporalConfig, TemporalDuplicates};
    (
        u16s(),
        any::<[bool; 4]>(),
        prop_oneof![
            Just(TemporalDuplicates::Keep),
            Just(TemporalDuplicates::PruneQuiescent),
            Just(TemporalDuplicates::PruneAll),
        ],
        u64s(),
        u32s(),
        u32s(),
    )
        .prop_map(
            |(max_steps, flags, duplicates, dropped_goals, max_expansions, max_windows)| {
                TemporalConfig {
                    max_steps,
                    compression: flags[0],
                    preferred_operators: flags[1],
                    shed_when_full: flags[2],
                    duplicates,
                    duration_costs: flags[3],
                    dropped_goals,
                    max_expansions,
                    max_windows,
                }
            },
        )
}
pub fn temporal_begin() -> impl Strategy<Value = HostToTarget> {
    (u16s(), u32s(), u32s(), temporal_configs()).prop_map(|(job, len, crc32, config)| {
        HostToTarget::TemporalBegin {
            job,
            len,
            crc32,
            config,
        }
    })
}
pub fn temporal_chunk() -> impl Strategy<Value = HostToTarget> {
    use fsw_bridge::temporal::TEMPORAL_CHUNK_MAX;
    (u16s(), u32s(), hvec::<u8, _, TEMPORAL_CHUNK_MAX>(any::<u8>))
        .prop_map(|(job, offset, bytes)| HostToTarget::TemporalChunk { job, offset, bytes })
}

pub fn hello() -> impl Strategy<Value = TargetToHost> {
    (
        u16s(),
        any::<[u8; 8]>(),
        reset_causes(),
        u32s(),
        kernel_faults(),
    )
        .prop_map(
            |(protocol_version, build_id, reset_cause, boot_count, kernel_fault)| {
                TargetToHost::Hello {
                    protocol_version,
                    build_id,
                    reset_cause,
                    boot_count,
                    kernel_fault,
                }
            },
        )
}
pub fn pong() -> impl Strategy<Value = TargetToHost> {
    (u32s(), link_counters()).prop_map(|(seq, link)| TargetToHost::Pong { seq, link })
}
pub fn frame_done() -> impl Strategy<Value = TargetToHost> {
    (u32s(), proptest::option::of(times()))
        .prop_map(|(frame, next_wakeup)| TargetToHost::FrameDone { frame, next_wakeup })
}
pub fn command_dispatch() -> impl Strategy<Value = TargetToHost> {
    (u32s(), u16s(), hvec::<i32, _, MAX_COMMAND_ARGS>(i32s)).prop_map(|(id, opcode, args)| {
        let args: CommandArgs = args;
        TargetToHost::CommandDispatch {
            id,
            opcode: Opcode(opcode),
            args,
        }
    })
}
pub fn log() -> impl Strategy<Value = TargetToHost> {
    hvec::<u8, _, LOG_CHUNK_MAX>(any::<u8>).prop_map(|bytes| TargetToHost::Log { bytes })
}
pub fn telemetry() -> impl Strategy<Value = TargetToHost> {
    telemetry_events().prop_map(TargetToHost::Telemetry)
}
pub fn uplink_ack() -> impl Strategy<Value = TargetToHost> {
    u16s().prop_map(|seq| TargetToHost::UplinkAck { seq })
}
pub fn uplink_nak() -> impl Strategy<Value = TargetToHost> {
    (u16s(), u16s()).prop_map(|(seq, reason)| TargetToHost::UplinkNak { seq, reason })
}
pub fn panic_report() -> impl Strategy<Value = TargetToHost> {
    (hvec::<u8, _, PANIC_FILE_MAX>(any::<u8>), u32s())
        .prop_map(|(file, line)| TargetToHost::Panic { file, line })
}

pub fn command_refusals() -> impl Strategy<Value = fsw_bridge::CommandRefusal> {
    use fsw_bridge::{CommandRefusal, SecurityRefusal};
    prop_oneof![
        proptest::sample::select(SecurityRefusal::ALL.to_vec()).prop_map(CommandRefusal::Security),
        Just(CommandRefusal::HoldOutOfRange),
    ]
}
pub fn ground_command_reply() -> impl Strategy<Value = TargetToHost> {
    prop_oneof![
        u32s().prop_map(|sequence| TargetToHost::GroundCommandAck { sequence }),
        (u32s(), command_refusals())
            .prop_map(|(sequence, reason)| TargetToHost::GroundCommandNak { sequence, reason }),
    ]
}

pub fn target_to_host() -> impl Strategy<Value = TargetToHost> {
    prop_oneof![
        hello(),
        pong(),
        frame_done(),
        command_dispatch(),
        log(),
        telemetry(),
        uplink_ack(),
        uplink_nak(),
        panic_report(),
        ground_command_reply(),
        temporal_report(),
    ]
}

pub fn temporal_report() -> impl Strategy<Value = TargetToHost> {
    use fsw_bridge::temporal::{TemporalOutcome, TemporalRefusal, TemporalRegion, TemporalReport};
    let region = prop_oneof![
        Just(TemporalRegion::Tables),
        Just(TemporalRegion::Nodes),
        Just(TemporalRegion::RegularOpen),
        Just(TemporalRegion::PreferredOpen),
        Just(TemporalRegion::PlanLength),
    ];
    let outcome = prop_oneof![
        Just(TemporalOutcome::Solved),
        Just(TemporalOutcome::Unsolvable),
        region.prop_map(TemporalOutcome::OutOfMemory),
        Just(TemporalOutcome::ExpansionLimit),
        Just(TemporalOutcome::WindowLimit),
    ];
    let refusal = prop_oneof![
        u32s().prop_map(|expected_offset| TemporalRefusal::OutOfSequence { expected_offset }),
        u32s().prop_map(|capacity| TemporalRefusal::TooLarge { capacity }),
        u32s().prop_map(|computed| TemporalRefusal::BadCrc { computed }),
        (any::<u8>(), u32s()).prop_map(|(kind, offset)| TemporalRefusal::BadTask { kind, offset }),
        (0..fsw_bridge::SecurityRefusal::COUNT)
            .prop_map(|i| TemporalRefusal::Security(fsw_bridge::SecurityRefusal::ALL[i])),
        u16s().prop_map(|job| TemporalRefusal::Busy { job }),
    ];
    prop_oneof![
        (u16s(), [u32s(), u32s(), u32s(), u32s()]).prop_map(|(job, [f, a, b, t])| {
            TemporalReport::Accepted {
                job,
                facts: f,
                actions: a,
                task_bytes: b,
                ticks_per_unit: t,
                receive_ticks: t,
                auth_ticks: a,
            }
        }),
        (u16s(), refusal).prop_map(|(job, reason)| TemporalReport::Refused { job, reason }),
        (u16s(), u16s(), u16s(), [u32s(), u32s(), u32s(), u32s()]).prop_map(
            |(job, index, action, [start, duration, start_lb, start_ub])| TemporalReport::Step {
                job,
                index,
                action,
                start,
                duration,
                start_lb,
                start_ub,
            }
        ),
        (u16s(), u64s(), u16s(), [u32s(), u32s(), u32s()]).prop_map(
            |(job, first_plan_ticks, first_plan_steps, [first_makespan, checks, worst])| {
                TemporalReport::Improved {
                    job,
                    first_plan_ticks,
                    first_plan_steps,
                    first_makespan,
                    elimination_checks: checks,
                    worst_elimination_ticks: worst,
                }
            }
        ),
        (u16s(), proptest::array::uniform10(u32s())).prop_map(|(job, v)| TemporalReport::Stats {
            job,
            expanded: v[0],
            generated: v[1],
            evaluated: v[2],
            inconsistent: v[3],
            duplicates: v[4],
            dead_ends: v[5],
            nodes: v[6],
            too_long: v[7],
            shed: v[8],
            best_h: v[9],
        }),
        (
            u16s(),
            outcome,
            u16s(),
            [u32s(), u32s(), u32s(), u32s(), u32s(), u32s()],
            u64s()
        )
            .prop_map(
                |(
                    job,
                    outcome,
                    steps,
                    [makespan, tpu, peak, arena, windows, worst],
                    planning_ticks,
                )| {
                    TemporalReport::Done {
                        job,
                        outcome,
                        steps,
                        makespan,
                        ticks_per_unit: tpu,
                        peak_arena_bytes: peak,
                        arena_bytes: arena,
                        planning_ticks,
                        windows,
                        worst_expansion_ticks: worst,
                        worst_set_up_ticks: worst,
                    }
                }
            ),
        (u16s(), u32s(), u32s()).prop_map(|(job, task_bytes, verify_ticks)| {
            TemporalReport::Resumed {
                job,
                task_bytes,
                verify_ticks,
            }
        }),
    ]
    .prop_map(TargetToHost::Temporal)
}

// ---------------------------------------------------------------------------------------------
// Framing helpers.

/// `encode` into a Vec.
pub fn frame<M: serde::Serialize>(msg: &M) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(msg, &mut buf).expect("message fits in a frame");
    buf[..n].to_vec()
}

/// postcard bytes of `msg`, without framing.
pub fn postcard_bytes<M: serde::Serialize>(msg: &M) -> Vec<u8> {
    let mut buf = [0u8; 1024];
    postcard::to_slice(msg, &mut buf).expect("fits").to_vec()
}

/// Textbook COBS encoder (no trailing block after a final full block), independent of the
/// crate's.
pub fn reference_cobs(src: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8];
    let mut code_at = 0;
    for (i, &b) in src.iter().enumerate() {
        if b == 0 {
            out[code_at] = (out.len() - code_at) as u8;
            code_at = out.len();
            out.push(0);
        } else {
            out.push(b);
            if out.len() - code_at == 0xff {
                out[code_at] = 0xff;
                if i + 1 < src.len() {
                    code_at = out.len();
                    out.push(0);
                } else {
                    return out;
                }
            }
        }
    }
    out[code_at] = (out.len() - code_at) as u8;
    out
}

/// A frame around arbitrary payload bytes with a correct CRC: `0, COBS(payload ++ crc), 0`.
pub fn raw_frame(payload: &[u8]) -> Vec<u8> {
    let crc = LINK_CRC.checksum(payload);
    raw_frame_with_crc(payload, crc)
}

/// Same with a CRC of the caller's choice.
pub fn raw_frame_with_crc(payload: &[u8], crc: u32) -> Vec<u8> {
    let mut raw = payload.to_vec();
    raw.extend_from_slice(&crc.to_le_bytes());
    stuffed_frame(&reference_cobs(&raw))
}

/// Delimit already stuffed bytes.
pub fn stuffed_frame(stuffed: &[u8]) -> Vec<u8> {
    let mut f = vec![0u8];
    f.extend_from_slice(stuffed);
    f.push(0);
    f
}

/// Every result a fresh decoder yields for `bytes`, and the decoder.
pub fn decode_all<M: WireMessage>(bytes: &[u8]) -> (Vec<Result<M, DecodeError>>, FrameDecoder) {
    let mut dec = FrameDecoder::new();
    let out = feed(&mut dec, bytes);
    (out, dec)
}

pub fn feed<M: WireMessage>(dec: &mut FrameDecoder, bytes: &[u8]) -> Vec<Result<M, DecodeError>> {
    bytes.iter().filter_map(|&b| dec.push::<M>(b)).collect()
}

/// Decode exactly one frame's worth of bytes, expecting exactly one result.
pub fn decode_one<M: WireMessage + core::fmt::Debug>(bytes: &[u8]) -> Result<M, DecodeError> {
    let (mut out, _) = decode_all::<M>(bytes);
    assert_eq!(
        out.len(),
        1,
        "expected exactly one result from {bytes:02x?}, got {out:?}"
    );
    out.pop().unwrap()
}

/// Serializes as its bytes verbatim (a postcard tuple of u8 has neither length nor varints), to
/// push arbitrary payloads through `encode`.
pub struct RawPayload(pub Vec<u8>);

impl serde::Serialize for RawPayload {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeTuple;
        let mut t = s.serialize_tuple(self.0.len())?;
        for b in &self.0 {
            t.serialize_element(b)?;
        }
        t.end()
    }
}

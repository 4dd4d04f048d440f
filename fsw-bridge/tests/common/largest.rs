//! Variant indices and the largest instance of every message variant (every varint at its
//! longest, every Vec full, every Option Some), shared by the codec and link encoding tests.
use fsw_bridge::lander::{
    LanderDirective, LanderEvent, LanderInput, LanderObservation, LanderProduct, LanderReport,
    LanderTaskResult, LANDER_CHUNK_MAX, LANDER_PRODUCTS_PER_MESSAGE,
};
use fsw_bridge::messages::{LOG_CHUNK_MAX, PANIC_FILE_MAX, UPLINK_CHUNK_MAX};
use fsw_bridge::security::{SecurityRefusal, MAC_LEN};
use fsw_bridge::temporal::{
    RoverEvent, RoverReport, TemporalConfig, TemporalDuplicates, TemporalOutcome, TemporalRefusal,
    TemporalRegion, TemporalReport, TEMPORAL_CHUNK_MAX,
};
use fsw_bridge::{
    CommandRefusal, CommandStatus, GroundCommand, HostToTarget, LinkCounters, MissionTimeUs,
    Opcode, ResetCause, ResetKind, SecurityHeader, StateKey, StateValue, TargetToHost,
    TelemetryEvent, MAX_COMMAND_ARGS,
};

/// Variants of each message set.
pub const H2T_VARIANTS: usize = 14;
pub const T2H_VARIANTS: usize = 13;

/// Declaration index of each variant. Exhaustive on purpose: adding a variant breaks the build
/// here, which is the reminder to bump VARIANT_COUNT and extend these tests.
pub fn h2t_index(m: &HostToTarget) -> usize {
    match m {
        HostToTarget::Ping { .. } => 0,
        HostToTarget::TimeGrant { .. } => 1,
        HostToTarget::StateUpdate { .. } => 2,
        HostToTarget::CommandResponse { .. } => 3,
        HostToTarget::UplinkChunk { .. } => 4,
        HostToTarget::ResetRequest { .. } => 5,
        HostToTarget::GroundCommand { .. } => 6,
        HostToTarget::TemporalBegin { .. } => 7,
        HostToTarget::TemporalChunk { .. } => 8,
        HostToTarget::LanderBegin { .. } => 9,
        HostToTarget::LanderChunk { .. } => 10,
        HostToTarget::LanderStep { .. } => 11,
        HostToTarget::LanderInput { .. } => 12,
        HostToTarget::Rover { .. } => 13,
    }
}

pub fn t2h_index(m: &TargetToHost) -> usize {
    match m {
        TargetToHost::Hello { .. } => 0,
        TargetToHost::Pong { .. } => 1,
        TargetToHost::FrameDone { .. } => 2,
        TargetToHost::CommandDispatch { .. } => 3,
        TargetToHost::Log { .. } => 4,
        TargetToHost::Telemetry(_) => 5,
        TargetToHost::UplinkAck { .. } => 6,
        TargetToHost::UplinkNak { .. } => 7,
        TargetToHost::Panic { .. } => 8,
        TargetToHost::GroundCommandAck { .. } => 9,
        TargetToHost::GroundCommandNak { .. } => 10,
        TargetToHost::Temporal(_) => 11,
        TargetToHost::Lander(_) => 12,
    }
}

pub fn full<const N: usize>(byte: u8) -> heapless::Vec<u8, N> {
    heapless::Vec::from_slice(&[byte; N]).unwrap()
}

/// The largest instance of variant `i`: every varint at its longest (u*::MAX, i*::MIN), every
/// Vec full, every Option Some, the longest inner variant.
pub fn largest_h2t(i: usize) -> HostToTarget {
    match i {
        0 => HostToTarget::Ping { seq: u32::MAX },
        1 => HostToTarget::TimeGrant {
            frame: u32::MAX,
            now: MissionTimeUs::MAX,
            until: MissionTimeUs::MAX,
        },
        2 => HostToTarget::StateUpdate {
            key: StateKey(u16::MAX),
            value: StateValue::Int(i64::MIN),
            timestamp: MissionTimeUs::MAX,
        },
        3 => HostToTarget::CommandResponse {
            id: u32::MAX,
            status: CommandStatus::Failed(u16::MAX),
            data: Some(i64::MIN),
        },
        4 => HostToTarget::UplinkChunk {
            seq: u16::MAX,
            total: u16::MAX,
            bytes: full::<UPLINK_CHUNK_MAX>(0xff),
        },
        5 => HostToTarget::ResetRequest {
            kind: ResetKind::WarmAfterTicks { ticks: u32::MAX },
        },
        6 => HostToTarget::GroundCommand {
            header: SecurityHeader {
                spi: u16::MAX,
                sequence: u32::MAX,
            },
            command: GroundCommand::ReleaseHold(u8::MAX),
            mac: full::<MAC_LEN>(0xff),
        },
        7 => HostToTarget::TemporalBegin {
            job: u16::MAX,
            len: u32::MAX,
            crc32: u32::MAX,
            config: largest_temporal_config(),
        },
        8 => HostToTarget::TemporalChunk {
            job: u16::MAX,
            offset: u32::MAX,
            bytes: full::<TEMPORAL_CHUNK_MAX>(0xff),
        },
        9 => HostToTarget::LanderBegin {
            setup: u16::MAX,
            len: u32::MAX,
            crc32: u32::MAX,
        },
        10 => HostToTarget::LanderChunk {
            setup: u16::MAX,
            offset: u32::MAX,
            bytes: full::<LANDER_CHUNK_MAX>(0xff),
        },
        11 => HostToTarget::LanderStep {
            setup: u16::MAX,
            seq: u32::MAX,
            observation: LanderObservation {
                now: MissionTimeUs::MAX,
                battery_mj: u64::MAX,
                preconditions_met: true,
                event: Some(LanderEvent::Finished {
                    result: LanderTaskResult::Faulted,
                    duration_us: u64::MAX,
                    energy_mj: u64::MAX,
                    positive: Some(false),
                }),
            },
        },
        // The larger of the two inputs: a full part of the product list.
        12 => HostToTarget::LanderInput {
            setup: u16::MAX,
            input: LanderInput::Products {
                first: u8::MAX,
                total: u8::MAX,
                products: heapless::Vec::from_slice(
                    &[LanderProduct {
                        size_bytes: u64::MAX,
                        value: u64::MAX,
                        created_at: MissionTimeUs::MAX,
                        tier: u8::MAX,
                    }; LANDER_PRODUCTS_PER_MESSAGE],
                )
                .unwrap(),
            },
        },
        // The largest rover event: the mission's start.
        13 => HostToTarget::Rover {
            job: u16::MAX,
            event: RoverEvent::Start {
                horizon_slack_ms: u32::MAX,
                max_expansions: u32::MAX,
                us_per_expansion: u32::MAX,
            },
        },
        _ => panic!("HostToTarget has no variant {i}"),
    }
}

pub fn largest_t2h(i: usize) -> TargetToHost {
    match i {
        0 => TargetToHost::Hello {
            protocol_version: u16::MAX,
            build_id: [0xff; 8],
            reset_cause: ResetCause::KernelFault,
            boot_count: u32::MAX,
            kernel_fault: Some(fsw_bridge::KernelFault {
                vector: u32::MAX,
                pc: u32::MAX,
                dar: u32::MAX,
            }),
        },
        1 => TargetToHost::Pong {
            seq: u32::MAX,
            link: LinkCounters {
                frames_ok: u32::MAX,
                crc_errors: u32::MAX,
                oversize: u32::MAX,
                unknown_type: u32::MAX,
                truncated: u32::MAX,
                malformed: u32::MAX,
            },
        },
        2 => TargetToHost::FrameDone {
            frame: u32::MAX,
            next_wakeup: Some(MissionTimeUs::MAX),
        },
        3 => TargetToHost::CommandDispatch {
            id: u32::MAX,
            opcode: Opcode(u16::MAX),
            args: heapless::Vec::from_slice(&[i32::MIN; MAX_COMMAND_ARGS]).unwrap(),
        },
        4 => TargetToHost::Log {
            bytes: full::<LOG_CHUNK_MAX>(0xff),
        },
        // The longest telemetry event: a key and two times.
        5 => TargetToHost::Telemetry(TelemetryEvent::StateStale {
            key: StateKey(u16::MAX),
            measured_at: MissionTimeUs::MAX,
            at: MissionTimeUs::MAX,
        }),
        6 => TargetToHost::UplinkAck { seq: u16::MAX },
        7 => TargetToHost::UplinkNak {
            seq: u16::MAX,
            reason: u16::MAX,
        },
        8 => TargetToHost::Panic {
            file: full::<PANIC_FILE_MAX>(0xff),
            line: u32::MAX,
        },
        9 => TargetToHost::GroundCommandAck { sequence: u32::MAX },
        10 => TargetToHost::GroundCommandNak {
            sequence: u32::MAX,
            reason: CommandRefusal::Security(SecurityRefusal::CounterNotStored),
        },
        // The longest temporal report: the statistics.
        11 => TargetToHost::Temporal(largest_temporal_report(3)),
        // The longest lander report: a step's answer with a dispatch.
        12 => TargetToHost::Lander(LanderReport::Answer {
            setup: u16::MAX,
            seq: u32::MAX,
            directive: LanderDirective::Dispatch {
                chain: u16::MAX,
                primitive: u8::MAX,
                kind: u8::MAX,
                site: Some(u8::MAX),
                target: Some(u8::MAX),
                expected_end: MissionTimeUs::MAX,
                expected_energy_mj: u64::MAX,
            },
            log_len: u16::MAX,
            ticks: u32::MAX,
            windows: u16::MAX,
        }),
        _ => panic!("TargetToHost has no variant {i}"),
    }
}

/// The largest temporal configuration (every varint at its longest).
pub fn largest_temporal_config() -> TemporalConfig {
    TemporalConfig {
        max_steps: u16::MAX,
        compression: true,
        preferred_operators: true,
        shed_when_full: true,
        duplicates: TemporalDuplicates::PruneAll,
        duration_costs: true,
        dropped_goals: u64::MAX,
        max_expansions: u32::MAX,
        max_windows: u32::MAX,
    }
}

/// Kinds of temporal report.
pub const TEMPORAL_REPORT_KINDS: usize = 8;

/// The largest temporal report of kind `i` (Accepted, Refused, Step, Stats, Done).
pub fn largest_temporal_report(i: usize) -> TemporalReport {
    let job = u16::MAX;
    let m = u32::MAX;
    match i {
        0 => TemporalReport::Accepted {
            job,
            facts: m,
            actions: m,
            task_bytes: m,
            ticks_per_unit: m,
            receive_ticks: m,
            auth_ticks: m,
        },
        1 => TemporalReport::Refused {
            job,
            reason: TemporalRefusal::BadTask {
                kind: u8::MAX,
                offset: m,
            },
        },
        2 => TemporalReport::Step {
            job,
            index: u16::MAX,
            action: u16::MAX,
            start: m,
            duration: m,
            start_lb: m,
            start_ub: m,
        },
        3 => TemporalReport::Stats {
            job,
            expanded: m,
            generated: m,
            evaluated: m,
            inconsistent: m,
            duplicates: m,
            dead_ends: m,
            nodes: m,
            too_long: m,
            shed: m,
            best_h: m,
        },
        4 => TemporalReport::Done {
            job,
            outcome: TemporalOutcome::OutOfMemory(TemporalRegion::PreferredOpen),
            steps: u16::MAX,
            makespan: m,
            ticks_per_unit: m,
            peak_arena_bytes: m,
            arena_bytes: m,
            planning_ticks: u64::MAX,
            windows: m,
            worst_expansion_ticks: m,
            worst_set_up_ticks: m,
        },
        5 => TemporalReport::Resumed {
            job,
            task_bytes: m,
            verify_ticks: m,
        },
        // The largest of the rover mission's reports: an attempt.
        6 => TemporalReport::Rover {
            job,
            report: RoverReport::Attempt {
                index: u16::MAX,
                hard_goals: u16::MAX,
                outcome: TemporalOutcome::OutOfMemory(TemporalRegion::PreferredOpen),
                actions: u16::MAX,
                expanded: m,
                peak_arena_bytes: m,
                build_ticks: m,
                planning_ticks: u64::MAX,
            },
        },
        7 => TemporalReport::Improved {
            job,
            first_plan_ticks: u64::MAX,
            first_plan_steps: u16::MAX,
            first_makespan: m,
            elimination_checks: m,
            worst_elimination_ticks: m,
        },
        _ => panic!("TemporalReport has no kind {i}"),
    }
}

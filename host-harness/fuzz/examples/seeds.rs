//! Writes the seed corpora of every fuzz target (a few dozen small files each, committed):
//!
//! * `fsw-bridge/fuzz/seeds/frame_decoder`: link frames (protocol v2) of every kind, carrying
//!   every message kind of both directions, whole bursts of a host and a target endpoint, and
//!   a stream with garbage and a corrupted frame between frames;
//! * `fsw-bridge/fuzz/seeds/link_endpoint`: scripts in which the fuzzed endpoint (either role)
//!   talks with a real peer for a few rounds: opening the channels, messages both ways on both
//!   virtual channels, a damaged frame, a consumer without room, a reset;
//! * `firmware/autonomy/fuzz/seeds/uplink`: the shipped task networks compiled by
//!   `hil::tasknet`, the flyby of `autonomy::scenarios`, and variants refused for each
//!   capacity (five constraints, a name of 33 bytes, 33 tasks, ...);
//! * `firmware/autonomy/fuzz/seeds/checkpoint`: checkpoints of the single-core autonomy core
//!   (its own format), each shipped network flown natively with every command answered, one
//!   every few steps;
//! * `firmware/autonomy/fuzz/seeds/{executive,planner}_checkpoint`: the two partitions'
//!   checkpoints of the shipped missions flown on the native target (resets, power cycles,
//!   failing commands, link faults), one every few frames;
//! * `firmware/flight-app/fuzz/seeds/messages`: the host messages, resets and power cycles of
//!   each shipped mission, as the flight application received them from the link (`hil`
//!   signs its uplinks and commands with the key the harness provisions), a few variants
//!   (time going backwards, grants repeated, a reset in the middle of the uplink), and the
//!   security verdicts one by one (uplinks and commands secured by the harness, replayed,
//!   forged, with the counter's memory failing, across resets);
//! * `firmware/flight-app/fuzz/seeds/uplink_chunks`: the shipped networks as chunked uplinks
//!   (secured by the harness), whole and with defects, and one sent unsecured;
//! * `host-harness/fuzz/seeds/{scenario_toml,tasknet_toml}`: the shipped scenario and task
//!   network files.
//!
//! Run from anywhere in the checkout: `cargo run --manifest-path host-harness/fuzz/Cargo.toml
//! --example seeds`. Regression seeds (files named `regression-*`) are kept; everything else in
//! the seed folders is rewritten.
#[path = "../../../firmware/flight-app/fuzz/src/lib.rs"]
#[allow(dead_code)]
mod flight_app_fuzz;

// Both fuzz libraries include the shared `bounded.rs`; each keeps its own copy here.
#[path = "../../../fsw-bridge/fuzz/src/lib.rs"]
#[allow(dead_code, clippy::duplicate_mod)]
mod fsw_bridge_fuzz;

use std::path::{Path, PathBuf};

use autonomy::{
    ConstraintSpec, NetworkSpec, TaskSpec, MAX_CONDITION_TERMS, MAX_CONSTRAINTS_PER_TASK,
    MAX_IMPACTS_PER_TASK, MAX_TASKS,
};
use flight_app_fuzz::{encode_ops, Harness, Op};
use fsw_bridge::codec::{encode, FrameDecoder, MAX_FRAME_LEN};
use fsw_bridge::link::{
    Directive, Endpoint, HostEndpoint, LinkConfig, LinkFrame, LinkMessage, Received, Role,
    TargetEndpoint, VirtualChannel,
};
use fsw_bridge::messages::UPLINK_CHUNK_MAX;
use fsw_bridge::*;
use fsw_bridge_fuzz::script;
use hil::mission::target::{MissionTarget, NativeTarget, ResetLanding, TargetError};
use hil::session::Hello;

fn main() {
    // At the lander capacities (issue 14) the flight application and the networks the
    // generator builds by value outgrow the main thread's 8 MiB stack in a debug build.
    std::thread::Builder::new()
        .stack_size(256 << 20)
        .spawn(generate)
        .unwrap()
        .join()
        .unwrap();
}

fn generate() {
    // The harness secures with hil's test key, so that the recorded missions verify in it.
    assert_eq!(flight_app_fuzz::KEY, hil::mission::auth::TEST_KEY);
    let root = hil::repo_root();
    let scenarios = root.join("scenarios");
    let networks = shipped_networks(&scenarios);
    let missions = recorded_missions(&scenarios);

    let frame_seeds = frame_decoder_seeds();
    write(
        &root.join("fsw-bridge/fuzz/seeds/frame_decoder"),
        &frame_seeds,
    );
    write(
        &root.join("fsw-bridge/fuzz/seeds/link_endpoint"),
        &link_endpoint_seeds(),
    );

    let mut uplinks: Vec<(String, Vec<u8>)> = networks.clone();
    uplinks.extend(capacity_variants(
        &autonomy::scenarios::flyby_spec().expect("fits"),
    ));
    write(&root.join("firmware/autonomy/fuzz/seeds/uplink"), &uplinks);

    write(
        &root.join("firmware/autonomy/fuzz/seeds/checkpoint"),
        &core_checkpoint_seeds(&networks),
    );
    let (executive, planner) = partition_checkpoint_seeds(&missions);
    write(
        &root.join("firmware/autonomy/fuzz/seeds/executive_checkpoint"),
        &executive,
    );
    write(
        &root.join("firmware/autonomy/fuzz/seeds/planner_checkpoint"),
        &planner,
    );
    let mut messages = message_seeds(&missions);
    messages.extend(security_seeds(&networks));
    write(
        &root.join("firmware/flight-app/fuzz/seeds/messages"),
        &messages,
    );
    write(
        &root.join("firmware/flight-app/fuzz/seeds/uplink_chunks"),
        &chunk_seeds(&networks),
    );
    write(
        &root.join("firmware/flight-app/fuzz/seeds/rover_checkpoint"),
        &rover_checkpoint_seeds(),
    );

    let copies = |dir: &Path| -> Vec<(String, Vec<u8>)> {
        let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
            .expect("readable")
            .map(|e| e.expect("entry").path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        files.sort();
        files
            .into_iter()
            .map(|p| {
                let name = p.file_name().unwrap().to_string_lossy().into_owned();
                (name, std::fs::read(&p).expect("readable"))
            })
            .collect()
    };
    write(
        &root.join("host-harness/fuzz/seeds/scenario_toml"),
        &copies(&scenarios),
    );
    let mut tasknets = copies(&scenarios.join("tasknets"));
    tasknets.push(("doc-example.toml".into(), DOC_EXAMPLE.as_bytes().to_vec()));
    write(
        &root.join("host-harness/fuzz/seeds/tasknet_toml"),
        &tasknets,
    );
}

/// The task network of `host-harness/src/tasknet.rs`'s documentation (every feature of the
/// format: conditions, after_reset, response bounds, temporal constraints).
const DOC_EXAMPLE: &str = include_str!("doc-example.toml");

/// Replaces the seed files of `dir` (keeping `regression-*`) with `seeds`.
fn write(dir: &Path, seeds: &[(String, Vec<u8>)]) {
    std::fs::create_dir_all(dir).expect("seed folder");
    for entry in std::fs::read_dir(dir).expect("readable") {
        let path = entry.expect("entry").path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if path.is_file() && !name.starts_with("regression") {
            std::fs::remove_file(&path).expect("removable");
        }
    }
    let mut total = 0;
    for (name, bytes) in seeds {
        std::fs::write(dir.join(name), bytes).expect("writable");
        total += bytes.len();
    }
    println!("{}: {} seeds, {} bytes", dir.display(), seeds.len(), total);
}

fn frame(msg: &impl serde::Serialize) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(msg, &mut buf).expect("fits a frame");
    buf[..n].to_vec()
}

/// `msg` as the link sends it: Hello, Ping and Pong as Type-BD, anything else as Type-AD on
/// the Mission channel with sequence number `ns`.
fn link_frame<M: serde::Serialize>(msg: &M, expedited: bool, ns: u8) -> Vec<u8> {
    if expedited {
        frame(&LinkFrame::Bd(msg))
    } else {
        frame(&LinkFrame::Ad {
            vc: VirtualChannel::Mission,
            ns,
            msg,
        })
    }
}

fn frame_decoder_seeds() -> Vec<(String, Vec<u8>)> {
    let args: CommandArgs = heapless::Vec::from_slice(&[1, -2, 3]).unwrap();
    let now = MissionTimeUs::from_mins(600);
    let header = SecurityHeader {
        spi: 1,
        sequence: 9,
    };
    let to_target = [
        HostToTarget::Ping { seq: 7 },
        HostToTarget::TimeGrant {
            frame: 3,
            now,
            until: now.saturating_add(60_000_000),
        },
        HostToTarget::StateUpdate {
            key: StateKey(1),
            value: StateValue::Enum(2),
            timestamp: now,
        },
        HostToTarget::CommandResponse {
            id: 65_539,
            status: CommandStatus::Failed(9),
            data: Some(-4),
        },
        HostToTarget::UplinkChunk {
            seq: 1,
            total: 8,
            bytes: heapless::Vec::from_slice(&[0x55; UPLINK_CHUNK_MAX]).unwrap(),
        },
        HostToTarget::ResetRequest {
            kind: ResetKind::WarmDuringCheckpointWrite { permille: 500 },
        },
        flight_app_fuzz::secure_command(9, GroundCommand::SetHold(3)),
        HostToTarget::TemporalBegin {
            job: 1,
            len: 300,
            crc32: 0x1234_5678,
            config: fsw_bridge::temporal::TemporalConfig::DEFAULT,
        },
        HostToTarget::TemporalChunk {
            job: 1,
            offset: 128,
            bytes: heapless::Vec::from_slice(&[0x53; fsw_bridge::temporal::TEMPORAL_CHUNK_MAX])
                .unwrap(),
        },
        HostToTarget::LanderBegin {
            setup: 1,
            len: 2_680,
            crc32: 0x8765_4321,
        },
        HostToTarget::LanderChunk {
            setup: 1,
            offset: 256,
            bytes: heapless::Vec::from_slice(&[0x4c; fsw_bridge::lander::LANDER_CHUNK_MAX])
                .unwrap(),
        },
        HostToTarget::LanderStep {
            setup: 1,
            seq: 12,
            observation: fsw_bridge::lander::LanderObservation {
                now,
                battery_mj: 72_000_000,
                preconditions_met: true,
                event: Some(fsw_bridge::lander::LanderEvent::Finished {
                    result: fsw_bridge::lander::LanderTaskResult::Succeeded,
                    duration_us: 3_600_000_000,
                    energy_mj: 180_000,
                    positive: Some(true),
                }),
            },
        },
        HostToTarget::LanderInput {
            setup: 1,
            input: fsw_bridge::lander::LanderInput::Products {
                first: 0,
                total: 2,
                products: heapless::Vec::from_slice(&[
                    fsw_bridge::lander::LanderProduct {
                        size_bytes: 2_400_000,
                        value: 80,
                        created_at: now,
                        tier: 1,
                    },
                    fsw_bridge::lander::LanderProduct {
                        size_bytes: 640_000,
                        value: 20,
                        created_at: now,
                        tier: 3,
                    },
                ])
                .unwrap(),
            },
        },
        HostToTarget::Rover {
            job: 2,
            event: fsw_bridge::temporal::RoverEvent::Ended {
                action: 17,
                at_ms: 656_512,
            },
        },
    ];
    let to_host = [
        TargetToHost::Hello {
            protocol_version: PROTOCOL_VERSION,
            build_id: *b"native\0\0",
            reset_cause: ResetCause::Warm,
            boot_count: 2,
            kernel_fault: None,
        },
        TargetToHost::Pong {
            seq: 7,
            link: LinkCounters::default(),
        },
        TargetToHost::FrameDone {
            frame: 3,
            next_wakeup: Some(now),
        },
        TargetToHost::CommandDispatch {
            id: 4,
            opcode: Opcode(0x0101),
            args,
        },
        TargetToHost::Log {
            bytes: heapless::Vec::from_slice(&[1, 2, 3, 0, 4]).unwrap(),
        },
        TargetToHost::Telemetry(TelemetryEvent::TaskTransition {
            task: 3,
            from: 4,
            to: 0x14,
            at: now,
        }),
        TargetToHost::Telemetry(TelemetryEvent::Metric {
            id: 0x1003,
            value: 123_456,
        }),
        TargetToHost::Telemetry(TelemetryEvent::StateStale {
            key: StateKey(1),
            measured_at: now,
            at: now.saturating_add(5_000_000),
        }),
        TargetToHost::UplinkAck { seq: 8 },
        TargetToHost::UplinkNak { seq: 8, reason: 12 },
        TargetToHost::Panic {
            file: heapless::Vec::from_slice(b"src/kernel/mod.rs").unwrap(),
            line: 42,
        },
        TargetToHost::GroundCommandAck {
            sequence: header.sequence,
        },
        TargetToHost::GroundCommandNak {
            sequence: header.sequence,
            reason: CommandRefusal::Security(SecurityRefusal::Replay),
        },
        TargetToHost::Hello {
            protocol_version: PROTOCOL_VERSION,
            build_id: *b"native\0\0",
            reset_cause: ResetCause::KernelFault,
            boot_count: 3,
            kernel_fault: Some(fsw_bridge::KernelFault {
                vector: 0x700,
                pc: 0x1_2344,
                dar: 0,
            }),
        },
        TargetToHost::Temporal(fsw_bridge::temporal::TemporalReport::Step {
            job: 1,
            index: 0,
            action: 12,
            start: 0,
            duration: 5_000,
            start_lb: 0,
            start_ub: 1_000,
        }),
        TargetToHost::Lander(fsw_bridge::lander::LanderReport::Answer {
            setup: 1,
            seq: 12,
            directive: fsw_bridge::lander::LanderDirective::Dispatch {
                chain: 6,
                primitive: 2,
                kind: 3,
                site: Some(0),
                target: Some(1),
                expected_end: now.saturating_add(3_600_000_000),
                expected_energy_mj: 180_000,
            },
            log_len: 40,
            ticks: 5_000,
            windows: 1,
        }),
    ];
    let mut seeds = Vec::new();
    for (i, m) in to_target.iter().enumerate() {
        let expedited = matches!(m, HostToTarget::Ping { .. });
        seeds.push((format!("to-target-{i}"), link_frame(m, expedited, i as u8)));
    }
    for (i, m) in to_host.iter().enumerate() {
        let expedited = matches!(m, TargetToHost::Hello { .. } | TargetToHost::Pong { .. });
        seeds.push((format!("to-host-{i}"), link_frame(m, expedited, i as u8)));
    }
    // The link's own frames (the same bytes in both directions).
    let control: [(&str, LinkFrame<HostToTarget>); 4] = [
        (
            "link-unlock",
            LinkFrame::Bc {
                round: 1,
                directive: Directive::Unlock {
                    vc: VirtualChannel::Instrument,
                },
            },
        ),
        (
            "link-set-vr",
            LinkFrame::Bc {
                round: 1,
                directive: Directive::SetVr {
                    vc: VirtualChannel::Mission,
                    vr: 0,
                },
            },
        ),
        ("link-round-end", LinkFrame::RoundEnd { round: 2 }),
        ("link-report", LinkFrame::Report(exchange(2).1.report(2))),
    ];
    for (name, f) in control {
        seeds.push((name.into(), frame(&f)));
    }
    // Whole bursts of a host and a target endpoint after two rounds.
    let (host_bursts, target_bursts) = exchange(3).0;
    for (round, (h, t)) in host_bursts.iter().zip(&target_bursts).enumerate() {
        seeds.push((format!("burst-host-round{}", round + 1), h.clone()));
        seeds.push((format!("burst-target-round{}", round + 1), t.clone()));
    }
    // Several frames in one stream, with garbage and a corrupted frame between them.
    let mut stream = link_frame(&to_host[8], false, 0);
    stream.extend([0x13, 0x37, 0xff]); // garbage between frames
    stream.extend(link_frame(&to_target[1], false, 1));
    let mut corrupted = link_frame(&to_target[2], false, 2);
    corrupted[3] ^= 0x10;
    stream.extend(corrupted);
    stream.extend(link_frame(&to_host[3], false, 3));
    seeds.push(("stream".into(), stream));
    seeds
}

/// A host and a target endpoint (the default configuration) talking for `rounds` rounds, the
/// host sending a grant and a state update per round, the target a FrameDone and a metric on
/// the Instrument channel: every burst's bytes, (host's, target's), and the target endpoint.
#[allow(clippy::type_complexity)]
fn exchange(rounds: u32) -> ((Vec<Vec<u8>>, Vec<Vec<u8>>), Box<TargetEndpoint>) {
    let mut host = Box::new(HostEndpoint::new(Role::Initiator, LinkConfig::DEFAULT).unwrap());
    let mut target = Box::new(TargetEndpoint::new(Role::Responder, LinkConfig::DEFAULT).unwrap());
    let (mut host_bursts, mut target_bursts) = (Vec::new(), Vec::new());
    for round in 0..rounds {
        let now = MissionTimeUs::from_mins(600 + u64::from(round));
        host.submit(
            VirtualChannel::Mission,
            &HostToTarget::StateUpdate {
                key: StateKey(1),
                value: StateValue::Enum(round as u16),
                timestamp: now,
            },
        )
        .unwrap();
        host.submit(
            VirtualChannel::Mission,
            &HostToTarget::TimeGrant {
                frame: round,
                now,
                until: now.saturating_add(60_000_000),
            },
        )
        .unwrap();
        let mut wire = Vec::new();
        host.produce_burst(&mut |f: &[u8]| wire.extend_from_slice(f));
        deliver(&mut *target, &wire);
        target
            .submit(
                VirtualChannel::Mission,
                &TargetToHost::FrameDone {
                    frame: round,
                    next_wakeup: None,
                },
            )
            .unwrap();
        target
            .submit(
                VirtualChannel::Instrument,
                &TargetToHost::Telemetry(TelemetryEvent::Metric {
                    id: 0x1000,
                    value: 1234,
                }),
            )
            .unwrap();
        let mut answer = Vec::new();
        target.produce_burst(&mut |f: &[u8]| answer.extend_from_slice(f));
        deliver(&mut *host, &answer);
        host_bursts.push(wire);
        target_bursts.push(answer);
    }
    ((host_bursts, target_bursts), target)
}

/// Feeds `wire` to `endpoint` (its consumer always has room); the messages it delivered.
fn deliver<Out: LinkMessage, In: LinkMessage, const R: usize, const Q: usize>(
    endpoint: &mut Endpoint<Out, In, R, Q>,
    wire: &[u8],
) -> usize {
    let mut decoder = FrameDecoder::new();
    let mut delivered = 0;
    for &b in wire {
        if let Some(frame) = decoder.push::<LinkFrame<In>>(b) {
            if let Received::Delivered { .. } = endpoint.on_frame(frame, |_| true) {
                delivered += 1;
            }
        }
    }
    delivered
}

/// `bytes` arriving raw, in script steps of at most 255 bytes.
fn push_raw(script: &mut Vec<u8>, bytes: &[u8]) {
    for piece in bytes.chunks(255) {
        script.extend([script::RAW, piece.len() as u8]);
        script.extend_from_slice(piece);
    }
}

/// The fuzzed endpoint talking with a real peer: scripts for `fsw_bridge_fuzz::link_endpoint`.
/// Each is checked against a real endpoint of the fuzzed one's role and configuration, fed
/// the same: the script must deliver what it delivered.
fn link_endpoint_seeds() -> Vec<(String, Vec<u8>)> {
    let mut seeds = Vec::new();
    // The target (role byte even: a Responder, default configuration) hears a host.
    for (name, rounds, damage, full, reset) in [
        ("target-rounds", 4, false, false, false),
        ("target-damaged-frame", 4, true, false, false),
        ("target-consumer-full", 4, false, true, false),
        ("target-reset", 7, false, false, true),
    ] {
        let mut host = Box::new(HostEndpoint::new(Role::Initiator, LinkConfig::DEFAULT).unwrap());
        let mut mirror =
            Box::new(TargetEndpoint::new(Role::Responder, LinkConfig::DEFAULT).unwrap());
        let mut s = vec![0u8];
        let mut delivered = 0;
        for round in 0..rounds {
            for n in 0..3u32 {
                let _ = host.submit(
                    VirtualChannel::ALL[(n % 2) as usize],
                    &HostToTarget::Ping {
                        seq: round * 10 + n,
                    },
                );
            }
            let mut wire = Vec::new();
            host.produce_burst(&mut |f: &[u8]| wire.extend_from_slice(f));
            if damage && round == 1 {
                let at = wire.len() / 3;
                wire[at] ^= 0x04;
            }
            let room = !(full && round == 2);
            if !room {
                s.extend([script::ROOM, 1]);
            }
            push_raw(&mut s, &wire);
            let mut decoder = FrameDecoder::new();
            for &b in &wire {
                if let Some(f) = decoder.push::<LinkFrame<HostToTarget>>(b) {
                    if let Received::Delivered { .. } = mirror.on_frame(f, |_| room) {
                        delivered += 1;
                    }
                }
            }
            if !room {
                s.extend([script::ROOM, 0]);
            }
            if reset && round == 3 {
                // The target resets: both ends start again, the host on the target's Hello.
                s.push(script::RESET);
                mirror.reset();
                host.reset();
                delivered = 0;
            }
            for pick in [2 * round as u8, 2 * round as u8 + 1] {
                s.extend([script::SUBMIT, pick]);
                let _ = mirror.submit(
                    VirtualChannel::ALL[usize::from(pick & 1)],
                    &TargetToHost::UplinkAck {
                        seq: u16::from(pick),
                    },
                );
            }
            s.push(script::BURST);
            let mut answer = Vec::new();
            mirror.produce_burst(&mut |f: &[u8]| answer.extend_from_slice(f));
            deliver(&mut *host, &answer);
        }
        let run = fsw_bridge_fuzz::run_link_script(&s);
        assert_eq!(run.delivered.iter().sum::<u32>(), delivered, "{name}");
        assert!(delivered > 0, "{name} delivers nothing");
        seeds.push((name.to_string(), s));
    }
    // The host (role byte odd: an Initiator, window 3, transmission limit 2) hears a target.
    let config = LinkConfig {
        window_width: 3,
        transmission_limit: 2,
        ..LinkConfig::DEFAULT
    };
    let mut mirror = Box::new(
        Endpoint::<HostToTarget, TargetToHost, 1024, 16>::new(Role::Initiator, config).unwrap(),
    );
    let mut target = Box::new(TargetEndpoint::new(Role::Responder, config).unwrap());
    let mut s = vec![1u8];
    let mut delivered = 0;
    for round in 0..5u8 {
        for pick in [2 * round, 2 * round + 1] {
            s.extend([script::SUBMIT, pick]);
            let _ = mirror.submit(
                VirtualChannel::ALL[usize::from(pick & 1)],
                &HostToTarget::Ping {
                    seq: u32::from(pick),
                },
            );
        }
        s.push(script::BURST);
        let mut wire = Vec::new();
        mirror.produce_burst(&mut |f: &[u8]| wire.extend_from_slice(f));
        deliver(&mut *target, &wire);
        for n in 0..2u32 {
            let _ = target.submit(
                VirtualChannel::ALL[n as usize],
                &TargetToHost::FrameDone {
                    frame: u32::from(round) * 2 + n,
                    next_wakeup: None,
                },
            );
        }
        let mut answer = Vec::new();
        target.produce_burst(&mut |f: &[u8]| answer.extend_from_slice(f));
        push_raw(&mut s, &answer);
        delivered += deliver(&mut *mirror, &answer);
    }
    // A frame whose payload arrives behind a correct CRC: a RoundEnd of a round long gone.
    let stale = postcard::to_stdvec(&LinkFrame::<TargetToHost>::RoundEnd { round: 1 }).unwrap();
    s.extend([script::PAYLOAD, stale.len() as u8]);
    s.extend(stale);
    let run = fsw_bridge_fuzz::run_link_script(&s);
    assert_eq!(
        run.delivered.iter().sum::<u32>() as usize,
        delivered,
        "host-rounds"
    );
    assert!(delivered > 0, "host-rounds delivers nothing");
    seeds.push(("host-rounds".into(), s));
    seeds
}

/// Every shipped task network compiled, and the flyby of `autonomy::scenarios`.
fn shipped_networks(scenarios: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let dir = scenarios.join("tasknets");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("tasknets")
        .map(|e| e.expect("entry").path())
        .collect();
    files.sort();
    for path in files {
        let net = hil::tasknet::compile_file(&path).expect("a shipped network compiles");
        let stem = path.file_stem().unwrap().to_string_lossy();
        out.push((format!("{stem}.uplink"), net.uplink));
    }
    let doc = hil::tasknet::compile_str(DOC_EXAMPLE, "doc-example.toml").expect("compiles");
    out.push(("doc-example.uplink".into(), doc.uplink));
    let flyby = autonomy::scenarios::flyby_network().expect("valid");
    let mut buf = vec![0u8; 1 << 16];
    let len = flyby.encode(&mut buf).expect("fits");
    out.push(("scenarios-flyby.uplink".into(), buf[..len].to_vec()));
    out
}

/// postcard bytes of `value`.
fn bytes(value: &impl serde::Serialize) -> Vec<u8> {
    postcard::to_stdvec(value).expect("encodes")
}

/// The uplink of `spec` with task `edited`'s bytes replaced by `task_bytes`, or with the task
/// count replaced by `task_count` (its bytes then stop after the count).
fn uplink_with(spec: &NetworkSpec, edited: Option<(usize, Vec<u8>)>) -> Vec<u8> {
    let mut out = bytes(&spec.header);
    out.extend(bytes(&(spec.timelines.len() as u16)));
    for t in &spec.timelines {
        out.extend(bytes(t));
    }
    out.extend(bytes(&(spec.conditions.len() as u16)));
    for c in &spec.conditions {
        out.extend(bytes(c));
    }
    out.extend(bytes(&(spec.tasks.len() as u16)));
    for (i, t) in spec.tasks.iter().enumerate() {
        match &edited {
            Some((j, b)) if *j == i => out.extend(b),
            _ => out.extend(bytes(t)),
        }
    }
    out.extend(bytes(&(spec.temporal.len() as u16)));
    for tc in &spec.temporal {
        out.extend(bytes(tc));
    }
    out
}

/// A task's bytes with its lists given as plain vectors (over the capacities if need be):
/// postcard writes a struct as its fields in order, and any list as its length and items.
fn task_bytes(
    t: &TaskSpec,
    name: &str,
    args: Vec<i32>,
    constraints: Vec<ConstraintSpec>,
    impacts: Vec<autonomy::ImpactSpec>,
    contingencies: Vec<autonomy::Contingency>,
    may_add: Vec<u16>,
) -> Vec<u8> {
    let command = t
        .command
        .as_ref()
        .map(|c| (c.opcode, args, c.from_instance.to_vec()));
    let mut out = bytes(&(t.id, name, t.priority, t.role, command));
    out.extend(bytes(&(
        t.duration_us,
        t.min_duration_us,
        t.earliest_start,
        t.latest_start,
        t.latest_end,
    )));
    out.extend(bytes(&(constraints, impacts, &t.control, contingencies)));
    out.extend(bytes(&(
        t.permissions.may_move,
        t.permissions.may_delete,
        may_add,
    )));
    out
}

/// A task's name and lists, as plain vectors: name, command arguments, constraints, impacts,
/// contingencies, templates it may add.
type TaskLists = (
    String,
    Vec<i32>,
    Vec<ConstraintSpec>,
    Vec<autonomy::ImpactSpec>,
    Vec<autonomy::Contingency>,
    Vec<u16>,
);

/// The flyby refused for each capacity a list or name can exceed.
fn capacity_variants(spec: &NetworkSpec) -> Vec<(String, Vec<u8>)> {
    let flyby = 2; // "Instrument Flyby": constraints, impacts, contingencies, may_add
    let t = &spec.tasks[flyby];
    let base = |t: &TaskSpec| {
        (
            t.name.to_string(),
            t.command
                .as_ref()
                .map(|c| c.args.to_vec())
                .unwrap_or_default(),
            t.constraints.to_vec(),
            t.impacts.to_vec(),
            t.contingencies.to_vec(),
            t.permissions.may_add.to_vec(),
        )
    };
    let variant = |edit: &dyn Fn(&mut TaskLists)| {
        let mut parts = base(t);
        edit(&mut parts);
        let (name, args, c, i, k, p) = parts;
        uplink_with(spec, Some((flyby, task_bytes(t, &name, args, c, i, k, p))))
    };
    let mut out = vec![
        (
            "too-many-constraints.uplink".to_string(),
            variant(&|p| {
                let c = p.2[0];
                p.2.resize(MAX_CONSTRAINTS_PER_TASK + 1, c);
            }),
        ),
        (
            "too-many-impacts.uplink".into(),
            variant(&|p| {
                let i = p.3[0];
                p.3.resize(MAX_IMPACTS_PER_TASK + 1, i);
            }),
        ),
        (
            "too-many-contingencies.uplink".into(),
            variant(&|p| {
                let k = p.4[0];
                p.4.extend([k; 4]);
            }),
        ),
        (
            "too-many-permissions.uplink".into(),
            variant(&|p| {
                let m = p.5[0];
                p.5.extend([m; 3]);
            }),
        ),
        (
            "too-many-command-args.uplink".into(),
            variant(&|p| p.1 = vec![1, 2, 3, 4, 5]),
        ),
        (
            "name-too-long.uplink".into(),
            variant(&|p| p.0 = "x".repeat(33)),
        ),
    ];
    // One task more than MAX_TASKS announced (a u16 count: postcard's varint).
    let mut few = spec.clone();
    few.tasks.clear();
    few.temporal.clear();
    let mut b = uplink_with(&few, None);
    b.truncate(b.len() - 2);
    b.extend(bytes(&(MAX_TASKS as u16 + 1)));
    out.push(("too-many-tasks.uplink".into(), b));
    // A condition of nine terms.
    let mut cond = spec.clone();
    let term = autonomy::CondNode::Term {
        operand: autonomy::Operand::Timeline(0),
        op: autonomy::RelOp::Ne,
        value: 3,
    };
    cond.conditions
        .push(autonomy::ConditionSpec::default())
        .unwrap();
    let mut b = uplink_with(&cond, None);
    let empty = bytes(&autonomy::ConditionSpec::default());
    let at = {
        let mut prefix = bytes(&cond.header);
        prefix.extend(bytes(&(cond.timelines.len() as u16)));
        for t in &cond.timelines {
            prefix.extend(bytes(t));
        }
        prefix.extend(bytes(&1u16));
        prefix.len()
    };
    assert_eq!(b[at..at + empty.len()], empty[..]);
    let nine = bytes(&vec![term; MAX_CONDITION_TERMS + 1]);
    b.splice(at..at + empty.len(), nine);
    out.push(("too-many-condition-terms.uplink".into(), b));
    for (name, b) in &out {
        let e = autonomy::TaskNetwork::validate_uplink(b).expect_err(name);
        println!("  {name}: {:?} at {:?}", e.code, e.site);
    }
    out
}

/// What the flight application received during one shipped mission on the native target.
/// The native target's own end of the link is not reachable from outside, so the recording
/// runs a copy of it (a target endpoint, reset at every boot) on the same bytes: what the copy
/// delivers is what the application was handed, in that order (a FARM's deliveries depend
/// only on the frames that arrive).
struct Recording {
    inner: NativeTarget,
    link: Box<TargetEndpoint>,
    decoder: FrameDecoder,
    ops: Vec<Op>,
}

fn target_endpoint() -> Box<TargetEndpoint> {
    Box::new(TargetEndpoint::new(Role::Responder, LinkConfig::DEFAULT).expect("valid"))
}

impl Recording {
    fn record(&mut self, wire: &[Vec<u8>]) {
        for &b in wire.iter().flatten() {
            let Some(frame) = self.decoder.push::<LinkFrame<HostToTarget>>(b) else {
                continue;
            };
            match self.link.on_frame(frame, |_| true) {
                Received::Delivered { msg, .. } | Received::Expedited(msg) => {
                    self.ops.push(Op::Message(msg))
                }
                _ => {}
            }
        }
    }
}

impl MissionTarget for Recording {
    fn describe(&self) -> String {
        self.inner.describe()
    }
    fn counts_cycles(&self) -> bool {
        false
    }
    fn provision_key(&mut self, key: &sdls::Key) -> Result<(), TargetError> {
        self.inner.provision_key(key)
    }
    fn boot(&mut self) -> Result<Hello, TargetError> {
        self.link = target_endpoint();
        self.decoder = FrameDecoder::new();
        self.inner.boot()
    }
    fn round(&mut self, wire: &[Vec<u8>], round: u32) -> Result<Vec<Vec<u8>>, TargetError> {
        self.record(wire);
        let answer = self.inner.round(wire, round)?;
        self.link.produce_burst(&mut |_: &[u8]| {});
        Ok(answer)
    }
    fn warm_reset(&mut self, at: MissionTimeUs) -> Result<ResetLanding, TargetError> {
        let landing = self.inner.warm_reset(at)?;
        assert_eq!(
            landing,
            ResetLanding::Now,
            "the native target resets at once"
        );
        self.ops.push(Op::WarmReset);
        Ok(landing)
    }
    fn power_cycle(&mut self) -> Result<(), TargetError> {
        self.ops.push(Op::PowerCycle);
        self.inner.power_cycle()
    }
    fn observe(&mut self, msg: &TargetToHost) {
        self.inner.observe(msg)
    }
    fn take_logs(&mut self) -> Vec<hil::defmt_log::LogLine> {
        self.inner.take_logs()
    }
    fn arm_mid_frame_reset(&mut self, seed: u64) {
        self.inner.arm_mid_frame_reset(seed)
    }
    fn reset_notes(&self) -> Vec<String> {
        self.inner.reset_notes()
    }
}

/// Every shipped mission flown on the native target, as (name, operations).
fn recorded_missions(scenarios: &Path) -> Vec<(String, Vec<Op>)> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(scenarios)
        .expect("scenarios")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    let mut out = Vec::new();
    for path in files {
        let Ok(plan) = hil::mission::runner::prepare(&path) else {
            continue; // a link check, not a mission
        };
        let mut target = Recording {
            inner: NativeTarget::new(),
            link: target_endpoint(),
            decoder: FrameDecoder::new(),
            ops: Vec::new(),
        };
        let report = hil::mission::runner::run(&plan, &mut target, None, &mut |_, _, _| {})
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let _ = report;
        let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
        out.push((stem, target.ops));
    }
    out
}

fn message_seeds(missions: &[(String, Vec<Op>)]) -> Vec<(String, Vec<u8>)> {
    let mut out: Vec<(String, Vec<u8>)> = missions
        .iter()
        .map(|(name, ops)| (format!("{name}.ops"), encode_ops(ops)))
        .collect();
    let (_, nominal) = missions
        .iter()
        .find(|(n, _)| n == "flyby-nominal")
        .expect("the nominal flyby is shipped");
    let is_grant = |op: &Op| matches!(op, Op::Message(HostToTarget::TimeGrant { .. }));
    // Time going backwards: the grants of the second half in reverse order.
    let mut backwards = nominal.clone();
    let grants: Vec<usize> = (0..backwards.len())
        .filter(|&i| is_grant(&backwards[i]))
        .collect();
    let half = &grants[grants.len() / 2..];
    let reversed: Vec<Op> = half.iter().rev().map(|&i| backwards[i].clone()).collect();
    for (&i, op) in half.iter().zip(reversed) {
        backwards[i] = op;
    }
    out.push(("time-backwards.ops".into(), encode_ops(&backwards)));
    // Every grant twice (the host lost a FrameDone).
    let repeated: Vec<Op> = nominal
        .iter()
        .flat_map(|op| {
            let n = if is_grant(op) { 2 } else { 1 };
            std::iter::repeat_n(op.clone(), n)
        })
        .collect();
    out.push(("grants-repeated.ops".into(), encode_ops(&repeated)));
    // A warm reset in the middle of the uplink, then the uplink again and the mission.
    let first_grant = nominal.iter().position(is_grant).expect("a grant");
    let mut mid_uplink = nominal[..first_grant / 2].to_vec();
    mid_uplink.push(Op::WarmReset);
    mid_uplink.extend(nominal.iter().cloned());
    out.push(("reset-mid-uplink.ops".into(), encode_ops(&mid_uplink)));
    // A power cycle after every fifth grant.
    let mut cycles = Vec::new();
    for (n, op) in nominal.iter().enumerate() {
        cycles.push(op.clone());
        if is_grant(op) && n % 5 == 0 {
            cycles.push(Op::PowerCycle);
        }
    }
    out.push(("power-cycles.ops".into(), encode_ops(&cycles)));
    out
}

/// Checkpoints of the recorded missions: each partition's newest record in the warm-restart
/// area after every eighth grant (the flight application's own checkpoints, restored by the
/// harness), the executive's and the planner's.
type Seeds = Vec<(String, Vec<u8>)>;
fn partition_checkpoint_seeds(missions: &[(String, Vec<Op>)]) -> (Seeds, Seeds) {
    let (mut executive, mut planner) = (Vec::new(), Vec::new());
    for (name, ops) in missions {
        let mut harness = Harness::new();
        let mut grants = 0;
        for op in ops {
            harness.apply(op);
            if matches!(op, Op::Message(HostToTarget::TimeGrant { .. })) {
                grants += 1;
                if grants % 8 == 3 {
                    let seed = format!("{name}-frame{grants:03}");
                    if let Some(payload) = harness.warm_checkpoint() {
                        executive.push((seed.clone(), payload.to_vec()));
                    }
                    if let Some(payload) = harness.planner_checkpoint() {
                        planner.push((seed, payload.to_vec()));
                    }
                }
            }
        }
    }
    (executive, planner)
}

/// Records what the single-core autonomy core dispatches.
#[derive(Default)]
struct Dispatched(Vec<u32>);

impl autonomy::Outputs for Dispatched {
    fn dispatch(&mut self, id: u32, _: autonomy::Opcode, _: &autonomy::CommandArgs) {
        self.0.push(id);
    }
    fn telemetry(&mut self, _: autonomy::TelemetryEvent) {}
}

/// Checkpoints of the single-core autonomy core (its own format, which the `checkpoint` target
/// restores): each shipped network loaded and flown natively for 24 steps, every measured
/// timeline published (the first value of its type), every command answered (every fifth one
/// failed), a checkpoint after every third step.
fn core_checkpoint_seeds(networks: &[(String, Vec<u8>)]) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut buf = vec![0u8; 1 << 20];
    for (name, image) in networks {
        let mut network = autonomy::TaskNetwork::EMPTY;
        if autonomy::uplink::decode_into(&mut network, image).is_err() {
            continue;
        }
        let mut core = Box::new(autonomy::Autonomy::new());
        let mut now = network
            .tasks()
            .iter()
            .map(|t| t.earliest_start)
            .min()
            .unwrap_or(autonomy::MissionTimeUs::ZERO);
        core.load_network(network).expect("a new core loads a valid network");
        let mut pending: Vec<u32> = Vec::new();
        let mut answered = 0usize;
        let stem = name.trim_end_matches(".uplink");
        for step in 0..24 {
            let measured: Vec<_> = core.network().measured_timelines().collect();
            for (_, key, kind) in measured {
                let value = match kind {
                    autonomy::MeasuredValueType::Enum { .. } => autonomy::StateValue::Enum(0),
                    autonomy::MeasuredValueType::Int => autonomy::StateValue::Int(0),
                };
                core.on_state_update(key, value, now);
            }
            for id in pending.drain(..) {
                answered += 1;
                let status = if answered % 5 == 0 {
                    autonomy::CommandStatus::Failed(7)
                } else {
                    autonomy::CommandStatus::Ok
                };
                core.on_command_response(id, status);
            }
            let mut dispatched = Dispatched::default();
            core.step(
                now,
                autonomy::StepBudget {
                    planner_checks: 2_000,
                },
                &mut dispatched,
            );
            pending = dispatched.0;
            if step % 3 == 2 {
                let len = core.encode_state(&mut buf).expect("a checkpoint fits 1 MiB");
                out.push((format!("{stem}-step{step:02}"), buf[..len].to_vec()));
            }
            let next = core
                .next_wakeup()
                .unwrap_or(now.saturating_add(60_000_000));
            now = next.max(now.saturating_add(1));
        }
    }
    out
}

/// The shipped networks as chunked uplinks ([`flight_app_fuzz::uplink_chunks`]'s layout,
/// secured by the harness): whole, in 128-byte and 7-byte chunks, and with a duplicate, a
/// loss, a swap, a reset, a grant and a flipped bit; and one sent unsecured.
fn chunk_seeds(networks: &[(String, Vec<u8>)]) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for (name, image) in networks {
        let stem = name.trim_end_matches(".uplink");
        let with = |size: u8, script: &[u8]| {
            let mut b = (image.len() as u16).to_be_bytes().to_vec();
            b.push(size);
            b.extend(image);
            b.extend(script);
            b
        };
        out.push((format!("{stem}-127.chunks"), with(127, &[])));
        out.push((format!("{stem}-7.chunks"), with(6, &[])));
        if stem == "flyby" {
            out.push((format!("{stem}-duplicate.chunks"), with(99, &[0, 3])));
            out.push((format!("{stem}-loss.chunks"), with(99, &[1, 2])));
            out.push((format!("{stem}-swap.chunks"), with(99, &[2, 1])));
            out.push((format!("{stem}-reset.chunks"), with(99, &[5, 4])));
            out.push((format!("{stem}-grant.chunks"), with(99, &[4, 2])));
            out.push((format!("{stem}-flipped.chunks"), with(99, &[8, 5])));
            out.push((
                format!("{stem}-unsecured.chunks"),
                with(127 | flight_app_fuzz::RAW_IMAGE, &[]),
            ));
        }
    }
    out
}

/// Every verdict of the security checks, one after the other, on the flyby network: uplinks
/// and ground commands secured by the harness (fresh, replayed, with a hold out of range, an
/// invalid image with a fresh number), raw ones forged, truncated, too long and under
/// another key, the counter's memory failing, and all that across a warm reset and a power
/// cycle with the executive busy.
fn security_seeds(networks: &[(String, Vec<u8>)]) -> Vec<(String, Vec<u8>)> {
    let (_, flyby) = networks
        .iter()
        .find(|(n, _)| n == "flyby.uplink")
        .expect("the flyby network is shipped");
    let uplink = |step: i32| Op::SecuredUplink {
        image: flyby.clone(),
        chunk: 127,
        step,
    };
    let command = |command: GroundCommand, step: i32| Op::SecuredCommand { command, step };
    let chunks = |secured: &[u8]| -> Vec<Op> {
        let pieces: Vec<&[u8]> = secured.chunks(UPLINK_CHUNK_MAX).collect();
        pieces
            .iter()
            .enumerate()
            .map(|(seq, bytes)| {
                Op::Message(HostToTarget::UplinkChunk {
                    seq: seq as u16,
                    total: pieces.len() as u16,
                    bytes: heapless::Vec::from_slice(bytes).unwrap(),
                })
            })
            .collect()
    };
    let grant = |frame: u32, minutes: u64| {
        let now = MissionTimeUs::from_mins(minutes);
        Op::Message(HostToTarget::TimeGrant {
            frame,
            now,
            until: now.saturating_add(60_000_000),
        })
    };
    let fresh = 1_000; // above every number the seed accepts before it
    let mut forged = flight_app_fuzz::secure_uplink(fresh, flyby);
    forged[20] ^= 0x01;
    let good = flight_app_fuzz::secure_uplink(fresh, flyby);
    let truncated = &good[..good.len() - 1];
    let mut long = good.clone();
    long.push(0);
    let mut other_spi = vec![0u8; flyby.len() + sdls::uplink::OVERHEAD];
    let other = sdls::Key {
        spi: flight_app_fuzz::KEY.spi + 1,
        ..flight_app_fuzz::KEY
    };
    sdls::uplink::sign_into(&other, fresh, flyby, &mut other_spi).unwrap();
    let raw_command = |edit: &dyn Fn(&mut HostToTarget)| {
        let mut msg = flight_app_fuzz::secure_command(fresh, GroundCommand::NoOp);
        edit(&mut msg);
        Op::Message(msg)
    };
    let mut ops = vec![uplink(1), grant(0, 590)];
    ops.extend([
        command(GroundCommand::NoOp, 1),
        command(GroundCommand::SetHold(3), 1),
        command(GroundCommand::SetHold(40), 1),
        command(GroundCommand::ReleaseHold(3), 0),
        uplink(0),
        uplink(-2),
    ]);
    ops.extend(chunks(&forged));
    ops.extend(chunks(truncated));
    ops.extend(chunks(&long));
    ops.extend(chunks(&other_spi));
    ops.extend([
        raw_command(&|m| {
            if let HostToTarget::GroundCommand { mac, .. } = m {
                mac[0] ^= 0x80;
            }
        }),
        raw_command(&|m| {
            if let HostToTarget::GroundCommand { mac, .. } = m {
                mac.truncate(20);
            }
        }),
        raw_command(&|m| {
            if let HostToTarget::GroundCommand { header, .. } = m {
                header.spi = 7;
            }
        }),
        Op::SecurityWritesFail(true),
        uplink(1),
        command(GroundCommand::SetHold(1), 1),
        Op::SecurityWritesFail(false),
        Op::SecuredUplink {
            image: flyby[..flyby.len() - 3].to_vec(),
            chunk: 60,
            step: 1,
        },
        Op::WarmReset,
        uplink(0),
    ]);
    // Fly into the flyby's tasks, then uplink again while the executive owns them (busy), and
    // once more after a power cycle.
    for (frame, minutes) in (591..=640).step_by(5).enumerate() {
        ops.push(grant(frame as u32 + 1, minutes));
    }
    ops.extend([uplink(1), command(GroundCommand::ReleaseHold(3), 1)]);
    ops.extend([Op::PowerCycle, uplink(0), uplink(1), grant(20, 645)]);
    let mut harness = Harness::new();
    for op in &ops {
        harness.apply(op);
    }
    println!("  security verdicts: {:?}", harness.verdicts());
    // The number space ends: once u32::MAX is accepted every number is a replay (0 after the
    // wrap included) until a new key is provisioned.
    let wrap = vec![
        uplink(1),
        command(GroundCommand::NoOp, -2),
        uplink(1),
        command(GroundCommand::SetHold(0), 1),
    ];
    vec![
        ("security-verdicts.ops".into(), encode_ops(&ops)),
        ("security-sequence-end.ops".into(), encode_ops(&wrap)),
    ]
}

/// The rover mission's checkpoint as resets left it (`flight_app_fuzz::rover_checkpoint`):
/// sahara-day and field-trial flown natively, a reset injected in an event (before a plan,
/// with a plan flying, after a replan), the memories it keeps captured.
fn rover_checkpoint_seeds() -> Vec<(String, Vec<u8>)> {
    use flight_app::rover_mission::checkpoint::RoverCheckpoint;
    use hil::rover::{run_file, Backend, ResetAt};
    use std::sync::Mutex;
    static CAPTURED: Mutex<Option<Vec<u8>>> = Mutex::new(None);
    fn capture(cp: &mut RoverCheckpoint, task: &mut [u8]) {
        // The newest state record names where the mission's task is (payload words 5 and 6).
        let i = usize::from(cp.state[1][2] > cp.state[0][2]);
        let end = (cp.state[i][4 + 5] + cp.state[i][4 + 6]) as usize;
        *CAPTURED.lock().unwrap() = Some(flight_app_fuzz::encode_rover_checkpoint(
            &task[..end.min(task.len())],
            cp,
        ));
    }
    let mut seeds = Vec::new();
    for (name, events) in [("sahara-day", [1usize, 3, 10, 30, 60]), ("field-trial", [2, 5, 20, 40, 50])] {
        for event in events {
            let mut backend = Backend::native();
            backend.reset_at(ResetAt {
                event,
                after: 1,
                planner_ticks: 0,
                damage: Some(capture),
            });
            let path = hil::repo_root().join(format!("scenarios/rover/{name}.toml"));
            run_file(&path, None, &mut backend).expect("the mission resumes");
            // A reset armed past the run's last event does not land.
            if let Some(bytes) = CAPTURED.lock().unwrap().take() {
                seeds.push((format!("{name}-event{event:03}"), bytes));
            }
        }
    }
    seeds
}

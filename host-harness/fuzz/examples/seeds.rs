//! Writes the seed corpora of every fuzz target (a few dozen small files each, committed):
//!
//! * `fsw-bridge/fuzz/seeds/frame_decoder`: one frame of every message kind of both
//!   directions, and streams of frames with garbage and a corrupted frame between them;
//! * `firmware/autonomy/fuzz/seeds/uplink`: the shipped task networks compiled by
//!   `hil::tasknet`, the flyby of `autonomy::scenarios`, and variants refused for each
//!   capacity (five constraints, a name of 33 bytes, 33 tasks, ...);
//! * `firmware/autonomy/fuzz/seeds/checkpoint`: checkpoints of the shipped missions flown on
//!   the native target (resets, power cycles, failing commands, link faults), one every few
//!   frames;
//! * `firmware/flight-app/fuzz/seeds/messages`: the host messages, resets and power cycles of
//!   each shipped mission, as the flight application received them, and a few variants (time
//!   going backwards, grants repeated, a reset in the middle of the uplink);
//! * `firmware/flight-app/fuzz/seeds/uplink_chunks`: the shipped networks as chunked uplinks,
//!   whole and with defects;
//! * `host-harness/fuzz/seeds/{scenario_toml,tasknet_toml}`: the shipped scenario and task
//!   network files.
//!
//! Run from anywhere in the checkout: `cargo run --manifest-path host-harness/fuzz/Cargo.toml
//! --example seeds`. Regression seeds (files named `regression-*`) are kept; everything else in
//! the seed folders is rewritten.
#[path = "../../../firmware/flight-app/fuzz/src/lib.rs"]
#[allow(dead_code)]
mod flight_app_fuzz;

use std::path::{Path, PathBuf};

use autonomy::{ConstraintSpec, NetworkSpec, TaskSpec, MAX_CONDITION_TERMS};
use flight_app_fuzz::{encode_ops, Harness, Op};
use fsw_bridge::codec::{encode, FrameDecoder, MAX_FRAME_LEN};
use fsw_bridge::messages::UPLINK_CHUNK_MAX;
use fsw_bridge::*;
use hil::mission::target::{MissionTarget, NativeTarget, TargetError};
use hil::session::Hello;

fn main() {
    let root = hil::repo_root();
    let scenarios = root.join("scenarios");
    let networks = shipped_networks(&scenarios);
    let missions = recorded_missions(&scenarios);

    let frame_seeds = frame_decoder_seeds();
    write(
        &root.join("fsw-bridge/fuzz/seeds/frame_decoder"),
        &frame_seeds,
    );

    let mut uplinks: Vec<(String, Vec<u8>)> = networks.clone();
    uplinks.extend(capacity_variants(
        &autonomy::scenarios::flyby_spec().expect("fits"),
    ));
    write(&root.join("firmware/autonomy/fuzz/seeds/uplink"), &uplinks);

    write(
        &root.join("firmware/autonomy/fuzz/seeds/checkpoint"),
        &checkpoint_seeds(&missions),
    );
    write(
        &root.join("firmware/flight-app/fuzz/seeds/messages"),
        &message_seeds(&missions),
    );
    write(
        &root.join("firmware/flight-app/fuzz/seeds/uplink_chunks"),
        &chunk_seeds(&networks),
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

fn frame_decoder_seeds() -> Vec<(String, Vec<u8>)> {
    let args: CommandArgs = heapless::Vec::from_slice(&[1, -2, 3]).unwrap();
    let now = MissionTimeUs::from_mins(600);
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
    ];
    let to_host = [
        TargetToHost::Hello {
            protocol_version: PROTOCOL_VERSION,
            build_id: *b"native\0\0",
            reset_cause: ResetCause::Warm,
            boot_count: 2,
        },
        TargetToHost::Pong {
            seq: 7,
            link: LinkCounters::default(),
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
        TargetToHost::UplinkAck { seq: 8 },
        TargetToHost::UplinkNak { seq: 8, reason: 12 },
        TargetToHost::Panic {
            file: heapless::Vec::from_slice(b"src/kernel/mod.rs").unwrap(),
            line: 42,
        },
    ];
    let mut seeds = Vec::new();
    for (i, m) in to_target.iter().enumerate() {
        seeds.push((format!("to-target-{i}"), frame(m)));
    }
    for (i, m) in to_host.iter().enumerate() {
        seeds.push((format!("to-host-{i}"), frame(m)));
    }
    // Several frames in one stream, with garbage and a corrupted frame between them.
    let mut stream = frame(&to_host[6]);
    stream.extend([0x13, 0x37, 0xff]); // garbage between frames
    stream.extend(frame(&to_target[1]));
    let mut corrupted = frame(&to_target[2]);
    corrupted[3] ^= 0x10;
    stream.extend(corrupted);
    stream.extend(frame(&to_host[2]));
    seeds.push(("stream".into(), stream));
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
    let command = t.command.as_ref().map(|c| (c.opcode, args));
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
    let variant = |edit: &dyn Fn(
        &mut (
            String,
            Vec<i32>,
            Vec<ConstraintSpec>,
            Vec<autonomy::ImpactSpec>,
            Vec<autonomy::Contingency>,
            Vec<u16>,
        ),
    )| {
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
                p.2.extend([c; 3]);
            }),
        ),
        (
            "too-many-impacts.uplink".into(),
            variant(&|p| {
                let i = p.3[0];
                p.3.extend([i, i, i]);
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
    // 33 tasks announced.
    let mut few = spec.clone();
    few.tasks.clear();
    few.temporal.clear();
    let mut b = uplink_with(&few, None);
    b.truncate(b.len() - 2);
    b.push(33);
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
struct Recording {
    inner: NativeTarget,
    decoder: FrameDecoder,
    ops: Vec<Op>,
}

impl Recording {
    fn record(&mut self, frames: &[Vec<u8>]) {
        for &b in frames.iter().flatten() {
            if let Some(Ok(msg)) = self.decoder.push::<HostToTarget>(b) {
                self.ops.push(Op::Message(msg));
            }
        }
    }
}

impl MissionTarget for Recording {
    fn describe(&self) -> String {
        self.inner.describe()
    }
    fn boot(&mut self) -> Result<Hello, TargetError> {
        self.decoder = FrameDecoder::new();
        self.inner.boot()
    }
    fn exchange(
        &mut self,
        frames: &[Vec<u8>],
        frame: u32,
    ) -> Result<Vec<TargetToHost>, TargetError> {
        self.record(frames);
        self.inner.exchange(frames, frame)
    }
    fn exchange_until(
        &mut self,
        frames: &[Vec<u8>],
        until: &dyn Fn(&TargetToHost) -> bool,
    ) -> Result<Vec<TargetToHost>, TargetError> {
        self.record(frames);
        self.inner.exchange_until(frames, until)
    }
    fn warm_reset(&mut self) -> Result<(), TargetError> {
        self.ops.push(Op::WarmReset);
        self.inner.warm_reset()
    }
    fn power_cycle(&mut self) -> Result<(), TargetError> {
        self.ops.push(Op::PowerCycle);
        self.inner.power_cycle()
    }
    fn take_logs(&mut self) -> Vec<hil::defmt_log::LogLine> {
        self.inner.take_logs()
    }
    fn counts_cycles(&self) -> bool {
        false
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
            decoder: FrameDecoder::new(),
            ops: Vec::new(),
        };
        hil::mission::runner::run(&plan, &mut target, None, &mut |_, _, _| {})
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
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

/// Checkpoints of the recorded missions: the warm-restart area's newest record after every
/// fourth grant (the flight application's own checkpoints, restored by the harness).
fn checkpoint_seeds(missions: &[(String, Vec<Op>)]) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for (name, ops) in missions {
        let mut harness = Harness::new();
        let mut grants = 0;
        for op in ops {
            harness.apply(op);
            if matches!(op, Op::Message(HostToTarget::TimeGrant { .. })) {
                grants += 1;
                if grants % 8 == 3 {
                    let payload = harness.warm_checkpoint().expect("a frame checkpoints");
                    out.push((format!("{name}-frame{grants:03}"), payload.to_vec()));
                }
            }
        }
    }
    out
}

/// The shipped networks as chunked uplinks ([`flight_app_fuzz::uplink_chunks`]'s layout):
/// whole, in 128-byte and 7-byte chunks, and with a duplicate, a loss, a swap and a reset.
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
        }
    }
    out
}

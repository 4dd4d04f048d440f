//! Fuzz target logic for the flight application, in plain functions shared by the libFuzzer
//! wrappers (`fuzz_targets/`) and the bounded run on stable
//! (`firmware/flight-app/tests/fuzz_bounded.rs`).
//!
//! Both targets drive a [`Harness`]: a [`FlightApp`] with a warm-restart area and
//! non-volatile memory, fed [`Op`]s (a decoded host message, a warm reset, a power cycle),
//! checking after each one:
//! * a time grant is answered by exactly one `FrameDone`, for that frame, last;
//! * every uplink chunk gets the answers of [`UplinkModel`] (the transfer protocol written
//!   out as a specification), and a completed transfer loads exactly the network its bytes
//!   validate to, or is refused with the validator's code, or as busy;
//! * every checkpoint written restores, and restores to the same bytes;
//! * a boot restores the newest record of either memory (every record is one the application
//!   wrote, so every one validates), or comes up cold when there is none.
//!
//! * [`messages`]: any sequence of host messages and resets (postcard-encoded [`Op`]s back to
//!   back): time going backwards, grants repeated or out of order, arbitrary command
//!   responses, state updates of any key and type, uplink chunks, resets at any point.
//! * [`uplink_chunks`]: an uplink image cut into chunks and delivered with a script of
//!   defects (duplicates, losses, reordering, wrong totals, resets and grants in between).
//!
//! Seeds are in `seeds/<target>/`: the message sequences of the shipped scenarios flown on the
//! native target, and the shipped networks as chunked uplinks (regenerate them with
//! `cargo run --manifest-path host-harness/fuzz/Cargo.toml --example seeds`).
use autonomy::checkpoint::records;
use autonomy::{Autonomy, TaskNetwork, TaskRole};
use flight_app::{uplink_reason, BootOutcome, FlightApp, Memories, NoClock, MAX_UPLINK_BYTES};
use fsw_bridge::messages::UPLINK_CHUNK_MAX;
use fsw_bridge::{HostToTarget, MissionTimeUs, TargetToHost};
use serde::{Deserialize, Serialize};

#[path = "../../../../fsw-bridge/fuzz/src/bounded.rs"]
pub mod bounded;

/// The targets of this crate, by name.
pub const TARGETS: &[bounded::Target] = &[("messages", messages), ("uplink_chunks", uplink_chunks)];

/// Bytes of the warm-restart area in the harness (a checkpoint slot is half): small enough
/// that a large fuzzed network overflows it now and then (a failed checkpoint write) while
/// non-volatile memory still takes it.
pub const WARM_BYTES: usize = 16 * 1024;
/// Bytes of non-volatile memory in the harness.
pub const NV_BYTES: usize = 64 * 1024;
/// Most operations one input is cut to (keeps one input's run time bounded).
pub const MAX_OPS: usize = 1_000;

/// One thing that happens to the flight application.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Op {
    /// A message from the host, as the link decoded it.
    Message(HostToTarget),
    /// A warm reset: RAM is lost, both memories are kept; the application boots.
    WarmReset,
    /// A power cycle: RAM and the warm-restart area are lost; the application boots.
    PowerCycle,
}

/// `data` as operations: postcard-encoded [`Op`]s back to back, up to the first that does not
/// decode (at most [`MAX_OPS`]).
pub fn decode_ops(data: &[u8]) -> Vec<Op> {
    let mut ops = Vec::new();
    let mut rest = data;
    while ops.len() < MAX_OPS {
        match postcard::take_from_bytes::<Op>(rest) {
            Ok((op, more)) => {
                ops.push(op);
                rest = more;
            }
            Err(_) => break,
        }
    }
    ops
}

/// The input [`decode_ops`] reads back as `ops`.
pub fn encode_ops(ops: &[Op]) -> Vec<u8> {
    let mut out = Vec::new();
    for op in ops {
        out.extend(postcard::to_allocvec(op).expect("an op encodes"));
    }
    out
}

/// Any sequence of host messages and resets.
pub fn messages(data: &[u8]) {
    let mut harness = Harness::new();
    for op in decode_ops(data) {
        harness.apply(&op);
    }
}

/// An uplink image cut into chunks and delivered with a script of defects. Layout: image
/// length (2 bytes, big-endian), chunk size (1 byte: 1 + b % 128), the image, then the
/// script, two bytes per defect (see [`chunk_ops`]). A grant follows the last chunk, so a
/// network that loads is flown for a frame and checkpointed.
pub fn uplink_chunks(data: &[u8]) {
    let mut harness = Harness::new();
    for op in chunk_ops(data) {
        harness.apply(&op);
    }
}

/// The operations [`uplink_chunks`] performs for `data`.
pub fn chunk_ops(data: &[u8]) -> Vec<Op> {
    let [hi, lo, size, rest @ ..] = data else {
        return Vec::new();
    };
    let image_len = usize::from(u16::from_be_bytes([*hi, *lo])).min(rest.len());
    let chunk = 1 + usize::from(*size) % UPLINK_CHUNK_MAX;
    let (image, script) = rest.split_at(image_len);
    let pieces: Vec<&[u8]> = if image.is_empty() {
        vec![&[]]
    } else {
        image.chunks(chunk).collect()
    };
    let total = u16::try_from(pieces.len()).unwrap_or(u16::MAX);
    let mut ops: Vec<Op> = pieces
        .iter()
        .enumerate()
        .map(|(seq, bytes)| {
            Op::Message(HostToTarget::UplinkChunk {
                seq: u16::try_from(seq).unwrap_or(u16::MAX),
                total,
                bytes: heapless::Vec::from_slice(bytes).expect("a chunk fits"),
            })
        })
        .collect();
    for (n, defect) in script.chunks(2).take(64).enumerate() {
        let [kind, arg] = defect else { break };
        let i = usize::from(*arg) % ops.len();
        match kind % 8 {
            0 => {
                let again = ops[i].clone();
                ops.insert(i, again);
            }
            1 if ops.len() > 1 => {
                ops.remove(i);
            }
            2 if i + 1 < ops.len() => ops.swap(i, i + 1),
            3 => {
                if let Op::Message(HostToTarget::UplinkChunk { total, .. }) = &mut ops[i] {
                    *total = total.wrapping_add(1);
                }
            }
            4 => ops.insert(i, grant(n as u32, 0)),
            5 => ops.insert(i, Op::WarmReset),
            6 => {
                if let Op::Message(HostToTarget::UplinkChunk { seq, .. }) = &mut ops[i] {
                    *seq = u16::from(*arg);
                }
            }
            _ => {
                if let Op::Message(HostToTarget::UplinkChunk { bytes, .. }) = &mut ops[i] {
                    bytes.clear();
                }
            }
        }
    }
    ops.push(grant(u32::MAX, 1));
    ops
}

/// A grant for `frame` at 9:50 plus `minutes` (the shipped networks' morning).
fn grant(frame: u32, minutes: u64) -> Op {
    let now = MissionTimeUs::from_mins(590 + minutes);
    Op::Message(HostToTarget::TimeGrant {
        frame,
        now,
        until: now.saturating_add(60_000_000),
    })
}

/// The uplink transfer protocol written out as a specification: what the application must
/// answer to each chunk.
#[derive(Debug, Default)]
pub struct UplinkModel {
    transfer: Option<Transfer>,
}

#[derive(Debug)]
struct Transfer {
    next: u16,
    total: u16,
    image: Vec<u8>,
}

/// What one chunk must bring.
#[derive(Debug, PartialEq, Eq)]
pub enum ChunkAnswer {
    /// `UplinkNak { seq, reason }` and nothing else.
    Nak(u16),
    /// `UplinkAck { seq }` and nothing else.
    Ack,
    /// `UplinkAck { seq }`, then the whole image is loaded or refused.
    Complete(Vec<u8>),
}

impl UplinkModel {
    /// The answer to chunk `seq` of `total` carrying `bytes`. A chunk 0 starts a new transfer;
    /// any other chunk must be the next one of the transfer in progress, with its total; the
    /// image may not grow past [`MAX_UPLINK_BYTES`]; a refused chunk ends the transfer.
    pub fn answer(&mut self, seq: u16, total: u16, bytes: &[u8]) -> ChunkAnswer {
        if seq == 0 {
            self.transfer = Some(Transfer {
                next: 0,
                total,
                image: Vec::new(),
            });
        }
        let Some(t) = self.transfer.as_mut() else {
            return ChunkAnswer::Nak(uplink_reason::OUT_OF_SEQUENCE);
        };
        let refusal = if total == 0 || total != t.total {
            Some(uplink_reason::BAD_TOTAL)
        } else if seq != t.next {
            Some(uplink_reason::OUT_OF_SEQUENCE)
        } else if t.image.len() + bytes.len() > MAX_UPLINK_BYTES {
            Some(uplink_reason::TOO_LARGE)
        } else {
            None
        };
        if let Some(reason) = refusal {
            self.transfer = None;
            return ChunkAnswer::Nak(reason);
        }
        t.image.extend_from_slice(bytes);
        if u32::from(seq) + 1 < u32::from(total) {
            t.next = seq + 1;
            return ChunkAnswer::Ack;
        }
        let image = std::mem::take(&mut t.image);
        self.transfer = None;
        ChunkAnswer::Complete(image)
    }
}

/// A flight application with its two memories, checked after every operation.
pub struct Harness {
    app: Box<FlightApp>,
    warm: Vec<u8>,
    nv: Vec<u8>,
    model: UplinkModel,
}

impl Default for Harness {
    fn default() -> Self {
        Self::new()
    }
}

impl Harness {
    /// A power-on with both memories empty: cold.
    pub fn new() -> Self {
        let mut h = Self {
            app: Box::new(FlightApp::new()),
            warm: vec![0; WARM_BYTES],
            nv: vec![0; NV_BYTES],
            model: UplinkModel::default(),
        };
        assert_eq!(h.boot(), BootOutcome::Cold);
        h
    }

    /// The application.
    pub fn app(&self) -> &FlightApp {
        &self.app
    }

    /// The payload of the newest checkpoint in the warm-restart area.
    pub fn warm_checkpoint(&self) -> Option<&[u8]> {
        records(&self.warm)[0].map(|r| r.payload)
    }

    /// Performs `op` and checks what the application did.
    pub fn apply(&mut self, op: &Op) {
        match op {
            Op::WarmReset => {
                self.boot();
            }
            Op::PowerCycle => {
                self.warm.fill(0);
                self.boot();
            }
            Op::Message(msg) => self.message(msg),
        }
    }

    /// Boots a fresh application on the memories; it must restore the newest record of
    /// either (all were written by the application and checked to restore).
    fn boot(&mut self) -> BootOutcome {
        let newest = [&self.warm, &self.nv]
            .into_iter()
            .filter_map(|m| records(m)[0].map(|r| r.sequence))
            .reduce(|a, b| {
                if autonomy::checkpoint::is_newer(b, a) {
                    b
                } else {
                    a
                }
            });
        *self.app = FlightApp::new();
        self.model = UplinkModel::default();
        let mut memories = Memories {
            warm: &mut self.warm,
            nv: Some(&mut self.nv),
        };
        let outcome = self.app.boot(&mut memories, &mut NoClock, &mut |_| {});
        match (newest, outcome) {
            (None, BootOutcome::Cold) => {}
            (Some(seq), BootOutcome::RestoredWarm(info) | BootOutcome::RestoredNv(info)) => {
                assert_eq!(info.sequence, seq, "boot did not restore the newest record");
            }
            (newest, outcome) => panic!("newest record {newest:?}, boot {outcome:?}"),
        }
        outcome
    }

    fn message(&mut self, msg: &HostToTarget) {
        let busy = !self.app.autonomy().executive().entries().is_empty();
        let expected = match msg {
            HostToTarget::UplinkChunk { seq, total, bytes } => {
                Some(self.model.answer(*seq, *total, bytes))
            }
            _ => None,
        };
        let mut out = Vec::new();
        let handled = {
            let mut memories = Memories {
                warm: &mut self.warm,
                nv: Some(&mut self.nv),
            };
            self.app
                .handle(msg, &mut memories, &mut NoClock, &mut |m| out.push(m))
        };
        match msg {
            HostToTarget::Ping { .. } | HostToTarget::ResetRequest { .. } => {
                assert!(!handled && out.is_empty(), "{msg:?} is the I/O layer's");
            }
            HostToTarget::StateUpdate { .. } | HostToTarget::CommandResponse { .. } => {
                assert!(handled && out.is_empty(), "{msg:?} answered with {out:?}");
            }
            HostToTarget::TimeGrant { frame, .. } => {
                let done: Vec<_> = out
                    .iter()
                    .filter(|m| matches!(m, TargetToHost::FrameDone { .. }))
                    .collect();
                assert_eq!(done.len(), 1, "one FrameDone per grant: {out:?}");
                assert!(
                    matches!(out.last(), Some(TargetToHost::FrameDone { frame: f, .. }) if f == frame),
                    "the grant's FrameDone comes last: {out:?}"
                );
            }
            HostToTarget::UplinkChunk { seq, total, .. } => {
                let expected = expected.expect("computed for chunks");
                self.check_chunk(*seq, *total, expected, busy, &out);
            }
        }
        self.check_checkpoints();
    }

    fn check_chunk(
        &self,
        seq: u16,
        total: u16,
        expected: ChunkAnswer,
        busy: bool,
        out: &[TargetToHost],
    ) {
        // Checkpoint write failures may be reported between the answers.
        let answers: Vec<&TargetToHost> = out
            .iter()
            .filter(|m| !matches!(m, TargetToHost::Telemetry(_)))
            .collect();
        let image = match expected {
            ChunkAnswer::Nak(reason) => {
                assert_eq!(answers, [&TargetToHost::UplinkNak { seq, reason }]);
                return;
            }
            ChunkAnswer::Ack => {
                assert_eq!(answers, [&TargetToHost::UplinkAck { seq }]);
                return;
            }
            ChunkAnswer::Complete(image) => image,
        };
        let last = match TaskNetwork::validate_uplink(&image) {
            Err(e) => TargetToHost::UplinkNak {
                seq: total,
                reason: e.code.code(),
            },
            Ok(()) if busy => TargetToHost::UplinkNak {
                seq: total,
                reason: uplink_reason::BUSY,
            },
            Ok(()) => {
                let mut network = TaskNetwork::EMPTY;
                autonomy::uplink::decode_into(&mut network, &image).expect("validated");
                assert_eq!(self.app.autonomy().network(), &network, "loaded network");
                let requested = network
                    .tasks()
                    .iter()
                    .filter(|t| t.role == TaskRole::Requested)
                    .count();
                assert_eq!(self.app.autonomy().plan().len(), requested, "a fresh plan");
                TargetToHost::UplinkAck { seq: total }
            }
        };
        assert_eq!(answers, [&TargetToHost::UplinkAck { seq }, &last]);
    }

    /// Every record the last message wrote restores, to the same bytes. Both memories are
    /// written with the same state under the same number; the non-volatile copy is checked
    /// against the warm one, or on its own when the warm write failed.
    fn check_checkpoints(&mut self) {
        let warm = self.app.take_warm_write().is_some();
        let nv = self.app.take_nv_write().is_some();
        if warm && nv {
            let (w, n) = (records(&self.warm)[0], records(&self.nv)[0]);
            let (w, n) = (w.expect("written"), n.expect("written"));
            assert_eq!(w.sequence, n.sequence, "both memories carry one number");
            assert_eq!(w.payload, n.payload, "both memories hold the same checkpoint");
        }
        for (written, memory) in [(warm, &self.warm), (nv && !warm, &self.nv)] {
            if !written {
                continue;
            }
            let record = records(memory)[0].expect("a record was written");
            let mut core = Box::new(Autonomy::new());
            if let Err(e) = core.decode_state(record.payload) {
                panic!("a checkpoint the application wrote is refused: {e:?}");
            }
            let mut again = vec![0u8; record.payload.len()];
            let len = core.encode_state(&mut again).expect("fits as before");
            assert_eq!(&again[..len], record.payload, "restore changed the state");
        }
    }
}

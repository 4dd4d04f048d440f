//! A temporal plan's dispatch network on the checkpointed channel (issue 13 item 3, the
//! executive dispatching the plans): the planner partition sends a plan's network to the
//! executive in CRC'd chunks ([`ExecutiveInput::DispatchChunk`], `temporal::dispatch_wire`),
//! the executive takes them into a `temporal::Dispatcher` it keeps in its state
//! ([`ExecutiveDispatch`], checkpointed with the executive's record), and tells the planner
//! what came of it and which steps it executed ([`PlannerInput::Dispatch`], [`DispatchNote`]:
//! the network held, a chunk refused with its reason, a step executed at a time).
//!
//! Both are variants appended to the channel's messages, so every message the MEXEC planner's
//! protocol had keeps its encoding; the checkpoints changed (the executive's dispatch part, the
//! planner's notes), hence `CHECKPOINT_FORMAT` 5.
use super::*;

use temporal::dispatch_wire::{
    chunk, chunk_of, chunks, NetworkChunk, NetworkReceiver, Received, WireRefusal, CHUNK_WORDS,
};
use temporal::{Dispatcher, PlanNetwork};

/// Chunks the planner puts in its outbox per window at most (a full network, 289 chunks,
/// takes 19 windows; the rest of the outbox is kept for the window's commits and status).
pub const MAX_DISPATCH_CHUNKS_PER_WINDOW: usize = 16;
/// Notes from the executive the planner holds until its owner takes them.
pub const MAX_DISPATCH_NOTES: usize = 32;
/// Most chunks of a network the executive takes (2,688 words: 112 of [`CHUNK_WORDS`]), so that
/// its checkpoint part ([`dispatch_part_max_bytes`], 12,845 bytes with every one of
/// `MAX_DISPATCH_STEPS` steps executed) fits a record slot of the executive's warm-restart
/// slice (16 KiB, 16,364 bytes of payload on the target) beside the MEXEC side of the record:
/// with an idle one the record is 12,929 bytes, 3,435 under the slot's payload, which are the
/// MEXEC side's (`flight-app`'s test `dispatch_checkpoint_room` writes it into a slot). A network at the dispatcher's capacity (256
/// steps, 2,048 constraints: 6,915 words, 289 chunks, 27.7 KB of checkpoint) would not fit: it
/// is refused by name, [`ChunkRefusal::TooLarge`], by the sender before any chunk goes
/// ([`DispatchSender::check`]) and by the executive for any chunk of it that comes. Long-day's
/// network, thirty objectives and 71 actions, is 65 chunks.
pub const MAX_CHECKPOINTED_DISPATCH_CHUNKS: u16 = 112;

/// Bytes of the executive's dispatch part at most (see [`ExecutiveDispatch::encode`]): format
/// byte, length, nine header words, the words of [`MAX_CHECKPOINTED_DISPATCH_CHUNKS`] chunks,
/// every step executed (step and time), the CRC.
pub const fn dispatch_part_max_bytes() -> usize {
    1 + 4
        + 4 * (9
            + MAX_CHECKPOINTED_DISPATCH_CHUNKS as usize * CHUNK_WORDS
            + 2 * temporal::dispatch::MAX_DISPATCH_STEPS)
        + 4
}

/// Format of the executive's dispatch part in its checkpoint (see
/// [`ExecutiveDispatch::encode`]).
pub const DISPATCH_PART_FORMAT: u8 = 1;

/// One chunk of a plan's network as the channel carries it (`NetworkChunk`'s fields), encoded
/// as one byte string of [`CHUNK_BYTES`] (big-endian fields: a derived encoding of the 24-word
/// array cost the image 3 KB more, which every warm boot checks).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DispatchChunk {
    pub plan: u32,
    pub index: u16,
    pub total: u16,
    pub len: u16,
    pub words: [u32; CHUNK_WORDS],
    pub crc: u32,
}

impl From<NetworkChunk> for DispatchChunk {
    fn from(c: NetworkChunk) -> Self {
        Self {
            plan: c.plan,
            index: c.index,
            total: c.total,
            len: c.len,
            words: c.words,
            crc: c.crc,
        }
    }
}

impl From<DispatchChunk> for NetworkChunk {
    fn from(c: DispatchChunk) -> Self {
        Self {
            plan: c.plan,
            index: c.index,
            total: c.total,
            len: c.len,
            words: c.words,
            crc: c.crc,
        }
    }
}

/// Why the executive did not take a chunk (`WireRefusal`, on the channel).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChunkRefusal {
    BadCrc,
    OtherPlan {
        receiving: u32,
    },
    OutOfOrder {
        expected: u16,
    },
    BadLength,
    OutOfRange,
    Complete,
    /// The network came whole but has no schedule within its horizon.
    Inconsistent,
    /// The network has more chunks than the executive's checkpoint holds
    /// ([`MAX_CHECKPOINTED_DISPATCH_CHUNKS`]): not taken, the network held stays.
    TooLarge {
        max_chunks: u16,
    },
}

impl From<WireRefusal> for ChunkRefusal {
    fn from(r: WireRefusal) -> Self {
        match r {
            WireRefusal::BadCrc => Self::BadCrc,
            WireRefusal::OtherPlan { receiving } => Self::OtherPlan { receiving },
            WireRefusal::OutOfOrder { expected } => Self::OutOfOrder { expected },
            WireRefusal::BadLength => Self::BadLength,
            WireRefusal::OutOfRange => Self::OutOfRange,
            WireRefusal::Complete => Self::Complete,
        }
    }
}

/// What the executive tells the planner about the plan it dispatches, encoded as one byte
/// string of [`NOTE_BYTES`] (kind, plan, step or index, time or the refusal's argument, the
/// refusal's code; as for [`DispatchChunk`], smaller code than a derived encoding).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DispatchNote {
    /// Plan `plan`'s network is whole in the executive's dispatcher, its windows worked out.
    Loaded { plan: u32 },
    /// Chunk `index` of plan `plan` was not taken (nothing changed).
    Refused {
        plan: u32,
        index: u16,
        reason: ChunkRefusal,
    },
    /// Step `step` of plan `plan` was executed at `at` (ticks since the plan's epoch): a
    /// start the executive dispatched or an action's end it was told of (the planner's replan
    /// state is the happenings applied in order).
    Executed { plan: u32, step: u16, at: u32 },
}

/// Bytes of a chunk's encoding: plan, index, total, length, the words, the CRC.
const CHUNK_BYTES: usize = 4 + 2 + 2 + 2 + 4 * CHUNK_WORDS + 4;
/// Bytes of a note's encoding.
const NOTE_BYTES: usize = 1 + 4 + 4 + 4 + 1;

/// Reads a fixed-length byte string (what `serialize_bytes` wrote) into `T`.
struct FixedBytes<T, const N: usize>(fn(&[u8; N]) -> Option<T>);

impl<'de, T, const N: usize> serde::de::Visitor<'de> for FixedBytes<T, N> {
    type Value = T;

    fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("a dispatch message's bytes")
    }

    fn visit_bytes<E: serde::de::Error>(self, v: &[u8]) -> Result<T, E> {
        let bytes: &[u8; N] = v
            .try_into()
            .map_err(|_| E::invalid_length(v.len(), &self))?;
        (self.0)(bytes).ok_or_else(|| E::custom("a field out of range"))
    }
}

fn be32(b: &[u8], at: usize) -> u32 {
    b.get(at..at + 4)
        .and_then(|w| w.try_into().ok())
        .map(u32::from_be_bytes)
        .unwrap_or(0)
}

fn be16(b: &[u8], at: usize) -> u16 {
    b.get(at..at + 2)
        .and_then(|w| w.try_into().ok())
        .map(u16::from_be_bytes)
        .unwrap_or(0)
}

fn put_be(b: &mut [u8], at: usize, v: &[u8]) {
    if let Some(dst) = b.get_mut(at..at + v.len()) {
        dst.copy_from_slice(v);
    }
}

impl Serialize for DispatchChunk {
    #[inline(never)]
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut b = [0u8; CHUNK_BYTES];
        put_be(&mut b, 0, &self.plan.to_be_bytes());
        put_be(&mut b, 4, &self.index.to_be_bytes());
        put_be(&mut b, 6, &self.total.to_be_bytes());
        put_be(&mut b, 8, &self.len.to_be_bytes());
        for (i, w) in self.words.iter().enumerate() {
            put_be(&mut b, 10 + 4 * i, &w.to_be_bytes());
        }
        put_be(&mut b, CHUNK_BYTES - 4, &self.crc.to_be_bytes());
        s.serialize_bytes(&b)
    }
}

impl<'de> Deserialize<'de> for DispatchChunk {
    #[inline(never)]
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_bytes(FixedBytes::<Self, CHUNK_BYTES>(|b| {
            let mut words = [0u32; CHUNK_WORDS];
            for (i, w) in words.iter_mut().enumerate() {
                *w = be32(b, 10 + 4 * i);
            }
            Some(Self {
                plan: be32(b, 0),
                index: be16(b, 4),
                total: be16(b, 6),
                len: be16(b, 8),
                words,
                crc: be32(b, CHUNK_BYTES - 4),
            })
        }))
    }
}

impl Serialize for DispatchNote {
    #[inline(never)]
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let (kind, plan, a, b, code) = match *self {
            DispatchNote::Loaded { plan } => (0u8, plan, 0, 0, 0),
            DispatchNote::Refused {
                plan,
                index,
                reason,
            } => {
                let (code, arg) = deferred_refusal_code(Some(reason));
                (1, plan, u32::from(index), arg, code as u8)
            }
            DispatchNote::Executed { plan, step, at } => (2, plan, u32::from(step), at, 0),
        };
        let mut bytes = [0u8; NOTE_BYTES];
        bytes[0] = kind;
        put_be(&mut bytes, 1, &plan.to_be_bytes());
        put_be(&mut bytes, 5, &a.to_be_bytes());
        put_be(&mut bytes, 9, &b.to_be_bytes());
        bytes[NOTE_BYTES - 1] = code;
        s.serialize_bytes(&bytes)
    }
}

impl<'de> Deserialize<'de> for DispatchNote {
    #[inline(never)]
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_bytes(FixedBytes::<Self, NOTE_BYTES>(|b| {
            let (plan, a, arg) = (be32(b, 1), be32(b, 5), be32(b, 9));
            let (kind, code) = (b[0], b[NOTE_BYTES - 1]);
            let step = u16::try_from(a).ok()?;
            // What a kind does not use is zero.
            if (kind != 1 && code != 0) || (kind == 0 && (a | arg) != 0) {
                return None;
            }
            Some(match kind {
                0 => DispatchNote::Loaded { plan },
                1 => DispatchNote::Refused {
                    plan,
                    index: step,
                    reason: deferred_refusal_of(u32::from(code), arg)??,
                },
                2 => DispatchNote::Executed {
                    plan,
                    step,
                    at: arg,
                },
                _ => return None,
            })
        }))
    }
}

/// Why [`ExecutiveDispatch::executed`] refused a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExecutedRefusal {
    /// No whole network held.
    NoNetwork,
    /// Not a step of the network, or executed already.
    UnknownStep,
}

/// Why a checkpoint's dispatch part was refused (the executive's record is then refused).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DispatchRestoreError {
    /// Of another format.
    Version { found: u8 },
    /// Its length does not match what it says it holds.
    BadLength,
    /// Its CRC does not match its bytes.
    BadCrc,
    /// Its network's words refused by the receiver (as a received chunk would be).
    Chunk(ChunkRefusal),
    /// An executed step that is no step, or executed twice.
    OutOfRange,
}

/// A receiver that has taken nothing, as a constant: assigned, it calls no code of crate
/// `temporal` (see [`ExecutiveDispatch::active`]).
const EMPTY_RECEIVER: NetworkReceiver = NetworkReceiver::new();

/// The executive's side: the receiver of a network's chunks and the dispatcher it fills.
#[derive(Clone, Debug)]
pub struct ExecutiveDispatch {
    /// A chunk was taken or refused since the last reset. While not, nothing here calls code
    /// of crate `temporal` (in the firmware that code is in the deferred block, checked by the
    /// kernel at a partition's first fetch from it: the MEXEC executive's checkpoints,
    /// restores and resets, which never see a dispatch chunk, must not fetch from it).
    active: bool,
    receiver: NetworkReceiver,
    dispatcher: Dispatcher,
    /// The dispatcher holds the whole network of `receiver.plan()` with its windows.
    loaded: bool,
    /// Chunks refused, and the last reason.
    pub refused: u32,
    pub last_refusal: Option<ChunkRefusal>,
}

impl Default for ExecutiveDispatch {
    fn default() -> Self {
        Self::new()
    }
}

impl ExecutiveDispatch {
    pub const fn new() -> Self {
        Self {
            active: false,
            receiver: EMPTY_RECEIVER,
            dispatcher: Dispatcher::empty(),
            loaded: false,
            refused: 0,
            last_refusal: None,
        }
    }

    /// Makes this what [`ExecutiveDispatch::new`] is, in place (the dispatcher is 30 KB).
    pub fn reset(&mut self) {
        if self.active {
            self.deferred_clear();
        }
        self.active = false;
        self.receiver = EMPTY_RECEIVER;
        self.loaded = false;
        self.refused = 0;
        self.last_refusal = None;
    }

    #[inline(never)]
    fn deferred_clear(&mut self) {
        self.dispatcher.network_mut().clear();
    }

    /// The plan whose network the dispatcher holds whole, and the dispatcher.
    pub fn loaded(&self) -> Option<(u32, &Dispatcher)> {
        self.loaded
            .then(|| (self.receiver.plan(), &self.dispatcher))
    }

    /// The plan being received or held, and (chunks taken, chunks in all).
    pub fn receiving(&self) -> Option<(u32, (u16, u16))> {
        self.receiver
            .receiving()
            .then(|| (self.receiver.plan(), self.receiver.progress()))
    }

    /// Takes chunk `c`; when it makes the network whole, the dispatcher starts on it with every
    /// step by `horizon` (at least the makespan). What the planner should hear comes back: the
    /// network held, or the chunk refused; nothing for a chunk taken with more to come.
    pub fn take(&mut self, c: &DispatchChunk, horizon: u32) -> Option<DispatchNote> {
        self.deferred_take(c, horizon)
    }

    #[inline(never)]
    fn deferred_take(&mut self, c: &DispatchChunk, horizon: u32) -> Option<DispatchNote> {
        self.active = true;
        let chunk = NetworkChunk::from(*c);
        let refused = |this: &mut Self, reason: ChunkRefusal| {
            this.refused = this.refused.saturating_add(1);
            this.last_refusal = Some(reason);
            Some(DispatchNote::Refused {
                plan: c.plan,
                index: c.index,
                reason,
            })
        };
        if c.total > MAX_CHECKPOINTED_DISPATCH_CHUNKS {
            // Its checkpoint would not fit a slot: refused before the receiver sees it, so the
            // network held (or being received) stays.
            return refused(
                self,
                ChunkRefusal::TooLarge {
                    max_chunks: MAX_CHECKPOINTED_DISPATCH_CHUNKS,
                },
            );
        }
        let taken = self.receiver.take(&chunk, self.dispatcher.network_mut());
        if taken.is_ok() && c.index == 0 {
            // A new network: the one held is gone.
            self.loaded = false;
        }
        match taken {
            Err(r) => refused(self, r.into()),
            Ok(Received::More { .. }) => None,
            Ok(Received::Whole) => {
                let horizon = horizon.max(self.dispatcher.network().makespan);
                if self.dispatcher.restart(horizon).is_ok() {
                    self.loaded = true;
                    Some(DispatchNote::Loaded { plan: c.plan })
                } else {
                    // Nothing to dispatch: the planner hears why and plans again.
                    self.receiver = EMPTY_RECEIVER;
                    self.dispatcher.network_mut().clear();
                    refused(self, ChunkRefusal::Inconsistent)
                }
            }
        }
    }

    /// Step `step` of the held network was executed at `at`: the dispatcher marks it, and the
    /// note for the planner comes back.
    pub fn executed(&mut self, step: u16, at: u32) -> Result<DispatchNote, ExecutedRefusal> {
        self.deferred_executed(step, at)
    }

    #[inline(never)]
    fn deferred_executed(&mut self, step: u16, at: u32) -> Result<DispatchNote, ExecutedRefusal> {
        if !self.loaded {
            return Err(ExecutedRefusal::NoNetwork);
        }
        self.dispatcher
            .executed(usize::from(step), at)
            .map_err(|_| ExecutedRefusal::UnknownStep)?;
        Ok(DispatchNote::Executed {
            plan: self.receiver.plan(),
            step,
            at,
        })
    }

    /// The dispatcher, to poll (the executive's decisions).
    pub fn dispatcher_mut(&mut self) -> Option<&mut Dispatcher> {
        self.loaded.then_some(&mut self.dispatcher)
    }

    /// Appends this state to `buf` at `len`: one byte 0 when nothing was ever received or
    /// refused (what every MEXEC checkpoint carries), else `[DISPATCH_PART_FORMAT, length
    /// (u32), body, CRC-32 of the body]`, the body being big-endian words: plan, flags (bit 0
    /// receiving, bit 1 loaded), chunks taken | total << 16, words taken, horizon, refused,
    /// the last refusal (code, argument), the executed steps' count, the words taken, then
    /// each executed step and its time.
    pub fn encode(&self, buf: &mut [u8], len: &mut usize) -> Option<()> {
        if !self.active {
            *buf.get_mut(*len)? = 0;
            *len += 1;
            return Some(());
        }
        self.deferred_encode(buf, len)
    }

    /// [`ExecutiveDispatch::encode`] of an active part. Named `deferred_`: the firmware's
    /// linker script puts this module's `deferred_` functions and its trait impls in the
    /// deferred block (none runs before a dispatch chunk arrives); the paths every MEXEC
    /// checkpoint, restore and reset take stay in the code a warm boot checks.
    #[inline(never)]
    fn deferred_encode(&self, buf: &mut [u8], len: &mut usize) -> Option<()> {
        *buf.get_mut(*len)? = DISPATCH_PART_FORMAT;
        let length_at = *len + 1;
        let body_at = length_at + 4;
        let mut at = body_at;
        let mut put = |w: u32| -> Option<()> {
            buf.get_mut(at..at + 4)?.copy_from_slice(&w.to_be_bytes());
            at += 4;
            Some(())
        };
        let (next, total) = self.receiver.progress();
        let net = self.dispatcher.network();
        let steps = net.step_count();
        let executed = (1..=steps)
            .filter(|&k| self.loaded && self.dispatcher.executed_at(k).is_some())
            .count();
        let (code, arg) = deferred_refusal_code(self.last_refusal);
        put(self.receiver.plan())?;
        put(u32::from(self.receiver.receiving()) | (u32::from(self.loaded) << 1))?;
        put(u32::from(next) | (u32::from(total) << 16))?;
        put(self.receiver.words_taken() as u32)?;
        put(self.dispatcher.horizon())?;
        put(self.refused)?;
        put(code)?;
        put(arg)?;
        put(executed as u32)?;
        for p in 0..self.receiver.words_taken() {
            put(self.receiver.taken_word(net, p))?;
        }
        if self.loaded {
            for k in 1..=steps {
                if let Some(t) = self.dispatcher.executed_at(k) {
                    put(k as u32)?;
                    put(t)?;
                }
            }
        }
        let body_len = at - body_at;
        let crc = CRC32.checksum(buf.get(body_at..at)?);
        buf.get_mut(at..at + 4)?.copy_from_slice(&crc.to_be_bytes());
        buf.get_mut(length_at..body_at)?
            .copy_from_slice(&(body_len as u32).to_be_bytes());
        *len = at + 4;
        Some(())
    }

    /// Replaces this state with the part [`ExecutiveDispatch::encode`] wrote at the start of
    /// `bytes`; the bytes after it. The network's words go through a new receiver again as
    /// chunks (every check a received chunk has), the dispatcher restarts on a whole one and
    /// the executed steps are marked again. Refused with its reason (this is then the empty
    /// state).
    pub fn decode<'a>(&mut self, bytes: &'a [u8]) -> Result<&'a [u8], DispatchRestoreError> {
        if let (Some((&0, rest)), false) = (bytes.split_first(), self.active) {
            // Nothing received (every MEXEC checkpoint), and nothing held here.
            self.receiver = EMPTY_RECEIVER;
            self.loaded = false;
            self.refused = 0;
            self.last_refusal = None;
            return Ok(rest);
        }
        self.deferred_decode(bytes)
    }

    #[inline(never)]
    fn deferred_decode<'a>(&mut self, bytes: &'a [u8]) -> Result<&'a [u8], DispatchRestoreError> {
        self.reset();
        let r = self.deferred_decode_inner(bytes);
        if r.is_err() {
            self.reset();
        }
        r
    }

    fn deferred_decode_inner<'a>(
        &mut self,
        bytes: &'a [u8],
    ) -> Result<&'a [u8], DispatchRestoreError> {
        use DispatchRestoreError as E;
        let (&format, rest) = bytes.split_first().ok_or(E::BadLength)?;
        if format == 0 {
            return Ok(rest);
        }
        if format != DISPATCH_PART_FORMAT {
            return Err(E::Version { found: format });
        }
        self.active = true;
        let body_len = rest
            .get(..4)
            .and_then(|b| b.try_into().ok())
            .map(u32::from_be_bytes)
            .ok_or(E::BadLength)? as usize;
        let body = rest.get(4..4 + body_len).ok_or(E::BadLength)?;
        let crc = rest
            .get(4 + body_len..8 + body_len)
            .and_then(|b| b.try_into().ok())
            .map(u32::from_be_bytes)
            .ok_or(E::BadLength)?;
        let after = rest.get(8 + body_len..).ok_or(E::BadLength)?;
        if CRC32.checksum(body) != crc {
            return Err(E::BadCrc);
        }
        if !body_len.is_multiple_of(4) || body_len < 36 {
            return Err(E::BadLength);
        }
        let word = |i: usize| -> u32 {
            body.get(4 * i..4 * i + 4)
                .and_then(|b| b.try_into().ok())
                .map(u32::from_be_bytes)
                .unwrap_or(0)
        };
        let (plan, flags, progress, taken) = (word(0), word(1), word(2), word(3) as usize);
        let (horizon, refused, code, arg, executed) =
            (word(4), word(5), word(6), word(7), word(8) as usize);
        let (next, total) = ((progress & 0xffff) as u16, (progress >> 16) as u16);
        let (receiving, loaded) = (flags & 1 == 1, flags & 2 == 2);
        if flags > 3
            || (loaded && (!receiving || next != total))
            || (!receiving && (taken != 0 || next != 0))
            || taken > usize::from(next) * CHUNK_WORDS
            || body_len != 4 * (9 + taken + 2 * executed)
            || (!loaded && executed != 0)
        {
            return Err(E::BadLength);
        }
        if total > MAX_CHECKPOINTED_DISPATCH_CHUNKS {
            return Err(E::Chunk(ChunkRefusal::TooLarge {
                max_chunks: MAX_CHECKPOINTED_DISPATCH_CHUNKS,
            }));
        }
        self.refused = refused;
        self.last_refusal = deferred_refusal_of(code, arg).ok_or(E::OutOfRange)?;
        // The words again, chunk by chunk, through the receiver.
        let mut chunk_words = [0u32; CHUNK_WORDS];
        for i in 0..next {
            let from = usize::from(i) * CHUNK_WORDS;
            let n = taken.saturating_sub(from).min(CHUNK_WORDS);
            for (j, w) in chunk_words.iter_mut().take(n).enumerate() {
                *w = word(9 + from + j);
            }
            let c = chunk_of(plan, i, total, chunk_words.get(..n).unwrap_or(&[]));
            self.receiver
                .take(&c, self.dispatcher.network_mut())
                .map_err(|r| E::Chunk(r.into()))?;
        }
        if self.receiver.words_taken() != taken {
            return Err(E::BadLength);
        }
        if loaded {
            self.dispatcher
                .restart(horizon)
                .map_err(|_| E::Chunk(ChunkRefusal::Inconsistent))?;
            self.loaded = true;
            for e in 0..executed {
                let (k, t) = (word(9 + taken + 2 * e), word(10 + taken + 2 * e));
                self.dispatcher
                    .executed(k as usize, t)
                    .map_err(|_| E::OutOfRange)?;
            }
        }
        Ok(after)
    }
}

fn deferred_refusal_code(r: Option<ChunkRefusal>) -> (u32, u32) {
    match r {
        None => (0, 0),
        Some(ChunkRefusal::BadCrc) => (1, 0),
        Some(ChunkRefusal::OtherPlan { receiving }) => (2, receiving),
        Some(ChunkRefusal::OutOfOrder { expected }) => (3, u32::from(expected)),
        Some(ChunkRefusal::BadLength) => (4, 0),
        Some(ChunkRefusal::OutOfRange) => (5, 0),
        Some(ChunkRefusal::Complete) => (6, 0),
        Some(ChunkRefusal::Inconsistent) => (7, 0),
        Some(ChunkRefusal::TooLarge { max_chunks }) => (8, u32::from(max_chunks)),
    }
}

fn deferred_refusal_of(code: u32, arg: u32) -> Option<Option<ChunkRefusal>> {
    Some(match code {
        0 => None,
        1 => Some(ChunkRefusal::BadCrc),
        2 => Some(ChunkRefusal::OtherPlan { receiving: arg }),
        3 => Some(ChunkRefusal::OutOfOrder {
            expected: u16::try_from(arg).ok()?,
        }),
        4 => Some(ChunkRefusal::BadLength),
        5 => Some(ChunkRefusal::OutOfRange),
        6 => Some(ChunkRefusal::Complete),
        7 => Some(ChunkRefusal::Inconsistent),
        8 => Some(ChunkRefusal::TooLarge {
            max_chunks: u16::try_from(arg).ok()?,
        }),
        _ => return None,
    })
}

/// The planner's side of sending a network: which plan, the next chunk. Whoever holds the
/// network keeps this (and checkpoints it with the network).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DispatchSender {
    pub plan: u32,
    pub next: u16,
    pub horizon: u32,
}

impl DispatchSender {
    /// Sending plan `plan`'s network from its first chunk, every step by `horizon`.
    pub fn new(plan: u32, horizon: u32) -> Self {
        Self {
            plan,
            next: 0,
            horizon,
        }
    }

    /// Whether every chunk of `net` was put in the channel (never, for a network
    /// [`DispatchSender::check`] refuses).
    pub fn done(&self, net: &PlanNetwork) -> bool {
        usize::from(self.next) >= chunks(net)
    }

    /// The chunks `net` takes, or [`ChunkRefusal::TooLarge`] when the executive's checkpoint
    /// would not hold it (more than [`MAX_CHECKPOINTED_DISPATCH_CHUNKS`]): such a network is
    /// not sent ([`DispatchSender::pump`] sends none of it).
    pub fn check(net: &PlanNetwork) -> Result<usize, ChunkRefusal> {
        let n = chunks(net);
        if n > usize::from(MAX_CHECKPOINTED_DISPATCH_CHUNKS) {
            return Err(ChunkRefusal::TooLarge {
                max_chunks: MAX_CHECKPOINTED_DISPATCH_CHUNKS,
            });
        }
        Ok(n)
    }

    /// Puts the next chunks of `net` in `planner`'s outbox (at most
    /// [`MAX_DISPATCH_CHUNKS_PER_WINDOW`], leaving room for a window's status); how many (0 for a
    /// network [`DispatchSender::check`] refuses).
    pub fn pump(&mut self, net: &PlanNetwork, planner: &mut PlannerPartition) -> usize {
        if Self::check(net).is_err() {
            return 0;
        }
        let mut sent = 0;
        while sent < MAX_DISPATCH_CHUNKS_PER_WINDOW {
            let Some(c) = chunk(net, self.plan, usize::from(self.next)) else {
                break;
            };
            if !planner.send_dispatch_chunk(&c, self.horizon) {
                break;
            }
            self.next = self.next.saturating_add(1);
            sent += 1;
        }
        sent
    }
}

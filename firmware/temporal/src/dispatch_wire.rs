//! A plan's dispatch network carried in chunks (issue 13 item 3, the executive dispatching:
//! the first of what the move takes, the network sent from the planner partition to the
//! executive over a channel of bounded messages), and the executed happenings carried back.
//!
//! The network is the word sequence the rover checkpoint's plan record holds: `[makespan,
//! steps, constraints, each step (action | end << 16, window lo, window hi), each constraint
//! (before | after << 16, lb, ub)]`, at most [`network_words`] of a full network (6,915
//! words, in 289 chunks). [`chunk`] cuts chunk `index` of it (at most [`CHUNK_WORDS`] words) without a
//! buffer of the whole; [`NetworkReceiver`] takes the chunks in order into a [`PlanNetwork`],
//! each checked (its plan's generation, its index, its length, its CRC-32) and every field
//! checked against the capacities; a chunk it cannot take is refused with its reason
//! ([`WireRefusal`]) and changes nothing, so the sender may send it again.
//!
//! `no_std`, heap-free, never a panic on what comes in.
#![deny(clippy::indexing_slicing)]

use crate::constraints::Constraint;
use crate::dispatch::{PlanNetwork, PlanStep, MAX_DISPATCH_CONSTRAINTS, MAX_DISPATCH_STEPS};

/// Words of a chunk's payload at most: 24 words, 96 bytes, the size of the channel's chunks
/// of a task network's image (`autonomy::partitioned::NETWORK_CHUNK_BYTES`), so a chunk's
/// message is no larger than the channel's largest message now (the outboxes hold their
/// capacity of the largest message).
pub const CHUNK_WORDS: usize = 24;

/// The words of `net`'s sequence.
pub fn network_words(net: &PlanNetwork) -> usize {
    3 + 3 * net.step_count() + 3 * net.constraints().len()
}

/// Word `p` of `net`'s sequence (0 past its end).
fn word(net: &PlanNetwork, p: usize) -> u32 {
    let steps = net.step_count();
    let cs = net.constraints();
    match p {
        0 => net.makespan,
        1 => steps as u32,
        2 => cs.len() as u32,
        _ => {
            let q = p - 3;
            if q < 3 * steps {
                let Some(s) = net.step(q / 3 + 1) else {
                    return 0;
                };
                match q % 3 {
                    0 => u32::from(s.action) | (u32::from(s.end) << 16),
                    1 => s.window.0,
                    _ => s.window.1,
                }
            } else {
                let r = q - 3 * steps;
                let Some(c) = cs.get(r / 3) else {
                    return 0;
                };
                match r % 3 {
                    0 => u32::from(c.before) | (u32::from(c.after) << 16),
                    1 => c.lb,
                    _ => c.ub,
                }
            }
        }
    }
}

/// One chunk of a plan's network on the channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NetworkChunk {
    /// The plan's generation (the planner's count of plans): a chunk of another plan is refused.
    pub plan: u32,
    /// This chunk's index, from 0, and how many chunks the network takes.
    pub index: u16,
    pub total: u16,
    /// Its payload: `len` words of `words`.
    pub len: u16,
    pub words: [u32; CHUNK_WORDS],
    /// CRC-32 of (plan, index, total, len, the payload), big-endian bytes.
    pub crc: u32,
}

impl NetworkChunk {
    /// The CRC this chunk should carry.
    pub fn expected_crc(&self) -> u32 {
        let mut c = Crc::new();
        c.word(self.plan);
        c.word(u32::from(self.index) | (u32::from(self.total) << 16));
        c.word(u32::from(self.len));
        for &w in self.words.get(..usize::from(self.len)).unwrap_or(&[]) {
            c.word(w);
        }
        c.finish()
    }
}

/// How many chunks `net` takes.
pub fn chunks(net: &PlanNetwork) -> usize {
    network_words(net).div_ceil(CHUNK_WORDS)
}

/// Chunk `index` of `net` (plan generation `plan`); None past the last.
pub fn chunk(net: &PlanNetwork, plan: u32, index: usize) -> Option<NetworkChunk> {
    let total = chunks(net);
    if index >= total {
        return None;
    }
    let from = index * CHUNK_WORDS;
    let len = (network_words(net) - from).min(CHUNK_WORDS);
    let mut words = [0u32; CHUNK_WORDS];
    for (i, w) in words.iter_mut().take(len).enumerate() {
        *w = word(net, from + i);
    }
    let mut c = NetworkChunk {
        plan,
        index: index as u16,
        total: total as u16,
        len: len as u16,
        words,
        crc: 0,
    };
    c.crc = c.expected_crc();
    Some(c)
}

/// Chunk `index` of `total` of plan `plan` carrying `payload` (at most [`CHUNK_WORDS`]
/// words; more are cut), with its CRC: how a restore sends a checkpoint's words through a
/// receiver again.
pub fn chunk_of(plan: u32, index: u16, total: u16, payload: &[u32]) -> NetworkChunk {
    let mut words = [0u32; CHUNK_WORDS];
    let len = payload.len().min(CHUNK_WORDS);
    for (w, &p) in words.iter_mut().zip(payload) {
        *w = p;
    }
    let mut c = NetworkChunk {
        plan,
        index,
        total,
        len: len as u16,
        words,
        crc: 0,
    };
    c.crc = c.expected_crc();
    c
}

/// Why a chunk was not taken (nothing changed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WireRefusal {
    /// Its CRC does not match what it carries.
    BadCrc,
    /// A chunk of a plan other than the one being received.
    OtherPlan { receiving: u32 },
    /// Not the chunk expected next.
    OutOfOrder { expected: u16 },
    /// Its length or its total does not match the network's.
    BadLength,
    /// A field beyond a capacity or naming what the network does not have.
    OutOfRange,
    /// Every chunk was taken already.
    Complete,
}

/// What taking a chunk left.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Received {
    /// More chunks to come: the next one's index.
    More { next: u16 },
    /// The network is whole.
    Whole,
}

/// Takes a network's chunks in order into a [`PlanNetwork`] (see the module's documentation).
#[derive(Clone, Copy, Debug, Default)]
pub struct NetworkReceiver {
    receiving: bool,
    plan: u32,
    next: u16,
    total: u16,
    /// Words taken so far, and the sequence's length once its header is in.
    at: usize,
    words: usize,
    steps: usize,
    constraints: usize,
    /// The words of the step or constraint being read.
    pending: [u32; 3],
}

impl NetworkReceiver {
    pub const fn new() -> Self {
        Self {
            receiving: false,
            plan: 0,
            next: 0,
            total: 0,
            at: 0,
            words: 0,
            steps: 0,
            constraints: 0,
            pending: [0; 3],
        }
    }

    /// Take `c` into `net`: the first chunk (index 0) of any plan begins a network anew
    /// (clearing `net`); the others must follow in order. On a refusal nothing changes (the
    /// receiver's state nor `net`, but for a first chunk's refusal after `net` was cleared:
    /// then the receiver holds no network).
    pub fn take(
        &mut self,
        c: &NetworkChunk,
        net: &mut PlanNetwork,
    ) -> Result<Received, WireRefusal> {
        if c.crc != c.expected_crc() {
            return Err(WireRefusal::BadCrc);
        }
        let len = usize::from(c.len);
        if len == 0 || len > CHUNK_WORDS || c.total == 0 || c.index >= c.total {
            return Err(WireRefusal::BadLength);
        }
        let payload = c.words.get(..len).ok_or(WireRefusal::BadLength)?;
        if c.index != 0 {
            if !self.receiving {
                return Err(WireRefusal::OutOfOrder { expected: 0 });
            }
            if c.plan != self.plan {
                return Err(WireRefusal::OtherPlan {
                    receiving: self.plan,
                });
            }
            if self.next >= self.total {
                return Err(WireRefusal::Complete);
            }
            if c.index != self.next {
                return Err(WireRefusal::OutOfOrder {
                    expected: self.next,
                });
            }
            if c.total != self.total {
                return Err(WireRefusal::BadLength);
            }
        }
        // Check the chunk whole on a copy before anything changes.
        let mut probe = *self;
        if c.index == 0 {
            probe = Self::new();
            let (Some(&steps), Some(&constraints)) = (payload.get(1), payload.get(2)) else {
                return Err(WireRefusal::BadLength);
            };
            let (steps, constraints) = (steps as usize, constraints as usize);
            if steps > MAX_DISPATCH_STEPS || constraints > MAX_DISPATCH_CONSTRAINTS {
                return Err(WireRefusal::OutOfRange);
            }
            probe.words = 3 + 3 * steps + 3 * constraints;
            probe.steps = steps;
            probe.constraints = constraints;
            if usize::from(c.total) != probe.words.div_ceil(CHUNK_WORDS) {
                return Err(WireRefusal::BadLength);
            }
            probe.receiving = true;
            probe.plan = c.plan;
            probe.total = c.total;
        }
        let last = c.index + 1 == probe.total;
        let expected = if last {
            probe.words - usize::from(c.index) * CHUNK_WORDS
        } else {
            CHUNK_WORDS
        };
        if len != expected {
            return Err(WireRefusal::BadLength);
        }
        // Fields checked on the probe without writing; then written.
        for write in [false, true] {
            let mut r = probe;
            if write && c.index == 0 {
                net.clear();
            }
            for &w in payload {
                r.word(w, if write { Some(&mut *net) } else { None })?;
            }
            r.next = c.index + 1;
            if write {
                *self = r;
            }
        }
        Ok(if self.next == self.total {
            Received::Whole
        } else {
            Received::More { next: self.next }
        })
    }

    /// Whether a network is being received or held (a first chunk was taken).
    pub fn receiving(&self) -> bool {
        self.receiving
    }

    /// The plan's generation of the network received or held.
    pub fn plan(&self) -> u32 {
        self.plan
    }

    /// Chunks taken, and how many the network takes.
    pub fn progress(&self) -> (u16, u16) {
        (self.next, self.total)
    }

    /// Whether the whole network was taken.
    pub fn whole(&self) -> bool {
        self.receiving && self.next == self.total
    }

    /// Words taken so far (the chunks' payloads, in order).
    pub fn words_taken(&self) -> usize {
        self.at
    }

    /// Word `p` of the sequence taken so far into `net` (0 past what was taken): with
    /// [`NetworkReceiver::words_taken`], what a checkpoint of a network being received keeps,
    /// to send through a new receiver again at a restore (so a restored network passes every
    /// check a received one does).
    pub fn taken_word(&self, net: &PlanNetwork, p: usize) -> u32 {
        if p >= self.at {
            return 0;
        }
        match p {
            0 => return net.makespan,
            1 => return self.steps as u32,
            2 => return self.constraints as u32,
            _ => {}
        }
        let q = p - 3;
        // The item (step or constraint) being read when `at` stopped is in `pending`.
        let partial_from = 3 + (self.at - 3) / 3 * 3;
        if p >= partial_from {
            return self.pending.get(q % 3).copied().unwrap_or(0);
        }
        if q < 3 * self.steps {
            let Some(s) = net.step(q / 3 + 1) else {
                return 0;
            };
            match q % 3 {
                0 => u32::from(s.action) | (u32::from(s.end) << 16),
                1 => s.window.0,
                _ => s.window.1,
            }
        } else {
            let Some(c) = net.constraints().get((q - 3 * self.steps) / 3) else {
                return 0;
            };
            match q % 3 {
                0 => u32::from(c.before) | (u32::from(c.after) << 16),
                1 => c.lb,
                _ => c.ub,
            }
        }
    }

    /// Word `w` at position `self.at`, into `net` if given (else only checked).
    fn word(&mut self, w: u32, net: Option<&mut PlanNetwork>) -> Result<(), WireRefusal> {
        let p = self.at;
        self.at += 1;
        if p < 3 {
            if p == 0 {
                if let Some(net) = net {
                    net.makespan = w;
                }
            }
            return Ok(());
        }
        let q = p - 3;
        let i = q % 3;
        if let Some(slot) = self.pending.get_mut(i) {
            *slot = w;
        }
        if i != 2 {
            return Ok(());
        }
        let [a, b, c] = self.pending;
        if q < 3 * self.steps {
            let (action, end) = (a & 0xffff, a >> 16);
            if end > 1 {
                return Err(WireRefusal::OutOfRange);
            }
            if let Some(net) = net {
                net.add_step(PlanStep {
                    action: action as u16,
                    end: end == 1,
                    window: (b, c),
                })
                .map_err(|_| WireRefusal::OutOfRange)?;
            }
        } else {
            let (before, after) = ((a & 0xffff) as usize, (a >> 16) as usize);
            if before > self.steps || after > self.steps {
                return Err(WireRefusal::OutOfRange);
            }
            if let Some(net) = net {
                net.add_constraint(Constraint {
                    before: before as u16,
                    after: after as u16,
                    lb: b,
                    ub: c,
                })
                .map_err(|_| WireRefusal::OutOfRange)?;
            }
        }
        Ok(())
    }
}

/// A step the executive executed (a start it dispatched, or an action's end it was told of),
/// carried back to the planner partition for the replan state: the plan's generation, the
/// step, and when (ticks since the plan's epoch).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Happening {
    pub plan: u32,
    pub step: u16,
    pub at: u32,
}

/// CRC-32 (IEEE, reflected) over big-endian words, bit by bit (chunks are small).
struct Crc(u32);

impl Crc {
    const fn new() -> Self {
        Self(0xffff_ffff)
    }
    fn word(&mut self, w: u32) {
        for byte in w.to_be_bytes() {
            self.0 ^= u32::from(byte);
            for _ in 0..8 {
                let mask = (self.0 & 1).wrapping_neg();
                self.0 = (self.0 >> 1) ^ (0xedb8_8320 & mask);
            }
        }
    }
    fn finish(&self) -> u32 {
        !self.0
    }
}

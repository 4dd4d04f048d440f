//! Deterministic link faults: whether a frame is dropped, duplicated or delayed by a round, and
//! which of its bytes are corrupted, as a pure function of (seed, direction, frame identity,
//! transmission attempt, byte index). No state and no sequence of random draws: the same frame
//! sent the same n-th time meets the same fate whatever else crossed the link, so the host's
//! fault injector and the tests' `link::channel::LossyChannel` (which use exactly
//! these functions) inject the same faults into the Mission channel on the native and the
//! emulated target, and a retransmission (another attempt) meets an independent fate.
//!
//! The hash is SplitMix64's finaliser applied to each field in turn. Probabilities are integer
//! parts per million, so no floating point is involved in a decision.
//!
//! What must never be passed through these functions: the target's Hello (exempt by content,
//! the caller checks). RoundEnd frames are exempt here: [`frame_fate`] always delivers them and
//! [`byte_fault`] never corrupts them.
use crate::link::frame::{Directive, LinkFrame, VirtualChannel};

/// One million: probabilities are in parts per million.
pub const PPM: u32 = 1_000_000;

/// Which way a frame travels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Direction {
    /// Host to target.
    Uplink,
    /// Target to host.
    Downlink,
}

impl Direction {
    const fn word(self) -> u64 {
        match self {
            Direction::Uplink => 0x55,
            Direction::Downlink => 0xdd,
        }
    }
}

/// What identifies a frame for fault decisions, independent of its bytes: an AD frame by its
/// channel and N(S) (so a retransmission is the same frame, another attempt), any other frame by
/// its round and its place among the frames of its kind in that burst.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum FrameIdentity {
    Ad {
        vc: VirtualChannel,
        ns: u8,
    },
    /// The `index`-th BD frame of the burst of `round`.
    Bd {
        round: u32,
        index: u16,
    },
    /// The directive of `vc` in the burst of `round` (`set_vr`: Set V(R), else Unlock).
    Bc {
        round: u32,
        vc: VirtualChannel,
        set_vr: bool,
    },
    /// The `copy`-th Report of the burst of `round`.
    Report {
        round: u32,
        copy: u16,
    },
    RoundEnd {
        round: u32,
    },
}

impl FrameIdentity {
    /// The identity of `frame`, sent in the burst of `round` as the `index_of_kind`-th frame of
    /// its kind in that burst (counting from 0; only used for BD and Report frames).
    pub fn of<M>(frame: &LinkFrame<M>, round: u32, index_of_kind: u16) -> Self {
        match frame {
            LinkFrame::Ad { vc, ns, .. } => FrameIdentity::Ad { vc: *vc, ns: *ns },
            LinkFrame::Bd(_) => FrameIdentity::Bd {
                round,
                index: index_of_kind,
            },
            LinkFrame::Bc { round, directive } => FrameIdentity::Bc {
                round: *round,
                vc: directive.vc(),
                set_vr: matches!(directive, Directive::SetVr { .. }),
            },
            LinkFrame::Report(_) => FrameIdentity::Report {
                round,
                copy: index_of_kind,
            },
            LinkFrame::RoundEnd { round } => FrameIdentity::RoundEnd { round: *round },
        }
    }

    fn words(self) -> [u64; 3] {
        match self {
            FrameIdentity::Ad { vc, ns } => [1, vc.index() as u64, u64::from(ns)],
            FrameIdentity::Bd { round, index } => [2, u64::from(round), u64::from(index)],
            FrameIdentity::Bc { round, vc, set_vr } => [
                3,
                u64::from(round),
                (vc.index() as u64) << 1 | u64::from(set_vr),
            ],
            FrameIdentity::Report { round, copy } => [4, u64::from(round), u64::from(copy)],
            FrameIdentity::RoundEnd { round } => [5, u64::from(round), 0],
        }
    }
}

/// Everything a fault decision depends on, except the byte index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FaultKey {
    /// The scenario's (or test's) seed.
    pub seed: u64,
    pub direction: Direction,
    pub frame: FrameIdentity,
    /// How many times this identity crossed the link in this direction before (0 for the first
    /// transmission).
    pub attempt: u32,
}

/// Fault probabilities, in parts per million. `drop + duplicate + delay` must not exceed
/// [`PPM`] (one draw decides among them).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct FaultRates {
    /// Per byte between the delimiters: one bit of it flipped.
    pub corrupt_byte_ppm: u32,
    /// Per frame: not delivered.
    pub drop_ppm: u32,
    /// Per frame: delivered twice in a row.
    pub duplicate_ppm: u32,
    /// Per frame: held back and delivered at the start of the next burst in the same direction.
    pub delay_ppm: u32,
}

impl FaultRates {
    /// No faults.
    pub const NONE: Self = Self {
        corrupt_byte_ppm: 0,
        drop_ppm: 0,
        duplicate_ppm: 0,
        delay_ppm: 0,
    };

    /// From probabilities in 0..=1 (rounded to the nearest part per million; out-of-range
    /// values are clamped).
    pub fn from_probabilities(corrupt_byte: f64, drop: f64, duplicate: f64, delay: f64) -> Self {
        fn ppm(p: f64) -> u32 {
            let p = if p.is_nan() { 0.0 } else { p.clamp(0.0, 1.0) };
            (p * f64::from(PPM) + 0.5) as u32
        }
        Self {
            corrupt_byte_ppm: ppm(corrupt_byte),
            drop_ppm: ppm(drop),
            duplicate_ppm: ppm(duplicate),
            delay_ppm: ppm(delay),
        }
    }

    /// Every rate is a probability and the frame fates add up to at most one.
    pub fn is_valid(&self) -> bool {
        self.corrupt_byte_ppm <= PPM
            && u64::from(self.drop_ppm) + u64::from(self.duplicate_ppm) + u64::from(self.delay_ppm)
                <= u64::from(PPM)
    }

    /// Any fault at all.
    pub fn any(&self) -> bool {
        self.corrupt_byte_ppm > 0
            || self.drop_ppm > 0
            || self.duplicate_ppm > 0
            || self.delay_ppm > 0
    }
}

/// What happens to a frame as a whole.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FrameFate {
    Deliver,
    Drop,
    Duplicate,
    /// Delivered at the start of the next burst in the same direction.
    Delay,
}

/// SplitMix64's output function.
const fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Decision kinds, so that a frame's fate and its bytes' corruption are independent draws.
const SALT_FRAME_FATE: u64 = 0xf7a7e;
const SALT_BYTE: u64 = 0xb17e;

/// The hash of `key` for one decision.
fn hash(key: &FaultKey, salt: u64, index: u64) -> u64 {
    let [kind, a, b] = key.frame.words();
    let mut h = mix(key.seed);
    for word in [
        key.direction.word(),
        kind,
        a,
        b,
        u64::from(key.attempt),
        salt,
        index,
    ] {
        h = mix(h ^ word);
    }
    h
}

/// A uniform draw in 0..PPM from a hash (multiply-shift: no modulo bias).
fn draw_ppm(h: u64) -> u32 {
    (((h >> 32) * u64::from(PPM)) >> 32) as u32
}

/// The fate of the frame `key` names.
pub fn frame_fate(rates: &FaultRates, key: &FaultKey) -> FrameFate {
    if matches!(key.frame, FrameIdentity::RoundEnd { .. }) {
        return FrameFate::Deliver;
    }
    let draw = draw_ppm(hash(key, SALT_FRAME_FATE, 0));
    let drop = rates.drop_ppm;
    let duplicate = drop.saturating_add(rates.duplicate_ppm);
    let delay = duplicate.saturating_add(rates.delay_ppm);
    if draw < drop {
        FrameFate::Drop
    } else if draw < duplicate {
        FrameFate::Duplicate
    } else if draw < delay {
        FrameFate::Delay
    } else {
        FrameFate::Deliver
    }
}

/// Whether byte `byte_index` of the encoded frame (counting the leading delimiter as 0) is
/// corrupted, and if so the XOR mask (one bit) that corrupts it. The delimiters themselves are
/// the caller's to leave alone ([`corrupt_frame`] does).
pub fn byte_fault(rates: &FaultRates, key: &FaultKey, byte_index: usize) -> Option<u8> {
    if matches!(key.frame, FrameIdentity::RoundEnd { .. }) || rates.corrupt_byte_ppm == 0 {
        return None;
    }
    let h = hash(key, SALT_BYTE, byte_index as u64);
    (draw_ppm(h) < rates.corrupt_byte_ppm).then(|| 1u8 << (h & 7))
}

/// Corrupt the bytes of one encoded frame (`0x00, stuffed bytes, 0x00`) between its delimiters
/// as [`byte_fault`] says; returns how many bytes changed.
pub fn corrupt_frame(rates: &FaultRates, key: &FaultKey, frame: &mut [u8]) -> usize {
    let mut changed = 0;
    let inner = frame.len().saturating_sub(1);
    for (i, byte) in frame.iter_mut().enumerate().take(inner).skip(1) {
        if let Some(mask) = byte_fault(rates, key, i) {
            *byte ^= mask;
            changed += 1;
        }
    }
    changed
}

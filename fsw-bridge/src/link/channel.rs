//! A lossy channel for tests and for the host's fault injector (`std` feature): carries whole
//! bursts of encoded frames one way and applies the deterministic faults of
//! [`crate::link::faults`] to them. It counts how many times each frame identity crossed in each
//! direction (the attempt number), holds delayed frames until the next burst in the same
//! direction, and never touches RoundEnd or an exempt Type-BD frame (the target's Hello).
use std::collections::HashMap;
use std::vec::Vec;

use crate::codec::{FrameDecoder, WireMessage};
use crate::link::faults::{
    corrupt_frame, frame_fate, Direction, FaultKey, FaultRates, FrameFate, FrameIdentity,
};
use crate::link::frame::{FrameKind, LinkFrame};

/// Faults injected in one direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct InjectedFaults {
    /// Frames with at least one corrupted byte.
    pub corrupted_frames: u64,
    pub corrupted_bytes: u64,
    pub dropped: u64,
    pub duplicated: u64,
    pub delayed: u64,
    /// Frames carried (each burst's frames, before faults).
    pub frames_offered: u64,
}

impl InjectedFaults {
    /// Frames that met any fault.
    pub fn total(&self) -> u64 {
        self.corrupted_frames + self.dropped + self.duplicated + self.delayed
    }
}

/// The seeded lossy channel, both directions.
#[derive(Clone, Debug)]
pub struct LossyChannel {
    seed: u64,
    rates: FaultRates,
    attempts: HashMap<(Direction, FrameIdentity), u32>,
    /// Frames held back, per direction (Uplink, Downlink).
    delayed: [Vec<Vec<u8>>; 2],
    injected: [InjectedFaults; 2],
}

fn slot(direction: Direction) -> usize {
    match direction {
        Direction::Uplink => 0,
        Direction::Downlink => 1,
    }
}

impl LossyChannel {
    /// A channel injecting `rates` from `seed`. Panics if the rates are not valid
    /// ([`FaultRates::is_valid`]): a test or scenario error.
    pub fn new(seed: u64, rates: FaultRates) -> Self {
        assert!(rates.is_valid(), "fault rates out of range: {rates:?}");
        Self {
            seed,
            rates,
            attempts: HashMap::new(),
            delayed: [Vec::new(), Vec::new()],
            injected: [InjectedFaults::default(); 2],
        }
    }

    pub fn rates(&self) -> &FaultRates {
        &self.rates
    }

    /// Faults injected so far in `direction`.
    pub fn injected(&self, direction: Direction) -> &InjectedFaults {
        &self.injected[slot(direction)]
    }

    /// Carry one burst: `frames` are whole encoded frames as the sender wrote them for `round`
    /// (RoundEnd last). Returns what the receiver gets, in order: the frames held back from the
    /// previous burst in this direction, then this burst's frames after their faults.
    /// `exempt(msg)` says which Type-BD messages are never damaged (the target's Hello). Frames
    /// that do not decode as `LinkFrame<M>` pass unchanged (the sender's garbage is its own).
    pub fn carry<M: WireMessage>(
        &mut self,
        direction: Direction,
        round: u32,
        frames: &[Vec<u8>],
        exempt: impl Fn(&M) -> bool,
    ) -> Vec<Vec<u8>> {
        let d = slot(direction);
        let mut out = core::mem::take(&mut self.delayed[d]);
        let mut bd_index: u16 = 0;
        let mut report_index: u16 = 0;
        for bytes in frames {
            self.injected[d].frames_offered += 1;
            let Some(frame) = decode_one::<M>(bytes) else {
                out.push(bytes.clone());
                continue;
            };
            let index_of_kind = match frame.kind() {
                FrameKind::Bd => post_increment(&mut bd_index),
                FrameKind::Report => post_increment(&mut report_index),
                _ => 0,
            };
            let is_exempt = match &frame {
                LinkFrame::RoundEnd { .. } => true,
                LinkFrame::Bd(msg) => exempt(msg),
                _ => false,
            };
            if is_exempt {
                out.push(bytes.clone());
                continue;
            }
            let identity = FrameIdentity::of(&frame, round, index_of_kind);
            let attempts = self.attempts.entry((direction, identity)).or_insert(0);
            let key = FaultKey {
                seed: self.seed,
                direction,
                frame: identity,
                attempt: *attempts,
            };
            *attempts += 1;
            let injected = &mut self.injected[d];
            let mut bytes = bytes.clone();
            let corrupted = corrupt_frame(&self.rates, &key, &mut bytes);
            if corrupted > 0 {
                injected.corrupted_frames += 1;
                injected.corrupted_bytes += corrupted as u64;
            }
            match frame_fate(&self.rates, &key) {
                FrameFate::Deliver => out.push(bytes),
                FrameFate::Drop => injected.dropped += 1,
                FrameFate::Duplicate => {
                    injected.duplicated += 1;
                    out.push(bytes.clone());
                    out.push(bytes);
                }
                FrameFate::Delay => {
                    injected.delayed += 1;
                    self.delayed[d].push(bytes);
                }
            }
        }
        out
    }
}

fn post_increment(counter: &mut u16) -> u16 {
    let value = *counter;
    *counter = counter.saturating_add(1);
    value
}

/// The single frame `bytes` hold, if they hold exactly one valid frame.
fn decode_one<M: WireMessage>(bytes: &[u8]) -> Option<LinkFrame<M>> {
    let mut decoder = FrameDecoder::new();
    let mut found = None;
    for &b in bytes {
        match decoder.push::<LinkFrame<M>>(b) {
            Some(Ok(frame)) if found.is_none() => found = Some(frame),
            Some(_) => return None,
            None => {}
        }
    }
    found
}

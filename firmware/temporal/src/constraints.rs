//! The compact serialised encoding of temporal constraints (seed 001, section 4.3): each
//! constraint `lb <= t[after] - t[before] <= ub` between plan steps is a 32-bit word (a 2-bit
//! bound code, 15 bits for each step index) followed by zero, one or two continuation values.
//!
//! | code | bounds                | continuation            |
//! |------|-----------------------|-------------------------|
//! | 00   | lb = 0, ub = infinity | none                    |
//! | 01   | lb = epsilon, ub = infinity | none              |
//! | 10   | lb = ub = x           | x                       |
//! | 11   | lb = x, ub = y        | x, then y + 1 (0 for an unbounded ub) |
//!
//! Continuation values are LEB128 varints, so a bound below 128 ticks takes one continuation
//! byte, as in the paper, and larger bounds take as many as they need. Most constraints are
//! orderings (codes 00 and 01) and take four bytes.
#![deny(clippy::indexing_slicing)]

use crate::task::UNBOUNDED;

/// Most plan steps a constraint can name: step indices have 15 bits (step 0 is time zero).
pub const MAX_STEPS: usize = 1 << 15;

/// `lb <= t[after] - t[before] <= ub` (ub = [`UNBOUNDED`] for none), times in ticks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Constraint {
    pub before: u16,
    pub after: u16,
    pub lb: u32,
    pub ub: u32,
}

/// The encoding could not be written (no room) or read (malformed or truncated).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CodecError {
    NoRoom,
    StepOutOfRange,
    Truncated,
}

fn put_varint(out: &mut [u8], at: &mut usize, mut v: u32) -> Result<(), CodecError> {
    loop {
        let byte = (v & 0x7f) as u8;
        v >>= 7;
        let slot = out.get_mut(*at).ok_or(CodecError::NoRoom)?;
        *slot = if v == 0 { byte } else { byte | 0x80 };
        *at += 1;
        if v == 0 {
            return Ok(());
        }
    }
}

fn get_varint(bytes: &[u8], at: &mut usize) -> Result<u32, CodecError> {
    let mut v: u32 = 0;
    for shift in [0u32, 7, 14, 21, 28] {
        let byte = *bytes.get(*at).ok_or(CodecError::Truncated)?;
        *at += 1;
        v |= u32::from(byte & 0x7f) << shift;
        if byte & 0x80 == 0 {
            return Ok(v);
        }
    }
    Err(CodecError::Truncated)
}

/// Bytes [`encode`] writes for `c`.
pub fn encoded_len(c: &Constraint, epsilon: u32) -> usize {
    let varint = |v: u32| match v {
        0..=0x7f => 1,
        0x80..=0x3fff => 2,
        0x4000..=0x1f_ffff => 3,
        0x20_0000..=0xfff_ffff => 4,
        _ => 5,
    };
    4 + match (c.lb, c.ub) {
        (0, UNBOUNDED) => 0,
        (lb, UNBOUNDED) if lb == epsilon => 0,
        (lb, ub) if lb == ub => varint(lb),
        (lb, UNBOUNDED) => varint(lb) + 1,
        (lb, ub) => varint(lb) + varint(ub.saturating_add(1)),
    }
}

/// Append `c` to `out` at `*at`.
pub fn encode(
    c: &Constraint,
    epsilon: u32,
    out: &mut [u8],
    at: &mut usize,
) -> Result<(), CodecError> {
    if c.before as usize >= MAX_STEPS || c.after as usize >= MAX_STEPS {
        return Err(CodecError::StepOutOfRange);
    }
    let code: u32 = match (c.lb, c.ub) {
        (0, UNBOUNDED) => 0,
        (lb, UNBOUNDED) if lb == epsilon => 1,
        (lb, ub) if lb == ub => 2,
        _ => 3,
    };
    if *at + encoded_len(c, epsilon) > out.len() {
        return Err(CodecError::NoRoom);
    }
    let word = code << 30 | u32::from(c.after) << 15 | u32::from(c.before);
    for (i, b) in word.to_le_bytes().into_iter().enumerate() {
        if let Some(slot) = out.get_mut(*at + i) {
            *slot = b;
        }
    }
    *at += 4;
    match code {
        2 => put_varint(out, at, c.lb),
        3 => {
            put_varint(out, at, c.lb)?;
            let ub = if c.ub == UNBOUNDED { 0 } else { c.ub + 1 };
            put_varint(out, at, ub)
        }
        _ => Ok(()),
    }
}

/// Read one constraint at `*at`.
pub fn decode(bytes: &[u8], epsilon: u32, at: &mut usize) -> Result<Constraint, CodecError> {
    let word = match bytes.get(*at..*at + 4) {
        Some(&[a, b, c, d]) => u32::from_le_bytes([a, b, c, d]),
        _ => return Err(CodecError::Truncated),
    };
    *at += 4;
    let before = (word & 0x7fff) as u16;
    let after = ((word >> 15) & 0x7fff) as u16;
    let (lb, ub) = match word >> 30 {
        0 => (0, UNBOUNDED),
        1 => (epsilon, UNBOUNDED),
        2 => {
            let x = get_varint(bytes, at)?;
            (x, x)
        }
        _ => {
            let x = get_varint(bytes, at)?;
            let y = get_varint(bytes, at)?;
            (x, if y == 0 { UNBOUNDED } else { y - 1 })
        }
    };
    Ok(Constraint {
        before,
        after,
        lb,
        ub,
    })
}

/// Every constraint in `bytes`, in order; stops at the first malformed one (yielding its error).
pub fn decode_all(
    bytes: &[u8],
    epsilon: u32,
) -> impl Iterator<Item = Result<Constraint, CodecError>> + '_ {
    let mut at = 0;
    let mut failed = false;
    core::iter::from_fn(move || {
        if failed || at >= bytes.len() {
            return None;
        }
        let r = decode(bytes, epsilon, &mut at);
        failed = r.is_err();
        Some(r)
    })
}

//! The compact constraint encoding (2-bit bound codes, 15-bit step indices, continuation
//! values) against brute force: random constraints round-trip, take the bytes the table of
//! section 4.3 says, and no truncated or corrupted input panics.
mod common;

use common::Rng;
use temporal::constraints::{
    decode, decode_all, encode, encoded_len, CodecError, Constraint, MAX_STEPS,
};
use temporal::task::UNBOUNDED;

fn random_constraint(rng: &mut Rng, eps: u32) -> Constraint {
    let before = rng.below(MAX_STEPS as u64) as u16;
    let after = rng.below(MAX_STEPS as u64) as u16;
    let big = |rng: &mut Rng| match rng.below(4) {
        0 => rng.below(128) as u32,
        1 => rng.below(1 << 14) as u32,
        2 => rng.below(1 << 28) as u32,
        _ => u32::MAX - 1 - rng.below(4) as u32,
    };
    let (lb, ub) = match rng.below(6) {
        0 => (0, UNBOUNDED),
        1 => (eps, UNBOUNDED),
        2 => {
            let x = big(rng);
            (x, x)
        }
        3 => (big(rng), UNBOUNDED),
        _ => {
            let a = big(rng);
            let b = big(rng);
            (a.min(b), a.max(b))
        }
    };
    Constraint {
        before,
        after,
        lb,
        ub,
    }
}

#[test]
fn random_constraint_lists_round_trip() {
    let mut rng = Rng(0xc0de_0001);
    for _ in 0..2_000 {
        let eps = 1 + rng.below(20) as u32;
        let list: Vec<Constraint> = (0..rng.below(20))
            .map(|_| random_constraint(&mut rng, eps))
            .collect();
        let mut buf = vec![0u8; 20 * 14];
        let mut at = 0;
        for c in &list {
            let before = at;
            encode(c, eps, &mut buf, &mut at).expect("room");
            assert_eq!(at - before, encoded_len(c, eps), "{c:?}");
        }
        let back: Vec<Constraint> = decode_all(&buf[..at], eps)
            .map(|r| r.expect("well formed"))
            .collect();
        assert_eq!(back, list);
    }
}

#[test]
fn orderings_take_four_bytes_and_bounds_take_continuation_bytes() {
    let eps = 10;
    let c = |lb, ub| Constraint {
        before: 3,
        after: 7,
        lb,
        ub,
    };
    assert_eq!(encoded_len(&c(0, UNBOUNDED), eps), 4); // code 00
    assert_eq!(encoded_len(&c(eps, UNBOUNDED), eps), 4); // code 01
    assert_eq!(encoded_len(&c(100, 100), eps), 5); // code 10, one continuation byte
    assert_eq!(encoded_len(&c(5, 9), eps), 6); // code 11, two continuation bytes
    assert_eq!(encoded_len(&c(5000, 5000), eps), 6); // a larger bound takes two
    let mut buf = [0u8; 8];
    let mut at = 0;
    encode(&c(eps, UNBOUNDED), eps, &mut buf, &mut at).expect("room");
    let word = u32::from_le_bytes([buf[0], buf[1], buf[2], buf[3]]);
    assert_eq!(word >> 30, 0b01);
    assert_eq!((word >> 15) & 0x7fff, 7);
    assert_eq!(word & 0x7fff, 3);
}

#[test]
fn truncated_or_corrupted_encodings_are_errors_not_panics() {
    let mut rng = Rng(0xc0de_0002);
    for _ in 0..2_000 {
        let eps = 7;
        let list: Vec<Constraint> = (0..1 + rng.below(6))
            .map(|_| random_constraint(&mut rng, eps))
            .collect();
        let mut buf = vec![0u8; 6 * 14];
        let mut at = 0;
        for c in &list {
            encode(c, eps, &mut buf, &mut at).expect("room");
        }
        // Every prefix decodes to whole constraints then at most one error.
        for cut in 0..at {
            let results: Vec<_> = decode_all(&buf[..cut], eps).collect();
            let errors = results.iter().filter(|r| r.is_err()).count();
            assert!(errors <= 1);
            if let Some(Err(e)) = results.last() {
                assert_eq!(*e, CodecError::Truncated);
            }
        }
        // Random bytes never panic.
        let noise: Vec<u8> = (0..rng.below(40)).map(|_| rng.next_u64() as u8).collect();
        let mut p = 0;
        while p < noise.len() && decode(&noise, eps, &mut p).is_ok() {}
    }
}

#[test]
fn a_full_buffer_or_a_step_index_too_large_is_refused() {
    let c = Constraint {
        before: 1,
        after: 2,
        lb: 300,
        ub: 400,
    };
    let mut small = [0u8; 5];
    let mut at = 0;
    assert_eq!(encode(&c, 10, &mut small, &mut at), Err(CodecError::NoRoom));
    let far = Constraint {
        before: 1,
        after: MAX_STEPS as u16,
        lb: 0,
        ub: UNBOUNDED,
    };
    let mut buf = [0u8; 8];
    let mut at = 0;
    assert_eq!(
        encode(&far, 10, &mut buf, &mut at),
        Err(CodecError::StepOutOfRange)
    );
}

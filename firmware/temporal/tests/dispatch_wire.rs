//! A plan's dispatch network carried in chunks (the executive dispatching, issue 13 item 3):
//! random networks round trip whole through their chunks; a damaged, out-of-order, foreign or
//! mis-sized chunk is refused with its reason and changes nothing (the same chunk sent again is
//! taken); random words never panic.
mod common;

use common::Rng;
use temporal::constraints::Constraint;
use temporal::dispatch_wire::{chunk, chunks, NetworkReceiver, Received, WireRefusal, CHUNK_WORDS};
use temporal::task::UNBOUNDED;
use temporal::{PlanNetwork, PlanStep};

fn random_network(rng: &mut Rng, most_steps: u64) -> PlanNetwork {
    let mut net = PlanNetwork::new();
    let steps = rng.below(most_steps + 1) as usize;
    for k in 0..steps {
        net.add_step(PlanStep {
            action: rng.below(600) as u16,
            end: k % 2 == 1,
            window: (rng.below(1000) as u32, UNBOUNDED - rng.below(2) as u32),
        })
        .unwrap();
    }
    if steps > 0 {
        for _ in 0..rng.below(8 * steps as u64) {
            let _ = net.add_constraint(Constraint {
                before: rng.below(steps as u64 + 1) as u16,
                after: rng.below(steps as u64 + 1) as u16,
                lb: rng.below(5000) as u32,
                ub: if rng.chance(50) {
                    UNBOUNDED
                } else {
                    rng.below(9000) as u32
                },
            });
        }
    }
    net.makespan = rng.next_u64() as u32;
    net
}

fn same(a: &PlanNetwork, b: &PlanNetwork) {
    assert_eq!(a.step_count(), b.step_count());
    assert_eq!(a.makespan, b.makespan);
    assert_eq!(a.constraints(), b.constraints());
    for k in 1..=a.step_count() {
        assert_eq!(a.step(k), b.step(k));
    }
}

#[test]
fn random_networks_round_trip_through_their_chunks() {
    let mut rng = Rng(0xc4a1_2e55);
    for round in 0..300 {
        let most = if round == 0 { 256 } else { 1 + rng.below(80) };
        let net = random_network(&mut rng, most);
        let plan = rng.next_u64() as u32;
        let mut rx = NetworkReceiver::new();
        let mut got = PlanNetwork::new();
        let n = chunks(&net);
        for i in 0..n {
            let c = chunk(&net, plan, i).unwrap();
            let r = rx.take(&c, &mut got).unwrap();
            if i + 1 == n {
                assert_eq!(r, Received::Whole);
            } else {
                assert_eq!(r, Received::More { next: i as u16 + 1 });
            }
        }
        assert!(chunk(&net, plan, n).is_none());
        same(&net, &got);
    }
}

#[test]
fn a_full_network_takes_its_bounded_chunks() {
    let mut net = PlanNetwork::new();
    for k in 0..256 {
        net.add_step(PlanStep {
            action: k / 2,
            end: k % 2 == 1,
            window: (0, UNBOUNDED),
        })
        .unwrap();
    }
    for i in 0..2048u32 {
        net.add_constraint(Constraint {
            before: (i % 256) as u16,
            after: (i % 256 + 1) as u16,
            lb: i,
            ub: UNBOUNDED,
        })
        .unwrap();
    }
    // 3 + 3 x 256 + 3 x 2,048 words: 6,915, in 289 chunks of 24.
    assert_eq!(CHUNK_WORDS, 24);
    assert_eq!(chunks(&net), 289);
    let mut rx = NetworkReceiver::new();
    let mut got = PlanNetwork::new();
    for i in 0..289 {
        rx.take(&chunk(&net, 7, i).unwrap(), &mut got).unwrap();
    }
    same(&net, &got);
}

#[test]
fn bad_chunks_are_refused_with_their_reason_and_change_nothing() {
    let mut rng = Rng(77);
    let net = loop {
        let n = random_network(&mut rng, 40);
        if chunks(&n) >= 4 {
            break n;
        }
    };
    let mut rx = NetworkReceiver::new();
    let mut got = PlanNetwork::new();
    // A chunk after the first before any first one.
    assert_eq!(
        rx.take(&chunk(&net, 5, 1).unwrap(), &mut got),
        Err(WireRefusal::OutOfOrder { expected: 0 })
    );
    rx.take(&chunk(&net, 5, 0).unwrap(), &mut got).unwrap();
    let c1 = chunk(&net, 5, 1).unwrap();
    // Damaged: its CRC.
    let mut bad = c1;
    bad.words[3] ^= 1;
    assert_eq!(rx.take(&bad, &mut got), Err(WireRefusal::BadCrc));
    // Out of order: chunk 2 before 1; chunk 0 again is a new network (taken).
    assert_eq!(
        rx.take(&chunk(&net, 5, 2).unwrap(), &mut got),
        Err(WireRefusal::OutOfOrder { expected: 1 })
    );
    // Another plan's chunk.
    assert_eq!(
        rx.take(&chunk(&net, 6, 1).unwrap(), &mut got),
        Err(WireRefusal::OtherPlan { receiving: 5 })
    );
    // Its length wrong (CRC made right).
    let mut short = c1;
    short.len -= 1;
    short.crc = short.expected_crc();
    assert_eq!(rx.take(&short, &mut got), Err(WireRefusal::BadLength));
    // A step's end flag out of range in a first chunk (CRC made right).
    let mut first = chunk(&net, 9, 0).unwrap();
    first.words[3] |= 2 << 16;
    first.crc = first.expected_crc();
    assert_eq!(rx.take(&first, &mut got), Err(WireRefusal::OutOfRange));
    // Too many steps claimed.
    let mut many = chunk(&net, 9, 0).unwrap();
    many.words[1] = 257;
    many.crc = many.expected_crc();
    assert_eq!(rx.take(&many, &mut got), Err(WireRefusal::OutOfRange));
    // After all that, the rest of plan 5 is taken as if nothing happened.
    for i in 1..chunks(&net) {
        rx.take(&chunk(&net, 5, i).unwrap(), &mut got).unwrap();
    }
    same(&net, &got);
    assert_eq!(
        rx.take(&chunk(&net, 5, 1).unwrap(), &mut got),
        Err(WireRefusal::Complete)
    );
}

#[test]
fn random_chunks_never_panic() {
    let mut rng = Rng(0xbad);
    let mut rx = NetworkReceiver::new();
    let mut got = PlanNetwork::new();
    let net = random_network(&mut rng, 30);
    for _ in 0..20_000 {
        let mut c = chunk(&net, 1, rng.below(chunks(&net).max(1) as u64) as usize)
            .unwrap_or_else(|| chunk(&random_network(&mut rng, 5), 1, 0).unwrap());
        for _ in 0..rng.below(4) {
            let i = rng.below(CHUNK_WORDS as u64) as usize;
            c.words[i] = rng.next_u64() as u32;
        }
        if rng.chance(30) {
            c.len = rng.below(100) as u16;
            c.total = rng.below(300) as u16;
            c.index = rng.below(300) as u16;
        }
        if rng.chance(80) {
            c.crc = c.expected_crc();
        }
        let _ = rx.take(&c, &mut got);
        assert!(got.step_count() <= 256);
    }
}

#[test]
fn the_words_taken_are_the_chunks_payloads_at_every_cut() {
    // What a checkpoint of a network being received keeps: every word taken, a step or a
    // constraint cut across two chunks included, equal to the chunks' payloads.
    let mut rng = Rng(0x7a4e);
    for _ in 0..60 {
        let net = random_network(&mut rng, 40);
        let mut rx = NetworkReceiver::new();
        let mut got = PlanNetwork::new();
        let mut sent = Vec::new();
        for i in 0..chunks(&net) {
            let c = chunk(&net, 2, i).unwrap();
            sent.extend_from_slice(&c.words[..usize::from(c.len)]);
            rx.take(&c, &mut got).unwrap();
            assert_eq!(rx.words_taken(), sent.len());
            assert_eq!(rx.progress(), (i as u16 + 1, chunks(&net) as u16));
            for (p, &w) in sent.iter().enumerate() {
                assert_eq!(rx.taken_word(&got, p), w, "word {p} after chunk {i}");
            }
            // Sent again through a new receiver, as a restore does: the same state.
            let mut again = NetworkReceiver::new();
            let mut net2 = PlanNetwork::new();
            for (j, part) in sent.chunks(CHUNK_WORDS).enumerate() {
                let c = temporal::dispatch_wire::chunk_of(2, j as u16, chunks(&net) as u16, part);
                again.take(&c, &mut net2).unwrap();
            }
            assert_eq!(again.words_taken(), sent.len());
            assert_eq!(again.whole(), rx.whole());
        }
        assert!(rx.whole());
        same(&net, &got);
    }
}

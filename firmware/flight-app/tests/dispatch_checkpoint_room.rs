//! Room in the executive's checkpoint for a temporal plan's dispatch network (issue 13 item 3,
//! the README's "What remains" step 2): the largest network the executive takes
//! (`MAX_CHECKPOINTED_DISPATCH_CHUNKS` chunks, every step executed) is checkpointed into a
//! record slot of the executive partition's warm-restart slice (`EXECUTIVE_WARM`, two slots) and
//! restored from it; a network with more chunks (one at the dispatcher's capacity, 289 chunks)
//! is refused by name, `ChunkRefusal::TooLarge`, by the sender and by the executive, and the
//! network the executive held stays.
//!
//! `--nocapture` prints the sizes the README quotes.
use autonomy::checkpoint::WarmRestartArea;
use autonomy::partitioned::{
    dispatch_part_max_bytes, ChunkRefusal, DispatchNote, DispatchRestoreError, DispatchSender,
    ExecutiveInput, ExecutivePartition, PlannerPartition, Wire, MAX_CHECKPOINTED_DISPATCH_CHUNKS,
};
use temporal::constraints::Constraint;
use temporal::dispatch::{MAX_DISPATCH_CONSTRAINTS, MAX_DISPATCH_STEPS};
use temporal::dispatch_wire::{chunk, chunks, network_words, NetworkChunk, CHUNK_WORDS};
use temporal::task::UNBOUNDED;
use temporal::{PlanNetwork, PlanStep};

/// The executive's slice of the warm-restart area (its A/B records).
const EXECUTIVE_WARM_BYTES: usize = kernel_config::system::EXECUTIVE_WARM.len as usize;

/// `actions` actions one after the other (start 2a+1, end 2a+2, each start 10 ticks or more
/// after the previous end), then constraints "at or after the epoch" added until the network
/// has `constraints` of them.
fn network(actions: usize, constraints: usize) -> PlanNetwork {
    let mut net = PlanNetwork::new();
    let mut t = 5u32;
    let c = |net: &mut PlanNetwork, before: usize, after: usize, lb: u32| {
        net.add_constraint(Constraint {
            before: before as u16,
            after: after as u16,
            lb,
            ub: UNBOUNDED,
        })
        .unwrap();
    };
    for a in 0..actions {
        let d = 100 + 3 * a as u32;
        for end in [false, true] {
            net.add_step(PlanStep {
                action: (a % 40) as u16,
                end,
                window: if end {
                    (t + d, UNBOUNDED)
                } else {
                    (t, UNBOUNDED)
                },
            })
            .unwrap();
        }
        let (s, e) = (2 * a + 1, 2 * a + 2);
        c(
            &mut net,
            if a == 0 { 0 } else { s - 1 },
            s,
            if a == 0 { 5 } else { 10 },
        );
        c(&mut net, s, e, d);
        t += d + 10;
    }
    let steps = net.step_count();
    let mut k = 0;
    while net.constraints().len() < constraints {
        c(&mut net, 0, 1 + k % steps, 0);
        k += 1;
    }
    net.makespan = t;
    net
}

fn message(seq: u32, c: NetworkChunk) -> Wire<ExecutiveInput> {
    Wire::Message {
        seq,
        message: ExecutiveInput::DispatchChunk {
            horizon: 0,
            chunk: c.into(),
        },
    }
}

/// Hands the executive's outbox to `planner` (its notes).
fn notes_to(executive: &mut ExecutivePartition, planner: &mut PlannerPartition) {
    executive.checkpointed();
    executive.transmit(&mut |w| {
        planner.receive(w);
        true
    });
}

/// Hands the executive's outbox to `planner` (its notes), then the planner's to the executive
/// (what the planner took is acknowledged), as a frame does.
fn to_planner(executive: &mut ExecutivePartition, planner: &mut PlannerPartition) {
    executive.checkpointed();
    executive.transmit(&mut |w| {
        planner.receive(w);
        true
    });
    planner.checkpointed();
    planner.transmit(&mut |w| {
        executive.receive(w);
        true
    });
}

/// The executive holding `net` whole as plan `plan` (its chunks sent one by one from `seq`).
fn load(executive: &mut ExecutivePartition, net: &PlanNetwork, plan: u32, seq: &mut u32) {
    for i in 0..chunks(net) {
        *seq += 1;
        executive.receive(message(*seq, chunk(net, plan, i).unwrap()));
    }
}

#[test]
fn the_largest_network_taken_with_every_step_executed_fits_a_slot_of_the_executive_slice() {
    // As many steps as the dispatcher holds, and constraints up to the last word the
    // executive's checkpoint takes: the largest dispatch part there can be.
    let words = usize::from(MAX_CHECKPOINTED_DISPATCH_CHUNKS) * CHUNK_WORDS;
    let cs = (words - 3 - 3 * MAX_DISPATCH_STEPS) / 3;
    let net = network(MAX_DISPATCH_STEPS / 2, cs);
    assert_eq!(net.step_count(), MAX_DISPATCH_STEPS);
    assert_eq!(network_words(&net), words);
    assert_eq!(chunks(&net), usize::from(MAX_CHECKPOINTED_DISPATCH_CHUNKS));
    assert_eq!(DispatchSender::check(&net), Ok(chunks(&net)));

    let mut executive = Box::new(ExecutivePartition::new());
    let mut planner = Box::new(PlannerPartition::new());
    let mut buf = vec![0u8; 64 * 1024];
    let idle = executive.encode_state(&mut buf).unwrap();
    let mut seq = 0;
    load(&mut executive, &net, 4, &mut seq);
    assert!(executive.dispatch().loaded().is_some(), "held whole");
    // Every step executed, at its earliest time.
    for k in 1..=net.step_count() {
        let at = executive
            .dispatch()
            .loaded()
            .unwrap()
            .1
            .window(k)
            .unwrap()
            .0;
        executive.dispatch_executed(k as u16, at).unwrap();
        if k % 16 == 0 {
            to_planner(&mut executive, &mut planner);
            let _ = planner.take_dispatch_notes();
        }
    }
    let mut part = 0;
    executive.dispatch().encode(&mut buf, &mut part).unwrap();
    assert_eq!(part, dispatch_part_max_bytes(), "the bound is met exactly");

    // Written as a record into a slot of the executive's slice, and restored from it.
    let mut warm = vec![0u8; EXECUTIVE_WARM_BYTES];
    let mut area = WarmRestartArea::new(&mut warm);
    let capacity = area.payload_capacity();
    let state = executive.encode_state(&mut buf).unwrap();
    area.write_slot(0, 7, |slot| executive.encode_state(slot))
        .expect("the record fits a slot");
    let (sequence, payload) = area.record(0).expect("a whole record");
    assert_eq!((sequence, payload.len()), (7, state));
    let mut back = Box::new(ExecutivePartition::new());
    back.decode_state(payload).expect("restores");
    let held = back.dispatch().loaded().expect("held").1;
    for k in 1..=net.step_count() {
        assert_eq!(
            held.executed_at(k),
            executive.dispatch().loaded().unwrap().1.executed_at(k)
        );
    }
    let spare = capacity - state;
    println!(
        "slot payload {capacity} bytes; idle executive record {idle}; largest dispatch part \
         {part}; record {state}; spare for the MEXEC side {spare}"
    );
    // Room for the MEXEC side beside it (an idle one is `idle` bytes).
    assert!(spare >= 3_000, "{spare}");
}

#[test]
fn a_network_over_the_checkpoints_room_is_refused_by_name_and_the_one_held_stays() {
    // The dispatcher's capacity: 256 steps, 2,048 constraints, 289 chunks.
    let full = network(MAX_DISPATCH_STEPS / 2, MAX_DISPATCH_CONSTRAINTS);
    assert_eq!(chunks(&full), 289);
    // One word over the room: a chunk more than the executive takes.
    let words = usize::from(MAX_CHECKPOINTED_DISPATCH_CHUNKS) * CHUNK_WORDS;
    let over = network(20, (words + 1 - 3 - 3 * 40).div_ceil(3));
    assert_eq!(
        chunks(&over),
        usize::from(MAX_CHECKPOINTED_DISPATCH_CHUNKS) + 1
    );
    let too_large = ChunkRefusal::TooLarge {
        max_chunks: MAX_CHECKPOINTED_DISPATCH_CHUNKS,
    };
    let mut planner = Box::new(PlannerPartition::new());
    for net in [&full, &over] {
        // The sender does not send it.
        assert_eq!(DispatchSender::check(net), Err(too_large));
        let mut sender = DispatchSender::new(2, net.makespan);
        assert_eq!(sender.pump(net, &mut planner), 0);
        assert!(!sender.done(net));
    }
    planner.checkpointed();
    let mut nothing = 0;
    planner.transmit(&mut |w| {
        if let Wire::Message {
            message: ExecutiveInput::DispatchChunk { .. },
            ..
        } = w
        {
            nothing += 1;
        }
        true
    });
    assert_eq!(nothing, 0, "no chunk went");

    // The executive, holding a small plan, refuses every chunk of a network too large.
    let small = network(3, 6);
    let mut executive = Box::new(ExecutivePartition::new());
    let mut seq = 0;
    load(&mut executive, &small, 1, &mut seq);
    let mut planner = Box::new(PlannerPartition::new());
    notes_to(&mut executive, &mut planner);
    assert_eq!(
        planner.take_dispatch_notes().as_slice(),
        &[DispatchNote::Loaded { plan: 1 }]
    );
    let mut buf = vec![0u8; 64 * 1024];
    let before = executive.encode_state(&mut buf).unwrap();
    let before = buf[..before].to_vec();
    for i in [0, 1, 5] {
        seq += 1;
        executive.receive(message(seq, chunk(&full, 2, i).unwrap()));
    }
    notes_to(&mut executive, &mut planner);
    let notes = planner.take_dispatch_notes();
    assert_eq!(
        notes.as_slice(),
        &[0u16, 1, 5].map(|index| DispatchNote::Refused {
            plan: 2,
            index,
            reason: too_large
        })
    );
    assert_eq!(executive.dispatch().loaded().map(|(p, _)| p), Some(1));
    assert_eq!(executive.dispatch().refused, 3);
    assert_eq!(executive.dispatch().last_refusal, Some(too_large));
    // Nothing of the small plan changed: its dispatch part is the same but for the refusals'
    // count and reason (the MEXEC side is the same bytes but its channel's sequence).
    let mut other = Box::new(ExecutivePartition::new());
    other.decode_state(&before).unwrap();
    let now = executive.dispatch().loaded().unwrap().1;
    let was = other.dispatch().loaded().unwrap().1;
    assert_eq!(now.network().constraints(), was.network().constraints());
    for k in 0..=small.step_count() {
        assert_eq!(now.window(k), was.window(k));
    }
    // The refusal survives the checkpoint.
    let n = executive.encode_state(&mut buf).unwrap();
    let mut back = Box::new(ExecutivePartition::new());
    back.decode_state(&buf[..n]).unwrap();
    assert_eq!(back.dispatch().last_refusal, Some(too_large));
}

#[test]
fn a_checkpoint_naming_a_network_over_the_room_is_refused() {
    // A transfer under way of a small network, then its total changed to one over the room
    // (its CRC right): the part is refused as the chunk would be.
    let net = network(10, 30);
    let mut executive = Box::new(ExecutivePartition::new());
    let mut seq = 0;
    for i in 0..2 {
        seq += 1;
        executive.receive(message(seq, chunk(&net, 6, i).unwrap()));
    }
    let mut buf = vec![0u8; 64 * 1024];
    let idle = ExecutivePartition::new().encode_state(&mut buf).unwrap();
    let n = executive.encode_state(&mut buf).unwrap();
    // The dispatch part is the record's tail: [format, length, body, CRC].
    let part_at = idle - 1;
    let mut part = buf[part_at..n].to_vec();
    let body_len = u32::from_be_bytes(part[1..5].try_into().unwrap()) as usize;
    let mut body = part[5..5 + body_len].to_vec();
    let progress = u32::from_be_bytes(body[8..12].try_into().unwrap());
    let total = u32::from(MAX_CHECKPOINTED_DISPATCH_CHUNKS) + 1;
    body[8..12].copy_from_slice(&((progress & 0xffff) | (total << 16)).to_be_bytes());
    let crc = crc32(&body);
    part.truncate(5);
    part.extend_from_slice(&body);
    part.extend_from_slice(&crc.to_be_bytes());
    let mut dispatch = autonomy::partitioned::ExecutiveDispatch::new();
    assert!(matches!(
        dispatch.decode(&part),
        Err(DispatchRestoreError::Chunk(ChunkRefusal::TooLarge { max_chunks }))
            if max_chunks == MAX_CHECKPOINTED_DISPATCH_CHUNKS
    ));
    assert!(dispatch.receiving().is_none() && dispatch.loaded().is_none());
    // The record unchanged restores.
    let mut good = dispatch.clone();
    assert!(good.decode(&buf[part_at..n]).is_ok());
    assert_eq!(good.receiving(), Some((6, (2, chunks(&net) as u16))));
}

/// CRC-32 (IEEE), as the dispatch part's.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

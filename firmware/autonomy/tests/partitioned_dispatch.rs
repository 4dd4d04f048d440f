//! A temporal plan's dispatch network on the partitions' checkpointed channel (issue 13 item 3):
//! the planner partition sends it in chunks across its windows, the executive takes it into
//! the dispatcher it keeps and says so; the executive's executed steps come back to the
//! planner; a bad chunk is refused with its reason and changes nothing; both sides' checkpoints
//! keep what they hold (mid-transfer included), and a damaged dispatch part is refused with
//! its reason. The MEXEC messages keep their encodings.
use autonomy::partitioned::*;
use temporal::constraints::Constraint;
use temporal::dispatch_wire::{chunk, chunks, NetworkChunk};
use temporal::task::UNBOUNDED;
use temporal::{Decision, Dispatcher, PlanNetwork, PlanStep};

/// A plan of `actions` actions one after the other: action `a` starts (step 2a+1) at least
/// 10 ticks after the previous one ended (the first at 5 or later), lasts 100 to 100 + 7a
/// ticks, and its end (step 2a+2) is reported, not dispatched (no upper bound); every start
/// also within 400 ticks of the previous start's earliest.
fn chain(actions: usize) -> PlanNetwork {
    let mut net = PlanNetwork::new();
    let mut t = 5u32;
    let c = |net: &mut PlanNetwork, before: usize, after: usize, lb: u32, ub: u32| {
        net.add_constraint(Constraint {
            before: before as u16,
            after: after as u16,
            lb,
            ub,
        })
        .unwrap();
    };
    for a in 0..actions {
        let d = 100 + 7 * a as u32;
        net.add_step(PlanStep {
            action: (a % 40) as u16,
            end: false,
            window: (t, t + 400),
        })
        .unwrap();
        net.add_step(PlanStep {
            action: (a % 40) as u16,
            end: true,
            window: (t + d, UNBOUNDED),
        })
        .unwrap();
        let (s, e) = (2 * a + 1, 2 * a + 2);
        if a == 0 {
            c(&mut net, 0, s, 5, 400);
        } else {
            c(&mut net, s - 1, s, 10, UNBOUNDED);
            c(&mut net, s - 2, s, 0, d + 400);
        }
        c(&mut net, s, e, d, UNBOUNDED);
        t += d + 10;
    }
    net.makespan = t;
    net
}

fn same(a: &PlanNetwork, b: &PlanNetwork) {
    assert_eq!(a.step_count(), b.step_count());
    assert_eq!(a.makespan, b.makespan);
    assert_eq!(a.constraints(), b.constraints());
    for k in 1..=a.step_count() {
        assert_eq!(a.step(k), b.step(k), "step {k}");
    }
}

/// Both sides and what the executive's port and the planner's port carry, handed over as the
/// kernel does (each side checkpoints, then transmits).
struct Pair {
    executive: Box<ExecutivePartition>,
    planner: Box<PlannerPartition>,
}

impl Pair {
    fn new() -> Self {
        Self {
            executive: Box::new(ExecutivePartition::new()),
            planner: Box::new(PlannerPartition::new()),
        }
    }

    /// The planner's window (its outbox checkpointed, then sent), then the executive's (the
    /// same), as one frame does.
    fn exchange(&mut self) {
        self.planner.checkpointed();
        let executive = &mut self.executive;
        self.planner.transmit(&mut |w| {
            executive.receive(w);
            true
        });
        self.executive.checkpointed();
        let planner = &mut self.planner;
        self.executive.transmit(&mut |w| {
            planner.receive(w);
            true
        });
    }

    /// Sends `net` as plan `plan` with `sender`, one window's chunks at a time; the windows
    /// it took.
    fn send(&mut self, net: &PlanNetwork, sender: &mut DispatchSender) -> usize {
        let mut windows = 0;
        while !sender.done(net) {
            let sent = sender.pump(net, &mut self.planner);
            assert!(sent > 0 && sent <= MAX_DISPATCH_CHUNKS_PER_WINDOW);
            self.exchange();
            windows += 1;
            assert!(windows < 100);
        }
        self.exchange();
        windows
    }
}

#[test]
fn a_network_goes_to_the_executive_in_chunks_and_executed_steps_come_back() {
    let net = chain(60);
    let n = chunks(&net);
    assert!(n > 2 * MAX_DISPATCH_CHUNKS_PER_WINDOW, "{n} chunks");
    let mut pair = Pair::new();
    let mut sender = DispatchSender::new(3, net.makespan + 1000);
    let windows = pair.send(&net, &mut sender);
    assert_eq!(windows, n.div_ceil(MAX_DISPATCH_CHUNKS_PER_WINDOW));
    let (plan, held) = pair
        .executive
        .dispatch()
        .loaded()
        .expect("the network held whole");
    assert_eq!(plan, 3);
    same(&net, held.network());
    assert_eq!(held.horizon(), net.makespan + 1000);
    assert_eq!(
        pair.planner.take_dispatch_notes().as_slice(),
        &[DispatchNote::Loaded { plan: 3 }]
    );
    assert!(pair.planner.take_dispatch_notes().is_empty());
    // The executive's dispatcher decides as one built from the network itself, and each
    // executed step reaches the planner with its time.
    let mut reference = Dispatcher::new(net.clone(), net.makespan + 1000).unwrap();
    let mut now = 0u32;
    let mut executed = Vec::new();
    let mut notes = Vec::new();
    for _ in 0..400 {
        let ours = pair
            .executive
            .dispatcher_mut()
            .unwrap()
            .poll(now, &|_| true);
        assert_eq!(ours, reference.poll(now, &|_| true), "at {now}");
        match ours {
            Decision::Start { step, .. } => {
                pair.executive.dispatch_executed(step as u16, now).unwrap();
                reference.executed(step, now).unwrap();
                executed.push((step as u16, now));
                // Its end, reported: the action took its shortest duration plus 3 (60 actions 180
                // ticks late in all, within the horizon).
                let end = step + 1;
                let d = net
                    .constraints()
                    .iter()
                    .find(|c| c.after as usize == end)
                    .unwrap()
                    .lb;
                now += d + 3;
                pair.executive.dispatch_executed(end as u16, now).unwrap();
                reference.executed(end, now).unwrap();
                executed.push((end as u16, now));
            }
            Decision::Wait { until: Some(t) } => now = t,
            Decision::Finished => break,
            other => panic!("{other:?} at {now}"),
        }
        pair.exchange();
        // The planner's owner takes the notes each window (they are bounded).
        notes.extend(pair.planner.take_dispatch_notes());
    }
    assert_eq!(executed.len(), net.step_count());
    assert_eq!(pair.planner.dispatch_notes_dropped, 0);
    let back: Vec<(u16, u32)> = notes
        .iter()
        .map(|n| match *n {
            DispatchNote::Executed { plan: 3, step, at } => (step, at),
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(back, executed);
    // A step executed twice, or one that is no step, is refused and nothing goes out.
    let unsent = pair.executive.to_planner().unsent();
    assert_eq!(
        pair.executive.dispatch_executed(1, now),
        Err(ExecutedRefusal::UnknownStep)
    );
    assert_eq!(
        pair.executive.dispatch_executed(500, now),
        Err(ExecutedRefusal::UnknownStep)
    );
    assert_eq!(pair.executive.to_planner().unsent(), unsent);
    assert_eq!(
        ExecutivePartition::new().dispatch_executed(1, 0),
        Err(ExecutedRefusal::NoNetwork)
    );
    // Notes not taken beyond the planner's capacity are counted as dropped.
    let mut pair = Pair::new();
    let mut sender = DispatchSender::new(4, 0);
    pair.send(&net, &mut sender);
    for k in 1..=MAX_DISPATCH_NOTES as u16 + 4 {
        pair.executive.dispatch_executed(k, 0).unwrap();
    }
    pair.exchange();
    assert_eq!(pair.planner.take_dispatch_notes().len(), MAX_DISPATCH_NOTES);
    assert_eq!(pair.planner.dispatch_notes_dropped, 5);
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

#[test]
fn a_bad_chunk_is_refused_with_its_reason_and_changes_nothing() {
    let net = chain(12);
    let n = chunks(&net);
    assert!(n >= 4);
    let mut executive = ExecutivePartition::new();
    let mut seq = 0;
    let mut send = |executive: &mut ExecutivePartition, c: NetworkChunk| {
        seq += 1;
        executive.receive(message(seq, c));
    };
    send(&mut executive, chunk(&net, 9, 0).unwrap());
    send(&mut executive, chunk(&net, 9, 1).unwrap());
    let before = executive.dispatch().receiving();
    assert_eq!(before, Some((9, (2, n as u16))));
    let mut bad = chunk(&net, 9, 2).unwrap();
    bad.words[5] ^= 0x40;
    let cases = [
        (bad, ChunkRefusal::BadCrc),
        (
            chunk(&net, 9, 3).unwrap(),
            ChunkRefusal::OutOfOrder { expected: 2 },
        ),
        (
            chunk(&net, 8, 2).unwrap(),
            ChunkRefusal::OtherPlan { receiving: 9 },
        ),
    ];
    for (i, (c, reason)) in cases.into_iter().enumerate() {
        send(&mut executive, c);
        assert_eq!(executive.dispatch().receiving(), before);
        assert_eq!(executive.dispatch().refused, i as u32 + 1);
        assert_eq!(executive.dispatch().last_refusal, Some(reason));
    }
    // The planner hears each refusal, in order.
    executive.checkpointed();
    let mut planner = PlannerPartition::new();
    executive.transmit(&mut |w| {
        planner.receive(w);
        true
    });
    let notes = planner.take_dispatch_notes();
    let reasons: Vec<ChunkRefusal> = notes
        .iter()
        .map(|n| match *n {
            DispatchNote::Refused { reason, .. } => reason,
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(
        reasons,
        [
            ChunkRefusal::BadCrc,
            ChunkRefusal::OutOfOrder { expected: 2 },
            ChunkRefusal::OtherPlan { receiving: 9 }
        ]
    );
    // The good chunks then go in: the network is whole.
    for i in 2..n {
        send(&mut executive, chunk(&net, 9, i).unwrap());
    }
    same(&net, executive.dispatch().loaded().unwrap().1.network());
    // A chunk after the last: refused, the network still held.
    send(&mut executive, chunk(&net, 9, n - 1).unwrap());
    assert_eq!(
        executive.dispatch().last_refusal,
        Some(ChunkRefusal::Complete)
    );
    assert!(executive.dispatch().loaded().is_some());
    // A new plan's first chunk refused (damaged) leaves the old one held; a good one replaces it.
    let mut first = chunk(&chain(3), 10, 0).unwrap();
    first.crc ^= 1;
    send(&mut executive, first);
    assert_eq!(executive.dispatch().loaded().map(|(p, _)| p), Some(9));
    send(&mut executive, chunk(&chain(3), 10, 0).unwrap());
    assert!(executive.dispatch().loaded().is_none());
    assert_eq!(executive.dispatch().receiving().map(|(p, _)| p), Some(10));
}

/// `side`'s checkpoint payload decoded into a new side (as a restore does, without its
/// restart adjustments).
fn restored_executive(executive: &ExecutivePartition) -> Box<ExecutivePartition> {
    let mut buf = vec![0u8; 256 * 1024];
    let n = executive.encode_state(&mut buf).unwrap();
    let mut back = Box::new(ExecutivePartition::new());
    back.decode_state(&buf[..n]).expect("restored");
    back
}

#[test]
fn the_executive_checkpoint_keeps_the_network_mid_transfer_and_the_executed_steps() {
    let net = chain(30);
    let n = chunks(&net);
    let mut executive = Box::new(ExecutivePartition::new());
    // Nothing received: the dispatch part is one byte.
    let mut buf = vec![0u8; 256 * 1024];
    let empty = executive.encode_state(&mut buf).unwrap();
    let mut seq = 0;
    for i in 0..n {
        // A checkpoint after every chunk, one cut inside a step or a constraint included:
        // the restored side takes the rest.
        let mut back = restored_executive(&executive);
        assert_eq!(
            back.dispatch().receiving(),
            executive.dispatch().receiving()
        );
        for j in i..n {
            back.receive(message(
                seq + 1 + (j - i) as u32,
                chunk(&net, 4, j).unwrap(),
            ));
        }
        same(&net, back.dispatch().loaded().unwrap().1.network());
        seq += 1;
        executive.receive(message(seq, chunk(&net, 4, i).unwrap()));
    }
    assert!(executive.encode_state(&mut buf).unwrap() > empty + 4 * 3 * net.step_count());
    // Executed steps, and a refusal: kept too.
    for (k, at) in [(1u16, 5u32), (2, 110)] {
        executive.dispatch_executed(k, at).unwrap();
    }
    executive.receive(message(
        seq + 1,
        chunk(&net, 4, 0)
            .map(|mut c| {
                c.crc ^= 1;
                c
            })
            .unwrap(),
    ));
    let back = restored_executive(&executive);
    let (plan, d) = back.dispatch().loaded().unwrap();
    assert_eq!(plan, 4);
    same(&net, d.network());
    assert_eq!(
        (d.executed_at(1), d.executed_at(2), d.executed_at(3)),
        (Some(5), Some(110), None)
    );
    assert_eq!(back.dispatch().refused, 1);
    assert_eq!(back.dispatch().last_refusal, Some(ChunkRefusal::BadCrc));
    // It decides as the one checkpointed.
    let mut a = restored_executive(&executive);
    for now in [0, 120, 125, 300, 2000] {
        assert_eq!(
            a.dispatcher_mut().unwrap().poll(now, &|_| true),
            executive.dispatcher_mut().unwrap().poll(now, &|_| true)
        );
    }
}

#[test]
fn a_damaged_dispatch_part_is_refused_with_its_reason() {
    let net = chain(10);
    let mut executive = ExecutivePartition::new();
    for i in 0..chunks(&net) {
        executive.receive(message(i as u32 + 1, chunk(&net, 2, i).unwrap()));
    }
    executive.dispatch_executed(1, 5).unwrap();
    let mut buf = vec![0u8; 64 * 1024];
    let mut len = 0;
    executive.dispatch().encode(&mut buf, &mut len).unwrap();
    let part = buf[..len].to_vec();
    let decode = |bytes: &[u8]| {
        let mut d = ExecutiveDispatch::new();
        let r = d.decode(bytes).map(|rest| rest.len());
        (r, d.loaded().is_some())
    };
    assert_eq!(decode(&part), (Ok(0), true));
    // A byte of the body changed: its CRC.
    let mut bad = part.clone();
    bad[20] ^= 1;
    assert_eq!(decode(&bad), (Err(DispatchRestoreError::BadCrc), false));
    // Another format.
    let mut bad = part.clone();
    bad[0] = 7;
    assert_eq!(
        decode(&bad),
        (Err(DispatchRestoreError::Version { found: 7 }), false)
    );
    // Cut short.
    assert_eq!(
        decode(&part[..part.len() - 1]),
        (Err(DispatchRestoreError::BadLength), false)
    );
    // Fields out of range with their CRC right: an executed step that is no step, a network
    // of more steps than the capacity.
    let with_crc = |mut body: Vec<u8>| {
        let crc = crc32(&body);
        let mut b = vec![DISPATCH_PART_FORMAT];
        b.extend_from_slice(&(body.len() as u32).to_be_bytes());
        b.append(&mut body);
        b.extend_from_slice(&crc.to_be_bytes());
        b
    };
    let body = part[5..part.len() - 4].to_vec();
    let mut no_step = body.clone();
    let at = no_step.len() - 8;
    no_step[at..at + 4].copy_from_slice(&999u32.to_be_bytes());
    assert_eq!(
        decode(&with_crc(no_step)),
        (Err(DispatchRestoreError::OutOfRange), false)
    );
    let mut too_many = body.clone();
    // Word 9 + 1: the network's step count.
    too_many[40..44].copy_from_slice(&300u32.to_be_bytes());
    assert_eq!(
        decode(&with_crc(too_many)),
        (
            Err(DispatchRestoreError::Chunk(ChunkRefusal::OutOfRange)),
            false
        )
    );
    // The executive's record with a damaged part is refused whole.
    let mut state = vec![0u8; 256 * 1024];
    let n = executive.encode_state(&mut state).unwrap();
    let mut back = ExecutivePartition::new();
    assert!(back.decode_state(&state[..n]).is_some());
    state[n - 6] ^= 0x10;
    assert!(ExecutivePartition::new()
        .decode_state(&state[..n])
        .is_none());
    // Random bytes never panic.
    let mut x = 0x1234_5678u32;
    for _ in 0..5000 {
        let mut b = part.clone();
        for _ in 0..3 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            let i = x as usize % b.len();
            b[i] = (x >> 8) as u8;
        }
        let _ = decode(&b);
    }
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xffff_ffffu32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = (c >> 1) ^ (0xedb8_8320 & (c & 1).wrapping_neg());
        }
    }
    !c
}

#[test]
fn the_planner_checkpoint_keeps_the_notes_not_taken() {
    let net = chain(4);
    let mut pair = Pair::new();
    let mut sender = DispatchSender::new(1, 0);
    pair.send(&net, &mut sender);
    pair.executive.dispatch_executed(1, 5).unwrap();
    pair.exchange();
    let mut buf = vec![0u8; 256 * 1024];
    let n = pair.planner.encode_state(&mut buf).unwrap();
    let mut back = Box::new(PlannerPartition::new());
    back.decode_state(&buf[..n]).expect("restored");
    assert_eq!(
        back.take_dispatch_notes().as_slice(),
        &[
            DispatchNote::Loaded { plan: 1 },
            DispatchNote::Executed {
                plan: 1,
                step: 1,
                at: 5
            }
        ]
    );
}

#[test]
fn the_mexec_messages_keep_their_encodings() {
    // The dispatch variants come after every earlier one.
    let mut buf = [0u8; 256];
    let status = ExecutiveInput::Status(PlannerStatus::default());
    assert_eq!(postcard::to_slice(&status, &mut buf).unwrap()[0], 2);
    let c = ExecutiveInput::DispatchChunk {
        horizon: 0,
        chunk: chunk(&chain(1), 1, 0).unwrap().into(),
    };
    assert_eq!(postcard::to_slice(&c, &mut buf).unwrap()[0], 3);
    let frame = PlannerInput::Frame {
        frame: 1,
        now: fsw_bridge::MissionTimeUs(0),
    };
    assert_eq!(postcard::to_slice(&frame, &mut buf).unwrap()[0], 4);
    let note = PlannerInput::Dispatch(DispatchNote::Loaded { plan: 1 });
    assert_eq!(postcard::to_slice(&note, &mut buf).unwrap()[0], 5);
    // A chunk's message round trips.
    let n = postcard::to_slice(&c, &mut buf).unwrap().len();
    assert_eq!(
        postcard::from_bytes::<ExecutiveInput>(&buf[..n]).unwrap(),
        c
    );
}

#[test]
fn every_note_round_trips_and_a_bad_one_is_refused() {
    let mut buf = [0u8; 64];
    let notes = [
        DispatchNote::Loaded { plan: 7 },
        DispatchNote::Executed {
            plan: u32::MAX,
            step: 255,
            at: 123_456,
        },
        DispatchNote::Refused {
            plan: 1,
            index: 288,
            reason: ChunkRefusal::OtherPlan { receiving: 9 },
        },
        DispatchNote::Refused {
            plan: 1,
            index: 2,
            reason: ChunkRefusal::OutOfOrder { expected: 65_535 },
        },
        DispatchNote::Refused {
            plan: 1,
            index: 0,
            reason: ChunkRefusal::Inconsistent,
        },
        DispatchNote::Refused {
            plan: 1,
            index: 0,
            reason: ChunkRefusal::TooLarge {
                max_chunks: MAX_CHECKPOINTED_DISPATCH_CHUNKS,
            },
        },
    ];
    for note in notes {
        let m = PlannerInput::Dispatch(note);
        let n = postcard::to_slice(&m, &mut buf).unwrap().len();
        assert_eq!(postcard::from_bytes::<PlannerInput>(&buf[..n]).unwrap(), m);
        // An unknown kind, an unknown refusal, cut short: refused, never a panic.
        for (at, byte) in [(2, 9u8), (n - 1, 99)] {
            let mut bad = buf[..n].to_vec();
            bad[at] = byte;
            assert!(
                postcard::from_bytes::<PlannerInput>(&bad).is_err(),
                "{note:?}"
            );
        }
        assert!(postcard::from_bytes::<PlannerInput>(&buf[..n - 1]).is_err());
    }
    // A chunk's message cut short or with a wrong length: refused.
    let c = ExecutiveInput::DispatchChunk {
        horizon: 5,
        chunk: chunk(&chain(2), 1, 0).unwrap().into(),
    };
    let mut big = [0u8; 256];
    let n = postcard::to_slice(&c, &mut big).unwrap().len();
    assert!(postcard::from_bytes::<ExecutiveInput>(&big[..n - 1]).is_err());
    let mut bad = big[..n].to_vec();
    bad[2] -= 1; // the byte string's length (after the variant and the horizon)
    assert!(postcard::from_bytes::<ExecutiveInput>(&bad).is_err());
}

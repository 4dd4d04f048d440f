//! The executive's side of the rover's dispatch decisions (`flight_app::rover_exec`, issue 13
//! item 3): a network sent to an executive partition in chunks is dispatched by its
//! `RoverDecider` with the planner's readiness mask: a start step whose action the mask does
//! not name as ready is never started (the decider waits, or starts another), and starts as
//! soon as the mask names it; the completions of carried actions are executed at the epoch;
//! starts and ends reach the planner as `Executed` notes with their times relative to the
//! epoch; bad events are refused with their reason and change nothing; a network over the
//! executive's 112 chunks is not sent, and the decider refuses to take it as its plan (the
//! mission then dispatches it itself).
use autonomy::partitioned::{
    DispatchNote, DispatchSender, ExecutivePartition, PlannerPartition,
    MAX_CHECKPOINTED_DISPATCH_CHUNKS,
};
use flight_app::rover_exec::{
    executed_steps, ExecAnswer, RecordError, RoverDecider, RoverPlanNote, RECORD_MAX_BYTES,
};
use flight_app::rover_mission::{ReadyMask, MAX_ROVER_ACTIVE, READY_MASK_WORDS};
use fsw_bridge::temporal::{RoverRefusal, RoverReplanWhy, RoverReport, RoverStartKind};
use temporal::constraints::Constraint;
use temporal::dispatch::{Decision, Dispatcher};
use temporal::dispatch_wire::chunks;
use temporal::task::UNBOUNDED;
use temporal::{PlanNetwork, PlanStep};

const EPOCH: u32 = 1_000;
const BASE_ACTIONS: u16 = 10;
/// Actions: A (3, 100 ms) and B (5, 50 ms, by 400 ms after the epoch), unordered, and the
/// completion of a carried action (12, 20 ms left).
const A: u16 = 3;
const B: u16 = 5;
const CARRIED: u16 = 12;

fn c(net: &mut PlanNetwork, before: usize, after: usize, lb: u32, ub: u32) {
    net.add_constraint(Constraint {
        before: before as u16,
        after: after as u16,
        lb,
        ub,
    })
    .unwrap();
}

fn small() -> PlanNetwork {
    let mut net = PlanNetwork::new();
    for (action, d) in [(A, 100), (B, 50), (CARRIED, 20)] {
        let s = net
            .add_step(PlanStep {
                action,
                end: false,
                window: (0, UNBOUNDED),
            })
            .unwrap();
        let e = net
            .add_step(PlanStep {
                action,
                end: true,
                window: (d, UNBOUNDED),
            })
            .unwrap();
        c(&mut net, s, e, d, UNBOUNDED);
    }
    // B must start by 400.
    c(&mut net, 0, 3, 0, 400);
    net.makespan = 450;
    net
}

/// One window each way; the planner's notes.
fn exchange(
    executive: &mut ExecutivePartition,
    planner: &mut PlannerPartition,
) -> Vec<DispatchNote> {
    planner.checkpointed();
    planner.transmit(&mut |w| {
        executive.receive(w);
        true
    });
    executive.checkpointed();
    executive.transmit(&mut |w| {
        planner.receive(w);
        true
    });
    planner.take_dispatch_notes().to_vec()
}

fn mask(steps: &[usize]) -> ReadyMask {
    let mut m = [0u32; READY_MASK_WORDS];
    for &k in steps {
        m[k / 32] |= 1 << (k % 32);
    }
    m
}

/// The planner's mask naming `steps`, stamped with the steps executed so far (a mask made
/// after the last happening).
fn ready(d: &mut RoverDecider, executive: &ExecutivePartition, steps: &[usize]) {
    let stamp = executed_steps(executive.dispatch().loaded().unwrap().1);
    d.set_ready(executive, &mask(steps), stamp);
}

fn note(plan: u32, running: &[(u16, u16)]) -> RoverPlanNote {
    let mut r = [(0, 0); MAX_ROVER_ACTIVE];
    r[..running.len()].copy_from_slice(running);
    RoverPlanNote {
        plan,
        epoch: EPOCH,
        base_actions: BASE_ACTIONS,
        running: r,
        running_len: running.len() as u8,
    }
}

/// The executive holding `net` as plan 1, and the planner's notes of its loading.
fn loaded(net: &PlanNetwork) -> (Box<ExecutivePartition>, Box<PlannerPartition>) {
    let mut executive = Box::new(ExecutivePartition::new());
    let mut planner = Box::new(PlannerPartition::new());
    let mut sender = DispatchSender::new(1, net.makespan + 500);
    let mut notes = Vec::new();
    while !sender.done(net) {
        sender.pump(net, &mut planner);
        notes.extend(exchange(&mut executive, &mut planner));
    }
    notes.extend(exchange(&mut executive, &mut planner));
    assert_eq!(notes, vec![DispatchNote::Loaded { plan: 1 }]);
    (executive, planner)
}

fn started(a: ExecAnswer) -> (u16, u16, RoverStartKind) {
    match a {
        ExecAnswer::Report(RoverReport::Dispatch {
            step, action, kind, ..
        }) => (step, action, kind),
        other => panic!("not a start: {other:?}"),
    }
}

#[test]
fn a_step_the_mask_does_not_name_ready_is_not_started() {
    let net = small();
    let (mut executive, mut planner) = loaded(&net);
    let mut d = Box::new(RoverDecider::new());
    // The carried action runs; its completion (step 5) ends at step 6.
    d.plan_loaded(&mut executive, &note(1, &[(7, 6)])).unwrap();
    let held = executive.dispatch().loaded().unwrap().1;
    assert_eq!(
        held.executed_at(5),
        Some(0),
        "the completion starts at the epoch"
    );
    assert_eq!(
        exchange(&mut executive, &mut planner),
        vec![DispatchNote::Executed {
            plan: 1,
            step: 5,
            at: 0
        }]
    );

    // Only B ready: B starts, not A (both could by their windows).
    ready(&mut d, &executive, &[3, 5]);
    assert!(d.is_ready(B) && !d.is_ready(A));
    assert_eq!(
        started(d.poll(&mut executive, EPOCH)),
        (3, B, RoverStartKind::AtLb)
    );
    // A still not ready at 10 ms: a wait, not a start.
    ready(&mut d, &executive, &[]);
    let wait = d.poll(&mut executive, EPOCH + 10);
    assert!(
        matches!(wait, ExecAnswer::Report(RoverReport::Wait { .. })),
        "{wait:?}"
    );
    assert!(executive
        .dispatch()
        .loaded()
        .unwrap()
        .1
        .executed_at(1)
        .is_none());
    // The mask names A (an end the planner applied made its conditions hold): it starts, 10 ms
    // after its lb.
    ready(&mut d, &executive, &[1]);
    assert_eq!(
        started(d.poll(&mut executive, EPOCH + 10)),
        (1, A, RoverStartKind::Late { by_ms: 10 })
    );
    // Each start reached the planner with its time from the epoch.
    assert_eq!(
        exchange(&mut executive, &mut planner),
        vec![
            DispatchNote::Executed {
                plan: 1,
                step: 3,
                at: 0
            },
            DispatchNote::Executed {
                plan: 1,
                step: 1,
                at: 10
            }
        ]
    );
    // Ends: the carried action's (its completion's end), B's, A's; then finished.
    d.ended(&mut executive, 7, EPOCH + 20).unwrap();
    d.ended(&mut executive, B, EPOCH + 50).unwrap();
    d.ended(&mut executive, A, EPOCH + 110).unwrap();
    let notes = exchange(&mut executive, &mut planner);
    assert_eq!(
        notes,
        vec![
            DispatchNote::Executed {
                plan: 1,
                step: 6,
                at: 20
            },
            DispatchNote::Executed {
                plan: 1,
                step: 4,
                at: 50
            },
            DispatchNote::Executed {
                plan: 1,
                step: 2,
                at: 110
            }
        ]
    );
    ready(&mut d, &executive, &[]);
    assert_eq!(
        d.poll(&mut executive, EPOCH + 110),
        ExecAnswer::Report(RoverReport::Finished)
    );
}

#[test]
fn a_step_never_ready_past_its_ub_asks_for_a_replan() {
    let net = small();
    let (mut executive, _planner) = loaded(&net);
    let mut d = Box::new(RoverDecider::new());
    d.plan_loaded(&mut executive, &note(1, &[(7, 6)])).unwrap();
    ready(&mut d, &executive, &[1]);
    assert_eq!(started(d.poll(&mut executive, EPOCH)).1, A);
    // B never ready: waits until just past its ub (400), then a replan naming it.
    ready(&mut d, &executive, &[]);
    match d.poll(&mut executive, EPOCH + 5) {
        ExecAnswer::Report(RoverReport::Wait { wake_ms, .. }) => {
            assert_eq!(wake_ms, Some(EPOCH + 401))
        }
        other => panic!("{other:?}"),
    }
    // At its ub, still a wait.
    assert!(matches!(
        d.poll(&mut executive, EPOCH + 400),
        ExecAnswer::Report(RoverReport::Wait { .. })
    ));
    // The replan names the step the dispatcher's whole poll names (what the mission's poll
    // reports): B's start past its ub leaves no schedule.
    let mut reference = Dispatcher::new(net.clone(), net.makespan + 500).unwrap();
    reference.executed(5, 0).unwrap();
    reference.executed(1, 0).unwrap();
    let Decision::Replan { step, ub } = reference.poll(401, &|_| false) else {
        panic!("the reference does not replan")
    };
    let s = net.step(step).unwrap();
    assert_eq!(
        d.poll(&mut executive, EPOCH + 401),
        ExecAnswer::Replan {
            at_ms: EPOCH + 401,
            why: RoverReplanWhy::PastUb {
                step: step as u16,
                action: s.action,
                end: s.end,
                ub_ms: EPOCH + ub
            }
        }
    );
    // Nothing is dispatched until the next plan.
    assert!(!d.has_plan());
    assert_eq!(
        d.poll(&mut executive, EPOCH + 402),
        ExecAnswer::Refused(RoverRefusal::NoMission)
    );
}

#[test]
fn bad_events_are_refused_and_change_nothing() {
    let net = small();
    let (mut executive, _planner) = loaded(&net);
    let mut d = Box::new(RoverDecider::new());
    // No plan yet; a note for a plan the executive does not hold.
    assert_eq!(
        d.poll(&mut executive, EPOCH),
        ExecAnswer::Refused(RoverRefusal::NoMission)
    );
    assert_eq!(
        d.plan_loaded(&mut executive, &note(2, &[])),
        Err(RoverRefusal::BadTask)
    );
    let mut over = note(1, &[]);
    over.running_len = MAX_ROVER_ACTIVE as u8 + 1;
    assert_eq!(
        d.plan_loaded(&mut executive, &over),
        Err(RoverRefusal::BadTask)
    );
    d.plan_loaded(&mut executive, &note(1, &[])).unwrap();
    ready(&mut d, &executive, &[1, 3]);
    assert_eq!(started(d.poll(&mut executive, EPOCH + 20)).1, A);
    // An end of an action not started, an end before the last event, a poll before it.
    assert_eq!(
        d.ended(&mut executive, B, EPOCH + 30),
        Err(RoverRefusal::NotRunning { action: B })
    );
    assert_eq!(
        d.ended(&mut executive, A, EPOCH + 10),
        Err(RoverRefusal::OutOfOrder {
            last_ms: EPOCH + 20
        })
    );
    assert_eq!(
        d.poll(&mut executive, EPOCH + 19),
        ExecAnswer::Refused(RoverRefusal::OutOfOrder {
            last_ms: EPOCH + 20
        })
    );
    // Nothing changed: B starts next, A's end is taken.
    ready(&mut d, &executive, &[3]);
    assert_eq!(started(d.poll(&mut executive, EPOCH + 20)).1, B);
    d.ended(&mut executive, A, EPOCH + 120).unwrap();
    assert_eq!(
        executive.dispatch().loaded().unwrap().1.executed_at(2),
        Some(120)
    );
}

#[test]
fn a_network_over_the_executives_chunks_is_not_taken_as_the_plan() {
    // 128 actions one after the other, with constraints enough to pass 112 chunks.
    let mut net = PlanNetwork::new();
    for a in 0..128u16 {
        let s = net
            .add_step(PlanStep {
                action: a,
                end: false,
                window: (0, UNBOUNDED),
            })
            .unwrap();
        net.add_step(PlanStep {
            action: a,
            end: true,
            window: (0, UNBOUNDED),
        })
        .unwrap();
        c(&mut net, s, s + 1, 10, UNBOUNDED);
        if s > 1 {
            c(&mut net, s - 1, s, 0, UNBOUNDED);
        }
    }
    while chunks(&net) <= usize::from(MAX_CHECKPOINTED_DISPATCH_CHUNKS) {
        c(&mut net, 0, 1, 0, UNBOUNDED);
    }
    net.makespan = 128 * 10;
    assert!(DispatchSender::check(&net).is_err());
    let mut executive = Box::new(ExecutivePartition::new());
    let mut planner = Box::new(PlannerPartition::new());
    let mut sender = DispatchSender::new(1, net.makespan + 500);
    assert_eq!(sender.pump(&net, &mut planner), 0, "none of it is sent");
    assert!(exchange(&mut executive, &mut planner).is_empty());
    let mut d = Box::new(RoverDecider::new());
    assert_eq!(
        d.plan_loaded(&mut executive, &note(1, &[])),
        Err(RoverRefusal::BadTask)
    );
    assert!(!d.has_plan());
}

#[test]
fn the_deciders_record_restores_it_and_a_damaged_one_is_refused() {
    let net = small();
    let (mut executive, _planner) = loaded(&net);
    let mut d = Box::new(RoverDecider::new());
    d.plan_loaded(&mut executive, &note(1, &[(7, 6)])).unwrap();
    ready(&mut d, &executive, &[1]);
    assert_eq!(started(d.poll(&mut executive, EPOCH)).1, A);
    ready(&mut d, &executive, &[]);
    let wait = d.poll(&mut executive, EPOCH + 5);
    let mut buf = vec![0u8; RECORD_MAX_BYTES];
    let n = d.encode(net.step_count(), &mut buf).unwrap();
    assert!(
        d.encode(net.step_count(), &mut buf[..n - 1]).is_none(),
        "too small"
    );
    let record = buf[..n].to_vec();
    // Restored: the same answers as the one that wrote it (with the mask sent again).
    let mut back = Box::new(RoverDecider::new());
    assert_eq!(back.decode(&record), Ok(n));
    assert!(back.has_plan());
    let mut twin = executive.clone();
    ready(&mut back, &twin, &[3]);
    ready(&mut d, &executive, &[3]);
    assert_eq!(
        back.poll(&mut twin, EPOCH + 5),
        d.poll(&mut executive, EPOCH + 5)
    );
    assert!(matches!(wait, ExecAnswer::Report(RoverReport::Wait { .. })));
    assert_eq!(
        back.ended(&mut twin, A, EPOCH + 100),
        d.ended(&mut executive, A, EPOCH + 100)
    );
    // Damaged: every byte flipped in turn is refused, and leaves the decider as it was.
    for i in 0..n {
        let mut bad = record.clone();
        bad[i] ^= 0x5a;
        let mut fresh = Box::new(RoverDecider::new());
        let r = fresh.decode(&bad);
        assert!(
            matches!(
                r,
                Err(RecordError::BadCrc
                    | RecordError::Version
                    | RecordError::BadLength
                    | RecordError::OutOfRange)
            ),
            "byte {i}: {r:?}"
        );
        assert!(!fresh.has_plan(), "byte {i}: nothing taken");
    }
    assert_eq!(back.decode(&record[..n - 1]), Err(RecordError::BadLength));
    let mut other = record.clone();
    other[0] = 9;
    assert_eq!(back.decode(&other), Err(RecordError::Version));
    // Random bytes never panic.
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    let mut fresh = Box::new(RoverDecider::new());
    for len in 0..600 {
        let bytes: Vec<u8> = (0..len)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                x as u8
            })
            .collect();
        let _ = fresh.decode(&bytes);
    }
}

#[test]
fn a_mask_from_before_the_last_happening_is_not_polled_with() {
    let net = small();
    let (mut executive, _planner) = loaded(&net);
    let mut d = Box::new(RoverDecider::new());
    d.plan_loaded(&mut executive, &note(1, &[(7, 6)])).unwrap();
    // No mask since the plan was loaded: busy.
    assert_eq!(
        d.poll(&mut executive, EPOCH),
        ExecAnswer::Refused(RoverRefusal::Busy)
    );
    // The mask after the completion's start (1 step executed).
    d.set_ready(&executive, &mask(&[1, 3]), 1);
    assert_eq!(started(d.poll(&mut executive, EPOCH)).1, A);
    // A start the planner has not applied yet: its old mask (stamp 1) is not used, nothing
    // changes, and the poll goes on once the mask after the start (stamp 2) comes.
    assert_eq!(
        d.poll(&mut executive, EPOCH + 1),
        ExecAnswer::Refused(RoverRefusal::Busy)
    );
    d.set_ready(&executive, &mask(&[1, 3]), 1);
    assert_eq!(
        d.poll(&mut executive, EPOCH + 1),
        ExecAnswer::Refused(RoverRefusal::Busy)
    );
    assert!(executive
        .dispatch()
        .loaded()
        .unwrap()
        .1
        .executed_at(3)
        .is_none());
    d.set_ready(&executive, &mask(&[3]), 2);
    assert_eq!(started(d.poll(&mut executive, EPOCH + 1)).1, B);
    // An end the executive took: busy until the mask after it.
    d.ended(&mut executive, 7, EPOCH + 20).unwrap();
    d.set_ready(&executive, &mask(&[]), 3);
    assert_eq!(
        d.poll(&mut executive, EPOCH + 20),
        ExecAnswer::Refused(RoverRefusal::Busy)
    );
    d.set_ready(&executive, &mask(&[]), 4);
    assert!(matches!(
        d.poll(&mut executive, EPOCH + 20),
        ExecAnswer::Report(RoverReport::Wait { .. })
    ));
}

//! The rover's real plans through the partitions' checkpointed channel to the executive (issue
//! 13 item 3): long-day's network (thirty objectives: 71 actions, 142 steps as these tests plan it) and
//! sahara-day's first plan sent in
//! chunks from the planner partition, held whole by the executive, whose dispatcher then decides
//! as the planner partition's own does, poll for poll, with ends on time, early and late,
//! while the executive is restored from its checkpoint every third poll; each executed step
//! comes back to the planner with its time.
mod common;

use common::rover::{long_rover, plan_task, rover};

use autonomy::partitioned::{
    DispatchNote, DispatchSender, ExecutivePartition, PlannerPartition,
    MAX_DISPATCH_CHUNKS_PER_WINDOW,
};
use temporal::dispatch::{Decision, Dispatcher, PlanNetwork};
use temporal::dispatch_wire::chunks;
use temporal::replan;
use temporal::Task;

/// Work units of one call of the executive's divided poll (`Dispatcher::poll_continue`).
const SLICE_UNITS: u32 = 256;

/// One window each way, as a frame hands the ports over.
fn exchange(executive: &mut ExecutivePartition, planner: &mut PlannerPartition) {
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
}

/// The executive restored from its own checkpoint (a warm reset between two windows).
fn restored(executive: &ExecutivePartition) -> Box<ExecutivePartition> {
    let mut buf = vec![0u8; 512 * 1024];
    let n = executive.encode_state(&mut buf).expect("encodes");
    let mut back = Box::new(ExecutivePartition::new());
    back.decode_state(&buf[..n]).expect("restores");
    back
}

/// The size of the executive's checkpoint (empty MEXEC side) holding `net`.
fn checkpoint_bytes(executive: &ExecutivePartition) -> usize {
    let mut buf = vec![0u8; 512 * 1024];
    executive.encode_state(&mut buf).expect("encodes")
}

fn through_the_channel(problem: (String, String), least_actions: usize) {
    let (d, p) = problem;
    let compiled = common::compile(&d, &p).expect("compiles");
    let task = Task::parse(&compiled.task).unwrap();
    let plan = plan_task(task).expect("a plan");
    assert!(plan.len() >= least_actions, "{} actions", plan.len());
    let mut scratch = vec![0u32; task.fact_count() + task.numeric_count()];
    let mut net = PlanNetwork::new();
    replan::network_from_plan(&task, &plan, true, &mut scratch, &mut net).expect("network");
    let horizon = net.makespan + 30_000;

    let mut executive = Box::new(ExecutivePartition::new());
    let mut planner = Box::new(PlannerPartition::new());
    let empty = checkpoint_bytes(&executive);
    let mut sender = DispatchSender::new(1, horizon);
    let mut windows = 0;
    while !sender.done(&net) {
        sender.pump(&net, &mut planner);
        exchange(&mut executive, &mut planner);
        windows += 1;
    }
    exchange(&mut executive, &mut planner);
    assert_eq!(
        windows,
        chunks(&net).div_ceil(MAX_DISPATCH_CHUNKS_PER_WINDOW)
    );
    assert_eq!(
        planner.take_dispatch_notes().as_slice(),
        &[DispatchNote::Loaded { plan: 1 }]
    );
    let held = executive.dispatch().loaded().expect("held").1.network();
    assert_eq!(held.constraints(), net.constraints());
    assert_eq!(held.makespan, net.makespan);
    for k in 1..=net.step_count() {
        assert_eq!(held.step(k), net.step(k));
    }
    println!(
        "{} steps, {} constraints: {} chunks in {windows} windows; the executive's checkpoint {} bytes ({} with nothing held)",
        net.step_count(),
        net.constraints().len(),
        chunks(&net),
        checkpoint_bytes(&executive),
        empty
    );

    // The executive's dispatcher against the planner partition's own, ends on time, a tenth
    // early and a tenth late by turns.
    let mut reference = Dispatcher::new(net.clone(), horizon).expect("consistent");
    let mut now = 0u32;
    let mut ends: Vec<(u32, usize)> = Vec::new();
    let mut executed: Vec<(u16, u32)> = Vec::new();
    let mut notes: Vec<(u16, u32)> = Vec::new();
    let (mut starts, mut polls, mut restores) = (0usize, 0usize, 0usize);
    let execute = |executive: &mut ExecutivePartition,
                   reference: &mut Dispatcher,
                   executed: &mut Vec<(u16, u32)>,
                   k: usize,
                   at: u32| {
        executive.dispatch_executed(k as u16, at).unwrap();
        reference.executed(k, at).unwrap();
        executed.push((k as u16, at));
    };
    // The executive's polls divided across calls of `SLICE_UNITS` units (its cycles), the
    // reference's whole.
    let (mut most_units, mut most_calls) = (0u32, 0usize);
    for _ in 0..8 * net.step_count() {
        let d = executive.dispatcher_mut().unwrap();
        d.poll_begin(now);
        let mut calls = 0;
        let ours = loop {
            calls += 1;
            if let Some(decision) = d.poll_continue(&|_| true, SLICE_UNITS) {
                break decision;
            }
        };
        most_units = most_units.max(d.poll_units());
        most_calls = most_calls.max(calls);
        assert_eq!(ours, reference.poll(now, &|_| true), "at {now}");
        // (Finished works nothing out: the windows are those of each one's last poll, or of
        // the executive's restore.)
        for k in (0..=net.step_count()).filter(|_| ours != Decision::Finished) {
            assert_eq!(
                executive.dispatch().loaded().unwrap().1.window(k),
                reference.window(k),
                "step {k} at {now} after {polls} polls: {ours:?}"
            );
        }
        polls += 1;
        match ours {
            Decision::Start { step, action } => {
                execute(&mut executive, &mut reference, &mut executed, step, now);
                let planned = plan
                    .iter()
                    .find(|p| p.action == action)
                    .map_or(1000, |p| p.duration);
                let took = match starts % 3 {
                    0 => planned,
                    1 => planned - planned / 10,
                    _ => planned + planned / 10,
                };
                ends.push((now + took, reference.network().end_of(step).unwrap()));
                starts += 1;
            }
            Decision::Wait { until } => {
                ends.sort();
                let next = match (until, ends.first().map(|e| e.0)) {
                    (Some(u), Some(e)) => u.min(e),
                    (a, b) => match a.or(b) {
                        Some(t) => t,
                        None => break,
                    },
                };
                now = next.max(now);
                while ends.first().is_some_and(|e| e.0 <= now) {
                    let (t, k) = ends.remove(0);
                    execute(&mut executive, &mut reference, &mut executed, k, t);
                }
            }
            Decision::Finished => break,
            Decision::Replan { step, ub } => panic!("replan at step {step} (ub {ub}) at {now}"),
        }
        exchange(&mut executive, &mut planner);
        notes.extend(planner.take_dispatch_notes().iter().map(|n| match *n {
            DispatchNote::Executed { plan: 1, step, at } => (step, at),
            other => panic!("{other:?}"),
        }));
        if polls % 3 == 0 {
            executive = restored(&executive);
            restores += 1;
        }
    }
    println!(
        "{polls} polls; the costliest {most_units} units, {most_calls} calls of {SLICE_UNITS}"
    );
    assert!(most_units > 0 && most_calls > 1, "polls divided");
    assert_eq!(executed.len(), net.step_count(), "every step executed");
    assert_eq!(notes, executed);
    assert!(restores >= 3, "{restores} restores");
}

#[test]
fn long_days_network_goes_to_the_executive_and_is_dispatched_there_as_in_the_planner() {
    through_the_channel(long_rover(30), 60);
}

#[test]
fn sahara_days_first_plan_goes_to_the_executive_and_is_dispatched_there_as_in_the_planner() {
    through_the_channel(rover(), 5);
}

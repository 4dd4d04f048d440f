//! The uplink's element readers read the small fields (counts and ids as `u16` varints,
//! `u8`s, option tags, booleans) by hand instead of through postcard's deserializer: they
//! accept exactly what postcard's derived decoders accept, with the same value and the same
//! rest. Checked on every task and timeline of the flyby network (which has options present
//! and absent, ids, priorities, permissions) with every byte replaced by each of the values
//! where a varint, a tag or a boolean changes meaning, and cut at every length.
mod common;
use autonomy::model::{
    ConstraintSpec, ConstraintWhen, Effect, ImpactSpec, ImpactWhen, Requirement, TaskRole,
    TaskSpec, TimelineSpec,
};
use autonomy::uplink::{take_task, take_timeline};

/// Byte values at the edges: 0, 1, 2 (a bad tag or boolean), 3 and 4 (the largest third byte
/// of a `u16` varint and the first too large), 0x7F, 0x80 (a continuation), 0xFF.
const EDGES: [u8; 8] = [0, 1, 2, 3, 4, 0x7F, 0x80, 0xFF];

fn encode<T: serde::Serialize>(value: &T) -> Vec<u8> {
    let mut buf = vec![0u8; 4096];
    let n = postcard::to_slice(value, &mut buf).unwrap().len();
    buf.truncate(n);
    buf
}

fn variants(bytes: &[u8]) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    for i in 0..bytes.len() {
        for v in EDGES {
            let mut b = bytes.to_vec();
            b[i] = v;
            out.push(b);
        }
        out.push(bytes[..i].to_vec());
    }
    // A three-byte u16 varint (the largest and one over) where the task's id starts.
    for third in [0x03u8, 0x04] {
        let mut b = vec![0xFF, 0xFF, third];
        b.extend_from_slice(bytes.get(1..).unwrap_or(&[]));
        out.push(b);
    }
    out
}

/// The flyby's tasks, and one with every kind of requirement and effect (the flyby's
/// constraints and impacts need not use them all).
fn tasks() -> Vec<TaskSpec> {
    let mut tasks = common::flyby_spec().tasks.to_vec();
    let mut every = tasks[0].clone();
    every.constraints.clear();
    every.impacts.clear();
    for (i, require) in [
        Requirement::OneOf { mask: 0x8000_0001 },
        Requirement::Range {
            min: -5,
            max: 1 << 40,
        },
    ]
    .into_iter()
    .enumerate()
    {
        let when = [ConstraintWhen::Pre, ConstraintWhen::Maintain][i];
        every
            .constraints
            .push(ConstraintSpec {
                when,
                timeline: 1,
                require,
                start_offset_us: -3,
                end_offset_us: 1 << 35,
            })
            .unwrap();
    }
    for (i, effect) in [
        Effect::Assign(-1),
        Effect::Add(300),
        Effect::Rate(-(1 << 33)),
        Effect::Claim,
    ]
    .into_iter()
    .enumerate()
    {
        let when = [ImpactWhen::Pre, ImpactWhen::Maintain, ImpactWhen::Post][i % 3];
        every
            .impacts
            .push(ImpactSpec {
                when,
                timeline: 2,
                effect,
                start_offset_us: 7,
                end_offset_us: -7,
            })
            .unwrap();
    }
    every.role = TaskRole::Template;
    tasks.push(every);
    tasks
}

#[test]
fn task_reader_agrees_with_postcard_on_every_mutation() {
    let mut checked = 0;
    let mut accepted = 0;
    for task in &tasks() {
        let bytes = encode(task);
        assert_eq!(take_task(&bytes, 0).unwrap(), (task.clone(), &[][..]));
        for b in variants(&bytes) {
            let derived = postcard::take_from_bytes::<TaskSpec>(&b).ok();
            let ours = take_task(&b, 0).ok();
            accepted += usize::from(ours.is_some());
            assert_eq!(ours, derived, "task {} mutated: {b:02x?}", task.id);
            checked += 1;
        }
    }
    assert!(checked > 1000 && accepted > 100, "{checked} {accepted}");
}

#[test]
fn timeline_reader_agrees_with_postcard_on_every_mutation() {
    let spec = common::flyby_spec();
    let mut checked = 0;
    for timeline in &spec.timelines {
        let bytes = encode(timeline);
        assert_eq!(
            take_timeline(&bytes, 0).unwrap(),
            (timeline.clone(), &[][..])
        );
        for b in variants(&bytes) {
            let derived = postcard::take_from_bytes::<TimelineSpec>(&b).ok();
            assert_eq!(take_timeline(&b, 0).ok(), derived, "mutated: {b:02x?}");
            checked += 1;
        }
    }
    assert!(checked > 100, "{checked}");
}

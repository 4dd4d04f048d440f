//! A restored checkpoint is validated like an uplink (issue 15): a record whose CRC is right but
//! whose payload is inconsistent is refused with a typed error naming the defect and where it
//! is, and the core comes up from the other slot or cold, never with a corrupt plan.
//!
//! The payloads are real checkpoints of the flyby (taken after the reset at 10:30 has been
//! repaired, so the plan has requested, added and restarted instances and the executive is
//! running a command), decoded into a mirror of the payload layout, damaged in one field, and
//! encoded again.
mod common;
use autonomy::checkpoint::{PayloadDefect, PayloadError, PayloadSite, MAX_RESTORED_TIME_US};
use autonomy::condition::StateEntry;
use autonomy::executive::{ExecEntry, ExecutiveStats};
use autonomy::plan::{Origin, PlanEntry};
use autonomy::planner::{FailureLedger, PlannerStats, TaskReport};
use autonomy::timeline::{Measurement, TimelineAnchor};
use autonomy::*;
use common::*;
use serde::{Deserialize, Serialize};

/// Room for one item more than any list of a saved core holds.
type List<T> = heapless::Vec<T, { autonomy::MAX_PLAN_ENTRIES + 1 }>;

/// The payload's header part (`ImageMeta` in the core).
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Meta {
    loaded: bool,
    now: MissionTimeUs,
    state_type_mismatches: u32,
    last_state_type_mismatch: Option<StateKey>,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
enum Phase {
    Idle,
    Consolidate,
    Schedule,
    Repair,
}

/// The planner as it is saved (every field but its scratch buffer, in order).
#[derive(Clone, Debug, Serialize, Deserialize)]
struct SavedPlanner {
    entries: List<PlanEntry>,
    anchors: List<TimelineAnchor>,
    next_instance: u16,
    phase: Phase,
    dirty: bool,
    last_cycle_at: Option<MissionTimeUs>,
    attempted: List<u16>,
    placed_in_pass: bool,
    passes: u8,
    tried: List<(u16, u8)>,
    reports: List<TaskReport>,
    ledger: List<FailureLedger>,
    stats: PlannerStats,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
struct SavedExecutive {
    entries: List<ExecEntry>,
    responses: List<(u32, CommandStatus)>,
    next_command_id: u32,
    stats: ExecutiveStats,
}

/// A checkpoint payload taken apart.
#[derive(Clone, Debug)]
struct Payload {
    meta: Meta,
    network: Vec<u8>,
    planner: SavedPlanner,
    executive: SavedExecutive,
    states: List<StateEntry>,
}

impl Payload {
    fn decode(bytes: &[u8]) -> Self {
        let (meta, rest) = postcard::take_from_bytes(bytes).unwrap();
        let (len, rest) = rest.split_at(4);
        let len = u32::from_be_bytes(len.try_into().unwrap()) as usize;
        let (network, rest) = rest.split_at(len);
        let (planner, rest) = postcard::take_from_bytes(rest).unwrap();
        let (executive, rest) = postcard::take_from_bytes(rest).unwrap();
        let (states, rest) = postcard::take_from_bytes(rest).unwrap();
        assert!(rest.is_empty());
        Self {
            meta,
            network: network.to_vec(),
            planner,
            executive,
            states,
        }
    }

    fn encode(&self) -> Vec<u8> {
        let mut buf = vec![0u8; 64 * 1024];
        let mut len = postcard::to_slice(&self.meta, &mut buf).unwrap().len();
        buf[len..len + 4].copy_from_slice(&(self.network.len() as u32).to_be_bytes());
        len += 4;
        buf[len..len + self.network.len()].copy_from_slice(&self.network);
        len += self.network.len();
        len += postcard::to_slice(&self.planner, &mut buf[len..])
            .unwrap()
            .len();
        len += postcard::to_slice(&self.executive, &mut buf[len..])
            .unwrap()
            .len();
        len += postcard::to_slice(&self.states, &mut buf[len..])
            .unwrap()
            .len();
        buf.truncate(len);
        buf
    }
}

/// The flyby after the reset at 10:30 has been repaired (10:40): its checkpoint payload.
fn repaired_flyby_payload() -> Vec<u8> {
    let mut sim = Sim::flyby();
    sim.run(
        hm(10, 40),
        &[Reset {
            at: hm(10, 30),
            recovery_us: 3 * MIN,
        }],
    );
    let area = WarmRestartArea::new(&mut sim.area);
    area.latest().unwrap().2.to_vec()
}

fn restore(bytes: &[u8]) -> Result<(), PayloadError> {
    let mut core = Box::new(Autonomy::new());
    core.decode_state(bytes)
}

/// The refusal of the flyby's payload with `damage` applied.
fn refusal(damage: impl FnOnce(&mut Payload)) -> PayloadError {
    let mut p = Payload::decode(&repaired_flyby_payload());
    damage(&mut p);
    restore(&p.encode()).expect_err("damaged payload refused")
}

fn error(defect: PayloadDefect, site: PayloadSite) -> PayloadError {
    PayloadError::new(defect, site)
}

fn plan_index(p: &Payload, what: impl Fn(&PlanEntry) -> bool) -> usize {
    p.planner
        .entries
        .iter()
        .position(what)
        .expect("the repaired flyby has such an entry")
}

fn entry_site(i: usize) -> PayloadSite {
    PayloadSite::PlanEntry(i as u16)
}

#[test]
fn the_repaired_flyby_checkpoint_has_every_kind_of_entry_and_restores_unchanged() {
    let bytes = repaired_flyby_payload();
    let p = Payload::decode(&bytes);
    assert_eq!(p.encode(), bytes, "the mirror matches the payload layout");
    let origins = |f: fn(&Origin) -> bool| p.planner.entries.iter().any(|e| f(&e.origin));
    assert!(origins(|o| *o == Origin::Requested));
    assert!(origins(|o| matches!(o, Origin::Added { .. })));
    assert!(origins(|o| matches!(o, Origin::Restarted { .. })));
    assert!(p
        .executive
        .entries
        .iter()
        .any(|e| e.state == TaskState::Dispatched));
    assert!(!p.states.is_empty());
    restore(&bytes).expect("an undamaged checkpoint restores");
}

#[test]
fn payloads_that_do_not_decode_are_refused_with_the_part_they_are_in() {
    let bytes = repaired_flyby_payload();
    let p = Payload::decode(&bytes);
    let mut buf = vec![0u8; 64 * 1024];
    let meta_len = postcard::to_slice(&p.meta, &mut buf).unwrap().len();
    let planner_start = meta_len + 4 + p.network.len();
    let planner_len = postcard::to_slice(&p.planner, &mut buf).unwrap().len();
    let cut = |at: usize| restore(&bytes[..at]).unwrap_err();
    assert_eq!(cut(2), error(PayloadDefect::Decode, PayloadSite::Meta));
    assert_eq!(
        cut(meta_len + 4 + p.network.len() / 2),
        error(PayloadDefect::Decode, PayloadSite::Network)
    );
    assert_eq!(
        cut(planner_start + planner_len / 2),
        error(PayloadDefect::Decode, PayloadSite::Planner)
    );
    assert_eq!(
        cut(bytes.len() - 1),
        error(PayloadDefect::Decode, PayloadSite::States)
    );
    let mut trailing = bytes.clone();
    trailing.push(0);
    assert_eq!(
        restore(&trailing),
        Err(error(PayloadDefect::TrailingBytes, PayloadSite::End))
    );
    // A list over its capacity does not decode: MAX_PLAN_ENTRIES + 1 plan entries.
    let e = refusal(|p| {
        let first = p.planner.entries[0];
        p.planner
            .entries
            .resize(MAX_PLAN_ENTRIES + 1, first)
            .unwrap();
    });
    assert_eq!(e, error(PayloadDefect::Decode, PayloadSite::Planner));
}

#[test]
fn a_network_that_fails_the_uplink_validation_is_refused_with_its_validation_error() {
    let e = refusal(|p| p.network[0] = 9); // format version
    assert_eq!(e.site, PayloadSite::Network);
    match e.defect {
        PayloadDefect::InvalidNetwork(v) => assert_eq!(v.code, ValidationCode::FormatVersion),
        other => panic!("{other:?}"),
    }
    // A length prefix past the end of the payload.
    let e = refusal(|p| p.network.clear());
    assert_eq!(e.site, PayloadSite::Network);
}

#[test]
fn lists_sized_by_the_network_must_have_its_size() {
    use PayloadDefect::CountMismatch;
    assert_eq!(
        refusal(|p| {
            p.planner.anchors.pop();
        }),
        error(CountMismatch, PayloadSite::Planner)
    );
    assert_eq!(
        refusal(|p| {
            let l = p.planner.ledger[0];
            p.planner.ledger.push(l).unwrap();
        }),
        error(CountMismatch, PayloadSite::Planner)
    );
}

#[test]
fn entries_naming_a_missing_or_wrong_definition_are_refused() {
    use PayloadDefect::*;
    let p = Payload::decode(&repaired_flyby_payload());
    let requested = plan_index(&p, |e| e.origin == Origin::Requested);
    let added = plan_index(&p, |e| matches!(e.origin, Origin::Added { .. }));
    assert_eq!(
        refusal(|p| p.planner.entries[requested].def = 6),
        error(DanglingDefinition, entry_site(requested))
    );
    assert_eq!(
        refusal(|p| p.executive.entries[0].def = 200),
        error(DanglingDefinition, PayloadSite::ExecEntry(0))
    );
    // A requested instance of a template, or with another definition's ground id.
    assert_eq!(
        refusal(|p| p.planner.entries[requested].def = 4),
        error(WrongDefinition, entry_site(requested))
    );
    assert_eq!(
        refusal(|p| p.planner.entries[requested].instance += 1),
        error(WrongDefinition, entry_site(requested))
    );
    // Two requested instances of one definition: the second is refused.
    let e = refusal(|p| {
        let twin = p.planner.entries[requested];
        p.planner.entries.push(twin).unwrap();
    });
    assert_eq!(
        e,
        error(WrongDefinition, entry_site(p.planner.entries.len()))
    );
    // An added instance of a requested definition.
    assert_eq!(
        refusal(|p| p.planner.entries[added].def = 0),
        error(WrongDefinition, entry_site(added))
    );
}

#[test]
fn an_executive_entry_must_be_a_committed_or_running_instance_of_the_plan() {
    use PayloadDefect::NotInPlan;
    assert_eq!(
        refusal(|p| p.executive.entries[0].instance = 0x7777),
        error(NotInPlan, PayloadSite::ExecEntry(0))
    );
    // Its plan entry finished already.
    let e = refusal(|p| {
        let instance = p.executive.entries[0].instance;
        let i = plan_index(p, |e| e.instance == instance);
        p.planner.entries[i].state = TaskState::Completed;
    });
    assert_eq!(e, error(NotInPlan, PayloadSite::ExecEntry(0)));
}

#[test]
fn ids_and_indices_out_of_their_range_are_refused() {
    use PayloadDefect::*;
    let p = Payload::decode(&repaired_flyby_payload());
    let restarted = plan_index(&p, |e| matches!(e.origin, Origin::Restarted { .. }));
    assert_eq!(
        refusal(|p| p.planner.next_instance = 5),
        error(IdOutOfRange, PayloadSite::Planner)
    );
    assert_eq!(
        refusal(|p| p.planner.entries[restarted].instance = ID_FLYBY),
        error(IdOutOfRange, entry_site(restarted))
    );
    assert_eq!(
        refusal(|p| p.executive.next_command_id = 0),
        error(IdOutOfRange, PayloadSite::Executive)
    );
    assert_eq!(
        refusal(|p| p
            .planner
            .tried
            .push((ID_FLYBY, MAX_CONSTRAINTS_PER_TASK as u8))
            .unwrap()),
        error(IndexOutOfRange, PayloadSite::Tried(0))
    );
}

#[test]
fn times_out_of_range_are_refused_and_never_is_accepted() {
    use PayloadDefect::TimeOutOfRange;
    let late = MissionTimeUs(MAX_RESTORED_TIME_US + 1);
    assert_eq!(
        refusal(|p| p.meta.now = late),
        error(TimeOutOfRange, PayloadSite::Meta)
    );
    assert_eq!(
        refusal(|p| p.planner.entries[1].end = late),
        error(TimeOutOfRange, entry_site(1))
    );
    assert_eq!(
        refusal(|p| p.planner.anchors[2].at = late),
        error(TimeOutOfRange, PayloadSite::Anchor(2))
    );
    assert_eq!(
        refusal(|p| { p.planner.anchors[0].measured = Some(Measurement { value: 1, at: late }) }),
        error(TimeOutOfRange, PayloadSite::Anchor(0))
    );
    assert_eq!(
        refusal(|p| p.planner.ledger[3].not_before = late),
        error(TimeOutOfRange, PayloadSite::Ledger(3))
    );
    assert_eq!(
        refusal(|p| p.executive.entries[0].retry_at = late),
        error(TimeOutOfRange, PayloadSite::ExecEntry(0))
    );
    assert_eq!(
        refusal(|p| p.states[0].at = late),
        error(TimeOutOfRange, PayloadSite::StateEntry(0))
    );
    assert_eq!(
        refusal(|p| p.planner.last_cycle_at = Some(late)),
        error(TimeOutOfRange, PayloadSite::Planner)
    );
    assert_eq!(
        refusal(|p| {
            p.planner
                .reports
                .push(TaskReport {
                    instance: ID_FLYBY,
                    kind: autonomy::planner::ReportKind::Started,
                    at: late,
                })
                .unwrap()
        }),
        error(TimeOutOfRange, PayloadSite::Report(0))
    );
    // Durations: an executive entry longer than its definition (found by the checkpoint fuzz
    // target: its end, once started, left the range), a plan entry that ends before it starts
    // or spans more than its definition.
    assert_eq!(
        refusal(|p| p.executive.entries[1].duration_us = u64::MAX / 2),
        error(TimeOutOfRange, PayloadSite::ExecEntry(1))
    );
    let scheduled = {
        let p = Payload::decode(&repaired_flyby_payload());
        plan_index(&p, |e| e.state == TaskState::Scheduled)
    };
    assert_eq!(
        refusal(|p| p.planner.entries[scheduled].end.0 += 1),
        error(TimeOutOfRange, entry_site(scheduled))
    );
    assert_eq!(
        refusal(|p| {
            let e = &mut p.planner.entries[scheduled];
            e.end = MissionTimeUs(e.start.0 - 1);
        }),
        error(TimeOutOfRange, entry_site(scheduled))
    );
    // "Never" is a time the plan holds (latest starts of restarted instances).
    let mut p = Payload::decode(&repaired_flyby_payload());
    p.planner.entries[0].latest_start = MissionTimeUs::MAX;
    p.planner.entries[0].earliest_start = MissionTimeUs(MAX_RESTORED_TIME_US);
    assert_eq!(restore(&p.encode()), Ok(()));
}

#[test]
fn states_the_core_never_reaches_are_refused() {
    use PayloadDefect::ImpossibleState;
    let p = Payload::decode(&repaired_flyby_payload());
    let scheduled = plan_index(&p, |e| e.state == TaskState::Scheduled);
    // An executive state in the plan; a started flag on a task not started.
    assert_eq!(
        refusal(|p| p.planner.entries[scheduled].state = TaskState::Dispatched),
        error(ImpossibleState, entry_site(scheduled))
    );
    assert_eq!(
        refusal(|p| p.planner.entries[scheduled].started = true),
        error(ImpossibleState, entry_site(scheduled))
    );
    // A finished task still in the executive; a dispatch without a command id; a no-op task
    // with one; an interrupted task that was never dispatched.
    let d = p
        .executive
        .entries
        .iter()
        .position(|e| e.state == TaskState::Dispatched)
        .unwrap();
    let no_op = p
        .executive
        .entries
        .iter()
        .position(|e| e.state == TaskState::Running && e.command_id == 0)
        .unwrap();
    let exec = |i: usize| PayloadSite::ExecEntry(i as u16);
    assert_eq!(
        refusal(|p| p.executive.entries[d].state = TaskState::Completed),
        error(ImpossibleState, exec(d))
    );
    assert_eq!(
        refusal(|p| p.executive.entries[d].command_id = 0),
        error(ImpossibleState, exec(d))
    );
    assert_eq!(
        refusal(|p| p.executive.entries[no_op].command_id = 12),
        error(ImpossibleState, exec(no_op))
    );
    assert_eq!(
        refusal(|p| {
            p.executive.entries[d].state = TaskState::WaitingPre;
            p.executive.entries[d].interrupted = true;
        }),
        error(ImpossibleState, exec(d))
    );
    // A plan without a loaded network.
    assert_eq!(
        refusal(|p| p.meta.loaded = false),
        error(ImpossibleState, PayloadSite::Meta)
    );
    // Given up on a cause the planner never counts (unschedulable).
    assert_eq!(
        refusal(|p| p.planner.ledger[2].gave_up = FailureKind::Unschedulable.bit()),
        error(ImpossibleState, PayloadSite::Ledger(2))
    );
}

#[test]
fn counts_over_their_bound_are_refused() {
    use PayloadDefect::CountOutOfRange;
    for passes in [3, 255] {
        assert_eq!(
            refusal(|p| p.planner.passes = passes),
            error(CountOutOfRange, PayloadSite::Planner),
            "{passes} scheduling passes"
        );
    }
    // The flyby network allows no retries: one retry of a command failure is over the bound.
    assert_eq!(
        refusal(|p| p.executive.entries[0]
            .retries
            .set(FailureKind::CommandFailed, 1)),
        error(CountOutOfRange, PayloadSite::ExecEntry(0))
    );
    assert_eq!(
        refusal(|p| p.planner.ledger[1]
            .consecutive
            .set(FailureKind::Unschedulable, 1)),
        error(CountOutOfRange, PayloadSite::Ledger(1))
    );
}

#[test]
fn timeline_values_their_timeline_cannot_hold_are_refused() {
    use PayloadDefect::ValueOutOfRange;
    let attitude = PayloadSite::Anchor(TL_ATTITUDE.into());
    assert_eq!(
        refusal(|p| p.planner.anchors[TL_ATTITUDE as usize].value = 5), // 5 values: 0..=4
        error(ValueOutOfRange, attitude)
    );
    assert_eq!(
        refusal(|p| {
            p.planner.anchors[TL_ATTITUDE as usize].measured = Some(Measurement {
                value: -2,
                at: hm(10, 0),
            })
        }),
        error(ValueOutOfRange, attitude)
    );
    assert_eq!(
        refusal(|p| p.planner.anchors[TL_ATTITUDE as usize].rate = 1),
        error(ValueOutOfRange, attitude)
    );
    assert_eq!(
        refusal(|p| p.planner.anchors[TL_INSTRUMENT as usize].rate = -1),
        error(ValueOutOfRange, PayloadSite::Anchor(TL_INSTRUMENT.into()))
    );
    // Unknown is a value every timeline can hold; a rate on a cumulative one is fine.
    let mut p = Payload::decode(&repaired_flyby_payload());
    p.planner.anchors[TL_ATTITUDE as usize].value = i64::MIN;
    p.planner.anchors[TL_REQUEST as usize].rate = 7;
    assert_eq!(restore(&p.encode()), Ok(()));
}

#[test]
fn a_state_key_twice_in_the_state_buffer_is_refused() {
    let e = refusal(|p| {
        let again = p.states[0];
        p.states.push(again).unwrap();
    });
    let last = PayloadSite::StateEntry(1);
    assert_eq!(e, error(PayloadDefect::DuplicateKey, last));
}

/// Writes `payloads` as successive records of a fresh area.
fn area_with(payloads: &[&[u8]]) -> Vec<u8> {
    let mut bytes = vec![0u8; WARM_AREA_LEN];
    let mut area = WarmRestartArea::new(&mut bytes);
    for p in payloads {
        area.write(|buf| {
            buf[..p.len()].copy_from_slice(p);
            Some(p.len())
        })
        .unwrap();
    }
    bytes
}

#[test]
fn a_refused_newest_record_falls_back_to_the_other_slot() {
    let good = repaired_flyby_payload();
    let mut damaged = Payload::decode(&good);
    damaged.planner.passes = 9;
    let damaged = damaged.encode();
    // Slot A (sequence 1) good, slot B (sequence 2, newest) damaged.
    let mut bytes = area_with(&[&good, &damaged]);
    let area = WarmRestartArea::new(&mut bytes);
    let mut core = Box::new(Autonomy::new());
    let info = core.restore_from(&area).expect("the older slot restores");
    assert_eq!((info.slot, info.sequence), (0, 1));
    assert!(!core.plan().is_empty());
    // And the restored core runs on.
    let mut out = Recorder::default();
    core.step(hm(10, 41), StepBudget::UNLIMITED, &mut out);
}

#[test]
fn with_every_record_refused_the_core_comes_up_cold_and_says_why() {
    let mut damaged = Payload::decode(&repaired_flyby_payload());
    damaged.executive.next_command_id = 0;
    let damaged = damaged.encode();
    let mut older = Payload::decode(&repaired_flyby_payload());
    older.planner.entries[0].def = 99;
    let older = older.encode();
    let mut bytes = area_with(&[&older, &damaged]);
    let area = WarmRestartArea::new(&mut bytes);
    let mut core = Box::new(Autonomy::new());
    let e = core.restore_from(&area).unwrap_err();
    // The newest record's refusal is the one reported.
    assert_eq!(
        e,
        CheckpointError::BadPayload(error(PayloadDefect::IdOutOfRange, PayloadSite::Executive))
    );
    assert!(core.plan().is_empty());
    assert!(core.network().tasks().is_empty());
    assert!(core.executive().entries().is_empty());
    assert_eq!(core.next_wakeup(), None, "cold: waits for an uplink");
    let mut out = Recorder::default();
    core.step(hm(10, 41), StepBudget::UNLIMITED, &mut out);
    assert!(out.decisions.is_empty());
}

#[test]
fn grants_and_state_updates_past_the_latest_mission_time_keep_every_time_in_range() {
    let mut sim = Sim::flyby();
    sim.run(hm(10, 0), &[]);
    let late = MissionTimeUs(u64::MAX - 5);
    sim.autonomy
        .on_state_update(ATTITUDE_KEY, StateValue::Enum(NADIR), late);
    let mut out = Recorder::default();
    sim.autonomy.step(late, StepBudget::UNLIMITED, &mut out);
    assert_eq!(sim.autonomy.now(), MissionTimeUs(MAX_MISSION_TIME_US));
    assert!(sim
        .autonomy
        .states()
        .entries()
        .iter()
        .all(|e| e.at.0 <= MAX_MISSION_TIME_US));
    let mut bytes = vec![0u8; WARM_AREA_LEN];
    let mut area = WarmRestartArea::new(&mut bytes);
    sim.autonomy.checkpoint_to(&mut area).unwrap();
    let mut again = Box::new(Autonomy::new());
    again
        .restore_from(&area)
        .expect("a checkpoint the core wrote restores");
}

#[test]
fn two_plan_entries_with_one_instance_id_or_a_next_id_in_use_are_refused() {
    // Found by the checkpoint fuzz target (seed regression-duplicate-instance): an added and a
    // restarted instance with one id restored, then the executive's reports for one reached
    // the other, and the core wrote a checkpoint it refuses (a started, committed instance).
    let p = Payload::decode(&repaired_flyby_payload());
    let added = plan_index(&p, |e| matches!(e.origin, Origin::Added { .. }));
    let e = refusal(|p| {
        let mut twin = p.planner.entries[added];
        twin.state = TaskState::Unscheduled;
        twin.started = false;
        p.planner.entries.push(twin).unwrap();
    });
    assert_eq!(
        e,
        error(
            PayloadDefect::DuplicateInstance,
            entry_site(p.planner.entries.len())
        )
    );
    // The id the planner gives next must be free (seed regression-instance-id-in-use: the
    // next instance added took the id of one in the plan).
    let id = p.planner.entries[added].instance;
    assert_eq!(
        refusal(|p| p.planner.next_instance = id),
        error(PayloadDefect::DuplicateInstance, PayloadSite::Planner)
    );
}

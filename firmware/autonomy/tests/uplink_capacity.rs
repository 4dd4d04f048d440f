//! Over-capacity uplinks are refused with their own codes at the site of the first element that
//! does not fit (issue 15): `TooManyConstraints` for a fifth constraint, not `Decode`. The
//! uplinks are built with a wide mirror of the uplink format whose lists have no capacity, so
//! the bytes are exactly what a ground tool with larger lists would send.
mod common;
use autonomy::uplink::{
    take_condition, take_task, take_timeline, validate_uplink, ErrorSite, ResponseField, TaskField,
    ValidationCode,
};
use autonomy::*;
use common::*;
use serde::Serialize;

/// A list or name far over every capacity. postcard writes any list as its length and its
/// items, and a `u16` count exactly as a list length, so a network that fits encodes to the
/// same bytes as `encode_spec` (checked below).
/// A list with no capacity (serialized as postcard writes any list: its length, then its items).
#[derive(Clone, Debug)]
struct Wide<T>(Vec<T>);

impl<T: Serialize> Serialize for Wide<T> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.0.iter())
    }
}

impl<T> FromIterator<T> for Wide<T> {
    fn from_iter<I: IntoIterator<Item = T>>(items: I) -> Self {
        Self(items.into_iter().collect())
    }
}

impl<T> std::ops::Deref for Wide<T> {
    type Target = Vec<T>;
    fn deref(&self) -> &Vec<T> {
        &self.0
    }
}

impl<T> std::ops::DerefMut for Wide<T> {
    fn deref_mut(&mut self) -> &mut Vec<T> {
        &mut self.0
    }
}
type Few<T> = heapless::Vec<T, 20>;
type WideName = heapless::String<64>;

fn wide<T: Clone, C: FromIterator<T>>(items: &[T]) -> C {
    items.iter().cloned().collect()
}

fn wide_name(s: &str) -> WideName {
    WideName::try_from(s).unwrap()
}

/// `NetworkSpec` with room for more than the capacities.
#[derive(Clone, Debug, Serialize)]
struct WideNetwork {
    header: NetworkHeader,
    timelines: Wide<WideTimeline>,
    conditions: Wide<WideCondition>,
    tasks: Wide<WideTask>,
    temporal: Wide<TemporalConstraint>,
    timed: Wide<TimedValue>,
    params: Wide<ParamSpec>,
}

#[derive(Clone, Debug, Serialize)]
struct WideTimeline {
    name: WideName,
    kind: TimelineKind,
    state_key: Option<StateKey>,
    after_reset: Option<i64>,
    stale_after_us: Option<u64>,
    background_rate: i64,
    external: bool,
    thresholds: Wide<i64>,
}

#[derive(Clone, Debug, Serialize)]
struct WideCondition {
    nodes: Few<CondNode>,
}

#[derive(Clone, Debug, Serialize)]
struct WideCommand {
    opcode: Opcode,
    args: Few<i32>,
    from_instance: Few<InstanceArg>,
}

/// `TaskSpec` flattened: postcard puts no framing around a nested struct.
#[derive(Clone, Debug, Serialize)]
struct WideTask {
    id: u16,
    name: WideName,
    priority: u8,
    role: TaskRole,
    command: Option<WideCommand>,
    duration_us: u64,
    min_duration_us: u64,
    earliest_start: MissionTimeUs,
    latest_start: MissionTimeUs,
    latest_end: MissionTimeUs,
    constraints: Few<ConstraintSpec>,
    impacts: Few<ImpactSpec>,
    start_condition: Option<u8>,
    maintain_condition: Option<u8>,
    skip_condition: Option<u8>,
    pre_wait_timeout_us: u64,
    response_timeout_us: u64,
    on_failure_command: Option<WideCommand>,
    max_retries: Option<PerCause>,
    max_repairs: Option<PerCause>,
    backoff: Option<Backoff>,
    contingencies: Few<Contingency>,
    may_move: bool,
    may_delete: bool,
    may_add: Few<u16>,
}

fn wide_command(c: &CommandSpec) -> WideCommand {
    WideCommand {
        opcode: c.opcode,
        args: wide(&c.args),
        from_instance: wide(&c.from_instance),
    }
}

impl From<&NetworkSpec> for WideNetwork {
    fn from(n: &NetworkSpec) -> Self {
        Self {
            header: n.header,
            timelines: n
                .timelines
                .iter()
                .map(|t| WideTimeline {
                    name: wide_name(&t.name),
                    kind: t.kind,
                    state_key: t.state_key,
                    after_reset: t.after_reset,
                    stale_after_us: t.stale_after_us,
                    background_rate: t.background_rate,
                    external: t.external,
                    thresholds: wide(&t.thresholds),
                })
                .collect(),
            conditions: n
                .conditions
                .iter()
                .map(|c| WideCondition {
                    nodes: wide(&c.nodes),
                })
                .collect(),
            tasks: n
                .tasks
                .iter()
                .map(|t| WideTask {
                    id: t.id,
                    name: wide_name(&t.name),
                    priority: t.priority,
                    role: t.role,
                    command: t.command.as_ref().map(wide_command),
                    duration_us: t.duration_us,
                    min_duration_us: t.min_duration_us,
                    earliest_start: t.earliest_start,
                    latest_start: t.latest_start,
                    latest_end: t.latest_end,
                    constraints: wide(&t.constraints),
                    impacts: wide(&t.impacts),
                    start_condition: t.control.start_condition,
                    maintain_condition: t.control.maintain_condition,
                    skip_condition: t.control.skip_condition,
                    pre_wait_timeout_us: t.control.pre_wait_timeout_us,
                    response_timeout_us: t.control.response_timeout_us,
                    on_failure_command: t.control.on_failure_command.as_ref().map(wide_command),
                    max_retries: t.control.max_retries,
                    max_repairs: t.control.max_repairs,
                    backoff: t.control.backoff,
                    contingencies: wide(&t.contingencies),
                    may_move: t.permissions.may_move,
                    may_delete: t.permissions.may_delete,
                    may_add: wide(&t.permissions.may_add),
                })
                .collect(),
            temporal: wide(&n.temporal),
            timed: wide(&n.timed),
            params: wide(&n.params),
        }
    }
}

fn encode_wide(n: &WideNetwork) -> Vec<u8> {
    let mut buf = vec![0u8; 1 << 16];
    let len = postcard::to_slice(n, &mut buf).unwrap().len();
    buf.truncate(len);
    buf
}

fn flyby_wide() -> WideNetwork {
    WideNetwork::from(&flyby_spec())
}

/// The refusal of the flyby with `edit` applied.
fn refused(edit: impl FnOnce(&mut WideNetwork)) -> (ValidationCode, ErrorSite) {
    let mut n = flyby_wide();
    edit(&mut n);
    let e = validate_uplink(&encode_wide(&n)).expect_err("over capacity");
    (e.code, e.site)
}

fn task(i: u16, field: TaskField) -> ErrorSite {
    ErrorSite::Task { task: i, field }
}

const FLYBY_TASK: usize = 2; // "Instrument Flyby": constraints, impacts, contingencies, may_add

#[test]
fn the_wide_mirror_encodes_the_flyby_exactly_as_the_uplink_encoder() {
    let mut buf = vec![0u8; 1 << 16];
    let len = autonomy::uplink::encode_spec(&flyby_spec(), &mut buf).unwrap();
    assert_eq!(encode_wide(&flyby_wide()), buf[..len]);
    assert!(validate_uplink(&buf[..len]).is_ok());
}

#[test]
fn lists_in_a_task_over_capacity_have_their_codes_at_the_first_item_that_does_not_fit() {
    use ValidationCode::*;
    let t = FLYBY_TASK;
    let max = |n: usize| u8::try_from(n).unwrap();
    assert_eq!(
        refused(|n| {
            let c = n.tasks[t].constraints[0];
            n.tasks[t]
                .constraints
                .resize(MAX_CONSTRAINTS_PER_TASK + 1, c)
                .unwrap();
        }),
        (
            TooManyConstraints,
            task(2, TaskField::Constraint(max(MAX_CONSTRAINTS_PER_TASK)))
        )
    );
    assert_eq!(
        refused(|n| {
            let i = n.tasks[t].impacts[0];
            n.tasks[t]
                .impacts
                .resize(MAX_IMPACTS_PER_TASK + 1, i)
                .unwrap();
        }),
        (
            TooManyImpacts,
            task(2, TaskField::Impact(max(MAX_IMPACTS_PER_TASK)))
        )
    );
    assert_eq!(
        refused(|n| {
            let c = n.tasks[t].contingencies[0];
            n.tasks[t]
                .contingencies
                .resize(MAX_CONTINGENCIES_PER_TASK + 1, c)
                .unwrap();
        }),
        (
            TooManyContingencies,
            task(2, TaskField::Contingency(max(MAX_CONTINGENCIES_PER_TASK)))
        )
    );
    assert_eq!(
        refused(|n| {
            let p = n.tasks[t].may_add[0];
            n.tasks[t]
                .may_add
                .resize(MAX_ADD_PERMISSIONS_PER_TASK + 1, p)
                .unwrap();
        }),
        (
            TooManyPermissions,
            task(2, TaskField::Permission(max(MAX_ADD_PERMISSIONS_PER_TASK)))
        )
    );
}

#[test]
fn commands_with_too_many_arguments_are_named_with_their_field() {
    use ValidationCode::*;
    let args: Few<i32> = wide(&[1; fsw_bridge::MAX_COMMAND_ARGS + 1]);
    assert_eq!(
        refused(|n| n.tasks[0].command.as_mut().unwrap().args = args.clone()),
        (TooManyCommandArgs, task(0, TaskField::Command))
    );
    assert_eq!(
        refused(|n| {
            n.tasks[1].on_failure_command = Some(WideCommand {
                opcode: Opcode(7),
                args: args.clone(),
                from_instance: wide(&[]),
            })
        }),
        (TooManyCommandArgs, task(1, TaskField::Control))
    );
    // Instance arguments over the list's capacity (uplink format 5).
    let from_instance: Few<InstanceArg> =
        wide(&[InstanceArg::Instance; fsw_bridge::MAX_COMMAND_ARGS + 1]);
    assert_eq!(
        refused(|n| n.tasks[0].command.as_mut().unwrap().from_instance = from_instance.clone()),
        (TooManyCommandArgs, task(0, TaskField::Command))
    );
    assert_eq!(TooManyCommandArgs.code(), 21);
}

#[test]
fn names_over_their_capacity_are_name_too_long() {
    use ValidationCode::*;
    let long = wide_name(&"x".repeat(MAX_NAME_LEN + 1));
    assert_eq!(
        refused(|n| n.timelines[3].name = long.clone()),
        (NameTooLong, ErrorSite::Timeline(3))
    );
    assert_eq!(
        refused(|n| n.tasks[4].name = long.clone()),
        (NameTooLong, task(4, TaskField::Name))
    );
    // Exactly at the capacity is fine.
    let mut n = flyby_wide();
    n.tasks[4].name = wide_name(&"y".repeat(MAX_NAME_LEN));
    assert!(validate_uplink(&encode_wide(&n)).is_ok());
}

#[test]
fn conditions_with_too_many_terms_are_refused_at_the_first_term_that_does_not_fit() {
    let term = CondNode::Term {
        operand: Operand::Timeline(TL_ATTITUDE),
        op: RelOp::Eq,
        value: 1,
    };
    let (code, site) = refused(|n| {
        n.conditions.push(WideCondition {
            nodes: wide(&[term; MAX_CONDITION_TERMS + 1]),
        })
    });
    assert_eq!(code, ValidationCode::TooManyConditionTerms);
    assert_eq!(
        site,
        ErrorSite::Condition {
            condition: 0,
            node: u8::try_from(MAX_CONDITION_TERMS).unwrap()
        }
    );
}

#[test]
fn network_lists_over_capacity_are_refused_at_the_first_element_that_does_not_fit() {
    use ValidationCode::*;
    // The count is read before any element, so the elements need not even be distinct.
    assert_eq!(
        refused(|n| {
            let t = n.timelines[0].clone();
            n.timelines.resize(MAX_TIMELINES + 1, t);
        }),
        (
            TooManyTimelines,
            ErrorSite::Timeline(u8::try_from(MAX_TIMELINES).unwrap())
        )
    );
    assert_eq!(
        refused(|n| {
            let empty = WideCondition { nodes: Few::new() };
            n.conditions = wide(&vec![empty; MAX_CONDITIONS + 1]);
        }),
        (
            TooManyConditions,
            ErrorSite::Condition {
                condition: 16,
                node: 0
            }
        )
    );
    assert_eq!(
        refused(|n| {
            let t = n.tasks[0].clone();
            n.tasks.resize(MAX_TASKS + 1, t);
        }),
        (TooManyTasks, task(256, TaskField::Whole))
    );
    assert_eq!(
        refused(|n| {
            let tc = TemporalConstraint {
                from_task: ID_GNC_NADIR,
                from_point: TaskPoint::End,
                to_task: ID_FLYBY,
                to_point: TaskPoint::Start,
                min_us: 0,
                max_us: 0,
            };
            n.temporal = wide(&[tc; MAX_TEMPORAL_CONSTRAINTS + 1]);
        }),
        (TooManyTemporalConstraints, ErrorSite::Temporal(16))
    );
    assert_eq!(
        refused(|n| {
            let mut view = n.timelines[0].clone();
            view.name = wide_name("View");
            view.state_key = None;
            view.external = true;
            n.timelines.push(view);
            let tv = TimedValue {
                timeline: (n.timelines.len() - 1) as u8,
                at: MissionTimeUs(0),
                value: 0,
            };
            n.timed = wide(&[tv; MAX_TIMED_VALUES + 1]);
        }),
        (
            TooManyTimedValues,
            ErrorSite::TimedValue(MAX_TIMED_VALUES as u8)
        )
    );
    assert_eq!(
        refused(|n| n.timelines[0].thresholds = wide(&[1; MAX_THRESHOLDS + 1])),
        (TooManyThresholds, ErrorSite::TimelineThresholds(0))
    );
}

#[test]
fn bytes_that_do_not_decode_are_named_with_the_field_they_are_in() {
    use ValidationCode::*;
    let n = flyby_wide();
    let t = FLYBY_TASK;
    // The flyby task's own bytes, taken from the encoded network.
    let mut prefix = n.clone();
    prefix.tasks.truncate(t);
    let mut whole_task = n.clone();
    whole_task.tasks.truncate(t + 1);
    let before_task = encode_wide(&prefix).len() - 3; // minus the temporal, timed, param counts
    let task_bytes = &encode_wide(&whole_task)[before_task..];
    let (task_back, rest) = take_task(task_bytes, t).unwrap();
    assert_eq!(task_back, flyby_spec().tasks[t]);
    assert_eq!(rest, &[0u8, 0, 0]); // the temporal, timed and param counts of `whole_task`
                                    // The task's bytes cut at every length: each cut is Decode at the field it falls in.
    let mut sites = std::collections::BTreeSet::new();
    for cut in 0..task_bytes.len() - 3 {
        let e = take_task(&task_bytes[..cut], t).unwrap_err();
        assert_eq!(e.code, Decode, "cut at {cut}");
        sites.insert(format!("{:?}", e.site));
    }
    for field in [
        TaskField::Id,
        TaskField::Name,
        TaskField::Whole,
        TaskField::Command,
        TaskField::Duration,
        TaskField::Window,
        TaskField::Constraint(0),
        TaskField::Constraint(1),
        TaskField::Impact(0),
        TaskField::Control,
        TaskField::Responses(ResponseField::MaxRetries),
        TaskField::Responses(ResponseField::MaxRepairs),
        TaskField::Responses(ResponseField::Backoff),
        TaskField::Contingency(0),
        TaskField::Permission(0),
    ] {
        let site = format!("{:?}", task(2, field));
        assert!(sites.contains(&site), "no cut reported {site}: {sites:?}");
    }
    // A bad option tag is Decode at its field, not a capacity error.
    let mut bad_option = task_bytes.to_vec();
    let command_tag = 1 + 1 + n.tasks[t].name.len() + 1 + 1; // id, name length, name, priority, role
    assert_eq!(bad_option[command_tag], 1, "the flyby has a command");
    bad_option[command_tag] = 2;
    assert_eq!(
        take_task(&bad_option, t).unwrap_err(),
        autonomy::ValidationError::new(Decode, task(2, TaskField::Command))
    );
}

#[test]
fn the_element_decoders_decode_exactly_what_postcard_decodes() {
    let spec = flyby_spec();
    let mut buf = vec![0u8; 4096];
    for (i, t) in spec.timelines.iter().enumerate() {
        let len = postcard::to_slice(t, &mut buf).unwrap().len();
        buf[len] = 0xAB;
        let (back, rest) = take_timeline(&buf[..len + 1], i).unwrap();
        assert_eq!(&back, t);
        assert_eq!(rest, &[0xAB]);
    }
    let condition = ConditionSpec {
        nodes: heapless::Vec::from_slice(&[
            CondNode::Term {
                operand: Operand::State(StateKey(3)),
                op: RelOp::Ge,
                value: -5,
            },
            CondNode::Not,
        ])
        .unwrap(),
    };
    let len = postcard::to_slice(&condition, &mut buf).unwrap().len();
    assert_eq!(
        take_condition(&buf[..len], 0).unwrap(),
        (condition, &[][..])
    );
    for (i, t) in spec.tasks.iter().enumerate() {
        let len = postcard::to_slice(t, &mut buf).unwrap().len();
        let (back, rest) = take_task(&buf[..len], i).unwrap();
        assert_eq!(&back, t);
        assert!(rest.is_empty());
        let derived: TaskSpec = postcard::from_bytes(&buf[..len]).unwrap();
        assert_eq!(derived, back);
    }
}

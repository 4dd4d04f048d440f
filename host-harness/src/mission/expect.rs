//! Judging a mission record against the plan's expectations ([`Expect`], checked when the
//! mission was planned). One verdict per expectation; the run passes when every one holds.
//!
//! The flight software's downtime (from a reset to its restart) is explicit: tasks that ran
//! across it were interrupted, coverage over it is excused only when the expectation says so,
//! and state checks skip it (the software could not act then); each verdict's detail says how
//! much downtime it excused.
use fsw_bridge::{MissionTimeUs, StateValue};
use serde::Serialize;

use super::metrics;
use super::plan::{Expect, Outcome};
use super::record::{Instance, MissionRecord};
use crate::tasknet::CompiledNetwork;
use crate::time::{fmt_duration_us, fmt_time};

/// The verdict on one expectation.
#[derive(Clone, Debug, Serialize)]
pub struct Verdict {
    pub index: usize,
    pub what: String,
    pub passed: bool,
    pub detail: String,
}

/// Judge expectation number `index` (1-based).
pub fn evaluate(
    index: usize,
    expect: &Expect,
    rec: &MissionRecord,
    net: &CompiledNetwork,
    counts_cycles: bool,
) -> Verdict {
    let (what, result) = match expect {
        Expect::Metric { name, .. } if !counts_cycles && metrics::is_guest_cost(name) => (
            name.clone(),
            Ok("not applicable: the native target counts no guest cycles".to_string()),
        ),
        Expect::Metric { name, .. } if !counts_cycles && metrics::is_throttle_measure(name) => (
            name.clone(),
            Ok("not applicable: the native target plans unthrottled (the reference)".to_string()),
        ),
        Expect::Task {
            task,
            instance,
            outcome,
            started_at,
            or_at_restart,
            ended_at,
        } => check_task(
            rec,
            task,
            *instance,
            *outcome,
            *started_at,
            *or_at_restart,
            *ended_at,
        ),
        Expect::Added { template, count } => check_added(rec, template, *count),
        Expect::StateAt {
            timeline,
            key,
            value,
            at,
        } => {
            let what = format!(
                "{timeline} at {} is {}",
                fmt_time(*at),
                shown(net, timeline, Some(*value))
            );
            let got = rec.state_at(*key, *at);
            let result = if got == Some(*value) {
                Ok(shown(net, timeline, got))
            } else {
                Err(format!("it was {}", shown(net, timeline, got)))
            };
            (what, result)
        }
        Expect::StateDuring {
            timeline,
            key,
            value,
            task,
        } => check_during(rec, net, timeline, *key, *value, task),
        Expect::Order(order) => check_order(rec, order),
        Expect::Coverage {
            tasks,
            from,
            to,
            exclusive,
            allow_downtime,
        } => check_coverage(rec, tasks, *from, *to, *exclusive, *allow_downtime),
        Expect::Metric { name, min, max } => check_metric(rec, name, *min, *max),
        Expect::Command { opcode, at, args } => check_command(rec, *opcode, *at, args),
    };
    let passed = result.is_ok();
    Verdict {
        index,
        what,
        passed,
        detail: match result {
            Ok(d) | Err(d) => d,
        },
    }
}

type Judged = (String, Result<String, String>);

fn check_command(rec: &MissionRecord, opcode: u16, at: MissionTimeUs, args: &[i32]) -> Judged {
    use super::record::Decision;
    let what = format!("command {opcode:#06x} at {} with {args:?}", fmt_time(at));
    let sent: Vec<&Vec<i32>> = rec
        .decisions
        .iter()
        .filter_map(|d| match d {
            Decision::Dispatch {
                at: t,
                opcode: o,
                args: a,
                ..
            } if *o == opcode && *t == at.0 => Some(a),
            _ => None,
        })
        .collect();
    let result = if sent.iter().any(|a| a.as_slice() == args) {
        Ok(format!("sent with {args:?}"))
    } else if sent.is_empty() {
        Err(format!("no {opcode:#06x} command was sent then"))
    } else {
        Err(format!("sent with {sent:?}"))
    };
    (what, result)
}

fn instances_of<'r>(rec: &'r MissionRecord, name: &str) -> Vec<&'r Instance> {
    rec.instances.iter().filter(|i| i.name == name).collect()
}

fn at_or(t: Option<u64>, none: &str) -> String {
    t.map_or_else(|| none.to_string(), |x| fmt_time(MissionTimeUs(x)))
}

fn check_task(
    rec: &MissionRecord,
    task: &str,
    n: u32,
    outcome: Option<Outcome>,
    started_at: Option<MissionTimeUs>,
    or_at_restart: bool,
    ended_at: Option<MissionTimeUs>,
) -> Judged {
    let what = format!(
        "{task} #{n}{}{}{}",
        outcome
            .map(|o| format!(" {}", o.name()))
            .unwrap_or_default(),
        started_at
            .map(|s| format!(" started at {}", fmt_time(s)))
            .unwrap_or_default(),
        ended_at
            .map(|s| format!(" ended at {}", fmt_time(s)))
            .unwrap_or_default()
    );
    let all = instances_of(rec, task);
    let Some(inst) = all.get(n as usize - 1) else {
        let result = if outcome == Some(Outcome::NotRun) {
            Ok(format!("{} instance(s) of {task}", all.len()))
        } else {
            Err(format!("only {} instance(s) of {task} ran", all.len()))
        };
        return (what, result);
    };
    let mut problems = Vec::new();
    match outcome {
        Some(Outcome::NotRun) if inst.started_at.is_some() => {
            problems.push(format!("it started at {}", at_or(inst.started_at, "-")))
        }
        Some(Outcome::NotRun) | None => {}
        Some(o) if inst.outcome() != o => {
            problems.push(format!("outcome {}", inst.outcome().name()))
        }
        Some(_) => {}
    }
    if let Some(mut s) = started_at {
        if or_at_restart {
            if let Some((_, restart)) = down_at(rec, s.0) {
                s = MissionTimeUs(restart);
            }
        }
        if inst.started_at != Some(s.0) {
            problems.push(format!("started {}", at_or(inst.started_at, "never")));
        }
    }
    if let Some(e) = ended_at {
        if inst.ended_at != Some(e.0) {
            problems.push(format!("ended {}", at_or(inst.ended_at, "never")));
        }
    }
    let desc = inst.describe();
    (
        what,
        if problems.is_empty() {
            Ok(desc)
        } else {
            Err(format!("{}; {desc}", problems.join(", ")))
        },
    )
}

fn check_added(rec: &MissionRecord, template: &str, count: Option<u32>) -> Judged {
    let label = format!("{template} added");
    let n = rec.labels.iter().filter(|(_, l)| *l == label).count() as u32;
    let what = match count {
        Some(c) => format!("{template} added {c} time(s)"),
        None => format!("{template} added"),
    };
    let ok = count.map_or(n > 0, |c| n == c);
    let detail = format!("added {n} time(s)");
    (what, if ok { Ok(detail) } else { Err(detail) })
}

fn check_order(rec: &MissionRecord, order: &[String]) -> Judged {
    let what = format!("in order: {}", order.join(" -> "));
    let mut pos = 0usize;
    for want in order {
        match rec.labels[pos..].iter().position(|(_, l)| l == want) {
            Some(i) => pos += i + 1,
            None => {
                let elsewhere = rec.labels.iter().any(|(_, l)| l == want);
                return (
                    what,
                    Err(if elsewhere {
                        format!("{want:?} happened, but not after the previous entries")
                    } else {
                        format!("{want:?} never happened")
                    }),
                );
            }
        }
    }
    (what, Ok("all happened in this order".into()))
}

fn check_metric(rec: &MissionRecord, name: &str, min: Option<u64>, max: Option<u64>) -> Judged {
    let unit = metrics::lookup(name).map_or("", |m| m.unit);
    let what = format!(
        "{name}{}{}",
        min.map(|m| format!(" >= {m}")).unwrap_or_default(),
        max.map(|m| format!(" <= {m}")).unwrap_or_default()
    );
    let Some(&value) = rec.metrics.get(name) else {
        return (what, Err(format!("{name} was not measured in this run")));
    };
    let ok = min.is_none_or(|m| value >= m) && max.is_none_or(|m| value <= m);
    let detail = format!("{value} {unit}");
    (
        what,
        if ok {
            Ok(detail)
        } else {
            Err(format!("measured {detail}"))
        },
    )
}

/// When the flight software was down: from each reset to its restart.
pub fn downtimes(rec: &MissionRecord) -> Vec<(u64, u64)> {
    rec.resets.iter().map(|r| (r.at, r.restart_at)).collect()
}

/// The downtime `t` falls in, if any (half-open: the restart instant is up).
fn down_at(rec: &MissionRecord, t: u64) -> Option<(u64, u64)> {
    downtimes(rec)
        .into_iter()
        .find(|(a, b)| (*a..*b).contains(&t))
}

fn spans_text(spans: &[(u64, u64)]) -> String {
    spans
        .iter()
        .map(|(a, b)| {
            format!(
                "{}-{}",
                fmt_time(MissionTimeUs(*a)),
                fmt_time(MissionTimeUs(*b))
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Total length of `spans` clipped to `from..to`.
fn clipped_total(spans: &[(u64, u64)], from: u64, to: u64) -> u64 {
    spans
        .iter()
        .map(|&(a, b)| b.min(to).saturating_sub(a.max(from)))
        .sum()
}

/// The end of the run: the last thing recorded.
fn end_of_run(rec: &MissionRecord) -> u64 {
    rec.labels
        .iter()
        .map(|(t, _)| *t)
        .chain(rec.instances.iter().filter_map(|i| i.ended_at))
        .max()
        .unwrap_or(0)
}

/// Where each listed task's instances ran (an instance still running ends at `open_end`).
fn running_spans<'r>(
    rec: &'r MissionRecord,
    tasks: &[String],
    open_end: u64,
) -> Vec<(u64, u64, &'r Instance)> {
    rec.instances
        .iter()
        .filter(|i| tasks.contains(&i.name))
        .filter_map(|i| Some((i.started_at?, i.ended_at.unwrap_or(open_end), i)))
        .collect()
}

fn check_coverage(
    rec: &MissionRecord,
    tasks: &[String],
    from: MissionTimeUs,
    to: MissionTimeUs,
    exclusive: bool,
    allow_downtime: bool,
) -> Judged {
    let (from, to) = (from.0, to.0);
    let what = format!(
        "{} to {} covered by {}{}{}",
        fmt_time(MissionTimeUs(from)),
        fmt_time(MissionTimeUs(to)),
        tasks.join(" or "),
        if exclusive { ", one at a time" } else { "" },
        if allow_downtime {
            ", except while the flight software is down"
        } else {
            ""
        }
    );
    let open_end = end_of_run(rec).max(to);
    // A task does not observe while the software is down: its running interval stops at a
    // reset (the record ends an interrupted instance there) and the downtime is either excused
    // or a gap.
    let mut spans: Vec<(u64, u64)> = running_spans(rec, tasks, open_end)
        .into_iter()
        .map(|(s, e, _)| (s, e))
        .collect();
    let down = downtimes(rec);
    if allow_downtime {
        spans.extend(down.iter().copied());
    }
    spans.sort();
    let mut covered_to = from;
    let mut gaps = Vec::new();
    for &(s, e) in &spans {
        if s > covered_to && covered_to < to {
            gaps.push((covered_to, s.min(to)));
        }
        covered_to = covered_to.max(e);
    }
    if covered_to < to {
        gaps.push((covered_to, to));
    }
    let mut problems = Vec::new();
    if !gaps.is_empty() {
        let during_downtime = clipped_total(&down, from, to);
        problems.push(format!(
            "gaps: {}{}",
            spans_text(&gaps),
            if during_downtime > 0 && !allow_downtime {
                format!(
                    " (the flight software was down for {} of it)",
                    fmt_duration_us(during_downtime)
                )
            } else {
                String::new()
            }
        ));
    }
    if exclusive {
        let overlaps = overlaps(rec, tasks, from, to, open_end);
        if !overlaps.is_empty() {
            problems.push(format!("overlaps: {}", overlaps.join(", ")));
        }
    }
    let excused = clipped_total(&down, from, to);
    (
        what,
        if problems.is_empty() {
            Ok(if allow_downtime && excused > 0 {
                format!("no gap; {} of downtime excused", fmt_duration_us(excused))
            } else {
                "no gap".into()
            })
        } else {
            Err(problems.join("; "))
        },
    )
}

/// Pairs of the listed tasks' instances that ran at the same time within `from`..`to`.
fn overlaps(
    rec: &MissionRecord,
    tasks: &[String],
    from: u64,
    to: u64,
    open_end: u64,
) -> Vec<String> {
    let spans: Vec<(u64, u64, &Instance)> = running_spans(rec, tasks, open_end)
        .into_iter()
        .filter_map(|(s, e, i)| {
            let (s, e) = (s.max(from), e.min(to));
            (s < e).then_some((s, e, i))
        })
        .collect();
    let mut out = Vec::new();
    for (n, a) in spans.iter().enumerate() {
        for b in &spans[n + 1..] {
            let (s, e) = (a.0.max(b.0), a.1.min(b.1));
            if s < e {
                out.push(format!(
                    "{} ({}) and {} ({}) during {}",
                    a.2.name,
                    a.2.origin,
                    b.2.name,
                    b.2.origin,
                    spans_text(&[(s, e)])
                ));
            }
        }
    }
    out
}

/// A state value as the report shows it: its name for a state timeline.
fn shown(net: &CompiledNetwork, timeline: &str, v: Option<StateValue>) -> String {
    match v {
        Some(StateValue::Enum(i)) => net
            .timeline(timeline)
            .and_then(|t| t.values.get(usize::from(i)).cloned())
            .unwrap_or_else(|| format!("value {i}")),
        Some(StateValue::Int(i)) => i.to_string(),
        Some(StateValue::Bool(b)) => b.to_string(),
        Some(StateValue::Unknown) => "UNKNOWN".into(),
        None => "never published".into(),
    }
}

/// `timeline` = `value` while every instance of `task` ran, downtimes excepted.
fn check_during(
    rec: &MissionRecord,
    net: &CompiledNetwork,
    timeline: &str,
    key: fsw_bridge::StateKey,
    want: StateValue,
    task: &str,
) -> Judged {
    let what = format!(
        "{timeline} is {} while {task} runs",
        shown(net, timeline, Some(want))
    );
    let end = end_of_run(rec);
    let publications = rec.states.get(&key).map(Vec::as_slice).unwrap_or(&[]);
    let down = downtimes(rec);
    let mut problems = Vec::new();
    let (mut checked, mut excused) = (0, 0);
    for inst in instances_of(rec, task) {
        let Some(start) = inst.started_at else {
            continue;
        };
        let stop = inst.ended_at.unwrap_or(end);
        excused += clipped_total(&down, start, stop);
        // The running interval minus the downtimes.
        let mut pieces = vec![(start, stop)];
        for &(a, b) in &down {
            pieces = pieces
                .into_iter()
                .flat_map(|(s, e)| [(s, e.min(a)), (s.max(b), e)])
                .filter(|(s, e)| s < e)
                .collect();
        }
        for (s, e) in pieces {
            checked += 1;
            let mut bad: Vec<(u64, Option<StateValue>)> = Vec::new();
            let at_start = rec.state_at(key, MissionTimeUs(s));
            if at_start != Some(want) {
                bad.push((s, at_start));
            }
            for (t, v) in publications {
                if t.0 > s && t.0 < e && *v != want {
                    bad.push((t.0, Some(*v)));
                }
            }
            if let Some((t, v)) = bad.first() {
                problems.push(format!(
                    "{} ({}) ran {} but {timeline} was {} at {}",
                    inst.name,
                    inst.origin,
                    spans_text(&[(s, e)]),
                    shown(net, timeline, *v),
                    fmt_time(MissionTimeUs(*t))
                ));
            }
        }
    }
    (
        what,
        if problems.is_empty() {
            Ok(format!(
                "{checked} running interval(s) checked{}",
                if excused > 0 {
                    format!("; {} of downtime not checked", fmt_duration_us(excused))
                } else {
                    String::new()
                }
            ))
        } else {
            Err(problems.join("; "))
        },
    )
}

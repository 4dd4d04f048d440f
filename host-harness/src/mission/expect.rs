//! Checking a scenario's `[[expect]]` entries against a mission record.
use fsw_bridge::MissionTimeUs;
use serde::Serialize;

use super::driver::value_of;
use super::record::{Instance, MissionRecord};
use super::spec::ExpectSpec;
use super::time::{fmt_time, parse_time};
use super::CompiledNetwork;

/// The verdict on one expectation.
#[derive(Clone, Debug, Serialize)]
pub struct Verdict {
    pub index: usize,
    pub what: String,
    pub passed: bool,
    pub detail: String,
}

fn time(field: &str, text: &Option<String>) -> Result<Option<MissionTimeUs>, String> {
    text.as_deref()
        .map(|t| parse_time(t).map_err(|e| format!("{field}: {e}")))
        .transpose()
}

/// Check the form of an expectation before the run (so a typo fails before QEMU starts).
pub fn validate(spec: &ExpectSpec, net: &CompiledNetwork) -> Result<(), String> {
    let kinds = [
        spec.task.is_some(),
        spec.added.is_some(),
        spec.timeline.is_some(),
        spec.order.is_some(),
        spec.covered_by.is_some(),
        spec.metric.is_some(),
    ]
    .iter()
    .filter(|k| **k)
    .count();
    if kinds != 1 {
        return Err("an expectation checks exactly one of: task, added, timeline, order, covered_by, metric".into());
    }
    let known_task = |name: &str| net.network.tasks().iter().any(|t| t.name.as_str() == name);
    if let Some(task) = &spec.task {
        if !known_task(task) {
            return Err(format!("task: no task named {task:?} in the task network"));
        }
        if spec.outcome.is_none() && spec.started_at.is_none() && spec.ended_at.is_none() {
            return Err("task: give outcome, started_at or ended_at".into());
        }
        if let Some(o) = &spec.outcome {
            const OUTCOMES: [&str; 7] = [
                "completed",
                "aborted",
                "failed",
                "skipped",
                "deleted",
                "not-run",
                "not-finished",
            ];
            if !OUTCOMES.contains(&o.as_str()) {
                return Err(format!(
                    "outcome: {o:?} is not one of {}",
                    OUTCOMES.join(", ")
                ));
            }
        }
    }
    if let Some(t) = &spec.added {
        if !known_task(t) {
            return Err(format!("added: no task named {t:?} in the task network"));
        }
    }
    if let Some(tl) = &spec.timeline {
        let (key, values) = net
            .timeline(tl)
            .ok_or_else(|| format!("timeline: no timeline named {tl:?}"))?;
        if key.is_none() {
            return Err(format!(
                "timeline: {tl:?} is not published by the spacecraft (no state key)"
            ));
        }
        let v = spec.value.as_ref().ok_or("timeline: give value")?;
        value_of(v, values).map_err(|e| format!("value: {e}"))?;
        match (&spec.at, &spec.during) {
            (None, None) => return Err("timeline: give at or during".into()),
            (Some(_), Some(_)) => return Err("timeline: give at or during, not both".into()),
            (None, Some(task)) if !known_task(task) => {
                return Err(format!(
                    "during: no task named {task:?} in the task network"
                ))
            }
            _ => {}
        }
    }
    if let Some(tasks) = &spec.covered_by {
        for t in tasks {
            if !known_task(t) {
                return Err(format!("covered_by: no task named {t:?}"));
            }
        }
        if spec.from.is_none() || spec.to.is_none() {
            return Err("covered_by: give from and to".into());
        }
    }
    if spec.metric.is_some() && spec.max.is_none() && spec.min.is_none() {
        return Err("metric: give max or min".into());
    }
    for (f, t) in [
        ("at", &spec.at),
        ("from", &spec.from),
        ("to", &spec.to),
        ("started_at", &spec.started_at),
        ("ended_at", &spec.ended_at),
    ] {
        time(f, t)?;
    }
    Ok(())
}

fn instances_of<'r>(rec: &'r MissionRecord, name: &str) -> Vec<&'r Instance> {
    rec.instances.iter().filter(|i| i.name == name).collect()
}

/// Evaluate one (validated) expectation.
pub fn evaluate(
    index: usize,
    spec: &ExpectSpec,
    rec: &MissionRecord,
    net: &CompiledNetwork,
    counts_cycles: bool,
) -> Verdict {
    let cycle_metric = spec
        .metric
        .as_deref()
        .is_some_and(|m| m.ends_with("_ticks") || m.ends_with("_instructions"));
    if let (Some(metric), true, false) = (&spec.metric, cycle_metric, counts_cycles) {
        return Verdict {
            index,
            what: metric.clone(),
            passed: true,
            detail: "not applicable: the native target counts no guest cycles".into(),
        };
    }
    let (what, result) = check(spec, rec, net);
    Verdict {
        index,
        what,
        passed: result.is_ok(),
        detail: match result {
            Ok(d) | Err(d) => d,
        },
    }
}

fn check(
    spec: &ExpectSpec,
    rec: &MissionRecord,
    net: &CompiledNetwork,
) -> (String, Result<String, String>) {
    let t = |s: &Option<String>| s.as_deref().and_then(|x| parse_time(x).ok());
    if let Some(task) = &spec.task {
        let n = spec.instance.unwrap_or(1);
        let what = format!(
            "{task} #{n}{}{}{}",
            spec.outcome
                .as_ref()
                .map(|o| format!(" {o}"))
                .unwrap_or_default(),
            spec.started_at
                .as_ref()
                .map(|s| format!(" started at {s}"))
                .unwrap_or_default(),
            spec.ended_at
                .as_ref()
                .map(|s| format!(" ended at {s}"))
                .unwrap_or_default()
        );
        let all = instances_of(rec, task);
        let Some(inst) = all.get(n as usize - 1) else {
            return (
                what.clone(),
                if spec.outcome.as_deref() == Some("not-run") {
                    Ok(format!("{} instance(s) of {task}", all.len()))
                } else {
                    Err(format!("only {} instance(s) of {task} ran", all.len()))
                },
            );
        };
        let mut problems = Vec::new();
        if let Some(o) = &spec.outcome {
            if o == "not-run" {
                if inst.started_at.is_some() {
                    problems.push(format!(
                        "it started at {}",
                        fmt_time(MissionTimeUs(inst.started_at.unwrap_or(0)))
                    ));
                }
            } else if inst.outcome_name() != o {
                problems.push(format!("outcome {}", inst.outcome_name()));
            }
        }
        if let Some(mut s) = t(&spec.started_at) {
            if spec.or_at_restart == Some(true) {
                if let Some(r) = down_at(rec, s.0) {
                    s = MissionTimeUs(r.1);
                }
            }
            if inst.started_at != Some(s.0) {
                problems.push(format!(
                    "started {}",
                    inst.started_at
                        .map(|x| fmt_time(MissionTimeUs(x)))
                        .unwrap_or("never".into())
                ));
            }
        }
        if let Some(e) = t(&spec.ended_at) {
            if inst.ended_at != Some(e.0) {
                problems.push(format!(
                    "ended {}",
                    inst.ended_at
                        .map(|x| fmt_time(MissionTimeUs(x)))
                        .unwrap_or("never".into())
                ));
            }
        }
        let desc = describe(inst);
        return (
            what,
            if problems.is_empty() {
                Ok(desc)
            } else {
                Err(format!("{}; {desc}", problems.join(", ")))
            },
        );
    }
    if let Some(template) = &spec.added {
        let n = rec
            .labels
            .iter()
            .filter(|(_, l)| *l == format!("{template} added"))
            .count() as u32;
        let what = match spec.count {
            Some(c) => format!("{template} added {c} time(s)"),
            None => format!("{template} added"),
        };
        let ok = match spec.count {
            Some(c) => n == c,
            None => n > 0,
        };
        return (
            what,
            if ok {
                Ok(format!("added {n} time(s)"))
            } else {
                Err(format!("added {n} time(s)"))
            },
        );
    }
    if let (Some(tl), Some(task)) = (&spec.timeline, &spec.during) {
        return check_during(spec, tl, task, rec, net);
    }
    if let Some(tl) = &spec.timeline {
        let at = t(&spec.at).unwrap_or_default();
        let (key, values) = net.timeline(tl).expect("validated");
        let key = key.expect("validated");
        let want = value_of(spec.value.as_ref().expect("validated"), values).expect("validated");
        let got = rec.state_at(key, at);
        let what = format!(
            "{tl} at {} is {}",
            fmt_time(at),
            spec.value
                .as_ref()
                .map(|v| v.to_string())
                .unwrap_or_default()
        );
        let shown = |v: Option<fsw_bridge::StateValue>| match v {
            Some(fsw_bridge::StateValue::Enum(i)) => {
                values.get(i as usize).cloned().unwrap_or(format!("{i}"))
            }
            Some(other) => format!("{other:?}"),
            None => "never published".into(),
        };
        return (
            what,
            if got == Some(want) {
                Ok(shown(got))
            } else {
                Err(format!("it was {}", shown(got)))
            },
        );
    }
    if let Some(order) = &spec.order {
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
        return (what, Ok("all happened in this order".into()));
    }
    if let Some(tasks) = &spec.covered_by {
        let (from, to) = (
            t(&spec.from).unwrap_or_default(),
            t(&spec.to).unwrap_or_default(),
        );
        let what = format!(
            "{} to {} covered by {}",
            fmt_time(from),
            fmt_time(to),
            tasks.join(" or ")
        );
        let end_of_run = rec
            .instances
            .iter()
            .filter_map(|i| i.ended_at)
            .max()
            .unwrap_or(to.0);
        let mut spans: Vec<(u64, u64)> = rec
            .instances
            .iter()
            .filter(|i| tasks.contains(&i.name))
            .filter_map(|i| Some((i.started_at?, i.ended_at.unwrap_or(end_of_run.max(to.0)))))
            .collect();
        let exclusive = spec.exclusive == Some(true);
        let allow_reset_gaps = spec.allow_reset_gaps == Some(true);
        let what = format!(
            "{what}{}{}",
            if exclusive { ", one at a time" } else { "" },
            if allow_reset_gaps {
                ", except while the flight software is down"
            } else {
                ""
            }
        );
        if allow_reset_gaps {
            spans.extend(downtimes(rec));
        }
        spans.sort();
        let mut covered_to = from.0;
        let mut gaps = Vec::new();
        for &(s, e) in &spans {
            if s > covered_to && covered_to < to.0 {
                gaps.push((covered_to, s.min(to.0)));
            }
            covered_to = covered_to.max(e);
        }
        if covered_to < to.0 {
            gaps.push((covered_to, to.0));
        }
        let mut problems = Vec::new();
        if !gaps.is_empty() {
            problems.push(format!("gaps: {}", spans_text(&gaps)));
        }
        if exclusive {
            let overlaps = overlaps(rec, tasks, from.0, to.0, end_of_run.max(to.0));
            if !overlaps.is_empty() {
                problems.push(format!("overlaps: {}", overlaps.join(", ")));
            }
        }
        return (
            what,
            if problems.is_empty() {
                Ok("no gap".into())
            } else {
                Err(problems.join("; "))
            },
        );
    }
    if let Some(metric) = &spec.metric {
        let what = format!(
            "{metric}{}{}",
            spec.min.map(|m| format!(" >= {m}")).unwrap_or_default(),
            spec.max.map(|m| format!(" <= {m}")).unwrap_or_default()
        );
        let Some(&value) = rec.metrics.get(metric) else {
            return (
                what,
                Err(format!(
                    "no metric {metric:?} was measured (metrics: {})",
                    rec.metrics.keys().cloned().collect::<Vec<_>>().join(", ")
                )),
            );
        };
        let ok = spec.min.is_none_or(|m| value >= m) && spec.max.is_none_or(|m| value <= m);
        return (
            what,
            if ok {
                Ok(format!("{value}"))
            } else {
                Err(format!("measured {value}"))
            },
        );
    }
    ("?".into(), Err("empty expectation".into()))
}

/// When the flight software was down: from each reset to its restart.
fn downtimes(rec: &MissionRecord) -> Vec<(u64, u64)> {
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

/// Pairs of the listed tasks' instances that ran at the same time within `from`..`to`.
fn overlaps(
    rec: &MissionRecord,
    tasks: &[String],
    from: u64,
    to: u64,
    open_end: u64,
) -> Vec<String> {
    let spans: Vec<(u64, u64, &Instance)> = rec
        .instances
        .iter()
        .filter(|i| tasks.contains(&i.name))
        .filter_map(|i| {
            let (s, e) = (
                i.started_at?.max(from),
                i.ended_at.unwrap_or(open_end).min(to),
            );
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

/// `timeline` = `value` while every instance of `task` ran, downtimes excepted.
fn check_during(
    spec: &ExpectSpec,
    tl: &str,
    task: &str,
    rec: &MissionRecord,
    net: &CompiledNetwork,
) -> (String, Result<String, String>) {
    let (key, values) = net.timeline(tl).expect("validated");
    let key = key.expect("validated");
    let want = value_of(spec.value.as_ref().expect("validated"), values).expect("validated");
    let shown = |v: Option<fsw_bridge::StateValue>| match v {
        Some(fsw_bridge::StateValue::Enum(i)) => {
            values.get(i as usize).cloned().unwrap_or(format!("{i}"))
        }
        Some(other) => format!("{other:?}"),
        None => "never published".into(),
    };
    let what = format!("{tl} is {} while {task} runs", shown(Some(want)));
    let end_of_run = rec
        .labels
        .iter()
        .map(|(t, _)| *t)
        .chain(rec.instances.iter().filter_map(|i| i.ended_at))
        .max()
        .unwrap_or(0);
    let publications = rec.states.get(&key).map(Vec::as_slice).unwrap_or(&[]);
    let mut problems = Vec::new();
    let mut checked = 0;
    for inst in instances_of(rec, task) {
        let Some(start) = inst.started_at else {
            continue;
        };
        let end = inst.ended_at.unwrap_or(end_of_run);
        // The running interval minus the downtimes.
        let mut pieces = vec![(start, end)];
        for (a, b) in downtimes(rec) {
            pieces = pieces
                .into_iter()
                .flat_map(|(s, e)| [(s, e.min(a)), (s.max(b), e)])
                .filter(|(s, e)| s < e)
                .collect();
        }
        for (s, e) in pieces {
            checked += 1;
            let mut bad: Vec<(u64, Option<fsw_bridge::StateValue>)> = Vec::new();
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
                    "{} ({}) ran {} but {tl} was {} at {}",
                    inst.name,
                    inst.origin,
                    spans_text(&[(s, e)]),
                    shown(*v),
                    fmt_time(MissionTimeUs(*t))
                ));
            }
        }
    }
    (
        what,
        if problems.is_empty() {
            Ok(format!("{checked} running interval(s) checked"))
        } else {
            Err(problems.join("; "))
        },
    )
}

fn describe(i: &Instance) -> String {
    format!(
        "{} ({}): {} to {}, {}",
        i.name,
        i.origin,
        i.started_at
            .map(|x| fmt_time(MissionTimeUs(x)))
            .unwrap_or("-".into()),
        i.ended_at
            .map(|x| fmt_time(MissionTimeUs(x)))
            .unwrap_or("-".into()),
        i.outcome_name()
    )
}

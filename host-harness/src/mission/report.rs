//! The last stage of a mission: the verdicts and the record turned into the terminal summary,
//! the JSON report and JUnit XML (the Gantt chart is [`super::gantt`]).
use fsw_bridge::MissionTimeUs;
use serde::Serialize;

use super::driver::MissionRun;
use super::expect::{self, Verdict};
use super::plan::MissionPlan;
use super::record::MissionRecord;
use crate::firmware::{build_id_hex, FirmwareImage};
use crate::time::{fmt_duration_us, fmt_time};

/// One task instance on the Gantt chart and in the JSON report.
#[derive(Clone, Debug, Serialize)]
pub struct GanttRow {
    pub name: String,
    pub origin: String,
    pub planned_start: Option<String>,
    pub start: Option<String>,
    pub end: Option<String>,
    pub outcome: String,
    /// For an instance a reset interrupted: what the autonomy decided about it after the
    /// restart.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub after_restart: Option<String>,
}

/// Commands one task definition sent in a mission, and its bound per run.
#[derive(Clone, Debug, Serialize)]
pub struct CommandCount {
    pub task: String,
    pub commands: u32,
    pub bound_per_run: u32,
}

/// The JSON report of a mission run.
#[derive(Clone, Debug, Serialize)]
pub struct MissionReport {
    pub scenario: String,
    pub description: String,
    pub seed: u64,
    pub target: String,
    pub firmware_build_id: Option<String>,
    pub passed: bool,
    pub expectations: Vec<Verdict>,
    pub tasks: Vec<GanttRow>,
    pub events: Vec<(String, String)>,
    pub resets: Vec<super::record::ResetRecord>,
    /// Every boot with its boot-to-ready cost (emulated target).
    pub boots: Vec<super::record::BootRecord>,
    pub faults: Vec<(String, String)>,
    /// Where the autonomy gave up on a task, and the cause.
    pub gave_up: Vec<super::record::GaveUp>,
    /// Every authenticated uplink and ground command sent (deliberately bad ones included),
    /// with the target's answer.
    pub authenticated: Vec<super::record::AuthenticatedRecord>,
    /// Commands each task definition sent (retries included), with the most one run of it may
    /// send (`TaskNetwork::max_dispatches_per_run`).
    pub commands_per_task: Vec<CommandCount>,
    pub metrics: std::collections::BTreeMap<String, u64>,
    pub frames: u64,
    /// Mission time the flight software was down (resets to restarts), in microseconds.
    pub downtime_us: u64,
    /// The reliable link: rounds, retransmissions per message class, faults injected.
    pub link: super::link::LinkSummary,
    /// What ended the run before the mission's end, if something did.
    pub ended_early: Option<String>,
    pub transcript_sha256: String,
    pub transcript_frames: u64,
    pub injected_link_faults: u64,
    pub mission_start: String,
    pub mission_end: String,
    pub wall_time_ms: u64,
    /// Wall time after the target's first boot answered (the whole run less QEMU's start
    /// and the first boot), in µs.
    pub wall_after_boot_us: u64,
    /// Mission time covered per second of wall time.
    pub speedup: f64,
    pub decisions: Vec<super::record::Decision>,
    #[serde(skip)]
    pub record: MissionRecord,
    /// Every frame both ways, one readable line each (the hashed transcript).
    #[serde(skip)]
    pub transcript: Vec<String>,
}

impl MissionReport {
    /// Judge `run` of `plan` on a target described as `target` and build the report.
    pub fn new(
        plan: &MissionPlan,
        run: MissionRun,
        target: String,
        counts_cycles: bool,
        firmware: Option<&FirmwareImage>,
        wall: std::time::Duration,
    ) -> Self {
        let record = run.record;
        let mut expectations: Vec<Verdict> = plan
            .expectations
            .iter()
            .enumerate()
            .map(|(i, e)| expect::evaluate(i + 1, e, &record, &plan.network, counts_cycles))
            .collect();
        // Checks every run gets, whatever the scenario expects.
        if let Some(why) = &run.ended_early {
            expectations.push(Verdict {
                index: expectations.len() + 1,
                what: "the run reaches the end of the mission".into(),
                passed: false,
                detail: format!("it ended early {why}"),
            });
        }
        if let Some(&n) = record
            .metrics
            .get("state_type_mismatches")
            .filter(|n| **n > 0)
        {
            expectations.push(Verdict {
                index: expectations.len() + 1,
                what: "every state update has its timeline's value type".into(),
                passed: false,
                detail: format!(
                    "{n} state update(s) of the wrong type, read as UNKNOWN by the target (last: state key {})",
                    record.metrics.get("state_type_mismatch_key").copied().unwrap_or(0)
                ),
            });
        }
        let unrefused: Vec<String> = record
            .authenticated
            .iter()
            .filter(|a| a.attack_not_refused())
            .map(|a| {
                format!(
                    "the {} #{} at {} was {} (owed: {})",
                    a.what,
                    a.sequence,
                    fmt_time(MissionTimeUs(a.at)),
                    a.refused
                        .as_deref()
                        .map_or("accepted".to_string(), |r| format!("refused as {r}")),
                    a.expected_refusal.as_deref().unwrap_or("-"),
                )
            })
            .collect();
        if record
            .authenticated
            .iter()
            .any(|a| a.expected_refusal.is_some())
        {
            let attacks = record
                .authenticated
                .iter()
                .filter(|a| a.expected_refusal.is_some())
                .count();
            expectations.push(Verdict {
                index: expectations.len() + 1,
                what: "every deliberately bad uplink and ground command is refused with its reason"
                    .into(),
                passed: unrefused.is_empty(),
                detail: if unrefused.is_empty() {
                    format!("{attacks} refused, each with the reason it was owed")
                } else {
                    unrefused.join("; ")
                },
            });
        }
        let t = |x: Option<u64>| x.map(|v| fmt_time(MissionTimeUs(v)));
        let tasks = record
            .instances
            .iter()
            .map(|i| GanttRow {
                name: i.name.clone(),
                origin: i.origin.clone(),
                planned_start: t(i.committed_at),
                start: t(i.started_at),
                end: t(i.ended_at),
                outcome: i.outcome_name().into(),
                after_restart: i.after_restart_text(),
            })
            .collect();
        let span_us = plan.end.0 - plan.start.0;
        let downtime_us = expect::downtimes(&record)
            .iter()
            .map(|(a, b)| b.min(&plan.end.0).saturating_sub(*a))
            .sum();
        Self {
            scenario: plan.name().to_string(),
            description: plan.scenario.description.clone(),
            seed: plan.seed,
            target,
            firmware_build_id: firmware.map(|f| build_id_hex(&f.build_id)),
            passed: expectations.iter().all(|v| v.passed),
            expectations,
            tasks,
            events: record
                .labels
                .iter()
                .map(|(at, l)| (fmt_time(MissionTimeUs(*at)), l.clone()))
                .collect(),
            resets: record.resets.clone(),
            boots: record.boots.clone(),
            faults: record
                .faults
                .iter()
                .map(|(at, l)| (fmt_time(MissionTimeUs(*at)), l.clone()))
                .collect(),
            gave_up: record.gave_up.clone(),
            authenticated: record.authenticated.clone(),
            commands_per_task: record
                .commands_per_definition
                .iter()
                .map(|(&id, &commands)| CommandCount {
                    task: super::record::task_name(&plan.network.network, id),
                    commands,
                    bound_per_run: plan
                        .network
                        .network
                        .def_of_id(id)
                        .map_or(0, |def| plan.network.network.max_dispatches_per_run(def)),
                })
                .collect(),
            metrics: record.metrics.clone(),
            frames: record.frames,
            downtime_us,
            link: run.link,
            ended_early: run.ended_early,
            transcript_sha256: run.transcript_sha256,
            transcript_frames: run.transcript_frames,
            transcript: run.transcript,
            injected_link_faults: run.injected_link_faults,
            mission_start: fmt_time(plan.start),
            mission_end: fmt_time(plan.end),
            wall_time_ms: wall.as_millis() as u64,
            wall_after_boot_us: wall.saturating_sub(run.first_boot_wall).as_micros() as u64,
            speedup: span_us as f64 / 1e6 / wall.as_secs_f64().max(1e-9),
            decisions: record.decisions.clone(),
            record,
        }
    }
}

/// The terminal summary.
pub fn summary(r: &MissionReport) -> String {
    let mut out = String::new();
    out.push_str("  as executed:\n");
    for row in &r.tasks {
        let span = match (row.start.as_deref(), row.end.as_deref()) {
            (Some(s), Some(e)) => format!("{s} - {e}"),
            (Some(s), None) => format!("{s} - (running at the end)"),
            (None, Some(e)) => format!("never started; {e}"),
            (None, None) => "never started".to_string(),
        };
        let after = row
            .after_restart
            .as_deref()
            .map(|a| format!(" (after the restart: {a})"))
            .unwrap_or_default();
        out.push_str(&format!(
            "    {:<28} {:<10} {:<21}  {}{after}\n",
            row.name, row.origin, span, row.outcome
        ));
    }
    if let Some(ticks) = r.boots.first().and_then(|b| b.boot_to_ready_ticks) {
        out.push_str(&format!(
            "  boot ({}): ready after {ticks} ticks = {} instructions{}\n",
            r.boots[0].reset_cause,
            super::record::to_instructions(ticks),
            r.boots[0]
                .kernel_boot_ticks
                .map(|k| format!(" (kernel {k}, executive {})", ticks.saturating_sub(k)))
                .unwrap_or_default()
        ));
    }
    for (i, reset) in r.resets.iter().enumerate() {
        let cost = match (
            reset.boot_to_ready_ticks,
            reset.recovery_ticks,
            reset.reset_recovery_ticks,
        ) {
            (Some(boot), Some(recovery), Some(total)) => format!(
                "; reset to repaired plan {total} ticks = {} instructions (boot to ready {boot}, recovery {recovery}{})",
                super::record::to_instructions(total),
                reset
                    .planner_recovery_ticks
                    .map(|p| format!(", planner partition {p}"))
                    .unwrap_or_default()
            ),
            (_, Some(recovery), _) => format!(
                "; recovery took {recovery} ticks = {} instructions",
                super::record::to_instructions(recovery)
            ),
            _ => String::new(),
        };
        out.push_str(&format!(
            "  {} at {}: down {}, restarted ({}), {}{cost}\n",
            reset.kind,
            fmt_time(MissionTimeUs(reset.at)),
            fmt_duration_us(reset.recovery_us),
            reset.reset_cause,
            match &reset.restored_from {
                Some(from) => format!("plan restored from the {from}"),
                None => "no plan restored".to_string(),
            },
        ));
        if let Some(parts) = r.boots.get(i + 1).and_then(boot_parts) {
            out.push_str(&format!("    boot to ready, ticks by part: {parts}\n"));
        }
    }
    for g in &r.gave_up {
        out.push_str(&format!(
            "  the autonomy gave up on {} at {}: {} past its bound\n",
            g.task,
            fmt_time(MissionTimeUs(g.at)),
            g.cause
        ));
    }
    if !r.authenticated.is_empty() {
        let accepted = r
            .authenticated
            .iter()
            .filter(|a| a.refused.is_none())
            .count();
        let mut refused: std::collections::BTreeMap<&str, usize> = Default::default();
        for a in &r.authenticated {
            if let Some(reason) = &a.refused {
                *refused.entry(reason.as_str()).or_default() += 1;
            }
        }
        let refused_text = if refused.is_empty() {
            "none refused".to_string()
        } else {
            format!(
                "{} refused ({})",
                refused.values().sum::<usize>(),
                refused
                    .iter()
                    .map(|(reason, n)| format!("{reason} {n}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        };
        out.push_str(&format!(
            "  authenticated uplinks and ground commands: {accepted} accepted, {refused_text}\n"
        ));
        for a in r
            .authenticated
            .iter()
            .filter(|a| a.expected_refusal.is_some())
        {
            out.push_str(&format!(
                "    {} {} #{}: {}\n",
                fmt_time(MissionTimeUs(a.at)),
                a.what,
                a.sequence,
                a.refused
                    .as_deref()
                    .map_or("ACCEPTED".to_string(), |r| format!("refused ({r})"))
            ));
        }
    }
    let l = &r.link;
    out.push_str(&format!(
        "  link: {} rounds, {} faults injected, {} retransmissions ({} per 1000 frames), {} frames rejected{}\n",
        l.rounds,
        l.injected_uplink + l.injected_downlink,
        l.retransmissions,
        l.retransmissions_per_1000_frames,
        l.frames_rejected,
        if l.lost_to_reset > 0 {
            format!(", {} lost to resets", l.lost_to_reset)
        } else {
            String::new()
        }
    ));
    if !l.instrument_drained {
        out.push_str(&format!(
            "        the target's Instrument channel (costs, logs) had not emptied {} rounds after the mission: some instrumentation is missing\n",
            l.instrument_drain_rounds
        ));
    }
    if let Some(dropped) = r.metrics.get("instrument_messages_dropped") {
        out.push_str(&format!(
            "        the target dropped {dropped} Instrument-channel messages (costs, events, logs): that channel was full or lost; the Mission channel lost nothing\n"
        ));
    }
    let resent: Vec<String> = l
        .classes
        .iter()
        .filter(|c| c.retransmitted + c.received_again > 0)
        .map(|c| format!("{} {}+{}", c.class, c.retransmitted, c.received_again))
        .collect();
    if !resent.is_empty() {
        out.push_str(&format!(
            "        retransmitted by class (host+target): {}\n",
            resent.join(", ")
        ));
    }
    out.push_str("  expectations:\n");
    for v in &r.expectations {
        out.push_str(&format!(
            "    [{}] {}: {}\n",
            if v.passed { "ok  " } else { "FAIL" },
            v.what,
            v.detail
        ));
    }
    let passed = r.expectations.iter().filter(|v| v.passed).count();
    out.push_str(&format!(
        "{} {}: {}/{} expectations met; {} frames, mission {} to {} in {:.1} s wall ({:.0}x real time); transcript sha256 {}",
        if r.passed { "PASS" } else { "FAIL" },
        r.scenario,
        passed,
        r.expectations.len(),
        r.frames,
        r.mission_start,
        r.mission_end,
        r.wall_time_ms as f64 / 1000.0,
        r.speedup,
        &r.transcript_sha256[..16],
    ));
    out
}

/// JUnit XML: one test case per expectation.
pub fn junit(r: &MissionReport) -> String {
    use quick_junit::{NonSuccessKind, Report, TestCase, TestCaseStatus, TestSuite};
    let mut suite = TestSuite::new(r.scenario.as_str());
    suite.set_time(std::time::Duration::from_millis(r.wall_time_ms));
    for v in &r.expectations {
        let status = if v.passed {
            TestCaseStatus::success()
        } else {
            let mut s = TestCaseStatus::non_success(NonSuccessKind::Failure);
            s.set_message(v.detail.as_str());
            s
        };
        let mut case = TestCase::new(v.what.as_str(), status);
        case.set_classname(r.scenario.as_str());
        suite.add_test_case(case);
    }
    let mut report = Report::new(format!("hil run {}", r.scenario));
    report.add_test_suite(suite);
    report
        .to_string()
        .unwrap_or_else(|e| format!("<!-- JUnit XML could not be written: {e} -->\n"))
}

/// A boot's breakdown on one line ("image verified 16777, clears 1582, ..."), if measured.
fn boot_parts(boot: &super::record::BootRecord) -> Option<String> {
    let parts = boot.breakdown.parts();
    if parts.is_empty() {
        return None;
    }
    let image = boot.breakdown.image.as_deref();
    Some(
        parts
            .iter()
            .map(|&(label, ticks)| match (label, image) {
                ("image", Some(how)) => format!("image {how} {ticks}"),
                _ => format!("{label} {ticks}"),
            })
            .collect::<Vec<_>>()
            .join(", "),
    )
}

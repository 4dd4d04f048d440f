//! The temporal planner as a plug-in of the planner partition (`TemporalApp`, issue 13): a
//! task uplinked in chunks is accepted and planned across windows of a CPU share, with the
//! plan the planner finds when it runs to the end in one go; bad uplinks are refused with
//! their reason and leave the plug-in ready for the next job.
use flight_app::{
    planner_config, temporal_crc32, CpuClock, Downlink, Memories, PlannerApp, PlannerPlugin,
    PluginWindow, TemporalApp, TemporalStorage, MAX_TEMPORAL_PLAN_ACTIONS,
};
use fsw_bridge::temporal::{
    TemporalConfig, TemporalOutcome, TemporalRefusal, TemporalReport, TEMPORAL_CHUNK_MAX,
};
use fsw_bridge::{HostToTarget, TargetToHost};
use temporal::PlannedAction;

/// Arena of these tests: 4 MiB (the small benchmark instances need about 0.5 MiB).
const ARENA_WORDS: usize = 1 << 20;

fn compiled(domain: &str, instance: u32) -> Vec<u8> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../pddl/tests/benchmarks")
        .join(domain);
    let d = std::fs::read_to_string(dir.join("domain.pddl")).unwrap();
    let p = std::fs::read_to_string(dir.join(format!("instance-{instance}.pddl"))).unwrap();
    pddl::compile(
        pddl::Source {
            name: "domain.pddl",
            text: &d,
        },
        pddl::Source {
            name: "problem.pddl",
            text: &p,
        },
        &pddl::ModuleRegistry::new(),
        &pddl::Options::default(),
    )
    .unwrap()
    .task
}

/// A clock that advances `per_reading` ticks at every reading (a stand-in for the partition's
/// CPU time: the more the search reads it, the more it has spent).
struct Ticking {
    now: u64,
    per_reading: u64,
}

impl CpuClock for Ticking {
    fn ticks(&mut self) -> u64 {
        self.now += self.per_reading;
        self.now
    }
}

fn app() -> TemporalApp<'static> {
    let plan =
        Box::leak(vec![PlannedAction::default(); MAX_TEMPORAL_PLAN_ACTIONS].into_boxed_slice());
    let mut app = TemporalApp::new(plan);
    give(&mut app);
    app
}

fn give(app: &mut TemporalApp<'static>) {
    if app.needs_storage() {
        app.give_storage(TemporalStorage {
            task: Box::leak(vec![0u8; 64 * 1024].into_boxed_slice()),
            arena: Box::leak(vec![0u32; ARENA_WORDS].into_boxed_slice()),
        });
    }
}

fn uplink(job: u16, task: &[u8], crc32: u32, config: TemporalConfig) -> Vec<HostToTarget> {
    let mut msgs = vec![HostToTarget::TemporalBegin {
        job,
        len: task.len() as u32,
        crc32,
        config,
    }];
    for (i, chunk) in task.chunks(TEMPORAL_CHUNK_MAX).enumerate() {
        msgs.push(HostToTarget::TemporalChunk {
            job,
            offset: (i * TEMPORAL_CHUNK_MAX) as u32,
            bytes: heapless::Vec::from_slice(chunk).unwrap(),
        });
    }
    msgs
}

fn handle_all(app: &mut TemporalApp<'static>, msgs: &[HostToTarget]) -> Vec<TemporalReport> {
    let mut out = Vec::new();
    for m in msgs {
        give(app);
        let mut sink = |m: TargetToHost| out.push(m);
        assert!(app.handle(m, &mut sink as &mut dyn Downlink));
    }
    reports(out)
}

fn reports(out: Vec<TargetToHost>) -> Vec<TemporalReport> {
    out.into_iter()
        .map(|m| match m {
            TargetToHost::Temporal(r) => r,
            other => panic!("not a temporal report: {other:?}"),
        })
        .collect()
}

/// Runs windows of `share` ticks until the job is done; returns the reports and the windows.
fn plan_in_windows(app: &mut TemporalApp<'static>, share: u64) -> (Vec<TemporalReport>, u32) {
    let mut clock = Ticking {
        now: 0,
        per_reading: 10,
    };
    let mut warm = [0u8; 0];
    let mut memories = Memories {
        warm: &mut warm,
        nv: None,
        security: None,
    };
    let mut out = Vec::new();
    let mut windows = 0;
    while app.job().is_some() {
        windows += 1;
        assert!(windows < 100_000, "the search never ends");
        if app.planning_pending() {
            let until = clock.now + share;
            let mut sink = |m: TargetToHost| out.push(m);
            let mut w = PluginWindow {
                memories: &mut memories,
                fetch: None,
                clock: &mut clock,
                downlink: &mut sink,
                until: Some(until),
                hard_until: Some(until + share / 4),
            };
            app.window(&mut w);
        }
        // Room for four reports a window, as a nearly full queue would leave.
        let mut sink = |m: TargetToHost| out.push(m);
        app.report(4, &mut sink);
    }
    (reports(out), windows)
}

/// The same task planned by `temporal::Planner` in one go.
fn reference(task: &[u8], config: &TemporalConfig) -> (Vec<PlannedAction>, u32, temporal::Stats) {
    let parsed = temporal::Task::parse(task).unwrap();
    let mut arena = vec![0u32; ARENA_WORDS];
    let mut planner = temporal::Planner::new(
        parsed,
        &mut arena,
        planner_config(config, MAX_TEMPORAL_PLAN_ACTIONS),
    )
    .unwrap();
    assert_eq!(planner.step(u32::MAX), temporal::Status::Solved);
    let mut out = vec![PlannedAction::default(); MAX_TEMPORAL_PLAN_ACTIONS];
    let (n, makespan) = planner.plan(&mut out).unwrap();
    out.truncate(n);
    (out, makespan, planner.stats())
}

#[test]
fn a_task_uplinked_in_chunks_is_planned_across_windows_with_the_plan_of_one_go() {
    for (domain, instance) in [("satellite", 1), ("rovers", 2)] {
        let task = compiled(domain, instance);
        let config = TemporalConfig::DEFAULT;
        let mut app = app();
        let accepted = handle_all(&mut app, &uplink(7, &task, temporal_crc32(&task), config));
        assert!(
            matches!(accepted.as_slice(), [TemporalReport::Accepted { job: 7, task_bytes, .. }] if *task_bytes as usize == task.len()),
            "{accepted:?}"
        );
        assert!(app.planning_pending());
        // A share of 200 ticks is 20 clock readings: a few expansions per window.
        let (reports, windows) = plan_in_windows(&mut app, 200);
        let (plan, makespan, stats) = reference(&task, &config);
        let steps: Vec<PlannedAction> = reports
            .iter()
            .filter_map(|r| match *r {
                TemporalReport::Step {
                    action,
                    start,
                    duration,
                    start_lb,
                    start_ub,
                    ..
                } => Some(PlannedAction {
                    action,
                    start,
                    duration,
                    start_lb,
                    start_ub,
                }),
                _ => None,
            })
            .collect();
        assert_eq!(steps, plan, "{domain} {instance}");
        let Some(TemporalReport::Done {
            outcome,
            steps: n,
            makespan: m,
            windows: w,
            peak_arena_bytes,
            arena_bytes,
            planning_ticks,
            ..
        }) = reports.last().cloned()
        else {
            panic!("no Done: {reports:?}");
        };
        assert_eq!(outcome, TemporalOutcome::Solved);
        assert_eq!((n as usize, m), (plan.len(), makespan));
        assert!(
            w > 1 && w <= windows,
            "anytime across windows: {w} of {windows}"
        );
        assert_eq!(u64::from(peak_arena_bytes), stats.peak_words * 4);
        assert_eq!(arena_bytes as usize, ARENA_WORDS * 4);
        assert!(planning_ticks > 0);
        assert!(reports.iter().any(|r| matches!(r, TemporalReport::Stats { expanded, .. } if u64::from(*expanded) == stats.expanded)));
        // The job is over: the memory is asked for again, and the next job plans as well.
        assert!(app.job().is_none() && app.needs_storage());
        let again = handle_all(&mut app, &uplink(8, &task, temporal_crc32(&task), config));
        assert!(matches!(
            again.as_slice(),
            [TemporalReport::Accepted { job: 8, .. }]
        ));
        // With a share larger than the search: one window to set up, one to search.
        let (reports, _) = plan_in_windows(&mut app, 1_000_000);
        assert!(matches!(
            reports.last(),
            Some(TemporalReport::Done {
                outcome: TemporalOutcome::Solved,
                windows: 2,
                ..
            })
        ));
    }
}

#[test]
fn bad_uplinks_are_refused_with_their_reason_and_the_next_job_still_plans() {
    let task = compiled("satellite", 1);
    let config = TemporalConfig::DEFAULT;
    let mut app = app();
    // A flipped bit: the CRC no longer matches.
    let mut flipped = task.clone();
    flipped[40] ^= 0x10;
    let r = handle_all(
        &mut app,
        &uplink(1, &flipped, temporal_crc32(&task), config),
    );
    assert!(
        matches!(
            r.as_slice(),
            [TemporalReport::Refused {
                job: 1,
                reason: TemporalRefusal::BadCrc { .. }
            }]
        ),
        "{r:?}"
    );
    // Damaged with a matching CRC: the task's own validation refuses it, naming where.
    let mut bad = task.clone();
    bad[0] = b'X';
    let r = handle_all(&mut app, &uplink(2, &bad, temporal_crc32(&bad), config));
    assert!(
        matches!(
            r.as_slice(),
            [TemporalReport::Refused {
                job: 2,
                reason: TemporalRefusal::BadTask { kind: 0, offset: 0 }
            }]
        ),
        "{r:?}"
    );
    // Cut short: the length says more than the bytes (a truncated task).
    let short = &task[..task.len() / 2];
    let r = handle_all(&mut app, &uplink(3, short, temporal_crc32(short), config));
    assert!(
        matches!(
            r.as_slice(),
            [TemporalReport::Refused {
                job: 3,
                reason: TemporalRefusal::BadTask { .. }
            }]
        ),
        "{r:?}"
    );
    // Over the task buffer, and empty.
    for len in [0u32, 64 * 1024 + 1] {
        let r = handle_all(
            &mut app,
            &[HostToTarget::TemporalBegin {
                job: 4,
                len,
                crc32: 0,
                config,
            }],
        );
        assert!(
            matches!(
                r.as_slice(),
                [TemporalReport::Refused {
                    job: 4,
                    reason: TemporalRefusal::TooLarge { capacity: 65536 }
                }]
            ),
            "{r:?}"
        );
    }
    // A chunk out of order, and one of another job: refused, the job goes on.
    let mut msgs = uplink(5, &task, temporal_crc32(&task), config);
    let r = handle_all(&mut app, &msgs[..1]);
    assert!(r.is_empty());
    let r = handle_all(&mut app, &msgs[2..3]);
    assert!(
        matches!(
            r.as_slice(),
            [TemporalReport::Refused {
                job: 5,
                reason: TemporalRefusal::OutOfSequence { expected_offset: 0 }
            }]
        ),
        "{r:?}"
    );
    if let HostToTarget::TemporalChunk { job, .. } = &mut msgs[1] {
        *job = 6;
    }
    let r = handle_all(&mut app, &msgs[1..2]);
    assert!(
        matches!(r.as_slice(), [TemporalReport::Refused { job: 6, .. }]),
        "{r:?}"
    );
    let r = handle_all(
        &mut app,
        &uplink(5, &task, temporal_crc32(&task), config)[1..],
    );
    assert!(
        matches!(r.as_slice(), [TemporalReport::Accepted { job: 5, .. }]),
        "{r:?}"
    );
    let (reports, _) = plan_in_windows(&mut app, 10_000);
    assert!(matches!(
        reports.last(),
        Some(TemporalReport::Done {
            job: 5,
            outcome: TemporalOutcome::Solved,
            ..
        })
    ));
    assert_eq!((app.refused, app.finished), (7, 1));
}

#[test]
fn a_job_stops_at_its_expansion_and_window_limits() {
    let task = compiled("rovers", 3);
    for (config, expected) in [
        (
            TemporalConfig {
                max_expansions: 5,
                ..TemporalConfig::DEFAULT
            },
            TemporalOutcome::ExpansionLimit,
        ),
        (
            TemporalConfig {
                max_windows: 3,
                ..TemporalConfig::DEFAULT
            },
            TemporalOutcome::WindowLimit,
        ),
    ] {
        let mut app = app();
        handle_all(&mut app, &uplink(1, &task, temporal_crc32(&task), config));
        let (reports, _) = plan_in_windows(&mut app, 100);
        assert!(
            matches!(reports.last(), Some(TemporalReport::Done { outcome, steps: 0, makespan: 0, .. }) if *outcome == expected),
            "{reports:?}"
        );
    }
}

#[test]
fn the_mexec_planner_is_a_plug_in_too() {
    let mut mexec = PlannerApp::new();
    let plugins: [&mut dyn PlannerPlugin; 1] = [&mut mexec];
    for p in plugins {
        assert_eq!(p.name(), "mexec");
        // Its input is the executive's channel, not the host's messages.
        let mut sink = |_m: TargetToHost| panic!("nothing to say");
        assert!(!p.handle(&HostToTarget::Ping { seq: 1 }, &mut sink));
        assert!(!p.planning_pending() && !p.busy());
    }
    let mut temporal = app();
    assert_eq!(PlannerPlugin::name(&temporal), "temporal");
    let mut sink = |_m: TargetToHost| panic!("nothing to say");
    assert!(!temporal.handle(&HostToTarget::Ping { seq: 1 }, &mut sink));
}

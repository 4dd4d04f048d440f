//! The temporal planner as a plug-in of the planner partition (`TemporalApp`, issue 13): a
//! task uplinked in chunks is accepted and planned across windows of a CPU share, with the
//! plan the planner finds when it runs to the end in one go; bad uplinks are refused with
//! their reason and leave the plug-in ready for the next job. Uplinks are authenticated
//! (`sdls::temporal`): forged, replayed and tampered ones are refused, counted, and the
//! plug-in plans the next authentic one.
use flight_app::{
    planner_config, temporal_crc32, CpuClock, Downlink, Memories, PlannerApp, PlannerPlugin,
    PluginWindow, SecurityStore, StoreError, TemporalApp, TemporalStorage,
    MAX_TEMPORAL_PLAN_ACTIONS,
};
use fsw_bridge::temporal::{
    TemporalConfig, TemporalOutcome, TemporalRefusal, TemporalReport, TEMPORAL_CHUNK_MAX,
};
use fsw_bridge::SecurityRefusal;
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

/// The key these tests sign with.
const KEY: sdls::Key = sdls::Key {
    spi: 2,
    bytes: [0x3c; 32],
};

/// A security area in memory, shared by the applications of one test (as non-volatile memory
/// is by the partition's restarts).
#[derive(Clone)]
struct Nv(std::rc::Rc<std::cell::RefCell<[u8; sdls::nv::SECURITY_AREA_BYTES]>>);

impl Nv {
    fn provisioned() -> Self {
        let mut area = [0u8; sdls::nv::SECURITY_AREA_BYTES];
        sdls::nv::provision(&mut area, &KEY).unwrap();
        Self(std::rc::Rc::new(std::cell::RefCell::new(area)))
    }
}

impl SecurityStore for Nv {
    fn read(&mut self, area: &mut [u8; sdls::nv::SECURITY_AREA_BYTES]) -> Result<(), StoreError> {
        area.copy_from_slice(&*self.0.borrow());
        Ok(())
    }
    fn write(&mut self, offset: usize, bytes: &[u8]) -> Result<(), StoreError> {
        self.0.borrow_mut()[offset..offset + bytes.len()].copy_from_slice(bytes);
        Ok(())
    }
}

fn app() -> TemporalApp<'static> {
    app_with(Some(Nv::provisioned()))
}

/// An application whose security area is `nv` (None: no key).
fn app_with(nv: Option<Nv>) -> TemporalApp<'static> {
    let plan =
        Box::leak(vec![PlannedAction::default(); MAX_TEMPORAL_PLAN_ACTIONS].into_boxed_slice());
    let mut app = TemporalApp::new(plan);
    app.secure(nv.map(|nv| Box::leak(Box::new(nv)) as &mut dyn SecurityStore));
    give(&mut app);
    app
}

/// The secured task of `task` for job `job`, signed with `key` and `sequence`.
fn secured(
    key: &sdls::Key,
    sequence: u32,
    job: u16,
    config: &TemporalConfig,
    task: &[u8],
) -> Vec<u8> {
    let mut out = vec![0u8; task.len() + sdls::uplink::OVERHEAD];
    sdls::temporal::sign_into(key, sequence, job, config, task, &mut out).unwrap();
    out
}

/// The messages of an authentic job (signed with the test key, sequence `sequence`).
fn signed(job: u16, sequence: u32, task: &[u8], config: TemporalConfig) -> Vec<HostToTarget> {
    let bytes = secured(&KEY, sequence, job, &config, task);
    uplink(job, &bytes, temporal_crc32(&bytes), config)
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
        let accepted = handle_all(&mut app, &signed(7, 1, &task, config));
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
        let again = handle_all(&mut app, &signed(8, 2, &task, config));
        assert!(matches!(
            again.as_slice(),
            [TemporalReport::Accepted { job: 8, .. }]
        ));
        // With a share larger than the search: the set-up in five windows (the layout and
        // the duplicate table; the relaxation's indexes; the compression marks; the root's
        // heuristic; the root's successors: no window takes two of the last four, each up to
        // about an expansion's work), then one to search.
        let (reports, _) = plan_in_windows(&mut app, 1_000_000);
        assert!(
            matches!(
                reports.last(),
                Some(TemporalReport::Done {
                    outcome: TemporalOutcome::Solved,
                    windows: 6,
                    ..
                })
            ),
            "{:?}",
            reports.last()
        );
    }
}

#[test]
fn bad_uplinks_are_refused_with_their_reason_and_the_next_job_still_plans() {
    let task = compiled("satellite", 1);
    let config = TemporalConfig::DEFAULT;
    let mut app = app();
    // A flipped bit: the CRC no longer matches.
    let good = secured(&KEY, 1, 1, &config, &task);
    let mut flipped = good.clone();
    flipped[40] ^= 0x10;
    let r = handle_all(
        &mut app,
        &uplink(1, &flipped, temporal_crc32(&good), config),
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
    let r = handle_all(&mut app, &signed(2, 2, &bad, config));
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
    let r = handle_all(&mut app, &signed(3, 3, short, config));
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
    let mut msgs = signed(5, 4, &task, config);
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
    let r = handle_all(&mut app, &signed(5, 4, &task, config)[1..]);
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
        handle_all(&mut app, &signed(1, 1, &task, config));
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

/// The security refusal of the only report in `r` for `job`.
fn security_refusal(r: &[TemporalReport], job: u16) -> SecurityRefusal {
    match r {
        [TemporalReport::Refused {
            job: j,
            reason: TemporalRefusal::Security(reason),
        }] if *j == job => *reason,
        other => panic!("job {job}: not one security refusal: {other:?}"),
    }
}

#[test]
fn forged_replayed_and_tampered_uplinks_are_refused_counted_and_the_next_authentic_job_plans() {
    let task = compiled("satellite", 1);
    let config = TemporalConfig::DEFAULT;
    let nv = Nv::provisioned();
    let mut app = app_with(Some(nv.clone()));

    // Signed with another key: a forged MAC.
    let forger = sdls::Key {
        bytes: [0x3d; 32],
        ..KEY
    };
    let bytes = secured(&forger, 1, 1, &config, &task);
    let r = handle_all(&mut app, &uplink(1, &bytes, temporal_crc32(&bytes), config));
    assert_eq!(security_refusal(&r, 1), SecurityRefusal::BadMac);
    // Nothing moved: sequence 1 is still fresh.
    assert_eq!(app.security().last_sequence(), 0);

    // A valid MAC, then one chunk tampered with on the way, its CRC made to match.
    let good = secured(&KEY, 1, 2, &config, &task);
    let mut tampered = good.clone();
    tampered[sdls::uplink::HEADER_LEN + 200] ^= 0x04;
    let r = handle_all(
        &mut app,
        &uplink(2, &tampered, temporal_crc32(&tampered), config),
    );
    assert_eq!(security_refusal(&r, 2), SecurityRefusal::BadMac);
    // The job's configuration changed on the way (under the same task bytes): the MAC covers
    // it.
    let looser = TemporalConfig {
        max_expansions: 3,
        ..config
    };
    let r = handle_all(&mut app, &uplink(2, &good, temporal_crc32(&good), looser));
    assert_eq!(security_refusal(&r, 2), SecurityRefusal::BadMac);
    // Another SPI, and the secured string cut short under a matching CRC.
    let other_spi = sdls::Key { spi: 9, ..KEY };
    let bytes = secured(&other_spi, 1, 3, &config, &task);
    let r = handle_all(&mut app, &uplink(3, &bytes, temporal_crc32(&bytes), config));
    assert_eq!(security_refusal(&r, 3), SecurityRefusal::UnknownKey);
    let cut = &good[..good.len() - 1];
    let r = handle_all(&mut app, &uplink(2, cut, temporal_crc32(cut), config));
    assert_eq!(security_refusal(&r, 2), SecurityRefusal::Truncated);

    // The authentic job is accepted and planned.
    let r = handle_all(&mut app, &uplink(2, &good, temporal_crc32(&good), config));
    assert!(
        matches!(r.as_slice(), [TemporalReport::Accepted { job: 2, .. }]),
        "{r:?}"
    );
    assert_eq!(app.security().last_sequence(), 1);
    // While it plans, a Begin (here a replayed one) cannot end it: refused as busy.
    let r = handle_all(
        &mut app,
        &uplink(2, &good, temporal_crc32(&good), config)[..1],
    );
    assert!(
        matches!(
            r.as_slice(),
            [TemporalReport::Refused {
                job: 2,
                reason: TemporalRefusal::Busy { job: 2 }
            }]
        ),
        "{r:?}"
    );
    assert!(app.planning_pending());
    let (reports, _) = plan_in_windows(&mut app, 10_000);
    assert!(matches!(
        reports.last(),
        Some(TemporalReport::Done {
            job: 2,
            outcome: TemporalOutcome::Solved,
            ..
        })
    ));
    // The same messages again: a replay, refused.
    let r = handle_all(&mut app, &uplink(2, &good, temporal_crc32(&good), config));
    assert_eq!(security_refusal(&r, 2), SecurityRefusal::Replay);
    assert!(!app.planning_pending());

    let mut expected = [0u32; SecurityRefusal::COUNT];
    expected[SecurityRefusal::BadMac.index()] = 3;
    expected[SecurityRefusal::UnknownKey.index()] = 1;
    expected[SecurityRefusal::Truncated.index()] = 1;
    expected[SecurityRefusal::Replay.index()] = 1;
    assert_eq!(app.security_refused, expected);
    assert_eq!((app.refused, app.finished), (7, 1));

    // A restart of the partition (a new application on the same non-volatile memory): the
    // replay stays refused, and the next sequence number is taken.
    let mut restarted = app_with(Some(nv));
    let r = handle_all(
        &mut restarted,
        &uplink(2, &good, temporal_crc32(&good), config),
    );
    assert_eq!(security_refusal(&r, 2), SecurityRefusal::Replay);
    let r = handle_all(&mut restarted, &signed(4, 2, &task, config));
    assert!(
        matches!(r.as_slice(), [TemporalReport::Accepted { job: 4, .. }]),
        "{r:?}"
    );

    // No key provisioned: every job is refused, and nothing is planned.
    let mut keyless = app_with(None);
    let r = handle_all(&mut keyless, &signed(5, 3, &task, config));
    assert_eq!(security_refusal(&r, 5), SecurityRefusal::NoKey);
    assert!(!keyless.planning_pending());
}

/// The memory a warm reset keeps (the task buffer, the arena and the job's record), shared by
/// the applications that a test starts one after the other on it, as the planner partition
/// does at every (re)start.
struct KeptMemory {
    task: *mut [u8],
    arena: *mut [u32],
    record: *mut [u32; flight_app::TEMPORAL_RESUME_RECORD_WORDS],
    nv: Nv,
}

impl KeptMemory {
    fn new() -> Self {
        Self {
            task: Box::into_raw(vec![0u8; 64 * 1024].into_boxed_slice()),
            arena: Box::into_raw(vec![0u32; ARENA_WORDS].into_boxed_slice()),
            record: Box::into_raw(Box::new([0u32; flight_app::TEMPORAL_RESUME_RECORD_WORDS])),
            nv: Nv::provisioned(),
        }
    }

    /// A (re)started application on this memory. The application made before must be gone
    /// (dropped): it held the only references.
    fn start(&self) -> TemporalApp<'static> {
        let plan =
            Box::leak(vec![PlannedAction::default(); MAX_TEMPORAL_PLAN_ACTIONS].into_boxed_slice());
        let mut app = TemporalApp::new(plan);
        app.secure(Some(
            Box::leak(Box::new(self.nv.clone())) as &mut dyn SecurityStore
        ));
        // SAFETY: the buffers live for the test (never freed); the application before this one
        // was dropped, so these are the only references to them.
        unsafe {
            app.keep_jobs_in(&mut *self.record);
            app.give_storage(TemporalStorage {
                task: &mut *self.task,
                arena: &mut *self.arena,
            });
        }
        app
    }

    /// Fill the three with garbage from `seed` (what a cold boot may leave in RAM).
    fn garble(&self, seed: u32) {
        let mut x = seed | 1;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        // SAFETY: as in `start`, with no application alive.
        unsafe {
            (*self.task).iter_mut().for_each(|b| *b = next() as u8);
            (*self.record).iter_mut().for_each(|w| *w = next());
        }
    }
}

/// The application ends (a reset): the references it held into the kept memory end with it.
fn gone(_app: TemporalApp<'static>) {}

/// Windows of `share` ticks, at most `max` of them (the job is still going after them if it
/// needs more).
fn some_windows(app: &mut TemporalApp<'static>, share: u64, max: u32) -> Vec<TemporalReport> {
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
    for _ in 0..max {
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
        let mut sink = |m: TargetToHost| out.push(m);
        app.report(4, &mut sink);
    }
    reports(out)
}

fn steps_of(reports: &[TemporalReport]) -> Vec<PlannedAction> {
    reports
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
        .collect()
}

#[test]
fn a_job_interrupted_by_a_warm_reset_is_resumed_and_gives_the_plan_of_one_go() {
    let task = compiled("rovers", 2);
    let config = TemporalConfig::DEFAULT;
    let (plan, makespan, _) = reference(&task, &config);
    let memory = KeptMemory::new();
    let mut app = memory.start();
    assert!(!app.resume(), "nothing to resume in zeroed memory");
    let r = handle_all(&mut app, &signed(3, 1, &task, config));
    assert!(matches!(
        r.as_slice(),
        [TemporalReport::Accepted { job: 3, .. }]
    ));
    // A few windows of search, then the reset: the application and its search are gone.
    let before = some_windows(&mut app, 20, 6);
    assert!(app.planning_pending(), "still searching: {before:?}");
    gone(app);

    let mut app = memory.start();
    assert!(app.resume());
    assert_eq!(app.job(), Some(3));
    // The stored task is checked again a piece at a time (small shares: several windows),
    // then the search restarts from the beginning.
    let after = some_windows(&mut app, 40, 100_000);
    assert!(
        matches!(after.first(), Some(TemporalReport::Resumed { job: 3, task_bytes, .. }) if *task_bytes as usize == task.len()),
        "{:?}",
        after.first()
    );
    assert_eq!(
        steps_of(&after),
        plan,
        "the plan of an uninterrupted search"
    );
    assert!(
        matches!(after.last(), Some(TemporalReport::Done { job: 3, outcome: TemporalOutcome::Solved, makespan: m, .. }) if *m == makespan),
        "{:?}",
        after.last()
    );
    assert_eq!((app.resumed, app.finished), (1, 1));
    // The job is over: its record is cleared, and the next start resumes nothing.
    gone(app);
    let mut app = memory.start();
    assert!(!app.resume());

    // A job accepted and not yet searched is resumed as well; a Begin meanwhile is refused
    // (busy) and changes nothing.
    handle_all(&mut app, &signed(4, 2, &task, config));
    let r = handle_all(&mut app, &signed(5, 3, &task, config)[..1]);
    assert!(matches!(
        r.as_slice(),
        [TemporalReport::Refused {
            reason: TemporalRefusal::Busy { job: 4 },
            ..
        }]
    ));
    gone(app);
    let mut app = memory.start();
    assert!(app.resume());
    assert_eq!(app.job(), Some(4));
}

#[test]
fn memory_a_cold_boot_left_resumes_nothing_and_a_damaged_task_is_refused_not_planned() {
    let task = compiled("satellite", 1);
    let config = TemporalConfig::DEFAULT;
    let memory = KeptMemory::new();
    for seed in 1..=2_000 {
        memory.garble(seed);
        let mut app = memory.start();
        assert!(!app.resume(), "seed {seed}: garbage resumed");
        assert!(!app.planning_pending() && app.job().is_none());
    }
    // A whole record with the magic but one word changed: its CRC fails.
    let mut app = memory.start();
    handle_all(&mut app, &signed(6, 1, &task, config));
    gone(app);
    // SAFETY: no application alive.
    let whole = unsafe { *memory.record };
    for word in 0..whole.len() {
        let mut changed = whole;
        changed[word] ^= 0x0100;
        unsafe { *memory.record = changed };
        assert!(!memory.start().resume(), "word {word} changed");
    }
    // The record whole, the task under it damaged: resumed, checked, refused, not planned.
    unsafe {
        *memory.record = whole;
        (*memory.task)[sdls::uplink::HEADER_LEN + 77] ^= 0x40;
    }
    let mut app = memory.start();
    assert!(app.resume());
    let r = some_windows(&mut app, 1_000, 50);
    assert!(
        matches!(
            r.as_slice(),
            [TemporalReport::Refused {
                job: 6,
                reason: TemporalRefusal::BadCrc { .. }
            }]
        ),
        "{r:?}"
    );
    assert!(app.job().is_none() && !app.planning_pending());
    gone(app);
    assert!(
        !memory.start().resume(),
        "the refused job's record is cleared"
    );
}

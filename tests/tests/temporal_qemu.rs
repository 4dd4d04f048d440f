//! The temporal PDDL planner on the emulated RAD750 (issue 13, items 2 and 4): `hil plan
//! --emulated` plans in the planner partition, anytime across its windows, with the plan the
//! native planner finds (the same search, the same arena size), and every plan passes the
//! independent validator of `pddl`'s tests. A corrupted or malformed task is refused with its
//! reason, and the target plans the next one as before. Uplinks are authenticated: a forged
//! MAC, a replayed sequence number and a chunk tampered with after a valid MAC are refused
//! with their reason, and the target plans the next authentic one.
use fsw_bridge::temporal::TemporalConfig;
use fsw_bridge::HostToTarget;
use hil::plan::{plan_compiled, PlanOptions, PlanReport};
use hil::plan_emulated::{EmulatedError, EmulatedPlanner};
use hil_tests::firmware;

#[path = "../../pddl/tests/common/mod.rs"]
#[allow(dead_code, clippy::all)]
mod pddl_common;

/// The compiled tasks' epsilon, in PDDL time units (`pddl::Options::default()`).
const EPSILON: f64 = 0.01;
/// Frames a job may take before the test gives up (the instances here take tens).
const MAX_FRAMES: u32 = 5_000;

/// Small benchmark instances: every domain of the goal's three, a few seconds of QEMU.
const INSTANCES: [(&str, u32); 5] = [
    ("satellite", 1),
    ("satellite", 2),
    ("rovers", 1),
    ("rovers", 2),
    ("driverlog", 1),
];

fn files(domain: &str, instance: u32) -> (String, String) {
    let dir = hil::repo_root().join("pddl/tests/benchmarks").join(domain);
    (
        std::fs::read_to_string(dir.join("domain.pddl")).unwrap(),
        std::fs::read_to_string(dir.join(format!("instance-{instance}.pddl"))).unwrap(),
    )
}

/// The same options on both targets: the target's arena size natively too, so that the open
/// lists and the duplicate table have the same sizes.
fn options() -> PlanOptions {
    PlanOptions {
        arena_bytes: flight_app::TEMPORAL_ARENA_BYTES,
        ..PlanOptions::default()
    }
}

fn steps(r: &PlanReport) -> Vec<pddl_common::Step> {
    r.plan
        .iter()
        .map(|s| pddl_common::Step {
            start: s.start,
            action: s.action.clone(),
            duration: s.duration,
        })
        .collect()
}

#[test]
fn emulated_plans_are_the_native_plans_and_valid_and_bad_tasks_are_refused() {
    let _one = hil_tests::exclusive_qemu();
    let mut target = EmulatedPlanner::boot(firmware()).unwrap_or_else(|e| panic!("{e}"));
    let options = options();
    for (domain, instance) in INSTANCES {
        let (d, p) = files(domain, instance);
        let compiled = pddl_common::compile(&d, &p).unwrap();
        let native = plan_compiled(&compiled, &options).unwrap();
        let emulated = target
            .plan(&compiled, &options, MAX_FRAMES)
            .unwrap_or_else(|e| panic!("{domain} {instance}: {e}"));
        let tag = format!("{domain} {instance}");
        assert!(emulated.solved, "{tag}: {}", emulated.outcome);
        assert_eq!(emulated.plan, native.plan, "{tag}: the same plan");
        assert_eq!(emulated.makespan, native.makespan, "{tag}");
        assert_eq!(
            (
                emulated.expanded,
                emulated.generated,
                emulated.evaluated,
                emulated.nodes,
                emulated.best_h
            ),
            (
                native.expanded,
                native.generated,
                native.evaluated,
                native.nodes,
                native.best_h
            ),
            "{tag}: the same search"
        );
        assert_eq!(emulated.peak_arena_bytes, native.peak_arena_bytes, "{tag}");
        // The search's plan before the elimination, and the elimination's tries, as natively.
        assert_eq!(
            (
                emulated.first_plan_actions,
                emulated.first_plan_makespan,
                emulated.eliminated,
                emulated.elimination_checks
            ),
            (
                native.first_plan_actions,
                native.first_plan_makespan,
                native.eliminated,
                native.elimination_checks
            ),
            "{tag}: the same elimination"
        );
        let validator = pddl_common::Validator::new(&d, &p, EPSILON);
        if let Err(why) = validator.validate(&steps(&emulated)) {
            panic!("{tag}: the emulated plan is invalid: {why}");
        }
        let costs = emulated.emulated.clone().expect("guest costs");
        assert!(costs.planning_ticks > 0 && costs.guest_instructions > costs.planning_ticks);
        // The elimination's cost apart from the instructions to the search's plan, its units
        // each within the planning share of a window (24,900 ticks) and no dearer than an
        // expansion.
        assert!(native.elimination_checks > 0, "{tag}");
        assert!(costs.elimination_ticks > 0, "{tag}");
        assert_eq!(
            costs.improved_plan_instructions,
            ((costs.planning_ticks + costs.elimination_ticks) as f64
                * hil::plan_emulated::INSTRUCTIONS_PER_TICK)
                .round() as u64,
            "{tag}"
        );
        assert!(
            costs.worst_elimination_ticks > 0
                && costs.worst_elimination_ticks <= costs.worst_expansion_ticks,
            "{tag}: {costs:?}"
        );
        assert!(costs.planner_windows >= 1 && costs.frames >= costs.planner_windows);
        assert!(costs.receive_ticks > costs.auth_ticks && costs.auth_ticks > 0);
        println!(
            "{tag}: receiving {} guest instructions ({} ticks), authentication {} ({} ticks), {} task bytes",
            costs.receive_instructions,
            costs.receive_ticks,
            costs.auth_instructions,
            costs.auth_ticks,
            compiled.task.len()
        );
        println!(
            "{tag}: makespan {:?} (search's {:?}), {} expanded, {} guest instructions (+{} elimination, costliest unit {} ticks), {} planner windows, {} frames, peak arena {} bytes, costliest expansion {} ticks, costliest set-up piece {} ticks, health events so far {:?}",
            emulated.makespan,
            emulated.first_plan_makespan,
            emulated.expanded,
            costs.guest_instructions,
            costs.elimination_instructions,
            costs.worst_elimination_ticks,
            costs.planner_windows,
            costs.frames,
            emulated.peak_arena_bytes,
            costs.worst_expansion_ticks,
            costs.worst_set_up_ticks,
            target.health_events
        );
    }
    // The search and its set-up stay within their windows: the set-up comes in pieces
    // (satellite 2's whole set-up, about 54,000 ticks, is more than a 33,200-tick window), so
    // the health monitor logs no overrun of the planner partition, uplinks included.
    assert!(
        target.health_events.is_empty(),
        "{:?}",
        target.health_events
    );

    // Corrupted on the way (a flipped bit under the announced CRC), malformed (a bad header
    // under a matching CRC), cut short, and a chunk of no job: each refused with its reason.
    let (d, p) = files("satellite", 1);
    let compiled = pddl_common::compile(&d, &p).unwrap();
    let task = &compiled.task;
    let config = TemporalConfig::DEFAULT;
    let job = target.new_job();
    let mut msgs = target.signed_job_messages(job, task, config);
    if let HostToTarget::TemporalChunk { bytes, .. } = &mut msgs[1] {
        bytes[40] ^= 0x10;
    }
    let e = target.uplink(job, msgs).expect_err("corrupted");
    assert!(
        matches!(&e, EmulatedError::Refused(r) if r.starts_with("BadCrc")),
        "{e}"
    );

    let mut bad = task.clone();
    bad[0] = b'X';
    let job = target.new_job();
    let msgs = target.signed_job_messages(job, &bad, config);
    let e = target.uplink(job, msgs).expect_err("malformed");
    assert!(
        matches!(&e, EmulatedError::Refused(r) if r == "BadTask { kind: 0, offset: 0 }"),
        "{e}"
    );

    let job = target.new_job();
    let short = &task[..task.len() / 3];
    let msgs = target.signed_job_messages(job, short, config);
    let e = target.uplink(job, msgs).expect_err("truncated");
    assert!(
        matches!(&e, EmulatedError::Refused(r) if r.starts_with("BadTask")),
        "{e}"
    );

    let job = target.new_job();
    let stray = target.signed_job_messages(job, task, config).remove(2);
    let e = target.uplink(job, vec![stray]).expect_err("no job");
    assert!(
        matches!(&e, EmulatedError::Refused(r) if r.starts_with("OutOfSequence")),
        "{e}"
    );

    let job = target.new_job();
    let e = target
        .uplink(
            job,
            vec![HostToTarget::TemporalBegin {
                job,
                len: (flight_app::MAX_TEMPORAL_TASK_BYTES + 1) as u32,
                crc32: 0,
                config,
            }],
        )
        .expect_err("too large");
    assert!(
        matches!(&e, EmulatedError::Refused(r) if *r == format!("TooLarge {{ capacity: {} }}", flight_app::MAX_TEMPORAL_TASK_BYTES)),
        "{e}"
    );

    // The target kept running: the next job plans as the first did.
    let again = target.plan(&compiled, &options, MAX_FRAMES).unwrap();
    let native = plan_compiled(&compiled, &options).unwrap();
    assert!(again.solved);
    assert_eq!(again.plan, native.plan);
}

/// The security refusal `e` names, if it is one.
fn security(e: &EmulatedError) -> Option<&str> {
    match e {
        EmulatedError::Refused(r) => r.strip_prefix("Security(")?.strip_suffix(')'),
        _ => None,
    }
}

#[test]
fn forged_replayed_and_tampered_temporal_uplinks_are_refused_and_the_target_plans_on() {
    let _one = hil_tests::exclusive_qemu();
    let mut target = EmulatedPlanner::boot(firmware()).unwrap_or_else(|e| panic!("{e}"));
    let options = options();
    let (d, p) = files("satellite", 1);
    let compiled = pddl_common::compile(&d, &p).unwrap();
    let task = &compiled.task;
    let config = TemporalConfig::DEFAULT;

    // A forged MAC: signed with a key the target does not hold (same SPI).
    let forger = sdls::Key {
        bytes: [0xa5; 32],
        ..hil::mission::auth::TEST_KEY
    };
    let job = target.new_job();
    let sequence = target.signer().burn_sequence();
    let forged = hil::mission::auth::secure_temporal(&forger, sequence, job, &config, task);
    let e = target
        .uplink(job, EmulatedPlanner::job_messages(job, &forged, config))
        .expect_err("forged");
    assert_eq!(security(&e), Some("BadMac"), "{e}");

    // A valid MAC, then a chunk tampered with on the way and the Begin's CRC made to match it:
    // the CRC passes, the MAC does not.
    let job = target.new_job();
    let sequence = target.signer().burn_sequence();
    let mut secured = hil::mission::auth::secure_temporal(
        &hil::mission::auth::TEST_KEY,
        sequence,
        job,
        &config,
        task,
    );
    secured[sdls::uplink::HEADER_LEN + 300] ^= 0x01;
    let e = target
        .uplink(job, EmulatedPlanner::job_messages(job, &secured, config))
        .expect_err("tampered");
    assert_eq!(security(&e), Some("BadMac"), "{e}");

    // An authentic job is planned (the native plan); the same messages sent again are a
    // replay, refused.
    let job = target.new_job();
    let msgs = target.signed_job_messages(job, task, config);
    let planned = target
        .plan_job(job, msgs.clone(), &compiled, MAX_FRAMES, None)
        .expect("authentic");
    let native = plan_compiled(&compiled, &options).unwrap();
    assert!(planned.solved);
    assert_eq!(planned.plan, native.plan);
    let e = target.uplink(job, msgs).expect_err("replayed");
    assert_eq!(security(&e), Some("Replay"), "{e}");

    // The target plans on: the next authentic job (a later sequence number; those the host
    // burnt above, which the target never saw, leave a gap, as allowed) has the native plan.
    let again = target.plan(&compiled, &options, MAX_FRAMES).unwrap();
    assert!(again.solved);
    assert_eq!(again.plan, native.plan);
}

#[test]
fn a_warm_reset_mid_search_resumes_the_job_with_the_same_plan_and_a_cold_boot_resumes_nothing() {
    let _one = hil_tests::exclusive_qemu();
    let mut target = EmulatedPlanner::boot(firmware()).unwrap_or_else(|e| panic!("{e}"));
    let options = options();
    let (d, p) = files("satellite", 2);
    let compiled = pddl_common::compile(&d, &p).unwrap();
    let uninterrupted = target.plan(&compiled, &options, MAX_FRAMES).unwrap();
    assert!(uninterrupted.solved);

    // A warm reset in the 6th frame of the search (satellite 2 searches for about 58), once
    // the planner partition has run 10,000 ticks of it: the target comes back, finds the job
    // in the memory the reset keeps, checks the task again and searches from the start.
    let reset = hil::plan_emulated::MidSearchReset {
        after_frames: 5,
        planner_ticks: 10_000,
    };
    let resumed = target
        .plan_with_reset(&compiled, &options, MAX_FRAMES, Some(reset))
        .unwrap_or_else(|e| panic!("{e}"));
    let costs = resumed.emulated.clone().expect("guest costs");
    assert_eq!(costs.resets, 1, "the reset landed");
    assert!(costs.resumed, "the target said it resumed the job");
    assert!(costs.verify_ticks > 0);
    assert!(resumed.solved);
    assert_eq!(
        resumed.plan, uninterrupted.plan,
        "the same plan as without the reset"
    );
    assert_eq!(resumed.makespan, uninterrupted.makespan);
    assert_eq!(
        (resumed.expanded, resumed.nodes, resumed.peak_arena_bytes),
        (
            uninterrupted.expanded,
            uninterrupted.nodes,
            uninterrupted.peak_arena_bytes
        ),
        "the same search"
    );
    let before = uninterrupted.emulated.clone().unwrap();
    println!(
        "satellite 2 with a warm reset in frame {}: {} frames (uninterrupted {}), planning {} guest instructions (uninterrupted {}), stored task checked again in {} ticks = {} instructions",
        reset.after_frames,
        costs.frames,
        before.frames,
        costs.guest_instructions,
        before.guest_instructions,
        costs.verify_ticks,
        (f64::from(costs.verify_ticks) * hil::plan_emulated::INSTRUCTIONS_PER_TICK).round()
    );

    // A cold boot (QEMU ended and started again: the RAM is not kept) in the middle of a job:
    // nothing of it comes back.
    let job = target.new_job();
    let msgs = target.signed_job_messages(job, &compiled.task, TemporalConfig::DEFAULT);
    target.uplink(job, msgs).expect("accepted");
    let during = target.grant_frames(3).unwrap();
    assert!(during.is_empty(), "still searching: {during:?}");
    target.power_cycle().unwrap();
    let after = target.grant_frames(20).unwrap();
    assert!(after.is_empty(), "a cold boot resumed something: {after:?}");
    // And the target plans the next job as before.
    let again = target.plan(&compiled, &options, MAX_FRAMES).unwrap();
    assert_eq!(again.plan, uninterrupted.plan);
}

#[test]
fn the_largest_instances_set_up_logs_no_overrun() {
    // Satellite 3 (18.6 KB, 188 actions) has the costliest set-up pieces here (about 31,700
    // ticks, against the window's 33,200): its uplink and the windows of its set-up (five,
    // then the search starts) log no overrun. (Its search may: its costliest expansion,
    // about 32,700 ticks, is not divided.)
    let _one = hil_tests::exclusive_qemu();
    let mut target = EmulatedPlanner::boot(firmware()).unwrap_or_else(|e| panic!("{e}"));
    let (d, p) = files("satellite", 3);
    let compiled = pddl_common::compile(&d, &p).unwrap();
    let job = target.new_job();
    let msgs = target.signed_job_messages(job, &compiled.task, TemporalConfig::DEFAULT);
    target.uplink(job, msgs).expect("accepted");
    // Five set-up windows and a frame for the health monitor's report to come down.
    let reports = target.grant_frames(7).unwrap();
    assert!(reports.is_empty(), "{reports:?}");
    assert!(
        target.health_events.is_empty(),
        "{:?}",
        target.health_events
    );
}

/// A job whose windows run out while the elimination after the search improves the plan is
/// solved with the best plan so far: valid, only removals of the search's plan, its makespan
/// no longer; the instructions to the search's plan are those of the job that ran to the end
/// (to a few ticks).
#[test]
fn a_window_limit_during_the_elimination_reports_the_best_plan_so_far() {
    let _one = hil_tests::exclusive_qemu();
    let mut target = EmulatedPlanner::boot(firmware()).unwrap_or_else(|e| panic!("{e}"));
    let options = options();
    let (d, p) = files("satellite", 2);
    let compiled = pddl_common::compile(&d, &p).unwrap();
    let validator = pddl_common::Validator::new(&d, &p, EPSILON);
    let whole = target.plan(&compiled, &options, MAX_FRAMES).unwrap();
    let costs = whole.emulated.clone().expect("guest costs");
    assert!(whole.eliminated > 0 && costs.elimination_ticks > 0);
    let names = |r: &PlanReport| {
        let mut v: Vec<String> = r.plan.iter().map(|s| s.action.clone()).collect();
        v.sort();
        v
    };
    let whole_names = names(&whole);
    // The last window of the job is the elimination's: one window fewer ends it mid-pass.
    let mut config = hil::plan_emulated::wire_config(&options).unwrap();
    config.max_windows = costs.planner_windows - 1;
    let job = target.new_job();
    let msgs = target.signed_job_messages(job, &compiled.task, config);
    let cut = target
        .plan_job(job, msgs, &compiled, MAX_FRAMES, None)
        .unwrap();
    assert!(cut.solved, "{}", cut.outcome);
    let cut_costs = cut.emulated.clone().expect("guest costs");
    // The same search to the same plan: its ticks the same but for the clock's reading at a
    // window's edge (measured: 1 tick apart, the job beginning in another frame's phase).
    assert!(
        cut_costs.planning_ticks.abs_diff(costs.planning_ticks) <= 10,
        "{} against {}",
        cut_costs.planning_ticks,
        costs.planning_ticks
    );
    assert!(cut_costs.elimination_ticks < costs.elimination_ticks);
    assert_eq!(cut.first_plan_actions, whole.first_plan_actions);
    assert!(cut.plan.len() >= whole.plan.len() && cut.plan.len() <= whole.first_plan_actions);
    assert!(cut.makespan.unwrap() <= whole.first_plan_makespan.unwrap() + 1e-9);
    if let Err(why) = validator.validate(&steps(&cut)) {
        panic!("the plan so far is invalid: {why}");
    }
    let cut_names = names(&cut);
    assert!(
        whole_names.iter().all(|n| cut_names.contains(n)),
        "the plan so far keeps the final plan's actions"
    );
}

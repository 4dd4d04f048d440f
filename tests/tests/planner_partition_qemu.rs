//! The planner in its own partition on the emulated RAD750 (issue 14): a planning load that
//! needs well over 50 planner windows, throttled in lockstep, while the executive partition
//! runs every frame.
use hil::mission::record::Decision;
use hil::mission::report::MissionReport;
use hil::mission::runner::prepare;
use hil_tests::{decisions, fly_emulated, fly_native, profile, scenario};

/// The executive partition's window (`kernel_config::system`), in ticks.
const EXECUTIVE_WINDOW_TICKS: u64 = 66_400;

fn metric(r: &MissionReport, name: &str) -> u64 {
    *r.metrics
        .get(name)
        .unwrap_or_else(|| panic!("{name} not measured: {:?}", r.metrics.keys()))
}

/// `scenarios/planner-load.toml`: 64 observations, the planner partition held to one
/// validity check per window, so its first cycle places one task per window. Mission time
/// advances one major frame (10 ms) per grant while it works (the lockstep throttle), and the
/// plan is committed that much later; the executive's windows run every frame meanwhile, its
/// CPU per frame bounded by its window; the same scenario unthrottled (the native target, the
/// reference) decides the same tasks at the same times, because the observations start long
/// after the throttled planner has finished.
#[test]
fn a_planning_load_of_over_fifty_windows_is_throttled_in_lockstep_and_the_executive_runs_every_frame(
) {
    let plan = prepare(&scenario("planner-load.toml")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(plan.planner_checks_per_window, Some(1));
    let r = fly_emulated(&plan, profile());
    let summary = hil::mission::report::summary(&r);
    assert!(r.passed, "{summary}");
    // The first cycle: one task placed per window, 64 frames of 10 ms of mission time with
    // planning pending (later cycles, during the mission, may be pending for frames too).
    let pending = metric(&r, "planner_pending_frames");
    assert!(pending > 50, "{pending} pending frames\n{summary}");
    let latency = metric(&r, "planning_latency_us");
    assert_eq!(latency, 64 * 10_000, "{summary}");
    // The executive's work per frame (both of its windows, its checkpoints) stays far inside
    // its window whatever the planner does.
    let executive = metric(&r, "max_executive_ticks");
    let checkpoint = metric(&r, "max_checkpoint_ticks");
    assert!(executive + checkpoint < EXECUTIVE_WINDOW_TICKS, "{summary}");
    // The planner's windows did the planning: the partition reported its own costs.
    assert!(metric(&r, "max_planner_ticks") > 0, "{summary}");

    // The unthrottled reference: no frame pending, no latency. It schedules the 64 tasks in one
    // frame; the throttled planner one per frame, each 10 ms later (the difference, reported
    // here); everything after (every start, end and completion) is identical.
    let native = fly_native(&plan);
    assert!(native.passed, "{}", hil::mission::report::summary(&native));
    assert!(!native.metrics.contains_key("planning_latency_us"));
    let scheduled = |d: &Decision| matches!(d, Decision::Transition { from: 0, to: 1, .. });
    let (throttled, reference) = (decisions(&r), decisions(&native));
    let rest = |ds: &[Decision]| {
        ds.iter()
            .filter(|d| !scheduled(d))
            .cloned()
            .collect::<Vec<_>>()
    };
    assert_eq!(rest(&throttled), rest(&reference));
    let times = |ds: &[Decision]| {
        ds.iter()
            .filter_map(|d| match d {
                Decision::Transition { at, task, .. } if scheduled(d) => Some((*task, *at)),
                _ => None,
            })
            .collect::<Vec<_>>()
    };
    let (late, first) = (times(&throttled), times(&reference));
    assert_eq!(late.len(), 64);
    assert_eq!(
        late.iter().map(|(t, _)| *t).collect::<Vec<_>>(),
        first.iter().map(|(t, _)| *t).collect::<Vec<_>>()
    );
    let delays: Vec<u64> = late
        .iter()
        .zip(&first)
        .map(|((_, a), (_, b))| a.checked_sub(*b).expect("never earlier than the reference"))
        .collect();
    eprintln!(
        "scheduled later than the unthrottled reference by 0 to {} ms (planning latency {} ms)",
        delays.iter().max().unwrap() / 1_000,
        latency / 1_000
    );
    assert!(*delays.iter().max().unwrap() < latency);
    assert!(delays.windows(2).all(|w| w[1] >= w[0]));
}

//! The rover mission's onboard side (`flight_app::rover_mission` in the temporal plug-in,
//! issue 13 item 3), natively: the host sends only the world's events and the time; the
//! mission refuses, with a reason and without changing anything, an end of an action it never
//! started, a goal that is no fact of the task or is one already, events out of time order,
//! and events with no mission flying; every decision in a run's transcript is one the mission
//! sent.
use fsw_bridge::temporal::{RoverEvent, RoverRefusal, RoverReport};
use hil::rover::{compile, run_file, Backend, RoverScenario};

fn sahara() -> std::path::PathBuf {
    hil::repo_root().join("scenarios/rover/sahara-day.toml")
}

fn start() -> RoverEvent {
    RoverEvent::Start {
        horizon_slack_ms: 30_000,
        max_expansions: 1_500,
        us_per_expansion: 500,
    }
}

fn last(reports: &[RoverReport]) -> RoverReport {
    *reports.last().expect("an answer")
}

fn refused(reports: &[RoverReport]) -> RoverRefusal {
    match last(reports) {
        RoverReport::Refused { reason } => reason,
        other => panic!("not refused: {other:?} ({reports:?})"),
    }
}

#[test]
fn the_mission_refuses_bad_events_with_a_reason_and_goes_on() {
    let path = sahara();
    let scenario = RoverScenario::load(&path).unwrap();
    let compiled = compile(&scenario, path.parent().unwrap()).unwrap();
    let task = temporal::Task::parse(&compiled.task).unwrap();
    let mut b = Backend::native();
    // No mission flying yet.
    assert_eq!(
        refused(&b.event(1, RoverEvent::Poll { now_ms: 0 }).unwrap()),
        RoverRefusal::NoMission
    );
    let (job, ready) = b.start(&compiled.task, start()).unwrap();
    assert!(
        matches!(last(&ready), RoverReport::Ready { .. }),
        "{ready:?}"
    );
    // Another job's events are not this mission's.
    assert_eq!(
        refused(&b.event(job + 1, RoverEvent::Poll { now_ms: 0 }).unwrap()),
        RoverRefusal::NoMission
    );
    // A goal that is no fact of the task, and one that is a goal already.
    let beyond = task.fact_count() as u16 + 3;
    assert_eq!(
        refused(
            &b.event(
                job,
                RoverEvent::Goal {
                    fact: beyond,
                    at_ms: 0
                }
            )
            .unwrap()
        ),
        RoverRefusal::UnknownGoal { fact: beyond }
    );
    let hard = task.goal_facts().iter().next().unwrap() as u16;
    assert_eq!(
        refused(
            &b.event(
                job,
                RoverEvent::Goal {
                    fact: hard,
                    at_ms: 0
                }
            )
            .unwrap()
        ),
        RoverRefusal::UnknownGoal { fact: hard }
    );
    // Before the first plan there is nothing running to end.
    assert_eq!(
        refused(
            &b.event(
                job,
                RoverEvent::Ended {
                    action: 0,
                    at_ms: 5
                }
            )
            .unwrap()
        ),
        RoverRefusal::NoMission
    );
    // The first plan; then the first poll after it dispatches.
    let plan = b.event(job, RoverEvent::Poll { now_ms: 0 }).unwrap();
    let RoverReport::PlanningTakes { until_ms, .. } = last(&plan) else {
        panic!("{plan:?}");
    };
    let first = b.event(job, RoverEvent::Poll { now_ms: until_ms }).unwrap();
    let RoverReport::Dispatch { action, .. } = last(&first) else {
        panic!("{first:?}");
    };
    // An end of an action never started.
    let other = (0..task.action_count() as u16)
        .find(|&a| a != action)
        .unwrap();
    assert_eq!(
        refused(
            &b.event(
                job,
                RoverEvent::Ended {
                    action: other,
                    at_ms: until_ms + 1
                }
            )
            .unwrap()
        ),
        RoverRefusal::NotRunning { action: other }
    );
    // Events out of time order: a poll and an end before the last event's time.
    assert_eq!(
        refused(
            &b.event(
                job,
                RoverEvent::Poll {
                    now_ms: until_ms - 1
                }
            )
            .unwrap()
        ),
        RoverRefusal::OutOfOrder { last_ms: until_ms }
    );
    assert_eq!(
        refused(
            &b.event(
                job,
                RoverEvent::Ended {
                    action,
                    at_ms: until_ms - 1
                }
            )
            .unwrap()
        ),
        RoverRefusal::OutOfOrder { last_ms: until_ms }
    );
    // An estimate for an action not running.
    assert_eq!(
        refused(
            &b.event(
                job,
                RoverEvent::Expected {
                    action: other,
                    ends_ms: until_ms + 10
                }
            )
            .unwrap()
        ),
        RoverRefusal::NotRunning { action: other }
    );
    // Nothing changed: the real end is taken, and the mission decides on.
    let end = b
        .event(
            job,
            RoverEvent::Ended {
                action,
                at_ms: until_ms + 1000,
            },
        )
        .unwrap();
    assert_eq!(last(&end), RoverReport::EndTaken { action });
    // The same end again: that action is not running any more.
    assert_eq!(
        refused(
            &b.event(
                job,
                RoverEvent::Ended {
                    action,
                    at_ms: until_ms + 1000
                }
            )
            .unwrap()
        ),
        RoverRefusal::NotRunning { action }
    );
    let next = b
        .event(
            job,
            RoverEvent::Poll {
                now_ms: until_ms + 1000,
            },
        )
        .unwrap();
    assert!(
        matches!(
            last(&next),
            RoverReport::Dispatch { .. } | RoverReport::Wait { .. }
        ),
        "{next:?}"
    );
    let closed = b
        .event(
            job,
            RoverEvent::Close {
                now_ms: until_ms + 1000,
            },
        )
        .unwrap();
    assert_eq!(last(&closed), RoverReport::Closed);
    // Closed: the mission is over.
    assert_eq!(
        refused(
            &b.event(
                job,
                RoverEvent::Poll {
                    now_ms: until_ms + 2000
                }
            )
            .unwrap()
        ),
        RoverRefusal::NoMission
    );
}

#[test]
fn every_decision_of_a_run_is_one_the_mission_sent() {
    let (run, verdicts) = run_file(&sahara(), None, &mut Backend::native()).expect("runs");
    assert!(verdicts.iter().all(|v| v.ok), "{verdicts:?}");
    let dispatch_lines = run
        .decisions
        .iter()
        .filter(|l| l.contains("  dispatch ("))
        .count();
    assert!(dispatch_lines > 0);
    assert_eq!(run.dispatches_received, dispatch_lines);
    assert!(run.reports_received > dispatch_lines);
    // Natively nothing is counted in guest instructions.
    assert_eq!(run.onboard.polls, 0);
    assert_eq!(run.decisions_sha256, "23b00d4803be8c09");
}

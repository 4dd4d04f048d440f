//! The onboard rover mission survives a reset of the planner partition (natively: the plug-in
//! made anew over the same memories, as the partition's restart does). Whatever event the reset
//! lands in, and wherever in its answer (before the mission took it, in the middle of a
//! replan's search, after the answer), the mission is taken up again from its checkpoint, the
//! host sends again the events after it (each answered exactly as before), and the run makes
//! exactly the decisions of the run without a reset: restore(save(m)) behaves like m, at every
//! point a checkpoint is taken.
use hil::rover::{run_file, Backend, ResetAt};

fn scenario(name: &str) -> std::path::PathBuf {
    hil::repo_root().join(format!("scenarios/rover/{name}.toml"))
}

fn with_reset(name: &str, at: ResetAt) -> hil::rover::RoverRun {
    let mut backend = Backend::native();
    backend.reset_at(at);
    let (run, verdicts) = run_file(&scenario(name), None, &mut backend)
        .unwrap_or_else(|e| panic!("{name} with a reset at {at:?}: {e}"));
    for v in &verdicts {
        assert!(v.ok, "{name} {at:?}: {}: {}", v.what, v.got);
    }
    run
}

#[test]
fn a_reset_in_any_event_resumes_the_mission_with_the_same_decisions() {
    for name in ["sahara-day", "field-trial"] {
        let (plain, _) = run_file(&scenario(name), None, &mut Backend::native()).unwrap();
        assert!(plain.resumes.is_empty());
        // The events of the run: every one of them gets a reset, before it is taken (after 0
        // windows) and after its first window (a replan's search has started then).
        let events = plain.reports_received; // more than the events: the loop ends on the last
        let mut landed = 0;
        let mut replayed = 0;
        let mut mid_search = 0;
        for event in 0..events {
            // field-trial's searches are long (2,500 expansions): fewer points there.
            let afters: &[u32] = if name == "sahara-day" || event % 4 == 0 {
                &[0, 1, 3]
            } else {
                &[1]
            };
            for &after in afters {
                let run = with_reset(
                    name,
                    ResetAt {
                        event,
                        after,
                        planner_ticks: 0,
                    },
                );
                assert_eq!(
                    run.decisions, plain.decisions,
                    "{name}: reset in event {event} after {after} windows"
                );
                assert_eq!(run.decisions_sha256, plain.decisions_sha256);
                assert!(run.resumes.len() <= 1, "{:?}", run.resumes);
                if let Some(r) = run.resumes.first() {
                    landed += 1;
                    assert_eq!(r.during_event, event);
                    // The checkpoint is the state before the event, or (the reset came
                    // before the mission took it) before the one before.
                    assert!(
                        r.resumed_after as usize == event || r.resumed_after as usize + 1 == event,
                        "{r:?}"
                    );
                    assert_eq!(r.replayed, event - r.resumed_after as usize);
                    replayed += r.replayed;
                    if after == 3 {
                        mid_search += 1;
                    }
                }
            }
        }
        // Resets landed in the events, some in the middle of a replan (an answer taking more
        // than three windows is a search), and some made the host send an event again.
        assert!(landed > 40, "{name}: {landed}");
        assert!(mid_search >= 2, "{name}: {mid_search}");
        assert!(replayed > 0, "{name}");
        eprintln!("{name}: {landed} resets landed, {mid_search} in a search, {replayed} events sent again");
    }
}

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
        // More than the events (reports are more): a reset armed past the last event never
        // lands.
        let events = plain.reports_received;
        let (mut landed, mut replayed, mut late) = (0, 0, 0);
        for event in 0..events {
            // Natively an answer takes a window to take the event, then (a replan) one for
            // the search, one for the attempt's end and the network's steps, one for the
            // dispatcher's windows: a reset after 0 windows comes before the mission took the
            // event, after 1 once it took it, after 2 or 3 only in a replan's answer.
            // field-trial's searches are long (2,500 expansions): fewer points there.
            let afters: &[u32] = match (name, event % 3) {
                ("sahara-day", 0) => &[0, 1, 2, 3],
                ("sahara-day", _) => &[0, 1],
                (_, 0) => &[1, 2, 3],
                _ => &[],
            };
            for &after in afters {
                let run = with_reset(
                    name,
                    ResetAt {
                        event,
                        after,
                        planner_ticks: 0,
                        damage: None,
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
                    let expected = if after == 0 {
                        event.saturating_sub(1)
                    } else {
                        event
                    };
                    assert_eq!(r.resumed_after as usize, expected, "{r:?}");
                    assert_eq!(r.replayed, event - r.resumed_after as usize);
                    replayed += r.replayed;
                    if after >= 2 {
                        late += 1;
                    }
                }
            }
        }
        // Resets landed in the events, some late in a replan's answer, and (sahara-day) some
        // made the host send an event again.
        eprintln!(
            "{name}: {landed} resets landed, {late} late in a replan, {replayed} events sent again"
        );
        assert!(landed > 20, "{name}: {landed}");
        assert!(late >= 2, "{name}: {late}");
        assert!(name != "sahara-day" || replayed > 20, "{name}: {replayed}");
    }
}

use flight_app::rover_mission::checkpoint::{RoverCheckpoint, VERSION};

/// A reset in event 30 of sahara-day (a plan flying), after its first window, with `damage`
/// done to the kept memories: the run's result.
fn damaged(damage: hil::rover::Damage) -> Result<hil::rover::RoverRun, String> {
    let mut backend = Backend::native();
    backend.reset_at(ResetAt {
        event: 30,
        after: 1,
        planner_ticks: 0,
        damage: Some(damage),
    });
    run_file(&scenario("sahara-day"), None, &mut backend).map(|(run, _)| run)
}

fn refused_with(damage: hil::rover::Damage, reason: &str) {
    let e = damaged(damage).expect_err("the damaged checkpoint was not refused");
    assert!(
        e.contains(&format!("NotResumed {{ reason: {reason}")),
        "{reason}: {e}"
    );
}

/// The slot holding the newest state record (the larger sequence).
fn newest(cp: &RoverCheckpoint) -> usize {
    usize::from(cp.state[1][2] > cp.state[0][2])
}

/// Seals slot words again after a test changed its payload (the record's own CRC-32).
fn reseal(slot: &mut [u32]) {
    let n = slot[3] as usize;
    let bytes: Vec<u8> = slot[..4 + n].iter().flat_map(|w| w.to_be_bytes()).collect();
    slot[4 + n] = flight_app::temporal_crc32(&bytes);
}

#[test]
fn a_damaged_newest_record_resumes_from_the_other_slot() {
    let (plain, _) = run_file(&scenario("sahara-day"), None, &mut Backend::native()).unwrap();
    let mut backend = Backend::native();
    backend.reset_at(ResetAt {
        event: 30,
        after: 1,
        planner_ticks: 0,
        damage: Some(|cp, _| {
            let i = newest(cp);
            cp.state[i][10] ^= 1;
        }),
    });
    let (run, _) = run_file(&scenario("sahara-day"), None, &mut backend).unwrap();
    assert_eq!(run.decisions, plain.decisions);
    // The record before it: the state before event 29, which is sent again.
    let r = &run.resumes[0];
    assert_eq!((r.resumed_after, r.replayed), (29, 1), "{r:?}");
}

#[test]
fn damaged_or_foreign_checkpoints_are_refused_with_their_reason() {
    refused_with(
        |cp, _| {
            cp.state[0][10] ^= 1;
            cp.state[1][12] ^= 0x8000;
        },
        "BadCrc",
    );
    refused_with(
        |cp, _| {
            for s in cp.state.iter_mut() {
                s[1] = VERSION + 1;
            }
        },
        "Version { found: 2 }",
    );
    refused_with(
        |cp, _| {
            for s in cp.state.iter_mut() {
                s[3] = u32::MAX - 2;
            }
        },
        "BadLength",
    );
    // The task the records were made with is no longer in the task buffer.
    refused_with(|_, task| task[200] ^= 0x10, "TaskChanged");
    // The plan's network is gone (both plan slots).
    refused_with(
        |cp, _| {
            for p in cp.plan.iter_mut() {
                p[7] ^= 1;
            }
        },
        "PlanMissing",
    );
    // Whole records (their CRC made right) with a field out of range: a phase, a count beyond
    // its capacity, a running action beyond the task.
    refused_with(
        |cp, _| {
            for s in cp.state.iter_mut() {
                s[4 + 1] = 9;
                reseal(s);
            }
        },
        "OutOfRange",
    );
    refused_with(
        |cp, _| {
            for s in cp.state.iter_mut() {
                s[4 + 20] = 129; // fact words beyond 128
                reseal(s);
            }
        },
        "OutOfRange",
    );
}

#[test]
fn garbage_in_the_checkpoint_never_panics_and_never_changes_a_decision() {
    let (plain, _) = run_file(&scenario("sahara-day"), None, &mut Backend::native()).unwrap();
    // Each seed writes random words at random places of the four slots (fn pointers take no
    // state: the seed is in a static).
    static SEED: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    static RESEALED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
    let (mut resumed, mut refused) = (0, 0);
    for seed in 1..=40u64 {
        SEED.store(seed, std::sync::atomic::Ordering::SeqCst);
        RESEALED.store(false, std::sync::atomic::Ordering::SeqCst);
        let result = damaged(|cp, _| {
            let mut x = SEED
                .load(std::sync::atomic::Ordering::SeqCst)
                .wrapping_mul(0x9e37_79b9_7f4a_7c15);
            let mut next = || {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                x
            };
            let n = 1 + next() % 4;
            for _ in 0..n {
                let v = next() as u32;
                let which = next() % 4;
                let at = next() as usize;
                // Header words often (magic, version, sequence, length), payload otherwise.
                let slot: &mut [u32] = match which {
                    0 | 1 => &mut cp.state[which as usize][..],
                    _ => &mut cp.plan[which as usize - 2][..],
                };
                let at = if next() % 2 == 0 {
                    at % 4
                } else {
                    at % slot.len()
                };
                slot[at] = v;
            }
            if next() % 3 == 0 {
                // Sometimes a whole record with garbage inside.
                let i = (next() % 2) as usize;
                let at = 4 + (next() as usize) % (cp.state[i][3] as usize).clamp(1, 300);
                cp.state[i][at.min(cp.state[i].len() - 2)] = next() as u32;
                if (cp.state[i][3] as usize) + 5 <= cp.state[i].len() {
                    reseal(&mut cp.state[i]);
                    RESEALED.store(true, std::sync::atomic::Ordering::SeqCst);
                }
            }
        });
        match result {
            // A record made whole again around garbage (its CRC recomputed) is believed when
            // its fields are in range: what it decides then is not checked, only that nothing
            // panics. Any other damage is caught, or the other slot is taken.
            Ok(_) if RESEALED.load(std::sync::atomic::Ordering::SeqCst) => resumed += 1,
            Ok(run) => {
                resumed += 1;
                assert_eq!(run.decisions, plain.decisions, "seed {seed}");
            }
            Err(e) => {
                refused += 1;
                assert!(
                    e.contains("not taken up again")
                        || RESEALED.load(std::sync::atomic::Ordering::SeqCst),
                    "seed {seed}: {e}"
                );
            }
        }
    }
    eprintln!("{resumed} resumed, {refused} refused");
    assert!(resumed > 0 && refused > 0);
}

/// The restore divided across windows (each window's share too small for more than its first
/// piece): the state record, the plan's network, the dispatcher's windows, one a window; the
/// mission takes up the same as whole, makes the same decisions, and a record refused in a
/// later piece (its plan record gone) is refused with the same reason after the other slot was
/// tried, and a damaged newest record falls back to the other slot.
#[test]
fn a_restore_divided_across_windows_takes_the_mission_up_as_whole() {
    let (plain, _) = run_file(&scenario("sahara-day"), None, &mut Backend::native()).unwrap();
    let divided = |at: ResetAt| {
        let mut backend = Backend::native();
        backend.native_onboard().unwrap().one_piece_restores = true;
        backend.reset_at(at);
        let run = run_file(&scenario("sahara-day"), None, &mut backend).map(|(run, _)| run);
        (
            run,
            backend.native_onboard().unwrap().restore_windows.clone(),
        )
    };
    for (event, pieces) in [(0, 1), (12, 3), (20, 3), (30, 3)] {
        let (run, windows) = divided(ResetAt {
            event,
            after: 1,
            planner_ticks: 0,
            damage: None,
        });
        let run = run.unwrap();
        assert_eq!(run.decisions, plain.decisions, "reset in event {event}");
        assert_eq!(run.resumes.len(), 1, "{:?}", run.resumes);
        assert_eq!(run.resumes[0].resumed_after as usize, event);
        // Before the first plan the state record is all; with a plan flying, three pieces in
        // three windows.
        assert_eq!(windows, vec![pieces], "reset in event {event}");
    }
    // The newest state record damaged: its CRC leaves it out before the first piece, the
    // other slot's three pieces take the mission up one event older.
    let (run, windows) = divided(ResetAt {
        event: 30,
        after: 1,
        planner_ticks: 0,
        damage: Some(|cp, _| {
            let i = newest(cp);
            cp.state[i][6] ^= 1;
        }),
    });
    let run = run.unwrap();
    assert_eq!(run.decisions, plain.decisions);
    assert_eq!(run.resumes[0].resumed_after, 29);
    assert_eq!(windows, vec![3]);
    // Both plan records gone: refused in the second piece of each state record.
    let (run, windows) = divided(ResetAt {
        event: 30,
        after: 1,
        planner_ticks: 0,
        damage: Some(|cp, _| {
            for p in cp.plan.iter_mut() {
                p[7] ^= 1;
            }
        }),
    });
    let e = run.expect_err("the checkpoint without its plan was not refused");
    assert!(e.contains("NotResumed { reason: PlanMissing"), "{e}");
    assert_eq!(windows, vec![4]);
}

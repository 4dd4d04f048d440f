//! The binary task the front end writes is validated when the planner loads it: every
//! truncation and random corruption of a real task is an error value or a task the planner can
//! search without panicking (the target never panics on input from outside).
mod common;

use common::Rng;
use temporal::{PlannerConfig, Task};

fn compiled(domain: &str, instance: u32) -> Vec<u8> {
    let dir = format!("{}/tests/benchmarks/{domain}", env!("CARGO_MANIFEST_DIR"));
    let d = std::fs::read_to_string(format!("{dir}/domain.pddl")).expect("domain");
    let p = std::fs::read_to_string(format!("{dir}/instance-{instance}.pddl")).expect("instance");
    common::compile(&d, &p).expect("compiles").task
}

/// Search `bytes` briefly if they load; they must not panic either way.
fn load_and_search(bytes: &[u8]) -> bool {
    let Ok(task) = Task::parse(bytes) else {
        return false;
    };
    let mut arena = vec![0u32; 1 << 18];
    if let Ok(mut planner) = temporal::Planner::new(task, &mut arena, PlannerConfig::default()) {
        planner.step(50);
        let mut out = vec![temporal::PlannedAction::default(); 256];
        let _ = planner.plan(&mut out);
    }
    true
}

#[test]
fn every_truncation_is_refused() {
    for (domain, instance) in [("satellite", 1), ("pipesworld", 1)] {
        let bytes = compiled(domain, instance);
        assert!(Task::parse(&bytes).is_ok());
        for cut in 0..bytes.len() {
            assert!(
                Task::parse(&bytes[..cut]).is_err(),
                "{domain}: {cut} of {} bytes loaded",
                bytes.len()
            );
        }
    }
}

#[test]
fn corrupted_tasks_are_errors_or_searchable_never_panics() {
    let mut rng = Rng(0xbad_7a5c);
    let mut refused = 0;
    for (domain, instance) in [("satellite", 1), ("rovers", 1), ("pipesworld", 1)] {
        let bytes = compiled(domain, instance);
        for _ in 0..400 {
            let mut b = bytes.clone();
            for _ in 0..1 + rng.below(4) {
                let at = rng.below(b.len() as u64) as usize;
                b[at] = rng.next_u64() as u8;
            }
            refused += usize::from(!load_and_search(&b));
        }
    }
    // The validation refuses a good share of them (the rest changed only values, such as
    // durations or initial facts, that any task may have).
    assert!(
        refused > 100,
        "only {refused} of 1200 corrupted tasks were refused"
    );
}

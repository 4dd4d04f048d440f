//! Issue 15: bounded responses to misbehaving subsystems.
mod common;
use common::*;

fn run_with(fates: &[GncFate]) -> Sim {
    let mut sim = Sim::flyby();
    sim.sc.gnc_fates = fates.to_vec();
    sim.run(hm(11, 30), &[]);
    sim
}

#[test]
#[ignore = "prints decision logs"]
fn print_each_misbehaviour() {
    for fate in [
        GncFate::Reject,
        GncFate::Fail,
        GncFate::AcceptNoSlew,
        GncFate::NoResponse,
        GncFate::WrongEndState,
        GncFate::Silent,
    ] {
        let sim = run_with(&[fate]);
        println!(
            "===== {fate:?}: {} steps, max {} at one time",
            sim.steps,
            sim.max_steps_at_one_time()
        );
        for l in decision_lines(&sim)
            .into_iter()
            .chain(timeline_lines(&sim.as_executed()))
        {
            println!("{l}");
        }
        println!("{:?}", sim.dispatches_per_definition());
    }
}

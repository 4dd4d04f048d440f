//! Misbehaving subsystems, natively: a GNC that rejects, fails, never answers, ignores, or
//! completes in the wrong state every attain command. The autonomy bounds its responses, so the
//! run reaches the mission's end (no livelock, no "could not start"), ends FAIL naming the
//! cause, and no task sends more commands than its bounds allow. A seeded campaign draws such
//! subsystems at random.
use hil::campaign::{bound_checks, run_campaign, CampaignOptions, MisbehaviourMode};
use hil::mission::plan::CommandFault;
use hil::mission::report::MissionReport;
use hil::mission::runner::{prepare, run};
use hil::mission::sim::CommandFate;
use hil::mission::target::NativeTarget;

const ATTAIN: u16 = 0x0101;

fn flyby_with(fate: CommandFate) -> MissionReport {
    let mut plan = prepare(&hil::repo_root().join("scenarios/flyby-nominal.toml")).unwrap();
    plan.add_command_fault(
        plan.start,
        CommandFault {
            opcode: fsw_bridge::Opcode(ATTAIN),
            skip: None,
            probability: 1.0,
            fate,
            spent: false,
        },
    );
    run(&plan, &mut NativeTarget::new(), None, &mut |_, _, _| {}).unwrap_or_else(|e| panic!("{e}"))
}

/// The run reached the end, failed, named its cause, and stayed within its bounds.
fn assert_bounded_fail(r: &MissionReport, cause: &str) {
    let summary = hil::mission::report::summary(r);
    assert!(r.ended_early.is_none(), "{summary}");
    assert!(
        !r.passed,
        "a GNC that never attains cannot fly the flyby: {summary}"
    );
    assert_eq!(r.mission_end, "11:30:00");
    assert!(
        r.gave_up.iter().any(|g| g.cause == cause)
            || r.record
                .instances
                .iter()
                .any(|i| i.failure_cause() == Some(cause)),
        "the report names {cause}: {summary}"
    );
    assert!(
        bound_checks(r).is_empty(),
        "{:?}\n{summary}",
        bound_checks(r)
    );
    let attains: u32 = r
        .commands_per_task
        .iter()
        .filter(|c| c.task.starts_with("GncAttain"))
        .map(|c| c.commands)
        .sum();
    // On main before the bounds: 10,001 attain commands at 10:00:00.
    assert!(attains <= 40, "{attains} attain commands: {summary}");
    // Mission time moved on: the next maneuver still went out at 11:05.
    assert!(
        r.record
            .instances
            .iter()
            .any(|i| i.name == "GncAttain EARTH" && i.started_at.is_some()),
        "{summary}"
    );
}

#[test]
fn a_gnc_that_rejects_every_attain_ends_fail_naming_the_rejections() {
    let r = flyby_with(CommandFate::Answer(fsw_bridge::CommandStatus::Rejected));
    assert_bounded_fail(&r, "command_rejected");
}

#[test]
fn a_gnc_that_fails_every_attain_ends_fail_naming_the_failures() {
    let r = flyby_with(CommandFate::Answer(fsw_bridge::CommandStatus::Failed(7)));
    assert_bounded_fail(&r, "command_failed");
}

/// A GNC that does nothing at all never reports TURNING, so the turn's MAINTAIN constraint
/// (TURNING or NADIR from a second after the command) is what fails first: that is the cause
/// the autonomy sees and the report names.
#[test]
fn a_gnc_that_never_answers_ends_fail_naming_the_attitude_that_never_turned() {
    let r = flyby_with(CommandFate::Silent);
    assert_bounded_fail(&r, "maintain_violation");
}

#[test]
fn a_gnc_that_accepts_but_never_slews_ends_fail_naming_the_attitude_that_never_turned() {
    let r = flyby_with(CommandFate::NoEffect);
    assert_bounded_fail(&r, "maintain_violation");
}

#[test]
fn a_gnc_that_ends_at_the_wrong_attitude_ends_fail_naming_the_post_condition() {
    // INERTIAL (value 0) instead of the commanded NADIR.
    let r = flyby_with(CommandFate::WrongState(fsw_bridge::StateValue::Enum(0)));
    assert_bounded_fail(&r, "post_condition");
}

#[test]
fn a_seeded_campaign_of_misbehaving_subsystems_holds_every_bound_and_names_every_cause() {
    let mut opts = CampaignOptions::new(
        hil::repo_root().join("scenarios/flyby-campaign.toml"),
        100,
        1,
    );
    opts.native = true;
    opts.jobs = 2;
    opts.misbehave = true;
    let report = run_campaign(&opts, &mut |_| {}).unwrap_or_else(|e| panic!("{e}"));
    let summary = hil::campaign::summary(&report);
    assert!(report.passed(), "{summary}");
    // Every mode was drawn, and the runs really misbehaved.
    for mode in MisbehaviourMode::ALL {
        assert!(
            report.results.iter().any(|r| r
                .variant
                .misbehaviour
                .as_ref()
                .is_some_and(|m| m.mode == mode)),
            "{mode:?} never drawn"
        );
    }
    assert!(report
        .results
        .iter()
        .all(|r| r.variant.misbehaviour.is_some()));
}

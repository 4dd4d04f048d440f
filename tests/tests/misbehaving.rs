//! Misbehaving subsystems, natively: a GNC that rejects, fails, never answers, ignores, or
//! completes in the wrong state every attain command. The autonomy bounds its responses, so the
//! run reaches the mission's end (no livelock, no "could not start"), ends FAIL naming the
//! cause, and no task sends more commands than its bounds allow. A seeded campaign draws such
//! subsystems at random.
use hil::campaign::{run_campaign, CampaignOptions, MisbehaviourMode};
use hil::mission::report::MissionReport;
use hil::mission::sim::CommandFate;
use hil_tests::{assert_bounded_fail, fly_native, flyby_with_misbehaving_gnc};

fn flyby_with(fate: CommandFate) -> MissionReport {
    fly_native(&flyby_with_misbehaving_gnc(fate))
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

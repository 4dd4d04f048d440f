//! Misbehaving subsystems on the emulated target: a GNC that rejects, fails, never answers,
//! does nothing, or settles at the wrong attitude for every attain command. On QEMU as natively
//! (`misbehaving.rs`), the autonomy bounds its responses: the run reaches the mission's end,
//! ends FAIL naming the cause, no task exceeds its bounds, and every decision (each retry, each
//! back-off, each give-up) is the native run's.
use fsw_bridge::{CommandStatus, StateValue};
use hil::mission::sim::CommandFate;
use hil_tests::{
    assert_bounded_fail, decisions, fly_emulated, fly_native, flyby_with_misbehaving_gnc, profile,
};

fn check(fate: CommandFate, cause: &str) {
    let plan = flyby_with_misbehaving_gnc(fate);
    let emulated = fly_emulated(&plan, profile());
    assert_bounded_fail(&emulated, cause);
    let native = fly_native(&plan);
    assert_eq!(
        decisions(&emulated),
        decisions(&native),
        "{fate:?}: the emulated target responded otherwise than the native one"
    );
    assert_eq!(emulated.gave_up, native.gave_up, "{fate:?}");
}

#[test]
fn a_gnc_that_rejects_every_attain_ends_fail_on_qemu_as_natively() {
    check(
        CommandFate::Answer(CommandStatus::Rejected),
        "command_rejected",
    );
}

#[test]
fn a_gnc_that_fails_every_attain_ends_fail_on_qemu_as_natively() {
    check(
        CommandFate::Answer(CommandStatus::Failed(7)),
        "command_failed",
    );
}

#[test]
fn a_gnc_that_never_answers_ends_fail_on_qemu_as_natively() {
    check(CommandFate::Silent, "maintain_violation");
}

#[test]
fn a_gnc_that_accepts_but_never_slews_ends_fail_on_qemu_as_natively() {
    check(CommandFate::NoEffect, "maintain_violation");
}

#[test]
fn a_gnc_that_ends_at_the_wrong_attitude_ends_fail_on_qemu_as_natively() {
    check(
        CommandFate::WrongState(StateValue::Enum(0)),
        "post_condition",
    );
}

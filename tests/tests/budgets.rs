//! Timing budgets in CI: every quantity in budgets.toml is measured on the emulated target and
//! must be within its budget; a budget lowered below its measurement must fail, by name.
use hil::budget;
use hil_tests::firmware;

/// What issue 6 asks `budgets.toml` to hold, at least.
const REQUIRED: [&str; 16] = [
    "boot_to_ready",
    "reset_recovery",
    "planner_cycle_worst",
    "executive_cycle_worst",
    "partition_switch",
    "syscall_round_trip",
    "io_frame_processing",
    "checkpoint_write_worst",
    "checkpoint_restore",
    "static_ram_executive",
    "static_ram_planner",
    // Issues 11 and 12: the lander's executor and downlink manager on the target.
    "lander_rsm1_full_plan",
    "lander_downlink_solve",
    "lander_planner_ram",
    "rover_replan_task_build",
    "rover_dispatch_poll",
];

#[test]
fn budgets_toml_has_every_required_quantity() {
    let list = budget::load(&hil::repo_root().join("budgets.toml")).unwrap();
    let names: Vec<&str> = list.iter().map(|b| b.spec.quantity.as_str()).collect();
    for q in REQUIRED
        .iter()
        .chain(&["static_ram_io", "boot_to_ready_warm"])
    {
        assert!(names.contains(q), "budgets.toml has no {q}: {names:?}");
    }
    // Recovery is counted from the reset vector: the boot is in it.
    let recovery = list
        .iter()
        .find(|b| b.spec.quantity == "reset_recovery")
        .unwrap();
    assert!(
        recovery
            .spec
            .source
            .ends_with(":max_reset_recovery_instructions"),
        "{}",
        recovery.spec.source
    );
}

#[test]
fn every_budget_holds_on_the_emulated_target() {
    let _one = hil_tests::exclusive_qemu();
    let root = hil::repo_root();
    let outcome = budget::check(
        &root.join("budgets.toml"),
        &root.join("budgets-baseline.toml"),
        firmware(),
        &mut |_| {},
    )
    .unwrap();
    assert!(
        outcome.offenders.is_empty(),
        "budgets exceeded or not measured:\n{}\n{}",
        outcome.offenders.join("\n"),
        budget::table(&outcome.rows)
    );
    assert!(outcome.rows.iter().all(|r| r.measured.is_some()));
    let table = budget::table(&outcome.rows);
    for q in REQUIRED {
        assert!(
            table.lines().any(|l| l.starts_with(&format!("{q} "))),
            "{q} not in\n{table}"
        );
    }
    let measured = |q: &str| {
        outcome
            .rows
            .iter()
            .find(|r| r.quantity == q)
            .and_then(|r| r.measured)
            .unwrap()
    };
    // Reset vector to repaired plan includes the warm boot to ready.
    assert!(measured("reset_recovery") > measured("boot_to_ready_warm") * 15);
    // The warm boot includes its image check and its restore's decode. (It no longer costs more
    // than the power-on boot: that copies the whole image, the warm boot checks the part below
    // the deferred code, which the kernel checks before it first runs.)
    assert!(
        measured("boot_to_ready_warm")
            > measured("warm_boot_image_check") + measured("warm_boot_decode")
    );
    assert!(measured("executive_cycle_worst") <= measured("autonomy_step_worst"));
}

#[test]
fn a_budget_lowered_below_its_measurement_fails_naming_it() {
    let _one = hil_tests::exclusive_qemu();
    let root = hil::repo_root();
    let text = std::fs::read_to_string(root.join("budgets.toml")).unwrap();
    // reset_recovery measures a few hundred thousand instructions: 1000 is far too little.
    // Its own `max` line, whatever its value (the first after its quantity line).
    let at = text
        .find("quantity = \"reset_recovery\"")
        .expect("budgets.toml has the reset_recovery budget");
    let max_line = text[at..]
        .lines()
        .find(|l| l.starts_with("max = "))
        .expect("the reset_recovery budget has a max");
    let lowered = format!(
        "{}{}",
        &text[..at],
        text[at..].replacen(max_line, "max = 1_000", 1)
    );
    assert_ne!(
        lowered, text,
        "budgets.toml no longer has the reset_recovery budget"
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("budgets.toml");
    std::fs::write(&path, lowered).unwrap();
    let outcome = budget::check(
        &path,
        &root.join("budgets-baseline.toml"),
        firmware(),
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(outcome.offenders.len(), 1, "{:?}", outcome.offenders);
    assert!(
        outcome.offenders[0].starts_with("reset_recovery: "),
        "{}",
        outcome.offenders[0]
    );
    let row = outcome
        .rows
        .iter()
        .find(|r| r.quantity == "reset_recovery")
        .unwrap();
    assert!(row.over_budget);
    assert!(row.headroom_percent.unwrap() < 0.0);
    assert!(budget::table(&outcome.rows).contains("OVER BUDGET"));
}

//! Timing budgets in CI: every quantity in budgets.toml is measured on the emulated target and
//! must be within its budget; a budget lowered below its measurement must fail, by name.
use hil::budget;
use hil_tests::firmware;

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
}

#[test]
fn a_budget_lowered_below_its_measurement_fails_naming_it() {
    let _one = hil_tests::exclusive_qemu();
    let root = hil::repo_root();
    let text = std::fs::read_to_string(root.join("budgets.toml")).unwrap();
    // reset_recovery measures a few hundred thousand instructions: 1000 is far too little.
    let lowered = text.replacen("max = 2_500_000", "max = 1_000", 1);
    assert_ne!(
        lowered, text,
        "budgets.toml no longer has the reset_recovery budget"
    );
    let dir = std::env::temp_dir().join(format!("hil-budgets-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("budgets.toml");
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

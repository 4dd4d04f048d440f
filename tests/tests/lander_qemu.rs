//! The Europa Lander's executor on the emulated RAD750 (issues 11 and 12, the emulated side):
//! `hil lander run --emulated` makes every decision in the planner partition
//! (`flight_app::LanderApp`), and BSM-1, RSM-1 and four ELAP scenarios (one of them a ground
//! model change, which uplinks a new setup mid-mission) decide on the target exactly as
//! natively: the same decision logs (times included), the same directives, the same run and
//! the same `[[expect]]` verdicts. A corrupted or malformed setup, a step out of order and a
//! step for no setup are refused with their reason, and the target goes on as before.
//!
//! The missions are the shipped files at their seeds, full length (12 sols; a run is a few
//! seconds of QEMU: the target answers a step in one 10 ms frame, a replan in one to a few hundred).
use fsw_bridge::lander::{LanderRefusal, LanderReport, LanderSetupError};
use fsw_bridge::MissionTimeUs;
use hil::lander_emulated::{EmulatedLander, Recorder};
use hil::study::load_scenario;
use hil_tests::firmware;
use lander::executor::{Directive, Observation};
use lander_sim::expect::check_all;
use lander_sim::sim::{autonomy_inputs, run_watched, RunConfig};

/// BSM-1, RSM-1 and every shipped ELAP scenario of V.B.1 (issue 12 item 3: each passes natively
/// and on the emulated target with identical decisions).
const MISSIONS: [&str; 14] = [
    "bsm-1.toml",
    "rsm-1.toml",
    "elap/01-all-samples-positive.toml",
    "elap/02-all-samples-negative.toml",
    "elap/03-low-start-soc.toml",
    "elap/04-ground-changes-excavation-order.toml",
    "elap/05-first-sample-negative.toml",
    "elap/06-ground-changes-mission-model.toml",
    // The data-volume scenarios: the link model, its changes and the products onboard go up
    // to the target (LanderInput) before the step that sees them.
    "elap/07-increased-decisional-volume.toml",
    "elap/08-sudden-low-battery.toml",
    "elap/09-higher-comm-allocation.toml",
    "elap/10-slower-heating.toml",
    "elap/11-sudden-downlink-slowdown.toml",
    "elap/12-increased-mandatory-volume.toml",
];

#[test]
fn lander_missions_decide_on_the_target_as_natively_and_bad_setups_are_refused() {
    let _one = hil_tests::exclusive_qemu();
    let mut target = EmulatedLander::boot(firmware()).unwrap_or_else(|e| panic!("{e}"));
    for file in MISSIONS {
        let path = hil::repo_root().join("scenarios/lander").join(file);
        let s = load_scenario(&path).unwrap_or_else(|d| panic!("{}", d.render()));
        let config = RunConfig::new(s.run.strategy.strategy(), s.run.seed);
        let mut native = Recorder::default();
        let want = run_watched(&s, &config, &mut native).unwrap();
        let got = target
            .run(&s, &config)
            .unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(got.transcript, native.transcript, "{file}: the decisions");
        assert_eq!(got.result, want, "{file}: the run");
        let verdicts = check_all(&s, &got.result);
        assert_eq!(verdicts, check_all(&s, &want), "{file}: the verdicts");
        assert!(
            verdicts.iter().all(|v| v.passed),
            "{file}: the shipped mission meets its expectations: {verdicts:?}"
        );
        let decisions: usize = got.transcript.logs.iter().map(Vec::len).sum();
        let c = &got.costs;
        assert!(
            decisions > 20 && c.steps > 20,
            "{file}: {decisions} decisions"
        );
        assert!(!c.plans.is_empty() && c.total_ticks > 0, "{file}");
        assert_eq!(c.setups as usize, got.transcript.logs.len());
        // No planner call overruns its window (the kernel's health monitor would report it),
        // in any mission: RSM-1 logged one overrun of the planner partition (error kind 8)
        // while its first plan cost about 105,000 instructions an exploration (4 explorations
        // a call); ELAP 12 logged one at step 29 (100.5 h: the downlink dispatched then was
        // sized by a downlink-manager solve of 4,004 knapsack nodes in one call, now divided
        // across calls, `lander::executor::SIZING_NODES_PER_EXPLORATION`).
        assert!(
            got.health_events.is_empty(),
            "{file}: the health monitor logged {:?}",
            got.health_events
        );
        println!(
            "{file}: {:.1} sols, {} steps, {decisions} decisions, {} setup(s) {:?} bytes, {} plans (worst {} guest instructions), planner {} ticks, {} frames, wall {:.2} s, health {:?}",
            got.result.end_us as f64 / lander::rsm1::SOL_US as f64,
            c.steps,
            c.setups,
            c.setup_bytes,
            c.plans.len(),
            c.plans.iter().map(|p| p.guest_instructions).max().unwrap_or(0),
            c.total_ticks,
            c.frames,
            c.wall.as_secs_f64(),
            got.health_events
        );
    }

    // A target that decides differently from the shadow (its setup's exploration bound
    // changed on the way up) ends the run at the first different step, named, and stays up.
    let path = hil::repo_root().join("scenarios/lander/bsm-1.toml");
    let s = load_scenario(&path).unwrap();
    let config = RunConfig::new(s.run.strategy.strategy(), s.run.seed);
    target.perturb_setup = Some(|setup| setup.config.exploration_bound = Some(2));
    let e = target.run(&s, &config).expect_err("diverges");
    assert!(
        e.starts_with("DIVERGED at step 0 (setup") && e.contains("decisions: target"),
        "{e}"
    );
    target.perturb_setup = None;
    assert!(target.run(&s, &config).is_ok());

    // Bad setups and steps, each refused with its reason; the target stays up.
    let s = load_scenario(&hil::repo_root().join("scenarios/lander/bsm-1.toml")).unwrap();
    let (model, network, timeline, context) = autonomy_inputs(&s, false).unwrap();
    let setup = lander::setup::LanderSetup {
        config: lander::executor::ExecConfig::new(s.run.strategy.strategy()),
        primitives: model.primitives.clone(),
        network,
        timeline,
        context,
        learned: Default::default(),
    };
    let bytes = EmulatedLander::encode(&setup).unwrap();
    // Corrupted on the way: a flipped bit under the announced CRC.
    let mut msgs = EmulatedLander::setup_messages(100, &bytes);
    if let fsw_bridge::HostToTarget::LanderChunk { bytes, .. } = &mut msgs[2] {
        bytes[5] ^= 0x08;
    }
    let r = target.uplink(100, msgs).unwrap();
    assert!(
        matches!(r, Err(LanderRefusal::BadCrc { .. })),
        "corrupted: {r:?}"
    );
    // Malformed under a matching CRC: another format version, then cut short.
    let mut bad = bytes.clone();
    bad[0] = 0x7f;
    let r = target
        .uplink(101, EmulatedLander::setup_messages(101, &bad))
        .unwrap();
    assert_eq!(
        r,
        Err(LanderRefusal::BadSetup(LanderSetupError::Version {
            got: 0x7f
        }))
    );
    let cut = &bytes[..bytes.len() - 3];
    let r = target
        .uplink(102, EmulatedLander::setup_messages(102, cut))
        .unwrap();
    assert!(
        matches!(
            r,
            Err(LanderRefusal::BadSetup(LanderSetupError::Malformed {
                part: 2,
                ..
            }))
        ),
        "cut short: {r:?}"
    );
    // A chain naming a primitive the model does not have.
    let mut wrong = setup.clone();
    wrong.network.chains[1].primitives[0] = 200;
    let r = target
        .uplink(
            103,
            EmulatedLander::setup_messages(103, &EmulatedLander::encode(&wrong).unwrap()),
        )
        .unwrap();
    assert_eq!(
        r,
        Err(LanderRefusal::BadSetup(LanderSetupError::BadChain {
            chain: 1
        }))
    );
    // A step for the refused setup: there is no executor.
    let observation = Observation {
        now: MissionTimeUs::ZERO,
        battery_mj: setup.timeline.battery_mj,
        preconditions_met: true,
        event: None,
    };
    assert_eq!(
        target.step_raw(0, &observation).unwrap().err(),
        Some(LanderRefusal::NoSetup)
    );
    // The good setup is accepted, and a step out of order refused.
    let accepted = target.load(&setup).unwrap();
    assert!(
        matches!(accepted, LanderReport::Accepted { .. }),
        "{accepted:?}"
    );
    assert_eq!(
        target.step_raw(5, &observation).unwrap().err(),
        Some(LanderRefusal::OutOfOrder { expected: 0 })
    );
    // Bad link and data inputs, each refused with its reason; the executor keeps what it had
    // (step 0 below decides as a native executor given none).
    let id = target.position().0;
    let comms = |rate_bps| fsw_bridge::HostToTarget::LanderInput {
        setup: id,
        input: fsw_bridge::lander::LanderInput::Comms(Some(fsw_bridge::lander::LanderComms {
            rate_bps,
            overhead_us: 600_000_000,
            thermal_limit_us: 3_600_000_000,
            radio_power_mw: 50_000,
            per_downlink_mj: 100_000_000,
            per_sol_mj: 200_000_000,
            sol_us: lander::rsm1::SOL_US,
        })),
    };
    let product = |tier| lander::downlink::DataProduct {
        size_bytes: 1_000,
        value: 10,
        created_at: MissionTimeUs::ZERO,
        tier,
    };
    assert_eq!(
        target.input_raw(vec![comms(0)], 20).unwrap(),
        Some(LanderRefusal::BadInput { error: 0 }),
        "a zero rate"
    );
    let mut unknown_tier =
        EmulatedLander::product_messages(id, &[product(lander::htn::Tier::Mandatory)]);
    if let fsw_bridge::HostToTarget::LanderInput {
        input: fsw_bridge::lander::LanderInput::Products { products, .. },
        ..
    } = &mut unknown_tier[0]
    {
        products[0].tier = 9;
    }
    assert_eq!(
        target.input_raw(unknown_tier, 20).unwrap(),
        Some(LanderRefusal::BadInput { error: 4 }),
        "an unknown tier"
    );
    // The second part of a six-product list without its first.
    let six = [product(lander::htn::Tier::Residual); 6];
    let parts = EmulatedLander::product_messages(id, &six);
    assert_eq!(parts.len(), 2);
    assert_eq!(
        target.input_raw(parts[1..].to_vec(), 20).unwrap(),
        Some(LanderRefusal::BadInput { error: 3 }),
        "a part out of order"
    );
    // More products than the target holds (refused at the first part, which alone is sent).
    let many = vec![product(lander::htn::Tier::Residual); lander::capacity::MAX_DATA_PRODUCTS + 1];
    let first_part = EmulatedLander::product_messages(id, &many)[..1].to_vec();
    assert_eq!(
        target.input_raw(first_part, 20).unwrap(),
        Some(LanderRefusal::BadInput { error: 1 }),
        "too many products"
    );
    // And the target goes on: step 0 plans and answers as the native executor does.
    let (decisions, directive, _, _) = target.step_raw(0, &observation).unwrap().unwrap();
    let mut exec = lander::executor::Executor::<
        { lander::capacity::MAX_SEARCH_NODES },
        { lander::capacity::MAX_EXPLORE_QUEUE },
    >::new(
        setup.config,
        &model,
        &setup.network,
        &setup.timeline,
        &setup.context,
        None,
    )
    .map(Box::new)
    .unwrap();
    let want = lander_sim::sim::step_to_answer(&mut exec, &observation, 1_000_000);
    assert_eq!(directive, want);
    assert!(!matches!(directive, Directive::Planning { .. }));
    assert_eq!(decisions, exec.log());
}

/// The downlink manager at mission size on the target (issue 11's measure): every product of
/// RSM-1's native run over the downlinks it made, solved in the planner
/// partition's windows to the same value, proof and node count as natively.
#[test]
fn the_downlink_manager_solves_a_mission_size_problem_on_the_target_as_natively() {
    let _one = hil_tests::exclusive_qemu();
    let mut target = EmulatedLander::boot(firmware()).unwrap_or_else(|e| panic!("{e}"));
    for file in ["rsm-1.toml", "elap/01-all-samples-positive.toml"] {
        let path = hil::repo_root().join("scenarios/lander").join(file);
        let s = load_scenario(&path).unwrap_or_else(|d| panic!("{}", d.render()));
        let config = RunConfig::new(s.run.strategy.strategy(), s.run.seed);
        let run = lander_sim::sim::run(&s, &config).unwrap();
        let problem = hil::lander_emulated::mission_downlink_problem(&run, &s);
        assert!(problem.products.len() >= 20 && problem.opportunities.len() >= 8);
        let mut native = lander::downlink::DownlinkManager::new();
        native
            .load(
                &problem.products,
                &problem.opportunities,
                &problem.allocations,
            )
            .unwrap();
        native.solve();
        let k = native.knapsack();
        let got = target.solve_downlink(&problem).unwrap();
        assert_eq!(
            (got.value, got.proven, u64::from(got.nodes)),
            (
                native.downlinked_value(),
                k.proven_optimal(),
                k.nodes() + k.bound_nodes()
            ),
            "{file}"
        );
        assert!(got.proven && got.ticks > 0, "{file}: {got:?}");
        // RSM-1's comm allowances bind: the knapsack searches (ELAP 1's 11 downlinks carry
        // everything, its bound proves the greedy assignment at the root).
        assert!(got.nodes > 0 || file != "rsm-1.toml", "{file}: {got:?}");
        println!(
            "{file}: downlink manager, {} products x {} opportunities: value {}, proven, {} nodes, {} guest instructions, {} planner windows",
            problem.products.len(),
            problem.opportunities.len(),
            got.value,
            got.nodes,
            got.guest_instructions,
            got.windows
        );
    }
    // A problem the manager refuses (a downlink before the one before it) is refused by name,
    // and the target goes on: the executor is built from a setup after it.
    let s = load_scenario(&hil::repo_root().join("scenarios/lander/bsm-1.toml")).unwrap();
    let run = lander_sim::sim::run(&s, &RunConfig::new(s.run.strategy.strategy(), 1)).unwrap();
    let mut problem = hil::lander_emulated::mission_downlink_problem(&run, &s);
    problem.opportunities.swap(0, 1);
    let e = target.solve_downlink(&problem).unwrap_err();
    assert!(e.contains("BadDownlinkProblem { error: 4 }"), "{e}");
    let got = target
        .run(&s, &RunConfig::new(s.run.strategy.strategy(), 1))
        .unwrap();
    assert!(got.costs.steps > 20);
}

/// `hil study --emulated` (issue 12's emulated subset): the strategy study with every run's
/// decisions made on the target (one run per cell here, 12 runs of BSM-1; the README's has 5)
/// is the native study, run for run.
#[test]
fn the_strategy_study_on_the_target_is_the_native_study() {
    use lander_sim::study::{run_study, run_study_with, StudyConfig};
    let path = hil::repo_root().join("scenarios/lander/bsm-1.toml");
    let s = load_scenario(&path).unwrap_or_else(|d| panic!("{}", d.render()));
    let config = StudyConfig::new(s, 1, 1);
    let native = run_study(&config, None, &mut |_| {}).unwrap();
    let _one = hil_tests::exclusive_qemu();
    let mut target = EmulatedLander::boot(firmware()).unwrap_or_else(|e| panic!("{e}"));
    let mut runs = 0;
    let emulated = run_study_with(&config, None, &mut |_| runs += 1, &mut |s, c| {
        target.run(s, c).map(|r| r.result)
    })
    .unwrap();
    assert_eq!(runs, 12);
    assert_eq!(emulated, native);
}

/// A model uplink after learning (`scenarios/lander/learned-across-uplink.toml`), and one
/// that carries task parameters the ground sets (`scenarios/lander/ground-sets-parameters.toml`):
/// the new setup carries what the replaced executor measured and what the ground set (its
/// learned part), and the target's new executor decides with it exactly as the native one (the
/// same decisions, directives, run and verdicts). A setup whose learned part is dropped on the
/// way up makes the target plan site 0's sampling at the model's priors: the run diverges after
/// the uplink (in its second setup), so the comparison would catch a target that lost it.
#[test]
fn what_was_learned_survives_a_model_uplink_on_the_target_as_natively() {
    let _one = hil_tests::exclusive_qemu();
    let mut target = EmulatedLander::boot(firmware()).unwrap_or_else(|e| panic!("{e}"));
    for file in ["learned-across-uplink.toml", "ground-sets-parameters.toml"] {
        let path = hil::repo_root().join("scenarios/lander").join(file);
        let s = load_scenario(&path).unwrap_or_else(|d| panic!("{}", d.render()));
        let config = RunConfig::new(s.run.strategy.strategy(), s.run.seed);
        // The learned part dropped on the way up: the target diverges in the run's second
        // setup, the new model's.
        let second = target.position().0 + 2;
        target.perturb_setup = Some(|setup| setup.learned = Default::default());
        let e = target.run(&s, &config).expect_err("diverges");
        target.perturb_setup = None;
        assert!(
            e.starts_with("DIVERGED at step") && e.contains(&format!("(setup {second},")),
            "{file}: {e}"
        );
        // Carried: the same decisions as natively.
        let mut native = Recorder::default();
        let want = run_watched(&s, &config, &mut native).unwrap();
        let got = target
            .run(&s, &config)
            .unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(got.transcript, native.transcript, "{file}: the decisions");
        assert_eq!(got.result, want, "{file}: the run");
        let verdicts = check_all(&s, &got.result);
        assert!(verdicts.iter().all(|v| v.passed), "{file}: {verdicts:?}");
        assert_eq!(
            got.costs.setups, 2,
            "{file}: the start and the model uplink"
        );
        assert!(
            got.transcript.logs[1].len() > 20,
            "{file}: the new executor decided: {:?}",
            got.transcript.logs[1]
        );
        println!(
            "{file}: {} steps, setups of {:?} bytes, built in {:?} ticks",
            got.costs.steps, got.costs.setup_bytes, got.costs.build_ticks
        );
    }
}

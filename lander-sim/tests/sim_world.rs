//! The lander world's parts: the Earth-in-view schedule, the battery, the failure draws, the
//! sampling physics, and a run's determinism.
use lander::executor::Strategy;
use lander::rsm1::{HOUR_US, WH_MJ};
use lander_sim::rng::{Rng, Stream};
use lander_sim::scenario::{ppm, Drop, Scenario};
use lander_sim::sim::{
    autonomy_inputs, draw_failure, run, EarthSchedule, EndReason, FailureClass, RunConfig, World,
};

#[test]
fn earth_is_in_view_42_hours_of_every_84() {
    let e = EarthSchedule::from_scenario(&Scenario::bsm1());
    let h = |x: u64| x * HOUR_US;
    assert!(e.in_view(0));
    assert!(e.in_view(h(42) - 1));
    assert!(!e.in_view(h(42)));
    assert!(!e.in_view(h(84) - 1));
    assert!(e.in_view(h(84)));
    // Over ten periods, in view exactly half the time, in 1-minute steps.
    let minutes = 10 * 84 * 60;
    let in_view = (0..minutes).filter(|m| e.in_view(m * 60_000_000)).count();
    assert_eq!(in_view, minutes as usize / 2);
    assert_eq!(e.next_in_view(h(50)), h(84));
    assert_eq!(e.next_in_view(h(10)), h(10));
    assert_eq!(e.view_end(h(10)), h(42));
    assert_eq!(e.view_end(h(90)), h(126));
    // Uplink windows at 1, 13, 25, 37 h into each in-view part.
    assert_eq!(e.next_uplink(h(2)), h(13));
    assert_eq!(e.next_uplink(h(38)), h(85));
    assert_eq!(e.next_uplink(h(85)), h(85));
}

#[test]
fn the_ground_answers_at_an_uplink_window_after_seeing_the_halt() {
    let s = Scenario::bsm1();
    let (model, ..) = autonomy_inputs(&s, false).unwrap();
    let w = World::new(&s, &model, 1, false);
    let h = |x: u64| x * HOUR_US;
    let light = 45 * 60_000_000;
    // Halt at 50 h (Earth not in view): seen at 84 h + light, ready 4 h later, uplink at
    // 84 + 13 h, on board a light time later.
    assert_eq!(w.ground_answer_at(h(50)), h(97) + light);
    // Halt at 2 h (in view): seen at once, ready at 6 h 45, uplink at 13 h.
    assert_eq!(w.ground_answer_at(h(2)), h(13) + light);
}

#[test]
fn the_battery_never_goes_negative_and_the_lander_dies_at_zero() {
    let mut s = Scenario::bsm1();
    s.mission.battery_wh = 300;
    s.power.drops = vec![Drop {
        at_h: 5,
        wh: 250,
        to_soc: None,
    }];
    let (model, ..) = autonomy_inputs(&s, false).unwrap();
    let mut w = World::new(&s, &model, 1, false);
    let mut last = w.battery_mj;
    for hour in 1..=100 {
        let alive = w.advance(hour * HOUR_US);
        assert!(w.battery_mj <= last, "charge rose at {hour} h");
        last = w.battery_mj;
        if !alive {
            break;
        }
    }
    // 300 Wh - 250 Wh at 5 h, the rest at 8-10 W: dead within a day, at zero exactly.
    assert!(w.dead);
    assert_eq!(w.battery_mj, 0);
    assert!(w.now < 24 * HOUR_US, "died at {} h", w.now / HOUR_US);
    assert!(!w.spend(1));
    assert_eq!(w.battery_mj, 0);
    // Whole runs under every strategy with a small battery end at zero, never below.
    s.power.drops.clear();
    s.mission.battery_wh = 2_500;
    for strategy in [
        Strategy::Static,
        Strategy::Ground,
        Strategy::FlexibleExecution,
        Strategy::Replan,
    ] {
        for seed in 0..5 {
            let r = run(&s, &RunConfig::new(strategy, seed)).unwrap();
            assert!(r.battery_end_mj <= r.battery_start_mj);
            if r.end == EndReason::BatteryExhausted {
                assert_eq!(r.battery_end_mj, 0);
            }
        }
    }
}

#[test]
fn failure_classes_are_drawn_with_their_probabilities() {
    let s = Scenario::bsm1();
    let f = &s.failures;
    let mut rng = Rng::stream(42, Stream::Failures);
    let n = 400_000u32;
    let mut counts = [0u32; 4];
    for _ in 0..n {
        let i = match draw_failure(&mut rng, ppm(f.p_fail), ppm(f.p_fe), ppm(f.p_replan)) {
            None => 3,
            Some(FailureClass::FlexibleExecution) => 0,
            Some(FailureClass::Replan) => 1,
            Some(FailureClass::Ground) => 2,
        };
        counts[i] += 1;
    }
    let p = |c: u32| f64::from(c) / f64::from(n);
    // Within 4 standard errors of each probability.
    for (got, want) in [
        (p(counts[0]), f.p_fe),
        (p(counts[1]), f.p_replan),
        (p(counts[2]), f.p_ground),
        (1.0 - p(counts[3]), f.p_fail),
    ] {
        let se = (want * (1.0 - want) / f64::from(n)).sqrt();
        assert!(
            (got - want).abs() < 4.0 * se,
            "drawn {got}, expected {want}"
        );
    }
}

#[test]
fn the_same_seed_gives_the_same_run_and_another_seed_another() {
    let s = Scenario::bsm1();
    for strategy in [
        Strategy::Static,
        Strategy::Ground,
        Strategy::FlexibleExecution,
        Strategy::Replan,
    ] {
        let a = run(&s, &RunConfig::new(strategy, 7)).unwrap();
        let b = run(&s, &RunConfig::new(strategy, 7)).unwrap();
        assert_eq!(a, b, "{strategy:?}");
    }
    let runs: Vec<_> = (0..6)
        .map(|seed| run(&s, &RunConfig::new(Strategy::Ground, seed)).unwrap())
        .collect();
    assert!(
        runs.windows(2).any(|w| w[0] != w[1]),
        "seeds change nothing"
    );
}

#[test]
fn utility_is_realised_only_by_downlinks() {
    let s = Scenario::bsm1();
    let mut c = RunConfig::new(Strategy::Static, 3);
    c.prescient = true;
    let r = run(&s, &c).unwrap();
    assert_eq!(r.end, EndReason::Done);
    assert_eq!(r.failures, [0, 0, 0]);
    assert!(r.utility_milli > 0);
    let downlinked: u64 = r.downlinks.iter().map(|d| d.value_milli).sum();
    assert_eq!(downlinked, r.utility_milli);
    // Every transmission is while Earth is in view.
    let e = EarthSchedule::from_scenario(&s);
    for d in &r.downlinks {
        assert!(
            e.in_view(d.start_us) && d.end_us <= e.view_end(d.start_us),
            "{d:?}"
        );
    }
}

#[test]
fn excavation_respects_depth_limits_and_collapses() {
    // A site that cannot be dug deep enough: no sample is ever collected.
    let mut s = Scenario::bsm1();
    s.sampling.depth_limit_cm = vec![30];
    s.failures.p_fail = 0.0;
    s.failures.p_fe = 0.0;
    s.failures.p_replan = 0.0;
    s.failures.p_ground = 0.0;
    let r = run(&s, &RunConfig::new(Strategy::Replan, 1)).unwrap();
    assert_eq!(r.samples_analyzed, 0, "{r:?}");
    // Collapses lengthen the excavation (and cost energy) against the same seed without.
    let mut calm = Scenario::bsm1();
    calm.failures = s.failures.clone();
    calm.energy.sd = 0.0;
    let mut shaky = calm.clone();
    shaky.sampling.collapse_per_h = 0.5;
    let c = RunConfig::new(Strategy::Static, 2);
    let a = run(&calm, &c).unwrap();
    let b = run(&shaky, &c).unwrap();
    assert!(
        b.energy_spent_mj() > a.energy_spent_mj() + 100 * WH_MJ,
        "{} vs {}",
        b.energy_spent_mj(),
        a.energy_spent_mj()
    );
}

#[test]
fn the_charge_starts_at_its_state_of_charge_and_a_drop_can_fall_to_one() {
    let mut s = Scenario::bsm1();
    s.mission.battery_wh = 1_000;
    s.power.start_soc = 0.5;
    s.power.drops = vec![Drop {
        at_h: 10,
        wh: 0,
        to_soc: Some(0.1),
    }];
    let (model, _, timeline, _) = autonomy_inputs(&s, false).unwrap();
    // The lander plans from the charge it has.
    assert_eq!(timeline.battery_mj, 500 * WH_MJ);
    let mut w = World::new(&s, &model, 1, false);
    assert_eq!(w.battery_mj, 500 * WH_MJ);
    assert!(w.advance(10 * HOUR_US));
    // 8 W of hotel load for 10 h, then down to 10% of the capacity.
    assert_eq!(w.battery_mj, 100 * WH_MJ);
    // A drop to a charge above the present one takes nothing.
    s.power.drops[0].to_soc = Some(0.9);
    let mut w = World::new(&s, &model, 1, false);
    assert!(w.advance(10 * HOUR_US));
    assert_eq!(w.battery_mj, 420 * WH_MJ);
}

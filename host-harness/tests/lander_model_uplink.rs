//! A model uplink rebuilds the lander's executor (issue 11 items 6 and 8): what the executor
//! it replaces had learned by measurement (IV.C.3's durations and energies per kind and site,
//! the product volume factors, the sol's radio energy spent) carries over to the new one, so
//! the new plan predicts with the measured values, not the model's priors again.
//!
//! The mission is `scenarios/lander/learned-across-uplink.toml`: ELAP 6's world with every
//! task costing 30% more energy than modelled and decisional products three times their
//! model's size, so what is learned differs from the priors, and a model uplink made in answer
//! to the first sample collected (new site values, in the same order): the new executor goes
//! on sampling at site 0, where it measured.
use hil::study::load_scenario;
use lander::executor::{Directive, ExecConfig, Learned, Observation};
use lander::htn::{FlatNetwork, HtnModel, PrimitiveKind};
use lander::placement::TimelinePlacement;
use lander_sim::scenario::Scenario;
use lander_sim::sim::{run_watched, Autonomy, RunConfig, StepWatch};

/// The shipped mission with a model uplink after learning.
pub fn learning_then_uplink() -> Scenario {
    let path = hil::repo_root().join("scenarios/lander/learned-across-uplink.toml");
    load_scenario(&path).unwrap_or_else(|e| panic!("{}", e.render()))
}

/// A primitive's (kind, site) and its prior (duration, energy).
type Prior = ((PrimitiveKind, Option<u8>), (u64, u64));

/// Per executor built: the model's priors (kind, site) -> (duration, energy), the learned
/// state it was given, the learned state it ended with, and its dispatches.
#[derive(Default)]
struct Build {
    priors: Vec<Prior>,
    given: Learned,
    last: Learned,
    dispatches: Vec<(PrimitiveKind, Option<u8>, u64)>,
    first_params: Option<Vec<lander::executor::ParameterUpdate>>,
}

#[derive(Default)]
struct Watch {
    builds: Vec<Build>,
}

impl StepWatch for Watch {
    fn built(
        &mut self,
        _: ExecConfig,
        model: &HtnModel,
        _: &FlatNetwork,
        _: &TimelinePlacement,
        _: &lander::assessor::ScienceContext,
        learned: &Learned,
    ) -> Result<(), String> {
        self.builds.push(Build {
            priors: model
                .primitives
                .iter()
                .map(|p| ((p.kind, p.site), (p.duration_us, p.energy_mj)))
                .collect(),
            given: learned.clone(),
            ..Build::default()
        });
        Ok(())
    }

    fn stepped(&mut self, _: &Observation, d: &Directive, exec: &Autonomy) -> Result<(), String> {
        let b = self.builds.last_mut().ok_or("a step before a build")?;
        b.last = exec.learned();
        b.first_params
            .get_or_insert_with(|| exec.parameters().to_vec());
        if let Directive::Dispatch {
            kind,
            site,
            expected_energy_mj,
            ..
        } = *d
        {
            b.dispatches.push((kind, site, expected_energy_mj));
        }
        Ok(())
    }
}

#[test]
fn what_the_executor_learned_survives_a_model_uplink() {
    let s = learning_then_uplink();
    let config = RunConfig::new(s.run.strategy.strategy(), s.run.seed);
    let mut watch = Watch::default();
    let run = run_watched(&s, &config, &mut watch).unwrap();
    assert_eq!(run.changes.len(), 1, "the model uplink was applied");
    let verdicts = lander_sim::expect::check_all(&s, &run);
    assert!(verdicts.iter().all(|v| v.passed), "{verdicts:?}");
    let [first, second] = &watch.builds[..] else {
        panic!("{} executors built, not 2", watch.builds.len());
    };
    assert_eq!(
        first.given,
        Learned::default(),
        "nothing learned at the start"
    );
    // The new executor is given exactly what the old one had learned by its last step ...
    assert_eq!(second.given, first.last);
    assert!(
        second.given.params.len() >= 3,
        "measured parameters before the uplink: {:?}",
        second.given.params
    );
    assert!(
        !second.given.volumes.entries().is_empty(),
        "volume factors learned before the uplink"
    );
    // ... holds it from its first answer on ...
    assert_eq!(
        second.first_params.as_deref(),
        Some(&second.given.params[..]),
        "the parameters in force at the new executor's first step"
    );
    // ... and predicts with it: the first dispatch after the uplink of a (kind, site) measured
    // before it (and not measured again in between) expects the measured energy, which is
    // not the model's prior.
    let mut checked = 0;
    let mut seen = Vec::new();
    for &(kind, site, expected) in &second.dispatches {
        if lander::placement::is_downlink(kind) || seen.contains(&(kind, site)) {
            continue;
        }
        seen.push((kind, site));
        let Some(p) = second
            .given
            .params
            .iter()
            .find(|p| p.kind == kind && Some(p.site) == site)
        else {
            continue;
        };
        let prior = second
            .priors
            .iter()
            .find(|(k, _)| *k == (kind, site))
            .map(|(_, v)| v.1)
            .unwrap();
        assert_ne!(
            p.energy_mj, prior,
            "{kind:?} at {site:?}: learned as modelled"
        );
        assert_eq!(
            expected, p.energy_mj,
            "{kind:?} at site {site:?}: the dispatch after the uplink expects the measured energy (prior {prior})"
        );
        checked += 1;
    }
    assert!(
        checked >= 1,
        "no dispatch after the uplink of a learned kind and site: params {:?}, dispatches {:?}",
        second.given.params,
        second.dispatches
    );
    println!(
        "carried {} parameters, {} volume factors, radio spent {:?}; {checked} dispatches checked",
        second.given.params.len(),
        second.given.volumes.entries().len(),
        second.given.comm_spent
    );
}

/// A ground command for model parameters (`scenarios/lander/ground-sets-parameters.toml`): the
/// ground sets sampling at site 0 to 3 h and 600 Wh (the model: 2 h, 400 Wh). The rebuilt
/// executor is given it among what it learned; its first sample at site 0 is expected at the
/// ground's values, and the lander's own measurement of it replaces them for the next ones.
#[test]
fn the_ground_sets_a_task_parameter_through_the_model_uplink() {
    let path = hil::repo_root().join("scenarios/lander/ground-sets-parameters.toml");
    let s = load_scenario(&path).unwrap_or_else(|e| panic!("{}", e.render()));
    let config = RunConfig::new(s.run.strategy.strategy(), s.run.seed);
    let mut watch = Watch::default();
    let run = run_watched(&s, &config, &mut watch).unwrap();
    let verdicts = lander_sim::expect::check_all(&s, &run);
    assert!(verdicts.iter().all(|v| v.passed), "{verdicts:?}");
    let [_, second] = &watch.builds[..] else {
        panic!("{} executors built, not 2", watch.builds.len());
    };
    let ground = lander::executor::ParameterUpdate {
        kind: PrimitiveKind::CollectSample,
        site: 0,
        duration_us: 180 * 60_000_000,
        energy_mj: 600 * 3_600_000,
    };
    assert!(
        second.given.params.contains(&ground),
        "{:?}",
        second.given.params
    );
    let site0: Vec<u64> = second
        .dispatches
        .iter()
        .filter(|&&(k, site, _)| k == PrimitiveKind::CollectSample && site == Some(0))
        .map(|&(_, _, e)| e)
        .collect();
    assert!(
        site0.len() >= 2,
        "samples at site 0 after the uplink: {site0:?}"
    );
    assert_eq!(
        site0[0], ground.energy_mj,
        "the first at the ground's value"
    );
    assert!(
        site0[1..].iter().all(|&e| e != ground.energy_mj),
        "the later ones at the measured value: {site0:?}"
    );
}

/// A ground parameter the lander has no task or site for is refused at its field.
#[test]
fn bad_ground_parameters_are_refused_at_their_field() {
    let path = hil::repo_root().join("scenarios/lander/ground-sets-parameters.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    for (from, to, field) in [
        (
            "task = \"collect_sample\"",
            "task = \"collect_samples\"",
            ".task",
        ),
        ("site = 0", "site = 3", ".site"),
        ("duration_min = 180", "duration_min = 0", ".duration_min"),
        ("energy_wh = 600", "energy_wh = 2000000", ".energy_wh"),
    ] {
        let bad = text.replacen(from, to, 1);
        let e = hil::study::parse_scenario(hil::diag::SourceFile::new("g.toml", bad)).unwrap_err();
        assert!(
            e.field.starts_with("ground.changes[0].parameters[0]") && e.field.ends_with(field),
            "{to}: {e}"
        );
    }
    assert_eq!(
        lander_sim::scenario::kind_named("find_collection_targets"),
        Some(PrimitiveKind::FindCollectionTargets)
    );
}

//! A mission run: the executor built from the scenario (and rebuilt at each model uplink),
//! stepped by the world until the horizon, the lander's death or the last step, and watched
//! by a [`StepWatch`] (the emulated target's comparison, tests).
use super::*;
use lander::executor::Learned;

/// The value of the products that reached Earth.
fn realised_of(products: &[Product]) -> u64 {
    products
        .iter()
        .filter(|p| p.received_us.is_some())
        .map(|p| p.value_milli)
        .sum()
}

/// The executor type the simulation drives (the default capacities).
pub type Autonomy = Executor;

/// An executor for the state `now`, `charge_mj`, `context` (what the lander has learned about
/// the science) and `learned` (the measured parameters and volumes of the executor it replaces,
/// and the sol's radio energy spent) with the model of `options` (a model uplink: the executor
/// is rebuilt and plans from the state).
#[allow(clippy::too_many_arguments)]
fn rebuild(
    s: &Scenario,
    options: Rsm1Options,
    context: &lander::assessor::ScienceContext,
    learned: &Learned,
    now: u64,
    charge_mj: u64,
    strategy: Strategy,
    preamble_done: bool,
    watch: &mut dyn StepWatch,
) -> Result<(HtnModel, Box<Autonomy>), String> {
    let model = rsm1::model_with_drains(options, s.mission.uplinks)
        .map_err(|_| "the new model exceeds the capacities")?;
    let mut net = flatten(
        &model,
        FlattenOptions {
            fully_autonomous: s.mission.fully_autonomous,
        },
    )
    .map_err(|e| format!("the new model does not flatten: {e:?}"))?;
    if preamble_done {
        // The new model's preamble (task 1) is done already: not planned again.
        net.chains.retain(|c| c.task != PREAMBLE_TASK);
    }
    let mut timeline =
        rsm1::placement(s.mission.sols, charge_mj).ok_or("no placement for the mission")?;
    timeline.horizon_start = MissionTimeUs(now);
    timeline.hotel_load_mw = (s.power.hotel_w + s.power.seismometer_w) * 1_000;
    timeline.earth.windows = EarthSchedule::from_scenario(s).view_timeline(now, horizon_us(s));
    let mut exec = Box::new(
        Executor::new(
            ExecConfig::new(strategy),
            &model,
            &net,
            &timeline,
            context,
            None,
        )
        .map_err(|e| format!("the executor refused the new model: {e:?}"))?,
    );
    exec.set_learned(learned);
    watch.built(
        ExecConfig::new(strategy),
        &model,
        &net,
        &timeline,
        context,
        learned,
    )?;
    Ok((model, exec))
}

/// The reference model's preamble task.
const PREAMBLE_TASK: u16 = 1;

/// A ground change on its way.
struct PendingChange {
    index: usize,
    decided_us: u64,
    /// On board (u64::MAX until its trigger happened).
    arrives_us: u64,
}

/// The next arrival of a ground change still to come.
fn next_arrival(pending: &[PendingChange]) -> Option<u64> {
    pending
        .iter()
        .map(|p| p.arrives_us)
        .filter(|&t| t != u64::MAX)
        .min()
}

/// What watches the executor the simulation drives (the emulated target, which runs the same
/// executor and must decide the same; tests that keep the decisions). An error ends the run
/// with it.
pub trait StepWatch {
    /// An executor was built (at the start, and at each model uplink) from these inputs, as
    /// [`Executor::new`] takes them without a plan, then given `learned`
    /// ([`Executor::set_learned`]: empty at the start, the replaced executor's at an uplink).
    fn built(
        &mut self,
        config: ExecConfig,
        model: &HtnModel,
        network: &lander::htn::FlatNetwork,
        timeline: &lander::placement::TimelinePlacement,
        context: &lander::assessor::ScienceContext,
        learned: &Learned,
    ) -> Result<(), String> {
        let _ = (config, model, network, timeline, context, learned);
        Ok(())
    }

    /// The executor answered `observation` with `directive` ([`step_to_answer`]); `exec` is
    /// the executor after the step (its log holds the step's decisions at its end).
    fn stepped(
        &mut self,
        observation: &Observation,
        directive: &Directive,
        exec: &Autonomy,
    ) -> Result<(), String> {
        let _ = (observation, directive, exec);
        Ok(())
    }
}

/// No watch.
impl StepWatch for () {}

/// One step as the planner partition answers it: the search runs `budget` explorations a
/// call, and the executor is called again (with the same observation, its event already
/// taken) while it answers [`Directive::Planning`], so the simulation sees only the step's
/// final directive and its mission time does not depend on how the search was split.
pub fn step_to_answer(exec: &mut Autonomy, observation: &Observation, budget: u32) -> Directive {
    let mut directive = exec.step(observation, budget);
    let again = Observation {
        event: None,
        ..*observation
    };
    while let Directive::Planning { .. } = directive {
        directive = exec.step(&again, budget);
    }
    directive
}

/// Runs one mission of scenario `s` under `config`.
pub fn run(s: &Scenario, config: &RunConfig) -> Result<RunResult, String> {
    run_watched(s, config, &mut ())
}

/// [`run`], with `watch` told of every executor built and every step.
pub fn run_watched(
    s: &Scenario,
    config: &RunConfig,
    watch: &mut dyn StepWatch,
) -> Result<RunResult, String> {
    let (mut model, net, timeline, context) = autonomy_inputs(s, config.prescient)?;
    let mut exec: Box<Autonomy> = Box::new(
        Executor::new(
            ExecConfig::new(config.strategy),
            &model,
            &net,
            &timeline,
            &context,
            None,
        )
        .map_err(|e| format!("the executor refused the plan: {e:?}"))?,
    );
    watch.built(
        ExecConfig::new(config.strategy),
        &model,
        &net,
        &timeline,
        &context,
        &Learned::default(),
    )?;
    // The world's truth: the model's priors (prescient: bias-scaled, as the planner's).
    let mut world = World::new(s, &model, config.seed, config.prescient);
    let _ = exec.set_comms(Some(world.comms_model()));
    let battery_start = world.battery_mj;
    let horizon = horizon_us(s);
    let replan_us = s.replan.duration_min * MIN_US;
    let replan_mj = s.replan.energy_wh * WH_MJ;
    let mut event = None;
    let mut dispatched = 0u32;
    let mut completed = 0u32;
    let mut failures = [0u32; 3];
    let mut replans_charged = 0u32;
    let mut analyzed = 0u32;
    let mut negatives = 0u32;
    let mut collections = Vec::new();
    let mut analyses = Vec::new();
    let mut hold_violations = 0u32;
    let mut options = rsm1_options(s);
    // Panoramas taken (the preamble's first, the panorama tasks' after it).
    let mut panoramas_taken = 0u8;
    let mut preamble_done = false;
    // Counters of the executors replaced by model uplinks.
    let mut past = lander::executor::ExecStats::default();
    let mut applied = Vec::new();
    let mut pending: Vec<PendingChange> = s
        .ground
        .changes
        .iter()
        .enumerate()
        .map(|(index, c)| {
            let decided = c.at_h.map_or(u64::MAX, |h| h * HOUR_US);
            PendingChange {
                index,
                decided_us: decided,
                arrives_us: if decided == u64::MAX {
                    u64::MAX
                } else {
                    world.earth.next_uplink(decided) + world.light_us
                },
            }
        })
        .collect();
    // The last dispatched primitive's chain, and whether it was the chain's last.
    let mut last_dispatch: Option<(u16, bool)> = None;
    let spec_of = |exec: &Autonomy, model: &HtnModel| {
        exec.remaining()
            .first()
            .and_then(|st| model.primitives.get(usize::from(st.primitive)))
            .cloned()
    };
    let mut end = EndReason::MissionEnd;
    for _ in 0..1_000_000 {
        trace::with(|t| t.loop_top(&world));
        if world.dead {
            end = EndReason::BatteryExhausted;
            break;
        }
        if world.now >= horizon {
            end = EndReason::MissionEnd;
            break;
        }
        // Ground changes on board: a rate or allowance at once, a model at a chain boundary.
        if event.is_none() {
            let boundary = match (exec.remaining().first(), last_dispatch) {
                (None, _) | (_, None) => true,
                (Some(step), Some((chain, last))) => last || step.chain != chain,
            };
            let mut k = 0;
            while k < pending.len() {
                let p = &pending[k];
                let change = &s.ground.changes[p.index];
                if p.arrives_us > world.now || (change.changes_model() && !boundary) {
                    k += 1;
                    continue;
                }
                let p = pending.remove(k);
                if let Some(r) = change.rate_bps {
                    world.rate_bps = r;
                }
                if let Some(w) = change.per_sol_wh {
                    world.per_sol_mj = w * WH_MJ;
                }
                let _ = exec.set_comms(Some(world.comms_model()));
                if change.changes_model() {
                    let mut context = exec.context().clone();
                    for (site, &v) in context.sites.iter_mut().zip(&change.site_values) {
                        site.estimated =
                            lander::utility::Score::new((milli(v).clamp(0, 1_000) * 10) as u32)
                                .unwrap_or(lander::utility::Score::ZERO);
                    }
                    if let Some(t) = change.targets_per_site {
                        options.targets_per_site = t;
                    }
                    // The new model holds the panoramas still to take.
                    let tasks_done = panoramas_taken.saturating_sub(u8::from(preamble_done));
                    options.panoramas = s.mission.panoramas.saturating_sub(tasks_done);
                    let stats = *exec.stats();
                    past.retries += stats.retries;
                    past.replans += stats.replans;
                    past.ground_halts += stats.ground_halts;
                    // What the executor measured carries over (IV.C.3 across the rebuild),
                    // with the parameters the ground sets.
                    let mut learned = exec.learned();
                    for p in &change.parameters {
                        let kind = crate::scenario::kind_named(&p.task)
                            .ok_or_else(|| format!("unknown task {:?}", p.task))?;
                        let update = lander::executor::ParameterUpdate {
                            kind,
                            site: p.site,
                            duration_us: p.duration_min * MIN_US,
                            energy_mj: p.energy_wh * WH_MJ,
                        };
                        if !learned.set_parameter(update) {
                            return Err("more task parameters than the executor holds".into());
                        }
                    }
                    let (m, e) = rebuild(
                        s,
                        options,
                        &context,
                        &learned,
                        world.now,
                        world.battery_mj,
                        config.strategy,
                        preamble_done,
                        watch,
                    )?;
                    model = m;
                    exec = e;
                    let _ = exec.set_comms(Some(world.comms_model()));
                    replans_charged = 0;
                    last_dispatch = None;
                }
                applied.push(AppliedChange {
                    index: p.index,
                    decided_us: p.decided_us,
                    arrived_us: p.arrives_us,
                    applied_us: world.now,
                });
            }
        }
        let preconditions_met =
            spec_of(&exec, &model).is_none_or(|spec| world.preconditions(&spec));
        let _ = exec.set_onboard_data(&world.onboard_products());
        let observation = Observation {
            now: MissionTimeUs(world.now),
            battery_mj: world.battery_mj,
            preconditions_met,
            event: event.take(),
        };
        let directive = step_to_answer(&mut exec, &observation, config.budget);
        watch.stepped(&observation, &directive, &exec)?;
        let replans = exec.stats().replans;
        while replans_charged < replans {
            replans_charged += 1;
            let to = world.now + replan_us;
            if !(world.advance(to) && world.spend(replan_mj)) {
                break;
            }
        }
        trace::with(|t| t.step(&world, &directive, exec.stats()));
        match directive {
            Directive::Dispatch {
                chain,
                primitive,
                expected_end,
                ..
            } => {
                let Some(spec) = model.primitives.get(usize::from(primitive)).cloned() else {
                    return Err(format!(
                        "the executor dispatched unknown primitive {primitive}"
                    ));
                };
                let chain_info = exec.network().chains.get(usize::from(chain));
                if world.hold_in_force() && chain_info.is_some_and(|c| c.waits_for_ground_release) {
                    hold_violations += 1;
                }
                last_dispatch = Some((
                    chain,
                    exec.remaining().first().is_none_or(|st| st.last_in_chain),
                ));
                dispatched += 1;
                let start = world.now;
                if is_downlink(spec.kind) {
                    let payload = exec.downlink_payload().to_vec();
                    world.commanded = Some((expected_end.0.saturating_sub(start), payload));
                }
                let (outcome, class) = world.execute(chain, primitive, &spec);
                trace::with(|t| {
                    t.dispatched(&world, chain, primitive, &spec, start, &outcome, class)
                });
                if let Some(f) = failures.get_mut(usize::from(class)) {
                    *f += 1;
                }
                if outcome.result == TaskResult::Succeeded && !world.dead {
                    completed += 1;
                    match spec.kind {
                        PrimitiveKind::ScienceAnalyze => {
                            analyzed += 1;
                            let negative = outcome.biosignature == Some(Biosignature::Negative);
                            if negative {
                                negatives += 1;
                            }
                            if let Some((site, target)) = world.instrument {
                                analyses.push(SampleEvent {
                                    at_us: start,
                                    site,
                                    target,
                                    positive: outcome
                                        .biosignature
                                        .map(|b| b == Biosignature::Positive),
                                });
                            }
                        }
                        PrimitiveKind::CollectSample => {
                            if let (Some(site), Some(target)) = (spec.site, spec.target) {
                                collections.push(SampleEvent {
                                    at_us: start,
                                    site,
                                    target,
                                    positive: None,
                                });
                                let n = collections.len() as u32;
                                for p in pending.iter_mut() {
                                    if s.ground.changes[p.index].after_samples == Some(n) {
                                        p.decided_us = world.now;
                                        p.arrives_us = world.ground_answer_at(world.now);
                                    }
                                }
                            }
                        }
                        PrimitiveKind::TakeMonoPanorama => {
                            panoramas_taken = panoramas_taken.saturating_add(1);
                        }
                        PrimitiveKind::FindExcavationSites => preamble_done = true,
                        PrimitiveKind::DownlinkWithGroundHold => world.set_hold(),
                        PrimitiveKind::Uplink => world.uplink(start),
                        _ => {}
                    }
                }
                event = Some(Event::Finished(outcome));
            }
            Directive::Wait { until } => {
                // Stop for a ground change arriving on the way.
                let next = next_arrival(&pending).unwrap_or(u64::MAX);
                world.advance(until.0.min(next).max(world.now).min(horizon));
            }
            Directive::Pushing { deadline } => {
                let next = world
                    .blocks
                    .iter()
                    .map(|b| b.until)
                    .filter(|&u| u > world.now)
                    .min()
                    .map_or(deadline.0, |u| u.min(deadline.0))
                    .min(next_arrival(&pending).unwrap_or(u64::MAX));
                world.advance(next.max(world.now + 1).min(horizon));
            }
            Directive::Planning { .. } | Directive::Running { .. } => {}
            Directive::HaltedForGround { .. } => {
                let at = world.ground_answer_at(world.now);
                if at >= horizon {
                    world.advance(horizon);
                    end = EndReason::MissionEnd;
                    break;
                }
                if world.advance(at) {
                    let spec = spec_of(&exec, &model);
                    world.ground_fix(spec.as_ref());
                    event = Some(Event::GroundResume);
                }
            }
            Directive::Abandoned { .. } => {
                end = EndReason::Abandoned;
                break;
            }
            Directive::Done => {
                // A model uplink still to come brings a new plan: wait for it.
                let next = pending
                    .iter()
                    .filter(|p| s.ground.changes[p.index].changes_model())
                    .map(|p| p.arrives_us)
                    .min();
                match next {
                    Some(t) if t < horizon => {
                        world.advance(t.max(world.now));
                    }
                    _ => {
                        end = EndReason::Done;
                        break;
                    }
                }
            }
        }
    }
    trace::with(|t| t.end(&world));
    if world.dead {
        end = EndReason::BatteryExhausted;
    }
    let stats = *exec.stats();
    let mut products = std::mem::take(&mut world.sent);
    products.extend(world.stored.iter().cloned());
    Ok(RunResult {
        seed: config.seed,
        utility_milli: realised_of(&products),
        end,
        end_us: world.now,
        battery_start_mj: battery_start,
        battery_end_mj: world.battery_mj,
        dispatched,
        completed,
        failures,
        retries: past.retries + stats.retries,
        replans: past.replans + stats.replans,
        ground_halts: past.ground_halts + stats.ground_halts,
        samples_analyzed: analyzed,
        negatives,
        downlinks: std::mem::take(&mut world.downlinks),
        unsent: world.stored.len() as u32,
        products,
        collections,
        analyses,
        holds_set: world.holds_set,
        holds_released: world.holds_released,
        hold_violations,
        changes: applied,
    })
}

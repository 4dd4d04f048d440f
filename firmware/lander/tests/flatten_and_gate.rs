//! The III.A flattening on the reference RSM-1 model (chains, sums, modes, phases, errors) and
//! the downlink manager's veto in the search (Appendix A: a chain whose data cannot go down is
//! not added).
use fsw_bridge::MissionTimeUs;
use heapless::Vec as HVec;
use lander::capacity::MAX_PLAN_CHAINS;
use lander::downlink::{capacities, Placement, SolAllocation};
use lander::gate::DownlinkGate;
use lander::htn::*;
use lander::rsm1::{self, Rsm1Options, WH_MJ};
use lander::search::{PlacedChain, Search, SearchConfig};
use lander::utility::RankedUtility;

fn flat(fully_autonomous: bool) -> (HtnModel, FlatNetwork) {
    let model = rsm1::model(Rsm1Options::FULL).expect("model fits");
    let net = flatten(&model, FlattenOptions { fully_autonomous }).expect("flattens");
    (model, net)
}

#[test]
fn every_chain_sums_its_primitives() {
    for mode in [false, true] {
        let (model, net) = flat(mode);
        for chain in &net.chains {
            let mut utility = RankedUtility::ZERO;
            let (mut energy, mut duration) = (0, 0);
            for &p in &chain.primitives {
                let spec = &model.primitives[usize::from(p)];
                utility = utility.checked_add(&spec.utility).expect("fits");
                energy += spec.energy_mj;
                duration += spec.duration_us;
            }
            assert_eq!(
                (chain.utility, chain.energy_mj, chain.duration_us),
                (utility, energy, duration)
            );
            let made = chain
                .primitives
                .iter()
                .filter(|&&p| model.primitives[usize::from(p)].product.is_some())
                .count();
            assert_eq!(chain.products.len(), made);
        }
    }
}

#[test]
fn each_sampling_task_flattens_to_raw_and_compressed_chains_in_either_mode() {
    // 6 uplinks + preamble + 9 sampling tasks x 2 + 4 panoramas.
    for mode in [false, true] {
        let (_, net) = flat(mode);
        assert_eq!(net.chains.len(), 6 + 1 + 18 + 4);
        let sampling: Vec<&Chain> = net.chains.iter().filter(|c| c.batch == 2).collect();
        assert_eq!(sampling.len(), 18);
        // With ground in the loop every sampling chain ends with a ground-hold downlink.
        assert!(sampling.iter().all(|c| c.holds_for_ground != mode));
        assert!(sampling.iter().all(|c| c.waits_for_ground_release));
    }
}

#[test]
fn a_decomposition_runs_only_in_its_phases() {
    let (_, net) = flat(true);
    let preamble = net.chains.iter().find(|c| c.task == 1).expect("preamble");
    assert!(preamble.phases.allows(0) && !preamble.phases.allows(1));
    let sample = net.chains.iter().find(|c| c.batch == 2).expect("sampling");
    assert!(sample.phases.allows(1) && !sample.phases.allows(0));
    let timeline = PhaseTimeline::new(&[(MissionTimeUs(100), 1)]).expect("valid");
    assert_eq!(
        timeline.earliest_span(sample.phases, MissionTimeUs(0), 10),
        Some(MissionTimeUs(100))
    );
    assert_eq!(
        timeline.earliest_span(preamble.phases, MissionTimeUs(95), 10),
        None
    );
}

#[test]
fn a_parent_step_must_name_an_earlier_parent() {
    let mut model = rsm1::model(Rsm1Options::FULL).expect("model fits");
    let last = model.parents.len() as u8;
    model.parents[0].decompositions[0].steps[0] = Step::Parent(last - 1);
    assert_eq!(
        flatten(
            &model,
            FlattenOptions {
                fully_autonomous: true
            }
        ),
        Err(FlattenError::ParentOrder { parent: 0, step: 0 })
    );
}

fn plan_of<const N: usize, const Q: usize>(search: &Search<N, Q>) -> Vec<PlacedChain> {
    let mut out: HVec<PlacedChain, MAX_PLAN_CHAINS> = HVec::new();
    search.best_plan(&mut out);
    out.to_vec()
}

#[test]
fn the_gate_refuses_chains_whose_data_cannot_go_down() {
    let (_, net) = flat(true);
    let sols = 6u64;
    let battery = 20_000 * WH_MJ;
    let opportunities = rsm1::opportunities(sols as u16);
    let allocations: Vec<SolAllocation> = (0..sols as u16)
        .map(|sol| SolAllocation {
            sol,
            energy_mj: 400 * WH_MJ,
        })
        .collect();
    let caps = capacities(&opportunities, &allocations).expect("capacities");
    let starts: Vec<MissionTimeUs> = opportunities.iter().map(|o| o.start).collect();
    // Only a third of the capacity: not every sampling chain's data fits.
    let small: Vec<u64> = caps.iter().map(|c| c / 3).collect();
    let config = SearchConfig {
        exploration_bound: Some(300),
        ..SearchConfig::exhaustive(battery)
    };

    let mut free: Search<2_048, 8_192> = Search::new(config);
    free.start(&net, &[]).expect("starts");
    let mut placement = rsm1::placement(sols, battery).expect("placement");
    free.run(&net, &mut placement);

    let mut gate = DownlinkGate::new(
        rsm1::placement(sols, battery).expect("placement"),
        &[],
        &starts,
        &small,
    )
    .expect("gate");
    let mut gated: Search<2_048, 8_192> = Search::new(config);
    gated.start(&net, &[]).expect("starts");
    gated.run(&net, &mut gate);
    assert!(gate.stats.vetoes > 0, "{:?}", gate.stats);

    // The last chain's products go down, and no Critical, Decisional or Mandatory product is
    // left behind (Residual data may give way to more valuable data added later).
    let plan = plan_of(&gated);
    let last = plan.last().expect("something planned");
    let mut check = DownlinkGate::new(
        rsm1::placement(sols, battery).expect("placement"),
        &[],
        &starts,
        &small,
    )
    .expect("gate");
    use lander::search::ChainPlacement;
    assert_eq!(
        check.place(&net, &plan[..plan.len() - 1], last.chain),
        Some(last.start)
    );
    let solution = check.last_solution();
    let n = solution.products().len();
    let own = net.chains[usize::from(last.chain)].products.len();
    for i in n - own..n {
        assert_ne!(
            solution.placement(i),
            Placement::NotDownlinked,
            "product {i}"
        );
    }
    assert_eq!(solution.required_unplaced(), 0);
    // The ungated plan creates more data than the small capacity takes.
    let made = |p: &[PlacedChain]| -> u64 {
        p.iter()
            .flat_map(|x| net.chains[usize::from(x.chain)].products.iter())
            .filter(|d| d.spec.tier != Tier::Residual)
            .map(|d| d.spec.size_bytes)
            .sum()
    };
    assert!(
        made(&plan_of(&free)) > small.iter().sum::<u64>(),
        "the case must need the gate"
    );
    assert!(made(&plan) <= small.iter().sum::<u64>());
}

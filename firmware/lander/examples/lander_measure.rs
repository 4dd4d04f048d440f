//! Host measurements of the lander algorithms (not guest instructions: this runs natively):
//! search explorations and knapsack nodes on the reference RSM-1 model, full RSM-1 replans by
//! the executor (search nodes and the gap to the optimum at each exploration bound), knapsack
//! nodes to the proof on random downlink problems, and the RAM of each structure at its
//! capacity.
//! `cargo run --release -p lander --example lander_measure` (`-- replans`: the replans only)
use fsw_bridge::MissionTimeUs;
use lander::assessor::{chain_science, Assessor, Biosignature, ScienceContext};
use lander::downlink::{
    capacities, DownlinkManager, KnapsackItem, MultipleKnapsack, SolAllocation,
};
use lander::executor::{
    Directive, ExecConfig, Executor, Observation, Strategy, DEFAULT_EXPLORATION_BOUND,
};
use lander::gate::DownlinkGate;
use lander::htn::{flatten, FlattenOptions};
use lander::placement::TimelinePlacement;
use lander::rsm1::{self, Rsm1Options, SOL_US, WH_MJ};
use lander::search::ChainPlacement;
use lander::search::{Search, SearchConfig};
use lander::utility::RankedUtility;

/// Nodes after which a random knapsack problem is counted as not proven.
const KNAPSACK_NODE_CAP: u64 = 5_000_000;

fn main() {
    if std::env::args().any(|a| a == "replans") {
        run_replans();
        return;
    }
    let model = rsm1::model(Rsm1Options::FULL).expect("model");
    let net = flatten(
        &model,
        FlattenOptions {
            fully_autonomous: true,
        },
    )
    .expect("flattens");
    println!(
        "RSM-1 reference model: {} primitives, {} parents, {} chains",
        model.primitives.len(),
        model.parents.len(),
        net.chains.len()
    );
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
    println!("\nsearch (batches: uplinks, preamble, sampling, panoramas), gate with 1/3 of the capacity:");
    println!(
        "{:>10} {:>9} {:>10} {:>8} {:>9} {:>10} {:>12} {:>10}",
        "bound",
        "explored",
        "placements",
        "nodes",
        "overflow",
        "gate chk",
        "knap nodes",
        "max/check"
    );
    for bound in [10u32, 100, 1_000, 10_000] {
        let small: Vec<u64> = caps.iter().map(|c| c / 3).collect();
        let mut gate = DownlinkGate::new(
            rsm1::placement(sols, battery).expect("p"),
            &[],
            &starts,
            &small,
        )
        .expect("gate");
        let mut search: Box<Search<4_096, 16_384>> = Box::new(Search::new(SearchConfig {
            exploration_bound: Some(bound),
            ..SearchConfig::exhaustive(battery)
        }));
        search.start(&net, &[]).expect("starts");
        search.run(&net, &mut gate);
        let s = search.stats();
        println!(
            "{:>10} {:>9} {:>10} {:>8} {:>9} {:>10} {:>12} {:>10}   utility {:?}",
            bound,
            s.explored,
            s.placement_calls,
            s.nodes,
            s.queue_overflows + s.node_overflows,
            gate.stats.checks,
            gate.stats.knapsack_nodes,
            gate.stats.max_knapsack_nodes,
            search.best_value().0.sums()
        );
    }
    run_replans();
    println!("\nknapsack to the proof (at most {KNAPSACK_NODE_CAP} nodes with the surrogate checks), random downlink problems (uncorrelated values, 10 per size):");
    println!(
        "{:>9} {:>6} {:>12} {:>12} {:>13} {:>13} {:>8}",
        "products", "opps", "median nodes", "max nodes", "median +check", "max +check", "proven"
    );
    for (n, m) in [
        (8usize, 4usize),
        (16, 4),
        (24, 4),
        (32, 8),
        (48, 8),
        (64, 16),
    ] {
        let mut nodes = Vec::new();
        let mut work = Vec::new();
        let mut proven = 0;
        for seed in 0..10u64 {
            let mut x = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ (n as u64) << 32;
            let mut next = |lo: u64, hi: u64| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                lo + x % (hi - lo + 1)
            };
            let items: Vec<KnapsackItem> = (0..n)
                .map(|_| {
                    let first = next(0, m as u64 - 1);
                    KnapsackItem {
                        size: next(1, 40) * 1_000_000,
                        value: next(1, 100),
                        allowed: (((1u32 << m) - 1) as u16) & !((1u16 << first) - 1),
                    }
                })
                .collect();
            let total: u64 = items.iter().map(|i| i.size).sum();
            let caps: Vec<u64> = (0..m)
                .map(|_| total / (2 * m as u64) + next(0, 20) * 1_000_000)
                .collect();
            let mut k = MultipleKnapsack::new();
            k.load(&items, &caps).expect("loads");
            while !k.step(1_000_000).done && k.nodes() + k.bound_nodes() < KNAPSACK_NODE_CAP {}
            proven += usize::from(k.proven_optimal());
            nodes.push(k.nodes());
            work.push(k.nodes() + k.bound_nodes());
        }
        nodes.sort();
        work.sort();
        println!(
            "{:>9} {:>6} {:>12} {:>12} {:>13} {:>13} {:>5}/10",
            n, m, nodes[5], nodes[9], work[5], work[9], proven
        );
    }
    println!("\nRAM at capacity (bytes):");
    println!(
        "  Search<1024, 2048> (default)      {}",
        core::mem::size_of::<Search>()
    );
    println!(
        "  Search<4096, 16384>               {}",
        core::mem::size_of::<Search<4_096, 16_384>>()
    );
    println!(
        "  MultipleKnapsack                  {}",
        core::mem::size_of::<MultipleKnapsack>()
    );
    println!(
        "  DownlinkManager                   {}",
        core::mem::size_of::<DownlinkManager>()
    );
    println!(
        "  DownlinkGate<TimelinePlacement>   {}",
        core::mem::size_of::<DownlinkGate<TimelinePlacement>>()
    );
    println!(
        "  Executor<1024, 2048> (default)    {}",
        core::mem::size_of::<Executor>()
    );
    println!(
        "  FlatNetwork                       {}",
        core::mem::size_of::<lander::htn::FlatNetwork>()
    );
    println!(
        "  HtnModel                          {}",
        core::mem::size_of::<lander::htn::HtnModel>()
    );
}

/// The replans run in a thread with a large stack: the reference search holds 60,000 nodes and
/// two million queued pairs. (`lander_measure replans` runs only these.)
fn run_replans() {
    std::thread::Builder::new()
        .stack_size(512 << 20)
        .spawn(replans)
        .expect("thread")
        .join()
        .expect("replans");
}

/// Nodes and queue of the reference search (the largest a `u16` node index allows).
type Reference = Executor<60_000, { 1 << 21 }>;
type Configured = Executor<4_096, 16_384>;

/// Plans from `now` with `battery_mj` and `context`, as a replan does (an executor built at that
/// state makes its plan with the same search, placement and Assessor as a replan), and returns
/// (explorations, nodes, exhaustive, utility, energy).
fn replan<const N: usize, const Q: usize>(
    exec: &mut Executor<N, Q>,
    now: MissionTimeUs,
    battery_mj: u64,
) -> (u32, u32, bool, RankedUtility, u64) {
    let observation = Observation {
        now,
        battery_mj,
        preconditions_met: true,
        event: None,
    };
    while let Directive::Planning { .. } = exec.step(&observation, 100_000) {}
    let s = exec.last_search();
    let (u, e) = exec.last_plan_value();
    (s.explored, s.nodes, s.exhaustive(), u, e)
}

/// The first rank where `a` and `b` differ, and by how much (in 1/10,000 of a score).
fn gap(best: &RankedUtility, found: &RankedUtility) -> String {
    let names = [
        "Mission", "Analysis", "PostColl", "PreColl", "PostExc", "PreExc", "Default",
    ];
    for (k, (x, y)) in best.sums().iter().zip(found.sums()).enumerate() {
        if *x != y {
            return format!("{} {:+}", names[k], i64::from(y) - i64::from(*x));
        }
    }
    "0".to_string()
}

fn replans() {
    let options = Rsm1Options::FULL;
    let model = rsm1::model(options).expect("model");
    let net = flatten(
        &model,
        FlattenOptions {
            fully_autonomous: true,
        },
    )
    .expect("flattens");
    let sols = 6u64;
    println!(
        "\nexecutor RAM: Executor<1024, 2048> (default) {} bytes, Executor<4096, 16384> {} bytes",
        core::mem::size_of::<Executor>(),
        core::mem::size_of::<Configured>()
    );
    let fresh = rsm1::context(options);
    let mut late = fresh.clone();
    for t in 0..2 {
        late.sites[0].targets[t].collected = true;
        late.sites[0].targets[t].biosignature = Some(Biosignature::Positive);
    }
    late.sites[0].post_excavation = late.sites[0]
        .post_excavation
        .or(Some(lander::utility::Score::new(4_000).expect("score")));
    late.sites[1].targets[0].collected = true;
    late.sites[1].targets[0].biosignature = Some(Biosignature::Negative);
    let states: [(&str, MissionTimeUs, u64, &ScienceContext); 3] = [
        (
            "mission start, 20,000 Wh",
            MissionTimeUs::ZERO,
            20_000 * WH_MJ,
            &fresh,
        ),
        (
            "surface ops start (sol 2), 19,800 Wh",
            MissionTimeUs(SOL_US),
            19_800 * WH_MJ,
            &fresh,
        ),
        (
            "sol 3, 3 samples done (site 1 negative), 6,000 Wh",
            MissionTimeUs(2 * SOL_US),
            6_000 * WH_MJ,
            &late,
        ),
    ];
    println!(
        "\nfull RSM-1 replans by the executor (Replan strategy, Assessor placement, fully autonomous, {} sols; configured bound {}):",
        sols, DEFAULT_EXPLORATION_BOUND
    );
    println!(
        "{:<50} {:>10} {:>9} {:>8} {:>10} {:>16} {:>10}",
        "state", "bound", "explored", "nodes", "exhaustive", "gap to best", "energy Wh"
    );
    for (label, now, battery, context) in states {
        let mut timeline = rsm1::placement(sols, 20_000 * WH_MJ).expect("placement");
        timeline.horizon_start = now;
        timeline.battery_mj = battery;
        let mut results = Vec::new();
        for bound in [
            Some(10u32),
            Some(100),
            Some(DEFAULT_EXPLORATION_BOUND),
            Some(10_000),
        ] {
            let config = ExecConfig {
                exploration_bound: bound,
                ..ExecConfig::new(Strategy::Replan)
            };
            let mut exec: Box<Configured> = Box::new(
                Executor::new(config, &model, &net, &timeline, context, None).expect("executor"),
            );
            results.push((bound, replan(&mut exec, now, battery)));
        }
        let config = ExecConfig {
            exploration_bound: None,
            ..ExecConfig::new(Strategy::Replan)
        };
        let mut exec: Box<Reference> = Box::new(
            Executor::new(config, &model, &net, &timeline, context, None).expect("executor"),
        );
        results.push((None, replan(&mut exec, now, battery)));
        let best = results
            .iter()
            .map(|(_, r)| (r.3, std::cmp::Reverse(r.4)))
            .max()
            .expect("results");
        let proven = results.last().is_some_and(|(_, r)| r.2);
        // An upper bound on the optimum: every task at its best alternative that can be placed
        // alone, with the utility the Assessor predicts for it (which the plan's other samples
        // can only forbid, never raise).
        let science = chain_science(&model.primitives, &net);
        let mut per_task: std::collections::BTreeMap<u16, RankedUtility> = Default::default();
        for (i, chain) in net.chains.iter().enumerate() {
            if timeline.clone().place(&net, &[], i as u16).is_none() {
                continue;
            }
            let u = match science[i].sample {
                Some(x) => {
                    match Assessor::default().predict_sample(context, &[], x, science[i].support) {
                        Ok(u) => u.saturating_add(&science[i].other_utility),
                        Err(_) => continue,
                    }
                }
                None => chain.utility,
            };
            let slot = per_task.entry(chain.task).or_default();
            *slot = (*slot).max(u);
        }
        let bound = per_task
            .values()
            .fold(RankedUtility::ZERO, |a, u| a.saturating_add(u));
        for (bound, (explored, nodes, exhaustive, u, e)) in &results {
            println!(
                "{:<50} {:>10} {:>9} {:>8} {:>10} {:>16} {:>10}",
                label,
                bound.map_or("none".to_string(), |b| b.to_string()),
                explored,
                nodes,
                exhaustive,
                gap(&best.0, u),
                e / WH_MJ
            );
        }
        println!(
            "{:<50} best {:?} ({})",
            "",
            best.0.sums(),
            if proven {
                "the optimum: the unbounded search was exhaustive"
            } else {
                "best known: the unbounded search overflowed its capacity"
            }
        );
        println!(
            "{:<50} upper bound {:?}; best's gap to it: {}",
            "",
            bound.sums(),
            gap(&bound, &best.0)
        );
    }
}

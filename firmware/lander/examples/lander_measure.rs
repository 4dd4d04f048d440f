//! Host measurements of the lander algorithms (not guest instructions: this runs natively):
//! search explorations and knapsack nodes on the reference RSM-1 model, knapsack nodes to the
//! proof on random downlink problems, and the RAM of each structure at its capacity.
//! `cargo run --release -p lander --example lander_measure`
use fsw_bridge::MissionTimeUs;
use lander::downlink::{
    capacities, DownlinkManager, KnapsackItem, MultipleKnapsack, SolAllocation,
};
use lander::gate::DownlinkGate;
use lander::htn::{flatten, FlattenOptions};
use lander::placement::TimelinePlacement;
use lander::rsm1::{self, Rsm1Options, WH_MJ};
use lander::search::{Search, SearchConfig};

/// Nodes after which a random knapsack problem is counted as not proven.
const KNAPSACK_NODE_CAP: u64 = 5_000_000;

fn main() {
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
        "  FlatNetwork                       {}",
        core::mem::size_of::<lander::htn::FlatNetwork>()
    );
    println!(
        "  HtnModel                          {}",
        core::mem::size_of::<lander::htn::HtnModel>()
    );
}

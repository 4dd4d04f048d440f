//! The temporal planner's search on the benchmark instances, natively, in the target's 8 MiB
//! arena: per instance the outcome, expansions, evaluations, plan actions and a proxy for the
//! target's cost (evaluations x ground actions, which the heuristic's work follows). For
//! comparing search changes quickly; `scripts/bench-planners.py` is the benchmark.
//!
//!     [ARENA_KIB=N] [END_CHECK=0|1|2] [NOVELTY_PHASES=MASK] [COMMIT=MASK,AFTER,THIRD] [FIRST_COMMIT=N] [FIRST_GIVES_WAY=N] [TRACE=1] cargo run --release -p pddl --example search_sweep -- [BENCH_DIR] [DOMAINS] [FIRST-LAST] [MAX_EXPANSIONS]
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let bench = args
        .get(1)
        .cloned()
        .unwrap_or_else(|| "../shared/benchmarks/pddl".into());
    let domains = args
        .get(2)
        .cloned()
        .unwrap_or_else(|| "satellite,rovers,driverlog".into());
    let range = args.get(3).cloned().unwrap_or_else(|| "1-20".into());
    let (lo, hi) = range
        .split_once('-')
        .map(|(a, b)| (a.parse().unwrap_or(1), b.parse().unwrap_or(20)))
        .unwrap_or((1, 20));
    let cap: u64 = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(50_000);
    // ARENA_KIB: another arena size (the target's is 8192).
    let kib: usize = std::env::var("ARENA_KIB")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(8192);
    let mut arena = vec![0u32; kib * 256];
    let mut total_work = 0u64;
    for dom in domains.split(',') {
        let folder = format!("{bench}/{}", folder_of(dom));
        let domain = std::fs::read_to_string(format!("{folder}/domain.pddl")).expect("domain");
        for i in lo..=hi {
            let problem = std::fs::read_to_string(format!("{folder}/instances/instance-{i}.pddl"))
                .expect("problem");
            let compiled = pddl::compile(
                pddl::Source {
                    name: "domain.pddl",
                    text: &domain,
                },
                pddl::Source {
                    name: "problem.pddl",
                    text: &problem,
                },
                &pddl::ModuleRegistry::default(),
                &pddl::Options::default(),
            )
            .expect("compiles");
            let task = temporal::Task::parse(&compiled.task).expect("valid");
            let actions = task.action_count() as u64;
            let started = Instant::now();
            arena.iter_mut().for_each(|w| *w = 0);
            let mut planner = temporal::Planner::new_deferred(
                task,
                &mut arena,
                temporal::PlannerConfig::default(),
            )
            .expect("fits");
            // NOVELTY_PHASES: which searches of the portfolio order by novelty (bit p: search p).
            if let Some(mask) = std::env::var("NOVELTY_PHASES")
                .ok()
                .and_then(|s| s.parse().ok())
            {
                planner.set_novelty_phases(mask);
            }
            // LOOKAHEAD_PHASES: which searches look ahead along the relaxed plan (bit p: search p).
            if let Some(mask) = std::env::var("LOOKAHEAD_PHASES")
                .ok()
                .and_then(|s| s.parse().ok())
            {
                planner.set_lookahead_phases(mask);
            }
            if let Some(n) = std::env::var("LOOKAHEAD_AFTER")
                .ok()
                .and_then(|s| s.parse().ok())
            {
                planner.set_lookahead_after(n);
            }
            // COMMIT=MASK,AFTER,THIRD: which searches commit to their best node, after how many
            // expansions without progress, and the third search's stall limit.
            if let Ok(k) = std::env::var("COMMIT") {
                let k: Vec<&str> = k.split(',').collect();
                let num = |i: usize| k.get(i).and_then(|s| s.parse().ok()).unwrap_or(u64::MAX);
                planner.set_commit(num(0) as u8, num(1), num(2));
            }
            // FIRST_COMMIT=N: the first search commits to its best node after N expansions
            // without a new best h.
            if let Some(n) = std::env::var("FIRST_COMMIT")
                .ok()
                .and_then(|s| s.parse().ok())
            {
                planner.set_first_commit_after(n);
            }
            // FIRST_GIVES_WAY=N: the first search gives way after N expansions without a new
            // best h (instead of 500).
            if let Some(n) = std::env::var("FIRST_GIVES_WAY")
                .ok()
                .and_then(|s| s.parse().ok())
            {
                planner.set_first_gives_way_after(n);
            }
            // END_CHECK=0|1|2: drop successors whose running actions can no longer end in time
            // in no task, in tasks without windows (the default), in every task.
            if let Some(k) = std::env::var("END_CHECK")
                .ok()
                .and_then(|s| s.parse::<u8>().ok())
            {
                use temporal::search::RunningEnds;
                let which = [
                    RunningEnds::Off,
                    RunningEnds::WithoutWindows,
                    RunningEnds::Always,
                ];
                planner.set_check_running_ends(which[usize::from(k.min(2))]);
            }
            let trace = std::env::var("TRACE").is_ok();
            let mut last = (u32::MAX, u64::MAX, u64::MAX);
            let status = loop {
                let s = planner.step(256);
                let st = planner.stats();
                let now = (st.best_h, st.restarts, planner.commits());
                if trace && now != last {
                    last = now;
                    eprintln!(
                        "  expanded {} evaluated {} restarts {} commits {} best h {} {:.1} s",
                        st.expanded,
                        st.evaluated,
                        now.1,
                        now.2,
                        now.0,
                        started.elapsed().as_secs_f64()
                    );
                }
                if s != temporal::Status::Searching || planner.stats().expanded >= cap {
                    break s;
                }
            };
            let stats = planner.stats();
            let mut out = vec![temporal::PlannedAction::default(); 1024];
            let (len, makespan) = planner.plan(&mut out).unwrap_or((0, 0));
            // The search's plan before the elimination (`temporal`'s eliminate.rs).
            let found_len = len as u64 + stats.eliminated;
            let found_makespan = planner.makespan_before_elimination().unwrap_or(makespan);
            let work = stats.evaluated * actions;
            total_work += work;
            println!(
                "{dom} {i}: {status:?} actions {actions} expanded {} evaluated {} restarts {} lookahead {} commits {} plan {found_len} makespan {found_makespan} eliminated to {len} makespan {makespan} checks {} inconsistent {} duplicates {} work {:.1}M peak {} KiB {:.2} s late ends {}",
                stats.expanded,
                stats.evaluated,
                stats.restarts,
                stats.lookahead_steps,
                planner.commits(),
                stats.elimination_checks,
                stats.inconsistent,
                stats.duplicates,
                work as f64 / 1e6,
                stats.peak_words * 4 / 1024,
                started.elapsed().as_secs_f64(),
                planner.late_ends()
            );
        }
    }
    println!("total work {:.1}M", total_work as f64 / 1e6);
}

/// The benchmark folder of a domain's short name: crew planning and pipesworld are named
/// after their IPC tracks, the others `{dom}-time-simple-automatic`.
fn folder_of(dom: &str) -> String {
    match dom {
        "crew" => "crew-planning-temporal-satisficing-strips".into(),
        "pipesworld" => "pipesworld-no-tankage-temporal-deadlines-strips".into(),
        _ => format!("{dom}-time-simple-automatic"),
    }
}

//! Temporary: trace best h over expansions for one instance.
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let folder = format!("{}/{}-time-simple-automatic", a[1], a[2]);
    let domain = std::fs::read_to_string(format!("{folder}/domain.pddl")).unwrap();
    let problem = std::fs::read_to_string(format!("{folder}/instances/instance-{}.pddl", a[3])).unwrap();
    let compiled = pddl::compile(
        pddl::Source { name: "d", text: &domain },
        pddl::Source { name: "p", text: &problem },
        &pddl::ModuleRegistry::default(),
        &pddl::Options::default(),
    ).unwrap();
    let task = temporal::Task::parse(&compiled.task).unwrap();
    let mut arena = vec![0u32; 8 << 18];
    let mut p = temporal::Planner::new(task, &mut arena, temporal::PlannerConfig::default()).unwrap();
    if let Ok(c) = std::env::var("CLIMB") {
        let (w, l) = c.split_once(',').unwrap();
        p.set_climb(w.parse().unwrap(), l.parse().unwrap());
    }
    let cap: u64 = a.get(4).and_then(|s| s.parse().ok()).unwrap_or(20000);
    let mut last = (u32::MAX, 0u64);
    loop {
        let s = p.step(1);
        let st = p.stats();
        if (st.best_h, st.restarts) != (last.0, last.1) {
            println!("exp {} eval {} h {} restarts {} gen {} dup {} incons {} dead {}", st.expanded, st.evaluated, st.best_h, st.restarts, st.generated, st.duplicates, st.inconsistent, st.dead_ends);
            last = (st.best_h, st.restarts);
        }
        if s != temporal::Status::Searching || st.expanded >= cap { println!("{s:?} {st:?}"); break; }
    }
}

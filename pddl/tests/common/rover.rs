//! The shipped rover scenario's task for the replanning and dispatch tests: the domain with the
//! path estimate written in as a static function, planned by the `no_std` planner.

use temporal::{PlannedAction, Planner, PlannerConfig, Status, Task};

/// The shipped rover domain with the path estimate's numbers written in as a static function
/// (the validator does not load modules): the same task the scenario plans.
pub fn rover() -> (String, String) {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/rover/");
    let domain = std::fs::read_to_string(format!("{root}domain.pddl")).expect("domain");
    let problem = std::fs::read_to_string(format!("{root}problem.pddl")).expect("problem");
    let domain = domain
        .replace(
            "(:modules (:module path_estimate (:function (traverse-time ?from ?to - waypoint))))",
            "",
        )
        .replace(
            "(:functions (energy ?r - rover))",
            "(:functions (energy ?r - rover) (traverse-time ?from ?to - waypoint))",
        );
    let pos: [(&str, f64, f64); 6] = [
        ("w0", 0.0, 0.0),
        ("w1", 60.0, 0.0),
        ("w2", 120.0, 20.0),
        ("w3", 80.0, 80.0),
        ("w4", 80.0, 200.0),
        ("w5", 80.0, 330.0),
    ];
    let mut times = String::new();
    for (a, xa, ya) in pos {
        for (b, xb, yb) in pos {
            let d: f64 = ((xa - xb) * (xa - xb) + (ya - yb) * (ya - yb)).sqrt() / 0.5;
            times.push_str(&format!("(= (traverse-time {a} {b}) {:.0})\n", d.round()));
        }
    }
    let problem = problem.replace(
        "(= (energy r0) 100)",
        &format!("(= (energy r0) 100)\n{times}"),
    );
    (domain, problem)
}

pub fn plan_task(task: Task<'_>) -> Option<Vec<PlannedAction>> {
    let mut arena = vec![0u32; 1 << 21];
    let mut planner = Planner::new(task, &mut arena, PlannerConfig::default()).expect("arena");
    let status = loop {
        let s = planner.step(64);
        if s != Status::Searching || planner.stats().expanded > 50_000 {
            break s;
        }
    };
    if status != Status::Solved {
        return None;
    }
    let mut out = vec![PlannedAction::default(); 256];
    let (n, _) = planner.plan(&mut out)?;
    out.truncate(n);
    Some(out)
}

/// The rover's problem made long (issue 13 item 3): `objectives` objectives to image and send
/// in one long window.
pub fn long_rover(objectives: usize) -> (String, String) {
    let (d, p) = rover();
    let names: Vec<String> = (1..=objectives).map(|i| format!("o{i}")).collect();
    let visible: String = names
        .iter()
        .enumerate()
        .map(|(i, o)| format!("(visible-from {o} w{})", 1 + i % 5))
        .collect::<Vec<_>>()
        .join(" ");
    let goals: String = names
        .iter()
        .map(|o| format!("(image-sent {o})"))
        .collect::<Vec<_>>()
        .join(" ");
    let p = p
        .replace(
            "o1 o2 o3 o4 - objective",
            &format!("{} - objective", names.join(" ")),
        )
        .replace(
            "(visible-from o1 w1) (visible-from o2 w3) (visible-from o3 w2) (visible-from o4 w5)",
            &visible,
        )
        .replace(
            "(at 900 (not (comm-open c1)))",
            "(at 5400 (not (comm-open c1)))",
        )
        .replace(
            "(:goal (and (image-sent o1) (rock-sent w2) (image-sent o2)))",
            &format!("(:goal (and {goals}))"),
        );
    (d, p)
}

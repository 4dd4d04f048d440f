//! `hil bench planner`: the planner cycle's cost against network size (issue 14), measured
//! natively in validity checks (the planner's own unit of work, the same number on every host
//! and on the target), with the growth exponent, and what such a network costs to carry: its
//! uplink and the checkpoint of its planned state, against [`flight_app::MAX_UPLINK_BYTES`]
//! and a checkpoint slot of the warm-restart area.
//!
//! The networks are [`autonomy::scenarios::synthetic_into`]'s, deterministic: `n` tasks
//! contending for 8 resources, two constraints and three impacts each, all inside the
//! scheduling window, so the first cycle places every one of them.
use serde::Serialize;

use autonomy::scenarios::{synthetic_into, SyntheticShape};
use autonomy::{
    Autonomy, CommandArgs, NetworkSpec, Opcode, Outputs, PlannerConfig, StepBudget, TaskState,
    TelemetryEvent, WarmRestartArea,
};

/// The sizes `hil bench planner` measures.
pub const SIZES: [usize; 4] = [8, 32, 128, 256];

/// One network size.
#[derive(Clone, Debug, Serialize)]
pub struct PlannerPoint {
    pub tasks: usize,
    /// Validity checks of the first planner cycle (every task scheduled).
    pub checks: u32,
    pub checks_per_task: f64,
    /// Instances the cycle placed (all of them, or the cycle is reported as not finished).
    pub placed: usize,
    /// The cycle ended in one step (unlimited budget).
    pub finished: bool,
    /// Bytes of the network in the uplink format.
    pub uplink_bytes: usize,
    /// Bytes of the checkpoint payload after the cycle (network, plan, executive, states).
    pub checkpoint_bytes: usize,
    /// Candidate lists that overflowed [`autonomy::MAX_CANDIDATES`].
    pub candidate_overflows: u32,
}

#[derive(Clone, Debug, Serialize)]
pub struct PlannerBench {
    pub points: Vec<PlannerPoint>,
    /// Least-squares slope of ln(checks) against ln(tasks): checks grow as tasks^exponent.
    pub growth_exponent: f64,
    /// The uplink buffer of the flight application.
    pub max_uplink_bytes: usize,
    /// Largest checkpoint payload one slot of the warm-restart area holds.
    pub checkpoint_capacity: usize,
}

struct Sink;

impl Outputs for Sink {
    fn dispatch(&mut self, _: u32, _: Opcode, _: &CommandArgs) {}
    fn telemetry(&mut self, _: TelemetryEvent) {}
}

/// The largest checkpoint payload one slot of the flight application's checkpoint memory holds
/// (the executive partition's slice of the warm-restart area).
pub fn checkpoint_capacity() -> usize {
    let area = kernel_config::system::EXECUTIVE_WARM.len as usize;
    let mut bytes = vec![0u8; area];
    WarmRestartArea::new(&mut bytes).payload_capacity()
}

/// Measures one network of `tasks` tasks.
pub fn measure(tasks: usize) -> Result<PlannerPoint, String> {
    let mut spec = Box::new(NetworkSpec::new(0, PlannerConfig::DEFAULT));
    synthetic_into(&mut spec, SyntheticShape::bench(tasks))
        .map_err(|_| format!("a synthetic network of {tasks} tasks is over a capacity"))?;
    let mut uplink = vec![0u8; 1 << 21];
    let uplink_bytes = autonomy::uplink::encode_spec(&spec, &mut uplink)
        .map_err(|_| "uplink buffer too small".to_string())?;
    let mut core: Box<Autonomy> = new_core();
    core.load_uplink(&uplink[..uplink_bytes])
        .map_err(|e| format!("{tasks} tasks refused: {e:?}"))?;
    let report = core.step(
        autonomy::MissionTimeUs::ZERO,
        StepBudget::UNLIMITED,
        &mut Sink,
    );
    let placed = core
        .plan()
        .iter()
        .filter(|e| matches!(e.state, TaskState::Scheduled | TaskState::Committed))
        .count();
    let mut state = vec![0u8; 1 << 21];
    let checkpoint_bytes = core
        .encode_state(&mut state)
        .ok_or("checkpoint buffer too small")?;
    Ok(PlannerPoint {
        tasks,
        checks: report.planner_checks,
        checks_per_task: f64::from(report.planner_checks) / tasks as f64,
        placed,
        finished: !report.planner_pending,
        uplink_bytes,
        checkpoint_bytes,
        candidate_overflows: core.planner().stats.candidate_overflows,
    })
}

fn new_core() -> Box<Autonomy> {
    // Autonomy is about half a megabyte at the lander capacities: built in place on the heap.
    let mut core: Box<std::mem::MaybeUninit<Autonomy>> = Box::new_uninit();
    core.write(Autonomy::new());
    // SAFETY: just initialised.
    unsafe { core.assume_init() }
}

/// The least-squares slope of ln(y) against ln(x).
pub fn growth_exponent(points: &[(f64, f64)]) -> f64 {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let n = logs.len() as f64;
    if logs.len() < 2 {
        return f64::NAN;
    }
    let (sx, sy) = logs
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    let (mx, my) = (sx / n, sy / n);
    let (num, den) = logs.iter().fold((0.0, 0.0), |(num, den), (x, y)| {
        (num + (x - mx) * (y - my), den + (x - mx) * (x - mx))
    });
    num / den
}

/// Measures every size of [`SIZES`].
pub fn planner(sizes: &[usize]) -> Result<PlannerBench, String> {
    let points = sizes
        .iter()
        .map(|&n| measure(n))
        .collect::<Result<Vec<_>, _>>()?;
    let growth = growth_exponent(
        &points
            .iter()
            .map(|p| (p.tasks as f64, f64::from(p.checks)))
            .collect::<Vec<_>>(),
    );
    Ok(PlannerBench {
        points,
        growth_exponent: growth,
        max_uplink_bytes: flight_app::MAX_UPLINK_BYTES,
        checkpoint_capacity: checkpoint_capacity(),
    })
}

/// The table `hil bench planner` prints (Markdown, as in the README).
pub fn table(b: &PlannerBench) -> String {
    let mut s = String::from(
        "planner cycle against network size (native; synthetic networks, first cycle schedules every task)\n\n\
         | tasks | validity checks | checks per task | placed | uplink bytes | checkpoint bytes |\n\
         |---:|---:|---:|---:|---:|---:|\n",
    );
    for p in &b.points {
        let over = |bytes: usize, cap: usize| if bytes > cap { " (over)" } else { "" };
        s += &format!(
            "| {} | {} | {:.1} | {}{} | {}{} | {}{} |\n",
            p.tasks,
            p.checks,
            p.checks_per_task,
            p.placed,
            if p.finished {
                ""
            } else {
                " (cycle not finished)"
            },
            p.uplink_bytes,
            over(p.uplink_bytes, b.max_uplink_bytes),
            p.checkpoint_bytes,
            over(p.checkpoint_bytes, b.checkpoint_capacity),
        );
    }
    s += &format!(
        "\ngrowth exponent (checks ~ tasks^k, least squares): k = {:.2}\n\
         uplink buffer {} bytes; checkpoint slot {} bytes (\"(over)\": does not fit, refused or counted)\n",
        b.growth_exponent, b.max_uplink_bytes, b.checkpoint_capacity
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_growth_exponent_of_a_power_law_is_its_power() {
        let cubic: Vec<(f64, f64)> = [2.0, 4.0, 8.0, 16.0]
            .iter()
            .map(|&x| (x, x * x * x))
            .collect();
        assert!((growth_exponent(&cubic) - 3.0).abs() < 1e-9);
        let linear: Vec<(f64, f64)> = [8.0, 32.0].iter().map(|&x| (x, 5.0 * x)).collect();
        assert!((growth_exponent(&linear) - 1.0).abs() < 1e-9);
        assert!(growth_exponent(&[(8.0, 1.0)]).is_nan());
    }

    #[test]
    fn every_size_is_planned_in_one_cycle_and_costs_more_than_the_smaller() {
        let b = planner(&[8, 32]).unwrap();
        for p in &b.points {
            assert!(p.finished && p.placed == p.tasks, "{p:?}");
            assert!(p.uplink_bytes > 0 && p.checkpoint_bytes > p.uplink_bytes);
        }
        assert!(b.points[1].checks > b.points[0].checks);
        assert!(b.growth_exponent >= 1.0, "{}", b.growth_exponent);
        // Deterministic: the same network costs the same checks.
        assert_eq!(measure(8).unwrap().checks, b.points[0].checks);
        assert!(table(&b).contains("| 32 |"));
    }
}

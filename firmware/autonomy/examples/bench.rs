//! Host timings of the flyby workload and the static size of each structure at the configured
//! capacities: `cargo run --release -p autonomy --example bench`. On the target the same
//! operations are to be counted in guest instructions under icount (not done here).
#[path = "../tests/common/mod.rs"]
mod common;

use std::time::Instant;

use autonomy::executive::Executive;
use autonomy::planner::Planner;
use autonomy::*;
use common::*;

struct Sink;
impl Outputs for Sink {
    fn dispatch(&mut self, _: u32, _: Opcode, _: &CommandArgs) {}
    fn telemetry(&mut self, _: TelemetryEvent) {}
}

fn time<R>(
    label: &str,
    iterations: u32,
    mut setup: impl FnMut() -> R,
    mut run: impl FnMut(&mut R),
) {
    let mut total = std::time::Duration::ZERO;
    for _ in 0..iterations {
        let mut state = setup();
        let t = Instant::now();
        run(&mut state);
        total += t.elapsed();
    }
    println!(
        "{label:<44} {:>9.1} us",
        total.as_secs_f64() * 1e6 / f64::from(iterations)
    );
}

fn main() {
    let n = 200;
    let network = flyby_network();

    time(
        "planner cycle: schedule the flyby plan",
        n,
        || {
            let mut a = Box::new(Autonomy::new());
            a.load_network(network.clone()).unwrap();
            a.on_state_update(ATTITUDE_KEY, StateValue::Enum(INERTIAL), hm(9, 50));
            a
        },
        |a| {
            a.step(hm(9, 50), StepBudget::UNLIMITED, &mut Sink);
        },
    );

    // The warm-restart area as it is at the early reset (10:30).
    let mut sim = Sim::flyby();
    sim.run(hm(10, 29), &[]);
    let area_at_reset = sim.area.clone();
    let mut checks = 0;
    time(
        "recovery after the early reset (restore+step)",
        n,
        || (Box::new(Autonomy::new()), area_at_reset.clone()),
        |(a, bytes)| {
            let area = WarmRestartArea::new(bytes);
            a.restore_from(&area).unwrap();
            a.on_state_update(ATTITUDE_KEY, StateValue::Enum(UNKNOWN), hm(10, 30));
            checks = a
                .step(hm(10, 33), StepBudget::UNLIMITED, &mut Sink)
                .planner_checks;
        },
    );
    println!("  (planner validity checks in the recovery step: {checks})");
    time(
        "repair only (step after restore)",
        n,
        || {
            let mut bytes = area_at_reset.clone();
            let mut a = Box::new(Autonomy::new());
            a.restore_from(&WarmRestartArea::new(&mut bytes)).unwrap();
            a.on_state_update(ATTITUDE_KEY, StateValue::Enum(UNKNOWN), hm(10, 30));
            a
        },
        |a| {
            a.step(hm(10, 33), StepBudget::UNLIMITED, &mut Sink);
        },
    );

    let mut quiet = Sim::flyby();
    quiet.run(hm(10, 40), &[]);
    let quiet_bytes = quiet.area.clone();
    time(
        "executive cycle (quiet step at 10:40)",
        n,
        || {
            let mut bytes = quiet_bytes.clone();
            let mut a = Box::new(Autonomy::new());
            a.restore_from(&WarmRestartArea::new(&mut bytes)).unwrap();
            a.step(hm(10, 40), StepBudget::UNLIMITED, &mut Sink);
            a
        },
        |a| {
            a.step(hm(10, 41), StepBudget::UNLIMITED, &mut Sink);
        },
    );

    let mut payload = 0;
    time(
        "checkpoint write (flyby at 10:29)",
        n,
        || vec![0u8; WARM_AREA_LEN],
        |bytes| {
            let mut area = WarmRestartArea::new(bytes);
            sim.autonomy.checkpoint_to(&mut area).unwrap();
            payload = area.latest().unwrap().2.len();
        },
    );
    println!(
        "  (checkpoint payload: {payload} bytes; record header: {} bytes)",
        checkpoint::RECORD_HEADER_LEN
    );
    time(
        "checkpoint restore (validate + decode)",
        n,
        || (Box::new(Autonomy::new()), area_at_reset.clone()),
        |(a, bytes)| {
            a.restore_from(&WarmRestartArea::new(bytes)).unwrap();
        },
    );
    let mut uplink = vec![0u8; 1 << 16];
    let uplink_len = network.encode(&mut uplink).unwrap();
    uplink.truncate(uplink_len);
    time(
        "uplink validate + load (flyby)",
        n,
        || Box::new(Autonomy::new()),
        |a| a.load_uplink(&uplink).unwrap(),
    );
    println!("  (flyby uplink: {uplink_len} bytes)");

    println!("\nstatic sizes at the configured capacities (bytes):");
    for (name, size) in [
        ("Autonomy", std::mem::size_of::<Autonomy>()),
        ("TaskNetwork", std::mem::size_of::<TaskNetwork>()),
        ("TaskSpec (one task)", std::mem::size_of::<TaskSpec>()),
        ("Planner", std::mem::size_of::<Planner>()),
        (
            "plan::PlanEntry",
            std::mem::size_of::<autonomy::plan::PlanEntry>(),
        ),
        ("Executive", std::mem::size_of::<Executive>()),
        (
            "condition::StateTable",
            std::mem::size_of::<autonomy::condition::StateTable>(),
        ),
    ] {
        println!("  {name:<28} {size:>7}");
    }
}

//! The RAM of each autonomy structure at its capacity (issue 14 item 6), against the partition
//! regions it lives in. Every structure is fixed-size (heapless lists), so `size_of` is its RAM
//! whatever it holds. Measured on the host (64-bit: `usize` is 8 bytes, 4 on the 32-bit target,
//! so these are upper bounds within a few bytes per list); the image's own sections are the
//! target's truth (`static_ram_*` in `budgets.toml`, checked on QEMU by `--test budgets`).
//!
//! Run with `--nocapture` to print the README's table.
use std::mem::size_of;

use autonomy::condition::StateTable;
use autonomy::executive::Executive;
use autonomy::partitioned::{ExecutivePartition, PlannerPartition};
use autonomy::planner::Planner;
use autonomy::{Autonomy, ControlLoop, TaskNetwork, TaskSpec};
use flight_app::FlightApp;
use kernel_config::system::{EXECUTIVE_REGION, PLANNER_REGION, PRODUCT as SYSTEM};

/// Room each partition keeps beyond its state: the flight application's I/O state in the
/// executive (two 64 KiB memory copies, queues) and code-side statics, and headroom for
/// growth. A quarter of the region.
const HEADROOM_DIVISOR: usize = 4;

fn stack_of(name: &str) -> usize {
    SYSTEM
        .partitions
        .iter()
        .find(|p| p.name == name)
        .map(|p| p.stack_size as usize)
        .unwrap()
}

fn sizes() -> Vec<(&'static str, usize)> {
    vec![
        ("TaskSpec", size_of::<TaskSpec>()),
        ("TaskNetwork", size_of::<TaskNetwork>()),
        ("Planner", size_of::<Planner>()),
        ("Executive", size_of::<Executive>()),
        ("StateTable", size_of::<StateTable>()),
        ("ControlLoop", size_of::<ControlLoop>()),
        ("Autonomy", size_of::<Autonomy>()),
        ("FlightApp", size_of::<FlightApp>()),
        ("ExecutivePartition", size_of::<ExecutivePartition>()),
        ("PlannerPartition", size_of::<PlannerPartition>()),
    ]
}

#[test]
fn print_the_ram_table() {
    println!("| structure | bytes | KiB |");
    println!("|---|---:|---:|");
    for (name, bytes) in sizes() {
        println!("| `{name}` | {bytes} | {:.1} |", bytes as f64 / 1024.0);
    }
    println!(
        "| executive region | {} | stack {} |",
        EXECUTIVE_REGION.size,
        stack_of("executive")
    );
    println!(
        "| planner region | {} | stack {} |",
        PLANNER_REGION.size,
        stack_of("planner")
    );
    // The table has every structure and none is empty.
    assert!(sizes().iter().all(|&(_, b)| b > 0));
}

/// The executive partition holds the flight application (the autonomy core as one partition,
/// today's image) or, once the planner moves out, the executive half of the two-partition
/// split; with its stack and a quarter of the region to spare.
#[test]
fn the_executive_partition_state_fits_its_region_with_headroom() {
    let region = EXECUTIVE_REGION.size as usize;
    let stack = stack_of("executive");
    let room = region - stack - region / HEADROOM_DIVISOR;
    let app = size_of::<FlightApp>();
    let split = size_of::<ExecutivePartition>();
    assert!(
        app <= room,
        "FlightApp is {app} bytes; the executive region ({region}) less its stack ({stack}) and a quarter leaves {room}"
    );
    assert!(
        split <= room,
        "ExecutivePartition is {split} bytes > {room}"
    );
}

/// The planner partition holds the planner half (its network and planner) with its stack and a
/// quarter of the region to spare.
#[test]
fn the_planner_partition_state_fits_its_region_with_headroom() {
    let region = PLANNER_REGION.size as usize;
    let stack = stack_of("planner");
    let room = region - stack - region / HEADROOM_DIVISOR;
    let planner = size_of::<PlannerPartition>();
    assert!(
        planner <= room,
        "PlannerPartition is {planner} bytes; the planner region ({region}) less its stack ({stack}) and a quarter leaves {room}"
    );
}

/// Nothing of a partition's size may be built on a partition's stack: the structures that the
/// firmware keeps in statics are each larger than a stack, so a by-value copy of one would
/// overflow it. This pins which ones (the firmware handles them in place: `decode_into`,
/// `reset`, `zeroed_state`), so that a new by-value use is a deliberate decision.
#[test]
fn the_large_structures_do_not_fit_a_partition_stack() {
    let stack = stack_of("executive").min(stack_of("planner"));
    for (name, bytes) in [
        ("TaskNetwork", size_of::<TaskNetwork>()),
        ("Autonomy", size_of::<Autonomy>()),
        ("FlightApp", size_of::<FlightApp>()),
    ] {
        assert!(
            bytes > stack,
            "{name} ({bytes}) now fits a {stack}-byte stack"
        );
    }
    // One task definition is what the uplink validator holds on the stack at a time.
    assert!(size_of::<TaskSpec>() * 4 < stack);
}

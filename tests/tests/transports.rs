//! The emulated target's two link transports give the same missions: the same scenario over the
//! serial line (as on a real board) and over the shared-memory link gives the same transcript
//! (hash), the same decisions and the same guest costs (to within the README's tick per span),
//! except that every boot's kernel part also finds and maps the link device. The firmware is
//! the same image on both; only the host's QEMU profile differs.
use std::path::{Path, PathBuf};

use hil::mission::report::MissionReport;
use hil::mission::runner::{prepare, run};
use hil::mission::target::EmulatedTarget;
use hil::qemu::Transport;
use hil_tests::{firmware, profile_over};

fn scenario(name: &str) -> PathBuf {
    hil::repo_root().join("scenarios").join(name)
}

fn run_over(transport: Transport, path: &Path) -> MissionReport {
    let _one = hil_tests::exclusive_qemu();
    let prepared = prepare(path).unwrap_or_else(|e| panic!("{e}"));
    let mut target = EmulatedTarget::with_temporary_nv(
        profile_over(transport),
        firmware().clone(),
        false,
        false,
    )
    .unwrap();
    run(&prepared, &mut target, Some(firmware()), &mut |_, _, _| {})
        .unwrap_or_else(|e| panic!("{} over {}: {e}", path.display(), transport.name()))
}

/// Resets through QMP and over the link, a power cycle (a new QEMU, the plan from non-volatile
/// memory) and frames corrupted on purpose: everything that touches the link's transport.
const SCENARIOS: [&str; 3] = [
    "flyby-two-resets.toml",
    "flyby-power-cycle.toml",
    "flyby-link-corruption.toml",
];

#[test]
fn missions_give_the_same_transcript_decisions_and_costs_over_both_transports() {
    for name in SCENARIOS {
        let path = scenario(name);
        let serial = run_over(Transport::Serial, &path);
        let shared = run_over(Transport::SharedMemory, &path);
        assert!(serial.passed && shared.passed, "{name}");
        if serial.transcript_sha256 != shared.transcript_sha256 {
            let first = serial
                .transcript
                .iter()
                .zip(&shared.transcript)
                .position(|(x, y)| x != y)
                .unwrap_or(serial.transcript.len().min(shared.transcript.len()));
            let window =
                |t: &[String]| t[first.saturating_sub(3)..(first + 8).min(t.len())].join("\n");
            panic!(
                "{name}: the transcripts differ from frame {first} on:\nserial:\n{}\nshared memory:\n{}",
                window(&serial.transcript),
                window(&shared.transcript)
            );
        }
        assert_eq!(serial.decisions, shared.decisions, "{name}");
        // The boards differ by one device: the kernel's boot finds and maps the shared-memory
        // link device too. That is the only difference in the boot; the executive's part of boot
        // to ready (restoring the plan) is the same.
        assert_eq!(serial.boots.len(), shared.boots.len(), "{name}");
        let kernel_part = |r: &MissionReport, i: usize| r.boots[i].kernel_boot_ticks.unwrap();
        let executive_part = |r: &MissionReport, i: usize| {
            r.boots[i].boot_to_ready_ticks.unwrap() - kernel_part(r, i)
        };
        let device_setup = kernel_part(&shared, 0) as i64 - kernel_part(&serial, 0) as i64;
        assert!(
            (1..200).contains(&device_setup),
            "{name}: the link device's set-up took {device_setup} ticks of the kernel's boot"
        );
        // The set-up is the same at every boot: each side of the difference is a tick reading
        // that can straddle one tick, so the difference may move by two (measured at warm
        // boots: 70 to 72 ticks against 72 at power-on).
        for i in 0..serial.boots.len() {
            let kernel = kernel_part(&shared, i) as i64 - kernel_part(&serial, i) as i64;
            assert!(
                kernel.abs_diff(device_setup) <= 2,
                "{name}: boot {i}: the link device's set-up took {kernel} ticks, {device_setup} at the first boot"
            );
            assert!(
                executive_part(&serial, i).abs_diff(executive_part(&shared, i)) <= 1,
                "{name}: boot {i}: the executive's part is {} ticks over serial, {} over shared memory",
                executive_part(&serial, i),
                executive_part(&shared, i)
            );
        }
        // The link's Mission traffic is the same frame for frame, so are its faults and
        // retransmissions. The Instrument channel carries the kernel's log (whose boot lines
        // name the link device) and cost metrics, so its traffic, and the faults it meets,
        // differ between the boards.
        assert_eq!(
            hil_tests::mission_link_figures(&serial),
            hil_tests::mission_link_figures(&shared),
            "{name}"
        );
        assert_eq!(
            serial.metrics.keys().collect::<Vec<_>>(),
            shared.metrics.keys().collect::<Vec<_>>()
        );
        for (metric, &value) in &serial.metrics {
            let other = shared.metrics[metric];
            if metric == "wall_time_ms" {
                continue; // the host's
            }
            if metric == "link_faults_injected" {
                continue; // counts the Instrument channel too (compared by class below)
            }
            // Costs that contain a boot, or its kernel set-up part, contain the device's
            // set-up once.
            let expected = if metric.contains("boot_to_ready")
                || metric.contains("reset_recovery")
                || metric.contains("kernel_init")
            {
                let ticks = device_setup as f64;
                if metric.contains("_instructions") {
                    value as f64 + ticks * hil::bench_kernel::INSTRUCTIONS_PER_TICK
                } else {
                    value as f64 + ticks
                }
            } else {
                value as f64
            };
            // As in missions_qemu: one tick per measured span, two for reset to repaired plan.
            let tolerance = if metric.contains("_ticks") {
                2.0
            } else if metric.contains("_instructions") {
                2.0 * (hil::mission::record::INSTRUCTIONS_PER_TICK_X1000 as f64 / 1000.0).ceil()
                    + 1.0
            } else {
                0.0
            };
            assert!(
                (other as f64 - expected).abs() <= tolerance,
                "{name}: {metric} is {value} over serial, {other} over shared memory"
            );
        }
    }
}

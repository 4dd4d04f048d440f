//! `hil bench link`: how fast the emulated target boots and how fast the link is, in wall time.
//! These are benchmarks (host-dependent numbers), never pass/fail tests.
use std::time::{Duration, Instant};

use fsw_bridge::{HostToTarget, TargetToHost};
use serde::Serialize;

use crate::firmware::FirmwareImage;
use crate::qemu::{LaunchOptions, QemuProfile};
use crate::run::PingStats;
use crate::session::{Session, SessionError};

#[derive(Clone, Debug, Serialize)]
pub struct LinkBench {
    /// Wall time from starting QEMU to receiving the Hello.
    pub boot_to_hello_ms: f64,
    /// Sequential ping round trips.
    pub pings: PingStats,
    /// Frames per second, both directions together, with `burst` pings in flight.
    pub frames_per_second: f64,
    pub burst: u32,
}

/// Boot the target and measure the link.
pub fn link(
    profile: &QemuProfile,
    firmware: &FirmwareImage,
    pings: u32,
) -> Result<LinkBench, SessionError> {
    let started = Instant::now();
    let mut session = Session::boot_qemu(profile, firmware, &LaunchOptions::default())?;
    session.expect_hello(Duration::from_secs(30))?;
    let boot_to_hello = started.elapsed();

    let mut rtts = Vec::with_capacity(pings as usize);
    for seq in 0..pings {
        rtts.push(session.ping(seq, Duration::from_secs(5))?.0);
    }
    let pings_stats = PingStats::from_rtts(&mut rtts).expect("pings >= 1");

    // Throughput: keep up to `window` pings in flight.
    let burst = pings;
    let window = 8u32;
    let t0 = Instant::now();
    let mut sent = 0u32;
    let mut received = 0u32;
    while received < burst {
        while sent < burst && sent - received < window {
            session.link.send(&HostToTarget::Ping {
                seq: 1_000_000 + sent,
            })?;
            sent += 1;
        }
        if let TargetToHost::Pong { .. } = session.recv(Duration::from_secs(5))? {
            received += 1;
        }
    }
    let elapsed = t0.elapsed().as_secs_f64();
    Ok(LinkBench {
        boot_to_hello_ms: boot_to_hello.as_secs_f64() * 1000.0,
        pings: pings_stats,
        frames_per_second: f64::from(2 * burst) / elapsed,
        burst,
    })
}

/// Kernel costs measured on the emulated target, by name, for the budgets: partition switch,
/// system-call round trip, window jitter, per-partition worst frame (ticks the partition used
/// in one major frame), from `hil bench kernel` over 100 major frames.
pub fn kernel_metrics(
    firmware: &FirmwareImage,
) -> Result<std::collections::BTreeMap<String, u64>, String> {
    let profile = QemuProfile::load("rad750-proxy").map_err(|e| e.to_string())?;
    let k = crate::bench_kernel::kernel(&profile, firmware, 100).map_err(|e| e.to_string())?;
    let mut m = std::collections::BTreeMap::new();
    m.insert(
        "partition_switch_mean_instructions".into(),
        k.switch_mean_instructions.round() as u64,
    );
    m.insert("partition_switch_max_ticks".into(), k.switch_max_ticks);
    m.insert(
        "syscall_round_trip_instructions".into(),
        k.syscall_round_trip_instructions.round() as u64,
    );
    m.insert("window_jitter_max_ticks".into(), k.jitter_max_ticks);
    m.insert("kernel_ram_bytes".into(), k.footprint.kernel_ram_bytes);
    m.insert("kernel_rom_bytes".into(), k.footprint.kernel_rom_bytes);
    for p in &k.partitions {
        m.insert(format!("{}_worst_frame_ticks", p.name), p.worst_frame_ticks);
        m.insert(format!("{}_overruns", p.name), p.overruns);
    }
    Ok(m)
}

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

/// Kernel costs measured on the emulated target, by name (partition switch, syscall round
/// trip, frame processing, footprints). Until the partitioning kernel reports them, every
/// kernel quantity is "not measured".
pub fn kernel_metrics(
    _firmware: &FirmwareImage,
) -> Result<std::collections::BTreeMap<String, u64>, String> {
    Err("the kernel benchmark is not available in this image yet".into())
}

//! `hil bench link`: how fast the emulated target boots and how fast the link is, in wall time,
//! over each link transport (the serial line a real board uses, and the shared-memory link), and
//! what a target waiting for the host costs the host. These are benchmarks (host-dependent
//! numbers), never pass/fail tests.
use std::time::{Duration, Instant};

use fsw_bridge::{HostToTarget, TargetToHost, TelemetryEvent};
use kernel_config::abi::metric;
use serde::Serialize;

use crate::firmware::FirmwareImage;
use crate::qemu::{LaunchOptions, QemuProfile, Transport};
use crate::run::PingStats;
use crate::session::{Session, SessionError};

/// How long the target is left waiting for the host while QEMU's CPU time is watched.
const IDLE_WATCH: Duration = Duration::from_secs(1);

/// The link over one transport.
#[derive(Clone, Debug, Serialize)]
pub struct TransportBench {
    pub transport: String,
    /// Wall time from starting QEMU to receiving the Hello.
    pub boot_to_hello_ms: f64,
    /// Wall time from starting QEMU to the executive's boot-to-ready report (the pings start
    /// then).
    pub boot_to_ready_ms: f64,
    /// Sequential ping round trips.
    pub pings: PingStats,
    /// Frames per second, both directions together, with `in_flight` pings outstanding.
    pub frames_per_second: f64,
    pub burst: u32,
    pub in_flight: u32,
    /// Host CPU the QEMU process used while the target waited for the host, in percent of one
    /// core (None where /proc is not readable).
    pub idle_cpu_percent: Option<f64>,
}

#[derive(Clone, Debug, Serialize)]
pub struct LinkBench {
    pub transports: Vec<TransportBench>,
}

/// Boot the target over each transport and measure the link.
pub fn link(
    profile: &QemuProfile,
    firmware: &FirmwareImage,
    pings: u32,
) -> Result<LinkBench, SessionError> {
    let transports = [Transport::Serial, Transport::SharedMemory]
        .into_iter()
        .map(|t| link_over(&profile.clone().with_transport(t), firmware, pings))
        .collect::<Result<_, _>>()?;
    Ok(LinkBench { transports })
}

fn link_over(
    profile: &QemuProfile,
    firmware: &FirmwareImage,
    pings: u32,
) -> Result<TransportBench, SessionError> {
    let started = Instant::now();
    let mut session = Session::boot_qemu(profile, firmware, &LaunchOptions::default())?;
    session.expect_hello(Duration::from_secs(30))?;
    let boot_to_hello = started.elapsed();
    // The partitions are still starting (the executive reads its memories, the planner builds
    // its table): the link is measured once the executive says it is ready.
    loop {
        if let TargetToHost::Telemetry(TelemetryEvent::Metric { id, .. }) =
            session.recv(Duration::from_secs(30))?
        {
            if id == metric::BOOT_TO_READY_TICKS {
                break;
            }
        }
    }
    let boot_to_ready = started.elapsed();

    let mut rtts = Vec::with_capacity(pings as usize);
    for seq in 0..pings {
        rtts.push(session.ping(seq, Duration::from_secs(5))?.0);
    }
    let pings_stats = PingStats::from_rtts(&mut rtts).expect("pings >= 1");

    // Throughput: keep up to `in_flight` pings outstanding.
    let burst = pings;
    let in_flight = 8u32;
    let t0 = Instant::now();
    let mut sent = 0u32;
    let mut received = 0u32;
    while received < burst {
        while sent < burst && sent - received < in_flight {
            session.link.send(&HostToTarget::Ping {
                seq: 1_000_000 + sent,
            })?;
            sent += 1;
        }
        if let TargetToHost::Pong { .. } = session.recv_expedited(Duration::from_secs(5))? {
            received += 1;
        }
    }
    let elapsed = t0.elapsed().as_secs_f64();

    // Everything answered: the target waits for the host. What does that cost the host?
    let idle_cpu_percent = session.qemu.as_ref().and_then(|qemu| {
        let before = qemu.cpu_time()?;
        std::thread::sleep(IDLE_WATCH);
        let used = qemu.cpu_time()? - before;
        Some(100.0 * used.as_secs_f64() / IDLE_WATCH.as_secs_f64())
    });
    Ok(TransportBench {
        transport: profile.transport.name().into(),
        boot_to_hello_ms: boot_to_hello.as_secs_f64() * 1000.0,
        boot_to_ready_ms: boot_to_ready.as_secs_f64() * 1000.0,
        pings: pings_stats,
        frames_per_second: f64::from(2 * burst) / elapsed,
        burst,
        in_flight,
        idle_cpu_percent,
    })
}

/// The table `hil bench link` prints.
pub fn link_table(b: &LinkBench) -> String {
    let mut out = String::from(
        "link benchmark (wall time; depends on the host and its load)\n\
         transport         to Hello  to ready  ping median      p99        max  frames/s  idle QEMU CPU\n",
    );
    for t in &b.transports {
        out.push_str(&format!(
            "{:<16} {:>6.1} ms {:>6.1} ms {:>9} us {:>6} us {:>7} us {:>9.0} {:>12}\n",
            t.transport,
            t.boot_to_hello_ms,
            t.boot_to_ready_ms,
            t.pings.median_us,
            t.pings.p99_us,
            t.pings.max_us,
            t.frames_per_second,
            t.idle_cpu_percent
                .map(|p| format!("{p:.1} %"))
                .unwrap_or_else(|| "-".into()),
        ));
    }
    if let Some(t) = b.transports.first() {
        out.push_str(&format!(
            "({} sequential pings once the target is ready (QEMU started to the executive's boot-to-ready report); frames/s with {} pings in flight, both directions; idle: QEMU's CPU time over {} s with nothing to do)\n",
            t.pings.count,
            t.in_flight,
            IDLE_WATCH.as_secs()
        ));
    }
    out
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

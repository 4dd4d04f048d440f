//! `hil bench kernel`: what the partitioning kernel costs, measured inside the guest in timebase
//! ticks (deterministic under `-icount shift=2,sleep=off`: one instruction is 4 ns, one tick
//! 60.24 ns, so a tick is ~15.06 instructions): partition switch cost, window-start jitter,
//! system-call round trip; plus the kernel's RAM and ROM footprint read from the ELF.
use std::collections::BTreeMap;
use std::path::Path;
use std::time::{Duration, Instant};

use fsw_bridge::{HostToTarget, MissionTimeUs, StateKey, StateValue, TargetToHost, TelemetryEvent};
use kernel_config::abi::{control, metric, SYSCALL_BENCH_CALLS};
use object::{Object, ObjectSection, ObjectSymbol};
use serde::Serialize;

use crate::firmware::FirmwareImage;
use crate::qemu::{LaunchOptions, QemuProfile};
use crate::session::{Session, SessionError};

/// Instructions per timebase tick under icount shift=2 (60.24 ns / 4 ns).
pub const INSTRUCTIONS_PER_TICK: f64 = 1e9 / 16.6e6 / 4.0;

#[derive(Clone, Debug, Serialize)]
pub struct KernelBench {
    /// Major frames the measurement covers.
    pub frames: u64,
    /// Window starts measured.
    pub switches: u64,
    /// Kernel time per partition switch (timer interrupt taken to return to the partition),
    /// mean and max, in ticks and instructions. Excludes the ~20 register-restore instructions
    /// after the last timebase read.
    pub switch_mean_ticks: f64,
    pub switch_max_ticks: u64,
    pub switch_mean_instructions: f64,
    /// Largest window-start jitter (switch-in minus scheduled start) over all windows, ticks.
    pub jitter_max_ticks: u64,
    /// Per partition: name, max jitter (ticks), ticks in the last frame, worst frame, overruns.
    pub partitions: Vec<PartitionAccounting>,
    /// Null system call (`sc` in, checks, `rfi` out) round trip.
    pub syscall_round_trip_ticks: f64,
    pub syscall_round_trip_instructions: f64,
    /// Queuing-port messages dropped on receive because their sender had restarted since
    /// sending them (`metric::PORT_STALE_DROPPED`, since boot).
    pub port_stale_dropped: u64,
    pub footprint: Footprint,
}

#[derive(Clone, Debug, Serialize)]
pub struct PartitionAccounting {
    pub name: String,
    pub max_jitter_ticks: u64,
    pub frame_ticks: u64,
    pub worst_frame_ticks: u64,
    pub overruns: u64,
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct Footprint {
    /// Kernel RAM: initialised data, bss (contexts, ports, log ring, events), kernel stack.
    pub kernel_ram_bytes: u64,
    /// The all-invalid hashed page table (the 750's minimum, 64 KiB), counted apart.
    pub page_table_bytes: u64,
    /// Kernel code: reset stub, vectors, entry/exit, and every function of the kernel module.
    pub kernel_rom_bytes: u64,
    /// The whole ROM image (kernel, partitions, libcore, postcard, rodata).
    pub image_rom_bytes: u64,
}

fn send_control(session: &mut Session, key: u16, value: StateValue) -> Result<(), SessionError> {
    session.link.send(&HostToTarget::StateUpdate {
        key: StateKey(key),
        value,
        timestamp: MissionTimeUs::ZERO,
    })?;
    Ok(())
}

fn metric_value(session: &mut Session, id: u16) -> Result<u64, SessionError> {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match session.recv(left)? {
            TargetToHost::Telemetry(TelemetryEvent::Metric { id: i, value }) if i == id => {
                return Ok(value)
            }
            other => session.unsolicited.push(other),
        }
    }
}

/// Major frames between the kernel's accounting reports while the benchmark runs.
const REPORT_PERIOD_FRAMES: i64 = 10;

/// The kernel's next accounting report.
fn next_report(session: &mut Session) -> Result<BTreeMap<u16, u64>, SessionError> {
    let mut out = BTreeMap::new();
    out.insert(
        metric::FRAME_NUMBER,
        metric_value(session, metric::FRAME_NUMBER)?,
    );
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match session.recv(left)? {
            TargetToHost::Telemetry(TelemetryEvent::Metric { id, value }) => {
                out.insert(id, value);
                if id == metric::EVENTS_DROPPED {
                    return Ok(out);
                }
            }
            other => session.unsolicited.push(other),
        }
    }
}

/// Boot the image, let it run `frames` major frames, and measure.
pub fn kernel(
    profile: &QemuProfile,
    firmware: &FirmwareImage,
    frames: u64,
) -> Result<KernelBench, SessionError> {
    let mut session = Session::boot_qemu(profile, firmware, &LaunchOptions::default())?;
    session.expect_hello(Duration::from_secs(30))?;
    // Periodic reports keep the schedule running (a module with nothing to do otherwise stops
    // it until the host sends something), so the frames measured are back-to-back.
    send_control(
        &mut session,
        control::REQUEST_METRICS,
        StateValue::Int(REPORT_PERIOD_FRAMES),
    )?;
    let mut metrics = next_report(&mut session)?;
    while metrics[&metric::FRAME_NUMBER] < frames {
        metrics = next_report(&mut session)?;
    }
    send_control(&mut session, control::REQUEST_METRICS, StateValue::Int(-1))?;
    send_control(&mut session, control::SYSCALL_BENCH, StateValue::Unknown)?;
    let syscall_ticks = metric_value(&mut session, metric::SYSCALL_BENCH_TICKS)?;
    let syscall = syscall_ticks as f64 / f64::from(SYSCALL_BENCH_CALLS);
    let switches = metrics[&metric::SWITCHES];
    let switch_mean = metrics[&metric::SWITCH_MILLITICKS] as f64 / 1000.0;
    let names = ["io", "executive", "planner", "rogue"];
    let partitions = (0..8u16)
        .take_while(|p| metrics.contains_key(&(metric::FRAME_TICKS + p)))
        .map(|p| PartitionAccounting {
            name: names.get(p as usize).unwrap_or(&"?").to_string(),
            max_jitter_ticks: metrics[&(metric::MAX_JITTER + p)],
            frame_ticks: metrics[&(metric::FRAME_TICKS + p)],
            worst_frame_ticks: metrics[&(metric::WORST_FRAME_TICKS + p)],
            overruns: metrics[&(metric::OVERRUNS + p)],
        })
        .collect();
    Ok(KernelBench {
        frames: metrics[&metric::FRAME_NUMBER],
        switches,
        switch_mean_ticks: switch_mean,
        switch_max_ticks: metrics[&metric::SWITCH_MAX_TICKS],
        switch_mean_instructions: switch_mean * INSTRUCTIONS_PER_TICK,
        jitter_max_ticks: metrics[&metric::MAX_JITTER_ALL],
        partitions,
        syscall_round_trip_ticks: syscall,
        syscall_round_trip_instructions: syscall * INSTRUCTIONS_PER_TICK,
        port_stale_dropped: metrics
            .get(&metric::PORT_STALE_DROPPED)
            .copied()
            .unwrap_or(0),
        footprint: footprint(&firmware.elf).unwrap_or_default(),
    })
}

/// The kernel's share of the image, from section sizes and symbols.
pub fn footprint(elf: &Path) -> Result<Footprint, String> {
    let bytes = std::fs::read(elf).map_err(|e| e.to_string())?;
    let file = object::File::parse(&*bytes).map_err(|e| e.to_string())?;
    let size = |name: &str| file.section_by_name(name).map(|s| s.size()).unwrap_or(0);
    let kernel_ram_bytes = size(".kdata") + size(".bss") + size(".kstack");
    let kernel_code: u64 = file
        .symbols()
        .filter(|s| s.kind() == object::SymbolKind::Text)
        .filter(|s| {
            let name = s.name().unwrap_or("");
            name.contains("rad750_firmware6kernel")
                || name.contains("rad750_firmware4boot")
                || name.contains("rad750_firmware4warm")
                || matches!(
                    name,
                    "kernel_trap" | "__exception_common" | "rust_start" | "_reset"
                )
        })
        .map(|s| s.size())
        .sum();
    // Vectors (0x0-0x3000) and the reset stub belong to the kernel too.
    let kernel_rom_bytes = kernel_code + 0x3000 + size(".reset");
    Ok(Footprint {
        kernel_ram_bytes,
        page_table_bytes: size(".htab"),
        kernel_rom_bytes,
        image_rom_bytes: size(".reset")
            + size(".ram_image")
            + size(".deferred_code")
            + size(".kdata"),
    })
}

//! Shared set-up for the integration tests in `tests/tests/`: the firmware is built once per
//! test process, and a pty pair stands in for a serial-attached board when a test plays target.
use std::ffi::CStr;
use std::fs::File;
use std::ops::{Deref, DerefMut};
use std::os::fd::FromRawFd;
use std::sync::{Condvar, Mutex, OnceLock};
use std::time::Duration;

use hil::firmware::{self, FirmwareImage};
use hil::qemu::{LaunchOptions, QemuProfile, Transport};
use hil::session::Session;

/// Generous liveness timeout (wall time) for anything the target must send: a bound that only
/// trips when something is broken, never a performance assertion.
pub const PATIENCE: Duration = Duration::from_secs(30);

/// The firmware image, built once per test process.
pub fn firmware() -> &'static FirmwareImage {
    static FW: OnceLock<FirmwareImage> = OnceLock::new();
    FW.get_or_init(|| firmware::build().unwrap_or_else(|e| panic!("firmware build failed: {e}")))
}

/// The test image (feature `test-partitions`: the product plus the rogue partition), built
/// once per test process into its own target directory.
pub fn test_firmware() -> &'static FirmwareImage {
    static FW: OnceLock<FirmwareImage> = OnceLock::new();
    FW.get_or_init(|| {
        firmware::build_with_features(&["test-partitions"])
            .unwrap_or_else(|e| panic!("test image build failed: {e}"))
    })
}

/// A slot for a QEMU: at most one QEMU per host core per test process; every test that starts
/// QEMU holds one while it runs (a test that runs several QEMUs itself, a campaign with jobs,
/// holds one for all of them).
///
/// It used to be one QEMU at a time: under `-icount sleep=off` a guest whose schedule kept
/// running while it waited for the host kept a host core busy, and on a 2-core machine two such
/// QEMUs starved each other's serial input for tens of seconds. A target with nothing to do now
/// stops its schedule and costs no host CPU while it waits (`tests/tests/waiting.rs`), so QEMUs
/// compete for the CPU only while their guests work.
pub fn exclusive_qemu() -> QemuSlot {
    static SLOTS: (Mutex<usize>, Condvar) = (Mutex::new(0), Condvar::new());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let (taken, freed) = &SLOTS;
    // A test that panicked while holding a slot has ended its QEMU (by PID, on drop) already.
    let mut guard = taken
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    while *guard >= cores {
        guard = freed
            .wait(guard)
            .unwrap_or_else(|poisoned| poisoned.into_inner());
    }
    *guard += 1;
    QemuSlot { slots: &SLOTS }
}

/// A taken QEMU slot, given back on drop.
pub struct QemuSlot {
    slots: &'static (Mutex<usize>, Condvar),
}

impl Drop for QemuSlot {
    fn drop(&mut self) {
        let (taken, freed) = self.slots;
        let mut guard = taken
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        *guard -= 1;
        freed.notify_one();
    }
}

/// A booted target that holds a QEMU slot until it is dropped (QEMU ends first).
pub struct Booted {
    session: Session,
    _slot: QemuSlot,
}

impl Deref for Booted {
    type Target = Session;
    fn deref(&self) -> &Session {
        &self.session
    }
}

impl DerefMut for Booted {
    fn deref_mut(&mut self) -> &mut Session {
        &mut self.session
    }
}

fn boot_image(image: &FirmwareImage, profile: QemuProfile) -> Booted {
    let slot = exclusive_qemu();
    let session = Session::boot_qemu(&profile, image, &LaunchOptions::default())
        .unwrap_or_else(|e| panic!("cannot boot {}: {e}", image.elf.display()));
    Booted {
        session,
        _slot: slot,
    }
}

/// Boot the test image under QEMU.
pub fn boot_test_image() -> Booted {
    boot_image(test_firmware(), profile())
}

/// The shipped profile (the link over shared memory, unless HIL_TRANSPORT says otherwise).
pub fn profile() -> QemuProfile {
    QemuProfile::load("rad750-proxy").expect("qemu/rad750-proxy.toml")
}

/// Both link transports an emulated target has: the serial line a real board uses, and the
/// shared-memory link.
pub const TRANSPORTS: [Transport; 2] = [Transport::Serial, Transport::SharedMemory];

/// The shipped profile with the link over `transport`.
pub fn profile_over(transport: Transport) -> QemuProfile {
    profile().with_transport(transport)
}

/// A temporary directory with the shipped flyby task network at `tasknets/flyby.toml`, where a
/// scenario written into the directory finds it.
pub fn beside_the_flyby_tasknet() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("tasknets")).unwrap();
    std::fs::copy(
        hil::repo_root().join("scenarios/tasknets/flyby.toml"),
        dir.path().join("tasknets/flyby.toml"),
    )
    .unwrap();
    dir
}

/// Boot the RAD750 proxy under QEMU and wait for nothing yet.
pub fn boot() -> Booted {
    boot_image(firmware(), profile())
}

/// Boot the RAD750 proxy with the link over `transport`.
pub fn boot_over(transport: Transport) -> Booted {
    boot_image(firmware(), profile_over(transport))
}

/// A pseudo-terminal pair: the test writes the "target" side on `master`; a `Session` opens
/// `slave_path` as if it were a serial device.
pub struct PtyPair {
    pub master: File,
    pub slave_path: String,
    _slave: File,
}

pub fn pty_pair() -> PtyPair {
    let (mut master, mut slave) = (0, 0);
    // SAFETY: openpty writes two valid descriptors on success; we own both afterwards.
    let rc = unsafe {
        libc::openpty(
            &mut master,
            &mut slave,
            std::ptr::null_mut(),
            std::ptr::null(),
            std::ptr::null(),
        )
    };
    assert_eq!(rc, 0, "openpty failed");
    // SAFETY: `slave` is a valid descriptor from openpty; ptsname_r-free path via ttyname.
    let name = unsafe { CStr::from_ptr(libc::ttyname(slave)) }
        .to_string_lossy()
        .into_owned();
    // SAFETY: both descriptors are valid and owned by nobody else.
    unsafe {
        PtyPair {
            master: File::from_raw_fd(master),
            slave_path: name,
            _slave: File::from_raw_fd(slave),
        }
    }
}

/// A shipped scenario's path.
pub fn scenario(name: &str) -> std::path::PathBuf {
    hil::repo_root().join("scenarios").join(name)
}

/// A shipped scenario, loaded and validated.
pub fn prepared(name: &str) -> hil::mission::plan::MissionPlan {
    hil::mission::runner::prepare(&scenario(name)).unwrap_or_else(|e| panic!("{e}"))
}

/// Fly `plan` on the native target.
pub fn fly_native(plan: &hil::mission::plan::MissionPlan) -> hil::mission::report::MissionReport {
    let mut target = hil::mission::target::NativeTarget::new();
    hil::mission::runner::run(plan, &mut target, None, &mut |_, _, _| {})
        .unwrap_or_else(|e| panic!("{} natively: {e}", plan.scenario.name))
}

/// Fly `plan` on an emulated target booted with `profile` (a QEMU slot held, a fresh
/// temporary non-volatile memory).
pub fn fly_emulated(
    plan: &hil::mission::plan::MissionPlan,
    profile: QemuProfile,
) -> hil::mission::report::MissionReport {
    let _one = exclusive_qemu();
    let mut target = hil::mission::target::EmulatedTarget::with_temporary_nv(
        profile,
        firmware().clone(),
        false,
        false,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    hil::mission::runner::run(plan, &mut target, Some(firmware()), &mut |_, _, _| {})
        .unwrap_or_else(|e| panic!("{} on the emulated target: {e}", plan.scenario.name))
}

/// A run's decisions without the command ids, which each target numbers from its own counter
/// (equal too, but not part of what the autonomy decided).
pub fn decisions(r: &hil::mission::report::MissionReport) -> Vec<hil::mission::record::Decision> {
    use hil::mission::record::Decision;
    r.decisions
        .iter()
        .map(|d| match d {
            Decision::Dispatch {
                at, opcode, args, ..
            } => Decision::Dispatch {
                at: *at,
                id: 0,
                opcode: *opcode,
                args: args.clone(),
            },
            other => other.clone(),
        })
        .collect()
}

/// One message class's link figures: class, sent, retransmitted, received, received again.
pub type ClassFigures = (&'static str, u64, u64, u64, u64);

/// The link's figures for the Mission channel's message classes (what the autonomy's exchange
/// needs): class, sent, retransmitted, received, received again; and the rounds. The Instrument
/// channel (logs, cost metrics, health events) carries what only one kind of target sends.
pub fn mission_link_figures(r: &hil::mission::report::MissionReport) -> (u64, Vec<ClassFigures>) {
    const INSTRUMENT: [&str; 3] = ["metric", "log", "health event"];
    let classes = r
        .link
        .classes
        .iter()
        .filter(|c| !INSTRUMENT.contains(&c.class))
        .map(|c| {
            (
                c.class,
                c.sent,
                c.retransmitted,
                c.received,
                c.received_again,
            )
        })
        .collect();
    (r.link.rounds, classes)
}

/// The nominal flyby with a GNC that treats every attain command (opcode 0x0101) as `fate`
/// from the mission's start.
pub fn flyby_with_misbehaving_gnc(
    fate: hil::mission::sim::CommandFate,
) -> hil::mission::plan::MissionPlan {
    const ATTAIN: u16 = 0x0101;
    let mut plan = prepared("flyby-nominal.toml");
    plan.add_command_fault(
        plan.start,
        hil::mission::plan::CommandFault {
            opcode: fsw_bridge::Opcode(ATTAIN),
            skip: None,
            probability: 1.0,
            fate,
            spent: false,
        },
    );
    plan
}

/// A flyby with a misbehaving GNC reached the mission's end, failed, named `cause`, and no task
/// sent more commands than its bounds allow (on main before the bounds: 10,001 attain commands
/// at 10:00:00, then "could not start").
pub fn assert_bounded_fail(r: &hil::mission::report::MissionReport, cause: &str) {
    let summary = hil::mission::report::summary(r);
    assert!(r.ended_early.is_none(), "{summary}");
    assert!(
        !r.passed,
        "a GNC that never attains cannot fly the flyby: {summary}"
    );
    assert_eq!(r.mission_end, "11:30:00");
    assert!(
        r.gave_up.iter().any(|g| g.cause == cause)
            || r.record
                .instances
                .iter()
                .any(|i| i.failure_cause() == Some(cause)),
        "the report names {cause}: {summary}"
    );
    let over = hil::campaign::bound_checks(r);
    assert!(over.is_empty(), "{over:?}\n{summary}");
    let attains: u32 = r
        .commands_per_task
        .iter()
        .filter(|c| c.task.starts_with("GncAttain"))
        .map(|c| c.commands)
        .sum();
    assert!(attains <= 40, "{attains} attain commands: {summary}");
    // Mission time moved on: the next maneuver still went out at 11:05.
    assert!(
        r.record
            .instances
            .iter()
            .any(|i| i.name == "GncAttain EARTH" && i.started_at.is_some()),
        "{summary}"
    );
}

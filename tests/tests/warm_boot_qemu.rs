//! The warm boot's image check under qemu-system-ppc. After a warm reset the reset stub checks
//! the RAM image against the image record it wrote when it last copied the image from ROM,
//! instead of copying it again; a damaged image, or a damaged record, takes the safe path (the
//! full copy from ROM) and the module comes up as after any warm reset.
//!
//! The code the warm boot leaves unchecked, the deferred code (the temporal planner's and the
//! lander's), is checked by the kernel before it first runs: intact, it runs; damaged, the
//! module warm-resets (a health-monitor event) and the reset stub copies the image from ROM.
//!
//! The guest's RAM is a shared file here (`-machine memory-backend=` a `memory-backend-file`),
//! so the test damages it from the host while the target runs, as a radiation upset or a stray
//! write would, and reads back what the boot left there.
use std::fs::{File, OpenOptions};
use std::os::unix::fs::FileExt;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use fsw_bridge::lander::LanderObservation;
use fsw_bridge::{HostToTarget, MissionTimeUs, ResetCause, TargetToHost, TelemetryEvent};
use hil::qemu::LaunchOptions;
use hil::session::Session;
use hil_tests::{exclusive_qemu, firmware, profile, QemuSlot};
use kernel_config::abi::{boot_image, metric};
use kernel_config::{
    ErrorKind, HmAction, DEFERRED_CODE_BASE, WARM_AREA_BASE, WARM_IMAGE_RECORD_OFFSET,
};

const PATIENCE: Duration = Duration::from_secs(60);

/// `rust_start`, the first Rust code a boot runs: the linker script places it at 0x3000 of the
/// RAM image (after the exception vectors).
const RUST_START: u64 = 0x3000;
/// The image record's check word (the complement of the XOR of its other seven words).
const RECORD_CHECK_WORD: u64 = (WARM_AREA_BASE + WARM_IMAGE_RECORD_OFFSET) as u64 + 28;
/// The first word of the deferred code: the linker script starts it at its BAT block.
const DEFERRED_CODE: u64 = DEFERRED_CODE_BASE as u64;
/// Its last words are somewhere below the end of its block; a word well inside it.
const DEFERRED_CODE_INSIDE: u64 = DEFERRED_CODE_BASE as u64 + 0x1_0000;

/// A target whose RAM is the file `ram`; the file is removed when it is dropped (after QEMU has
/// been ended by its PID).
struct Target {
    session: Session,
    ram: File,
    path: PathBuf,
    _slot: QemuSlot,
}

impl Drop for Target {
    fn drop(&mut self) {
        if let Some(qemu) = self.session.qemu.take() {
            qemu.kill();
        }
        let _ = std::fs::remove_file(&self.path);
    }
}

impl Target {
    fn boot() -> Target {
        let slot = exclusive_qemu();
        let path = PathBuf::from("/dev/shm").join(format!(
            "hil-test-ram-{}-{:?}",
            std::process::id(),
            std::thread::current().id()
        ));
        let mut profile = profile();
        let size = format!("{}M", profile.memory_mib);
        profile.extra_args.extend([
            "-object".to_string(),
            format!(
                "memory-backend-file,id=ram0,size={size},mem-path={},share=on",
                path.display()
            ),
            "-machine".to_string(),
            "memory-backend=ram0".to_string(),
        ]);
        let session = Session::boot_qemu(&profile, firmware(), &LaunchOptions::default())
            .unwrap_or_else(|e| panic!("cannot boot: {e}"));
        let ram = OpenOptions::new()
            .read(true)
            .write(true)
            .open(&path)
            .unwrap_or_else(|e| panic!("guest RAM {}: {e}", path.display()));
        Target {
            session,
            ram,
            path,
            _slot: slot,
        }
    }

    fn word(&self, address: u64) -> u32 {
        let mut bytes = [0u8; 4];
        self.ram.read_exact_at(&mut bytes, address).unwrap();
        u32::from_be_bytes(bytes)
    }

    /// Flip bits of the guest's RAM from outside, as an upset would.
    fn flip(&self, address: u64, mask: u32) {
        let word = self.word(address) ^ mask;
        self.ram.write_all_at(&word.to_be_bytes(), address).unwrap();
    }

    /// The next Hello, then how its boot made the RAM image good (`boot_image::*`).
    fn boot_image(&mut self, cause: ResetCause) -> u64 {
        let hello = self.session.expect_hello(PATIENCE).expect("Hello");
        assert_eq!(hello.reset_cause, cause);
        let deadline = Instant::now() + PATIENCE;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            assert!(!left.is_zero(), "no BOOT_IMAGE metric within {PATIENCE:?}");
            match self.session.recv(left).expect("the boot's metrics") {
                TargetToHost::Telemetry(TelemetryEvent::Metric { id, value })
                    if id == metric::BOOT_IMAGE =>
                {
                    return value
                }
                other => self.session.unsolicited.push(other),
            }
        }
    }

    fn warm_reset(&mut self) -> u64 {
        self.session.warm_reset_qmp().unwrap();
        self.boot_image(ResetCause::Warm)
    }

    /// Run lockstep rounds until a decoded log line contains `text` (logs travel on the
    /// reliable link's Instrument channel).
    fn wait_for_log(&mut self, text: &str) {
        let deadline = Instant::now() + PATIENCE;
        while !self.session.logs.iter().any(|l| l.message.contains(text)) {
            assert!(
                Instant::now() < deadline,
                "no log line containing {text:?}; logs: {:#?}",
                self.session
                    .logs
                    .iter()
                    .map(|l| &l.message)
                    .collect::<Vec<_>>()
            );
            self.session.sync(8, PATIENCE).expect("lockstep rounds");
            let delivered = self.session.take_delivered();
            self.session.unsolicited.extend(delivered);
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// A lander step for a setup the target does not have: the planner partition's lander
    /// plug-in takes it (deferred code) and refuses it.
    fn lander_step(&mut self) {
        self.session
            .link
            .send(&HostToTarget::LanderStep {
                setup: 1,
                seq: 0,
                observation: LanderObservation {
                    now: MissionTimeUs::ZERO,
                    battery_mj: 1_000,
                    preconditions_met: true,
                    event: None,
                },
            })
            .unwrap();
    }

    /// Receive until a health-monitor event that warm-resets the module arrives (the kernel
    /// sends it straight to the host before the reset, outside the lockstep rounds); return
    /// (partition, kind, address, action).
    fn health_event(&mut self) -> (u8, u8, u32, u8) {
        let deadline = Instant::now() + PATIENCE;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            assert!(
                !left.is_zero(),
                "no health-monitor event within {PATIENCE:?}"
            );
            match self
                .session
                .recv_expedited(left)
                .expect("a health-monitor event")
            {
                TargetToHost::Telemetry(TelemetryEvent::HealthMonitor {
                    partition,
                    kind,
                    address,
                    action,
                }) => return (partition, kind, address, action),
                other => self.session.unsolicited.push(other),
            }
        }
    }

    /// The module works: ping round trips come back.
    fn answers(&mut self) {
        for seq in 0..3 {
            self.session.ping(seq, PATIENCE).expect("a Pong");
        }
    }
}

#[test]
fn a_warm_boot_checks_the_ram_image_and_copies_it_from_rom_only_when_damaged() {
    let mut target = Target::boot();
    // Power-on: no image record yet, so the image is copied from ROM (and recorded).
    assert_eq!(target.boot_image(ResetCause::PowerOn), boot_image::COPIED);
    let pristine = target.word(RUST_START);
    // A warm reset finds the image as it was copied: checked, not copied.
    assert_eq!(target.warm_reset(), boot_image::VERIFIED);
    target.answers();

    // One bit of rust_start's first instruction flipped: the checksum catches it, and the image
    // is copied from ROM again before any of it runs.
    target.flip(RUST_START, 0x0000_0100);
    assert_ne!(target.word(RUST_START), pristine);
    assert_eq!(target.warm_reset(), boot_image::REPAIRED);
    assert_eq!(
        target.word(RUST_START),
        pristine,
        "the damaged word was not restored"
    );
    target.answers();
    target.wait_for_log("the RAM image failed its checksum; copied again from ROM");
    // The next warm reset finds the repaired image whole again.
    assert_eq!(target.warm_reset(), boot_image::VERIFIED);

    // The record itself damaged: it cannot be trusted to vouch for the image, which is copied.
    target.flip(RECORD_CHECK_WORD, 0x8000_0000);
    assert_eq!(target.warm_reset(), boot_image::COPIED);
    assert_eq!(target.warm_reset(), boot_image::VERIFIED);
    target.answers();
}

#[test]
fn the_deferred_code_is_checked_before_it_first_runs_and_copied_from_rom_when_damaged() {
    let mut target = Target::boot();
    assert_eq!(target.boot_image(ResetCause::PowerOn), boot_image::COPIED);
    let pristine = target.word(DEFERRED_CODE_INSIDE);
    // After a warm reset the boot leaves the deferred code to the kernel; intact, the first
    // lander message runs it once the kernel has checked it.
    assert_eq!(target.warm_reset(), boot_image::VERIFIED);
    target.lander_step();
    target.wait_for_log("deferred code checked before its first run");
    for line in &target.session.logs {
        if line.message.contains("checked before its first run") {
            println!("{}", line.message);
        }
    }
    assert!(
        target
            .session
            .logs
            .iter()
            .any(|l| l.message.contains("checked before its first run")
                && l.message.ends_with("intact")),
        "the intact deferred code was not found intact"
    );
    target.answers();

    // One bit of it flipped after a warm reset: the boot's own check does not read it (the
    // image is verified), but the kernel finds it at its first fetch, before any of it runs:
    // a health-monitor event in the planner partition, a warm reset, and the image copied
    // from ROM again.
    for damaged in [DEFERRED_CODE, DEFERRED_CODE_INSIDE] {
        assert_eq!(target.warm_reset(), boot_image::VERIFIED);
        let before = target.word(damaged);
        target.flip(damaged, 0x0400_0000);
        target.lander_step();
        let (partition, kind, address, action) = target.health_event();
        // The partition whose fetch found it: the lander message's decoders are deferred code
        // too, so the I/O partition, which decodes the message to route it, fetches first.
        assert_eq!(partition, kernel_config::system::IO as u8);
        assert_eq!(kind, ErrorKind::InstructionStorage as u8);
        assert!(
            (DEFERRED_CODE_BASE..DEFERRED_CODE_BASE + kernel_config::DEFERRED_CODE_SIZE)
                .contains(&address),
            "fault address {address:#x}"
        );
        assert_eq!(action, HmAction::WarmReset as u8);
        assert_eq!(
            target.boot_image(ResetCause::HealthMonitor),
            boot_image::REPAIRED
        );
        assert_eq!(
            target.word(damaged),
            before,
            "the damaged word was not restored"
        );
        target.answers();
    }
    assert_eq!(target.word(DEFERRED_CODE_INSIDE), pristine);
    // And the repaired image is whole at the next warm reset, the deferred code with it.
    assert_eq!(target.warm_reset(), boot_image::VERIFIED);
    target.session.logs.clear();
    target.lander_step();
    target.wait_for_log("deferred code checked before its first run");
    assert!(target
        .session
        .logs
        .iter()
        .any(|l| l.message.ends_with("intact")));
    target.answers();
}

//! The `hil` binary run as a user runs it, in a child process: it leaves nothing behind in the
//! temporary directory or in `/dev/shm` after a run that passes, fails, cannot start, or is
//! interrupted (Ctrl-C, SIGTERM); `--keep-nv` keeps the non-volatile memory image where asked;
//! a copy of `hil` outside any checkout still finds its QEMU profiles; and a missing QEMU is
//! named with where it was looked for and how to install it.
//!
//! Each child gets a fresh `TMPDIR` of its own (a `TempDir` of this test process), so other
//! users' files there never count; its files in `/dev/shm` are found by the `hil-<pid>-`
//! prefix every temporary path of `hil` carries.
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::{Mutex, MutexGuard, OnceLock};
use std::time::{Duration, Instant};

use tempfile::TempDir;

/// Liveness bound for a child `hil` (wall time): only trips when something is broken.
const PATIENCE: Duration = Duration::from_secs(300);

/// One emulated `hil` at a time from this test process (each may run QEMUs of its own).
fn one_qemu_at_a_time() -> MutexGuard<'static, ()> {
    static ONE: Mutex<()> = Mutex::new(());
    ONE.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// The firmware image, built once per test process.
fn firmware() -> &'static Path {
    static FW: OnceLock<PathBuf> = OnceLock::new();
    FW.get_or_init(|| {
        hil::firmware::build()
            .unwrap_or_else(|e| panic!("firmware build failed: {e}"))
            .elf
    })
}

fn scenario(name: &str) -> PathBuf {
    hil::repo_root().join("scenarios").join(name)
}

/// `run SCENARIO --firmware ELF --no-logs EXTRA...`: a run on the emulated target.
fn emulated<'a>(scenario: &'a Path, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "run",
        scenario.to_str().unwrap(),
        "--firmware",
        firmware().to_str().unwrap(),
        "--no-logs",
    ];
    args.extend_from_slice(extra);
    args
}

/// A fresh temporary directory for one child, and a fresh "checkout" for its run outputs.
struct Sandbox {
    tmp: TempDir,
    repo: TempDir,
}

impl Sandbox {
    fn new() -> Self {
        Self {
            tmp: tempfile::tempdir().unwrap(),
            repo: tempfile::tempdir().unwrap(),
        }
    }

    /// `hil ARGS` with this sandbox's TMPDIR, run outputs under its own directory.
    fn hil(&self, args: &[&str]) -> Command {
        self.command(Path::new(env!("CARGO_BIN_EXE_hil")), args)
    }

    /// `program ARGS` (a `hil` binary) with this sandbox's TMPDIR, run outputs under its own
    /// directory.
    fn command(&self, program: &Path, args: &[&str]) -> Command {
        let mut cmd = Command::new(program);
        cmd.args(args)
            .env("TMPDIR", self.tmp.path())
            .env("HIL_REPO", self.repo.path())
            .stdin(Stdio::null());
        cmd
    }

    /// What the child left in its TMPDIR (should be nothing).
    fn leftovers(&self) -> Vec<PathBuf> {
        entries(self.tmp.path())
    }
}

fn entries(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default()
}

/// Files of process `pid` in /dev/shm (every temporary path of `hil` starts `hil-<pid>-`).
fn shm_leftovers(pid: u32) -> Vec<PathBuf> {
    let prefix = format!("hil-{pid}-");
    entries(Path::new("/dev/shm"))
        .into_iter()
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with(&prefix))
        })
        .collect()
}

/// Run to the end (bounded), with its output.
fn finish(mut child: Child) -> (u32, Output) {
    let pid = child.id();
    let deadline = Instant::now() + PATIENCE;
    while child.try_wait().unwrap().is_none() {
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("hil (pid {pid}) did not finish within {PATIENCE:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    (pid, child.wait_with_output().unwrap())
}

fn run(mut cmd: Command) -> (u32, Output) {
    let child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    finish(child)
}

fn text(output: &Output) -> String {
    format!(
        "status {}\n--- stdout\n{}\n--- stderr\n{}",
        output.status,
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    )
}

fn assert_clean(sandbox: &Sandbox, pid: u32, output: &Output) {
    assert_eq!(
        sandbox.leftovers(),
        Vec::<PathBuf>::new(),
        "hil left files in its TMPDIR\n{}",
        text(output)
    );
    assert_eq!(
        shm_leftovers(pid),
        Vec::<PathBuf>::new(),
        "hil left files in /dev/shm\n{}",
        text(output)
    );
}

/// A copy of the shipped flyby scenario `name` (with its task network) in `dir`, changed by
/// `edit`.
fn scenario_copy(dir: &Path, name: &str, edit: impl Fn(String) -> String) -> PathBuf {
    std::fs::create_dir_all(dir.join("tasknets")).unwrap();
    std::fs::copy(
        scenario("tasknets/flyby.toml"),
        dir.join("tasknets/flyby.toml"),
    )
    .unwrap();
    let text = std::fs::read_to_string(scenario(name)).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, edit(text)).unwrap();
    path
}

#[test]
fn a_native_mission_leaves_nothing_behind() {
    let sandbox = Sandbox::new();
    let path = scenario("flyby-early-reset.toml");
    let (pid, output) = run(sandbox.hil(&["run", path.to_str().unwrap(), "--native"]));
    assert_eq!(output.status.code(), Some(0), "{}", text(&output));
    assert_clean(&sandbox, pid, &output);
}

#[test]
fn an_emulated_mission_with_a_power_cycle_leaves_nothing_behind() {
    let _one = one_qemu_at_a_time();
    let sandbox = Sandbox::new();
    let path = scenario("flyby-power-cycle.toml");
    let (pid, output) = run(sandbox.hil(&emulated(&path, &[])));
    assert_eq!(output.status.code(), Some(0), "{}", text(&output));
    assert_clean(&sandbox, pid, &output);
}

#[test]
fn a_failing_emulated_mission_leaves_nothing_behind_but_the_nv_image_it_was_asked_to_keep() {
    let _one = one_qemu_at_a_time();
    let sandbox = Sandbox::new();
    let kept = tempfile::tempdir().unwrap();
    let nv = kept.path().join("nv.bin");
    // The attitude is EARTH at 11:25: expecting NADIR fails the run (exit 1), after it flew.
    let path = scenario_copy(kept.path(), "flyby-nominal.toml", |t| {
        let failing = t.replace(
            "at = \"11:25\"\nvalue = \"EARTH\"",
            "at = \"11:25\"\nvalue = \"NADIR\"",
        );
        assert_ne!(
            failing, t,
            "flyby-nominal.toml no longer expects EARTH at 11:25"
        );
        failing
    });
    let (pid, output) = run(sandbox.hil(&emulated(&path, &["--keep-nv", nv.to_str().unwrap()])));
    assert_eq!(output.status.code(), Some(1), "{}", text(&output));
    assert!(
        String::from_utf8_lossy(&output.stdout).contains("FAIL flyby-nominal"),
        "{}",
        text(&output)
    );
    assert_clean(&sandbox, pid, &output);
    let kept_len = std::fs::metadata(&nv)
        .unwrap_or_else(|e| panic!("--keep-nv {}: {e}\n{}", nv.display(), text(&output)))
        .len();
    assert_eq!(kept_len, hil::mission::target::native::NV_BYTES as u64);
}

/// A link check scenario that only needs a Hello and a few pings.
fn link_check(dir: &Path, profile: &str) -> PathBuf {
    let path = dir.join("link-check.toml");
    std::fs::write(
        &path,
        format!(
            "name = \"link-check\"\n[target]\nprofile = \"{profile}\"\n\n[[steps]]\nexpect_hello = {{ reset_cause = \"power-on\" }}\n[[steps]]\nping = {{ count = 3 }}\n"
        ),
    )
    .unwrap();
    path
}

#[test]
fn a_missing_qemu_is_named_with_where_it_was_looked_for_and_how_to_install_it() {
    let sandbox = Sandbox::new();
    let empty_path = tempfile::tempdir().unwrap();
    let files = tempfile::tempdir().unwrap();
    let scenario = link_check(files.path(), "rad750-proxy");
    let args = emulated(&scenario, &[]);

    let mut cmd = sandbox.hil(&args);
    cmd.env("PATH", empty_path.path()).env_remove("HIL_QEMU");
    let (pid, output) = run(cmd);
    assert_eq!(output.status.code(), Some(2), "{}", text(&output));
    let stderr = String::from_utf8_lossy(&output.stderr);
    for needle in [
        "`qemu-system-ppc`",
        "the binary of QEMU profile rad750-proxy",
        &format!("searched: {}", empty_path.path().display()),
        "sudo apt-get install -y qemu-system-ppc",
        "HIL_QEMU",
    ] {
        assert!(
            stderr.contains(needle),
            "no {needle:?} in\n{}",
            text(&output)
        );
    }
    assert_clean(&sandbox, pid, &output);

    // HIL_QEMU names the executable; a path that is not one is refused as such.
    let missing = files.path().join("no-such-qemu");
    let mut cmd = sandbox.hil(&args);
    cmd.env("HIL_QEMU", &missing);
    let (pid, output) = run(cmd);
    assert_eq!(output.status.code(), Some(2), "{}", text(&output));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains(&format!("`{}` (from HIL_QEMU)", missing.display())),
        "{}",
        text(&output)
    );
    assert!(
        stderr.contains("no executable file at that path"),
        "{}",
        text(&output)
    );
    assert_clean(&sandbox, pid, &output);
}

/// `cargo install` puts `hil` somewhere else; run from elsewhere, with no checkout around it
/// (HIL_REPO names an empty directory), it still boots the target with its built-in profiles.
#[test]
fn a_copy_of_hil_outside_the_checkout_uses_its_built_in_profiles() {
    let _one = one_qemu_at_a_time();
    let sandbox = Sandbox::new();
    let install = tempfile::tempdir().unwrap();
    let binary = install.path().join("hil");
    std::fs::copy(env!("CARGO_BIN_EXE_hil"), &binary).unwrap();
    let elsewhere = tempfile::tempdir().unwrap();
    for profile in ["rad750-proxy", "rad750-proxy-serial"] {
        let scenario = link_check(elsewhere.path(), profile);
        let mut cmd = sandbox.command(&binary, &emulated(&scenario, &[]));
        cmd.current_dir(elsewhere.path())
            .env_remove("HIL_TRANSPORT");
        let (pid, output) = run(cmd);
        assert_eq!(
            output.status.code(),
            Some(0),
            "{profile}: {}",
            text(&output)
        );
        let stdout = String::from_utf8_lossy(&output.stdout);
        assert!(
            stdout.contains(&format!("target    {profile} (QEMU pid")),
            "{}",
            text(&output)
        );
        assert!(stdout.contains("PASS link-check"), "{}", text(&output));
        assert_clean(&sandbox, pid, &output);
    }
}

/// Ctrl-C and SIGTERM end the run's QEMU (by PID) and remove its temporary files.
#[test]
fn an_interrupted_emulated_run_ends_its_qemu_and_leaves_nothing_behind() {
    let _one = one_qemu_at_a_time();
    for signal in [libc::SIGINT, libc::SIGTERM] {
        let sandbox = Sandbox::new();
        // In real time the 100-minute flyby is still flying when the signal comes.
        let path = scenario("flyby-nominal.toml");
        let child = sandbox
            .hil(&emulated(&path, &["--realtime"]))
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let pid = child.id();
        // Wait until QEMU is up: its serial socket is in the sandbox's TMPDIR.
        let deadline = Instant::now() + PATIENCE;
        let run_dir = loop {
            let found = entries(sandbox.tmp.path())
                .into_iter()
                .find(|d| d.join("serial.sock").exists());
            if let Some(dir) = found {
                break dir;
            }
            assert!(Instant::now() < deadline, "no QEMU run directory appeared");
            std::thread::sleep(Duration::from_millis(20));
        };
        std::thread::sleep(Duration::from_millis(500));
        let qemus = processes_mentioning(&run_dir);
        assert_eq!(qemus.len(), 1, "one QEMU runs with {}", run_dir.display());
        // SAFETY: kill(2) has no memory-safety preconditions; `pid` is our own unreaped child.
        assert_eq!(unsafe { libc::kill(pid as libc::pid_t, signal) }, 0);
        let (_, output) = finish(child);
        assert_eq!(
            output.status.code(),
            Some(130),
            "signal {signal}: {}",
            text(&output)
        );
        assert!(
            String::from_utf8_lossy(&output.stderr).contains("hil: interrupted"),
            "{}",
            text(&output)
        );
        assert_clean(&sandbox, pid, &output);
        let deadline = Instant::now() + Duration::from_secs(10);
        while !processes_mentioning(&run_dir).is_empty() {
            assert!(
                Instant::now() < deadline,
                "QEMU {qemus:?} still runs after hil was interrupted"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

/// PIDs of the processes whose command line mentions `path` (a run directory is unique).
fn processes_mentioning(path: &Path) -> Vec<u32> {
    let needle = path.to_string_lossy().into_owned();
    entries(Path::new("/proc"))
        .into_iter()
        .filter_map(|p| {
            let pid: u32 = p.file_name()?.to_str()?.parse().ok()?;
            let cmdline = std::fs::read(p.join("cmdline")).ok()?;
            let alive = std::fs::read_to_string(p.join("stat"))
                .ok()
                .and_then(|s| {
                    s.rfind(')')
                        .map(|i| !s[i + 1..].trim_start().starts_with('Z'))
                })
                .unwrap_or(false);
            (alive && String::from_utf8_lossy(&cmdline).contains(&needle)).then_some(pid)
        })
        .collect()
}

/// A QEMU that dies in the middle of a campaign is one failed run that says so; the campaign
/// goes on with the next run and ends (exit 1), leaving nothing behind.
#[test]
fn a_campaign_whose_qemu_is_killed_fails_that_run_naming_it_and_goes_on() {
    let _one = one_qemu_at_a_time();
    let sandbox = Sandbox::new();
    let out = tempfile::tempdir().unwrap();
    let report = out.path().join("campaign.json");
    let path = scenario("flyby-campaign.toml");
    let child = sandbox
        .hil(&[
            "campaign",
            path.to_str().unwrap(),
            "--runs",
            "2",
            "--jobs",
            "1",
            "--firmware",
            firmware().to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    // The first run's QEMU: the one process whose command line names the sandbox's TMPDIR.
    let deadline = Instant::now() + PATIENCE;
    let qemu = loop {
        if let [qemu] = processes_mentioning(sandbox.tmp.path())[..] {
            break qemu;
        }
        assert!(Instant::now() < deadline, "the campaign started no QEMU");
        std::thread::sleep(Duration::from_millis(5));
    };
    // SAFETY: kill(2) has no memory-safety preconditions; `qemu` was started by our child
    // `hil` for this test (its command line names this test's own TMPDIR) and is alive.
    assert_eq!(unsafe { libc::kill(qemu as libc::pid_t, libc::SIGKILL) }, 0);
    let (_, output) = finish(child);
    assert_eq!(output.status.code(), Some(1), "{}", text(&output));
    assert_clean(&sandbox, pid, &output);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let results = report["results"].as_array().unwrap();
    assert_eq!(results.len(), 2, "{report:#}");
    assert_eq!(results[0]["passed"], false, "{report:#}");
    // Killed while it started (a run error) or while it flew (the mission ended early): either
    // way the failure says the QEMU ended and how.
    let failures = results[0]["failures"].to_string();
    assert!(
        failures.contains("QEMU") && failures.contains("(SIGKILL)"),
        "the failure does not name the QEMU's end: {failures}"
    );
    assert_eq!(results[1]["passed"], true, "{report:#}");
}

/// A QEMU that dies in the middle of a mission (here: killed at 10:30) ends the run at once
/// with an error naming it and how it ended, rather than a link error or a timeout. This runs
/// in this test process: no other test of this file starts a QEMU of its own (theirs belong
/// to child `hil` processes), so the only QEMU recorded here is this mission's.
#[test]
fn a_qemu_that_dies_mid_mission_ends_the_run_with_an_error_naming_it() {
    use hil::mission::runner;
    use hil::mission::target::EmulatedTarget;
    let _one = one_qemu_at_a_time();
    let plan = runner::prepare(&scenario("flyby-nominal.toml")).unwrap();
    let fw = hil::firmware::FirmwareImage::open(firmware()).unwrap();
    let profile = hil::qemu::QemuProfile::load("rad750-proxy").unwrap();
    let mut target = EmulatedTarget::with_temporary_nv(profile, fw.clone(), false, false).unwrap();
    let kill_at = hil::time::parse_time(&"10:30".into(), hil::time::Epoch::default()).unwrap();
    let mut killed = None;
    let started = Instant::now();
    let result = runner::run(&plan, &mut target, Some(&fw), &mut |now, _, _| {
        if now >= kill_at && killed.is_none() {
            let qemus = hil::cleanup::started_processes();
            assert_eq!(qemus.len(), 1, "one QEMU: {qemus:?}");
            assert!(hil::cleanup::kill_if_started(qemus[0]));
            killed = Some(qemus[0]);
        }
    });
    let pid = killed.expect("the mission reached 10:30");
    // The driver ends the mission early and the report says why (an emulated run that cannot
    // go on is a failed run, not a run that could not start).
    let report = result.unwrap_or_else(|e| panic!("the run ended without a report: {e}"));
    assert!(!report.passed);
    let summary = hil::mission::report::summary(&report);
    assert!(
        summary.contains("the run reaches the end of the mission: it ended early at ")
            && summary.contains(&format!(
                "the target's QEMU (pid {pid}) ended (signal: 9 (SIGKILL))"
            )),
        "{summary}"
    );
    // Ended by the closed link, not by a round's timeout.
    assert!(
        started.elapsed() < hil::mission::target::emulated::ROUND_TIMEOUT,
        "{summary}"
    );
    drop(target);
    assert!(hil::cleanup::started_processes().is_empty());
}

/// `hil ... | head`: a reader that goes away early ends `hil` quietly with 141 (128 + SIGPIPE),
/// as a Unix tool does, instead of a panic message (the read end is closed before `hil` starts,
/// so its first line already meets the broken pipe).
#[test]
fn a_closed_stdout_ends_hil_quietly() {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(["rover", "run", "scenarios/rover/sahara-day.toml"])
        .current_dir(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
        .stdout(writer)
        .stderr(std::process::Stdio::piped())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(141), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

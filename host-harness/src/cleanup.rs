//! Everything `hil` must undo when it is done: the QEMU processes it started, and the temporary
//! files and directories of its runs (QEMU's sockets and output, the shared-memory link file,
//! a non-volatile memory image nobody asked to keep).
//!
//! On the normal paths (success, failure, an error returned, a panic that unwinds) ownership
//! does it: a [`ScratchDir`] or [`ScratchFile`] (the `tempfile` crate's `TempDir` and
//! `NamedTempFile`, named by the crate) removes itself when dropped, and [`crate::qemu::Qemu`]
//! ends its process by PID when dropped. Ctrl-C and SIGTERM end the process without running
//! destructors, so both are also recorded here, and the handler [`install_interrupt_handler`]
//! ends every recorded QEMU by PID, removes every recorded temporary path, and exits 130. Each
//! temporary path is created and removed with the record's lock held, so the handler never
//! misses one that exists. `hil` never ends a process it did not start.
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Child, ExitStatus};
use std::sync::{Mutex, MutexGuard, Once};
use std::time::{Duration, Instant};

/// PIDs of the QEMU processes this process started and has not yet ended.
static STARTED: Mutex<BTreeSet<u32>> = Mutex::new(BTreeSet::new());
/// Temporary paths of this process that exist now.
static SCRATCH: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());
static HANDLER: Once = Once::new();

/// How long the interrupt handler waits for a killed QEMU to be gone before it removes files
/// (a liveness bound: a SIGKILLed process is gone in milliseconds).
const KILLED_PATIENCE: Duration = Duration::from_secs(2);

fn locked<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    // A thread that panicked while holding the lock left the set itself consistent.
    mutex
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Record a QEMU this process has just spawned (and make sure Ctrl-C and SIGTERM end it).
///
/// A recorded PID is always a child this process has not reaped: it stays a zombie until it is
/// waited for, so its PID cannot have been reused by anyone else's process. Every wait for a
/// recorded child therefore goes through [`try_reap`] or [`end`], which forget it first.
pub fn track_process(child: &Child) {
    install_interrupt_handler();
    locked(&STARTED).insert(child.id());
}

/// PIDs of the QEMU processes this process started and has not ended.
pub fn started_processes() -> Vec<u32> {
    locked(&STARTED).iter().copied().collect()
}

/// SIGKILL `pid` if it is a recorded QEMU (see [`track_process`]); false if it is not.
pub fn kill_if_started(pid: u32) -> bool {
    let started = locked(&STARTED);
    if started.contains(&pid) {
        kill_unreaped(pid);
    }
    started.contains(&pid)
}

/// SIGKILL a child that has not been reaped.
fn kill_unreaped(pid: u32) {
    // SAFETY: kill(2) has no memory-safety preconditions. The callers made true that `pid` is
    // recorded, so (see `track_process`) a child of this process that has not been reaped: the
    // PID cannot belong to anyone else's process.
    unsafe {
        libc::kill(pid as libc::pid_t, libc::SIGKILL);
    }
}

/// The exit status of a recorded child if it has exited (it is reaped and forgotten then).
pub fn try_reap(child: &mut Child) -> Option<ExitStatus> {
    let mut started = locked(&STARTED);
    let status = child.try_wait().ok().flatten();
    if status.is_some() {
        started.remove(&child.id());
    }
    status
}

/// End a recorded child by PID (if it still runs), reap it and forget it.
pub fn end(child: &mut Child) {
    {
        let mut started = locked(&STARTED);
        if started.remove(&child.id()) && matches!(child.try_wait(), Ok(None)) {
            kill_unreaped(child.id());
        }
    }
    let _ = child.wait();
}

/// True once `pid` has exited (a zombie waiting to be reaped, or gone).
fn has_exited(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        // The state follows the command name, which is in parentheses.
        Ok(stat) => stat
            .rfind(')')
            .and_then(|i| stat[i + 1..].split_whitespace().next())
            .is_none_or(|state| state == "Z" || state == "X"),
        Err(_) => true,
    }
}

/// On Ctrl-C or SIGTERM: end every recorded QEMU by PID, remove every recorded temporary path,
/// exit 130. Installed once per process, by the first QEMU or temporary path.
pub fn install_interrupt_handler() {
    HANDLER.call_once(|| {
        let _ = ctrlc::set_handler(|| {
            let pids = started_processes();
            for &pid in &pids {
                kill_if_started(pid);
            }
            // A QEMU still running could create a socket in a directory being removed.
            let deadline = Instant::now() + KILLED_PATIENCE;
            while !pids.iter().all(|&pid| has_exited(pid)) && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(5));
            }
            // Held until exit: no thread creates or removes a temporary path from here on.
            let scratch = locked(&SCRATCH);
            for path in scratch.iter() {
                remove_path(path);
            }
            eprintln!(
                "hil: interrupted; ended the {} QEMU process(es) it had started and removed its {} temporary path(s)",
                pids.len(),
                scratch.len()
            );
            std::process::exit(130);
        });
    });
}

fn remove_path(path: &Path) {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.is_dir() => {
            let _ = std::fs::remove_dir_all(path);
        }
        Ok(_) => {
            let _ = std::fs::remove_file(path);
        }
        Err(_) => {}
    }
}

/// `hil-<pid>-<what>-`: a temporary path names the `hil` process it belongs to.
fn prefix(what: &str) -> String {
    format!("hil-{}-{what}-", std::process::id())
}

/// A temporary directory ([`ScratchDir`]) or file ([`ScratchFile`]), recorded while it exists
/// and removed when dropped (or on Ctrl-C).
#[derive(Debug)]
pub struct Scratch<T> {
    /// The `tempfile` crate's owner; dropping it removes the path.
    owner: Option<T>,
    path: PathBuf,
}

/// A temporary directory, removed with everything in it.
pub type ScratchDir = Scratch<tempfile::TempDir>;
/// A temporary file.
pub type ScratchFile = Scratch<tempfile::NamedTempFile>;

impl<T> Scratch<T> {
    /// Create it with the record locked (so the interrupt handler sees every path that exists)
    /// and record its path.
    fn recorded(
        create: impl FnOnce() -> std::io::Result<T>,
        path_of: impl FnOnce(&T) -> &Path,
    ) -> std::io::Result<Self> {
        install_interrupt_handler();
        let mut scratch = locked(&SCRATCH);
        let owner = create()?;
        let path = path_of(&owner).to_path_buf();
        scratch.insert(path.clone());
        Ok(Self {
            owner: Some(owner),
            path,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl<T> Drop for Scratch<T> {
    /// Removes the path with the record locked, and forgets it.
    fn drop(&mut self) {
        let mut scratch = locked(&SCRATCH);
        drop(self.owner.take());
        scratch.remove(&self.path);
    }
}

impl ScratchDir {
    /// A new directory named `hil-<pid>-<what>-<random>` in the system's temporary directory
    /// (`TMPDIR`).
    pub fn new(what: &str) -> std::io::Result<Self> {
        Self::recorded(
            || tempfile::Builder::new().prefix(&prefix(what)).tempdir(),
            tempfile::TempDir::path,
        )
    }
}

impl ScratchFile {
    /// A new empty file named `hil-<pid>-<what>-<random>` in the system's temporary directory.
    pub fn new(what: &str) -> std::io::Result<Self> {
        Self::new_in(&std::env::temp_dir(), what)
    }

    /// A new empty file named `hil-<pid>-<what>-<random>` in `dir`.
    pub fn new_in(dir: &Path, what: &str) -> std::io::Result<Self> {
        Self::recorded(
            || {
                tempfile::Builder::new()
                    .prefix(&prefix(what))
                    .tempfile_in(dir)
            },
            tempfile::NamedTempFile::path,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scratch_paths_are_recorded_while_they_exist_and_removed_on_drop() {
        let dir = ScratchDir::new("unit").unwrap();
        std::fs::write(dir.path().join("inside"), b"x").unwrap();
        let file = ScratchFile::new_in(dir.path(), "unit").unwrap();
        let (dir_path, file_path) = (dir.path().to_path_buf(), file.path().to_path_buf());
        assert!(file_path
            .file_name()
            .unwrap()
            .to_string_lossy()
            .starts_with(&format!("hil-{}-unit-", std::process::id())));
        assert!(locked(&SCRATCH).contains(&dir_path));
        assert!(locked(&SCRATCH).contains(&file_path));
        drop(file);
        assert!(!file_path.exists());
        assert!(!locked(&SCRATCH).contains(&file_path));
        drop(dir);
        assert!(!dir_path.exists());
        assert!(!locked(&SCRATCH).contains(&dir_path));
    }

    #[test]
    fn a_process_that_has_exited_is_seen_as_exited() {
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let pid = child.id();
        let deadline = Instant::now() + Duration::from_secs(10);
        while !has_exited(pid) {
            assert!(Instant::now() < deadline, "`true` did not exit");
            std::thread::sleep(Duration::from_millis(5));
        }
        child.wait().unwrap();
        assert!(!has_exited(std::process::id()));
    }
}

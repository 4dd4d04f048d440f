//! Launching the emulated target: a QEMU profile from `qemu/`, the process started paused with
//! its serial port on a Unix socket and a QMP socket, and a guard that ends that process by its
//! PID whatever happens (normal return, error, panic, Ctrl-C or SIGTERM, or `hil` itself being
//! killed).
//!
//! The serial port (the target's ESCC channel A, the same UART a real board uses) is a
//! `-chardev socket` server that `hil` connects to before the guest runs. It used to be a pty,
//! but QEMU 7.2's pty backend only notices that the host opened the pty on a once-a-second
//! poll (`pty_chr_timer`): until then it does not read what the host writes, so the first bytes
//! after every QEMU start waited up to a second. A socket connection is accepted at once.
//!
//! The link's transport is the profile's `transport` (or `HIL_TRANSPORT` in the environment):
//! `serial`, the frames on the serial line as on a real board; or `shared-memory`, the same
//! frames through rings in a second `ivshmem-plain` device backed by a file in `/dev/shm`, with
//! the serial line as the doorbell (see `kernel_logic::shm_link` and [`crate::shm`]). QEMU hands
//! the guest one serial byte per turn of its main loop; shared memory moves a batch of frames
//! per turn. The firmware picks the shared-memory link up by itself when the device is there.
use std::collections::BTreeSet;
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Mutex, Once};
use std::time::{Duration, Instant};

use serde::Deserialize;
use serde_json::{json, Value};

use crate::repo_root;

/// How the link's frames travel between `hil` and an emulated target.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum Transport {
    /// On the serial line, as on a real board.
    #[default]
    Serial,
    /// Through rings in a shared-memory device, the serial line as the doorbell.
    SharedMemory,
}

impl Transport {
    pub fn name(self) -> &'static str {
        match self {
            Transport::Serial => "serial",
            Transport::SharedMemory => "shared-memory",
        }
    }

    fn parse(name: &str) -> Option<Self> {
        [Transport::Serial, Transport::SharedMemory]
            .into_iter()
            .find(|t| t.name() == name)
    }
}

/// The environment variable that overrides a profile's transport (`serial`, `shared-memory`).
pub const TRANSPORT_ENV: &str = "HIL_TRANSPORT";

/// A machine profile (`qemu/<name>.toml`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QemuProfile {
    pub name: String,
    pub binary: String,
    pub machine: String,
    pub cpu: String,
    pub memory_mib: u32,
    pub icount_lockstep: String,
    pub icount_realtime: String,
    /// The link's transport (default: serial).
    #[serde(default)]
    pub transport: Transport,
    #[serde(default)]
    pub extra_args: Vec<String>,
}

#[derive(Debug, thiserror::Error)]
pub enum QemuError {
    #[error("cannot read QEMU profile {path}: {source}")]
    ProfileRead {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    ProfileInvalid { path: PathBuf, message: String },
    #[error("`{binary}` was not found on PATH.\nhint: install QEMU for PowerPC, e.g. `sudo apt-get install -y qemu-system-ppc` (Debian/Ubuntu)")]
    Missing { binary: String },
    #[error("could not start `{binary}`: {source}")]
    Spawn {
        binary: String,
        source: std::io::Error,
    },
    #[error("QEMU exited during start-up ({status}); its output (in {log}):\n{tail}")]
    ExitedEarly {
        status: String,
        log: PathBuf,
        tail: String,
    },
    #[error("QMP: {0}")]
    Qmp(String),
    #[error("I/O error with QEMU: {0}")]
    Io(#[from] std::io::Error),
}

impl QemuProfile {
    /// Load `qemu/<name>.toml` from the repository, or a path to a profile file.
    pub fn load(name_or_path: &str) -> Result<Self, QemuError> {
        let path = if name_or_path.ends_with(".toml") {
            PathBuf::from(name_or_path)
        } else {
            repo_root()
                .join("qemu")
                .join(format!("{name_or_path}.toml"))
        };
        let text = std::fs::read_to_string(&path).map_err(|source| QemuError::ProfileRead {
            path: path.clone(),
            source,
        })?;
        let mut profile: QemuProfile =
            toml::from_str(&text).map_err(|e| QemuError::ProfileInvalid {
                path: path.clone(),
                message: e.to_string(),
            })?;
        if let Some(name) = std::env::var_os(TRANSPORT_ENV) {
            let name = name.to_string_lossy();
            profile.transport =
                Transport::parse(&name).ok_or_else(|| QemuError::ProfileInvalid {
                    path: path.clone(),
                    message: format!(
                        "{TRANSPORT_ENV}={name} is not a transport (serial, shared-memory)"
                    ),
                })?;
        }
        Ok(profile)
    }

    /// The same profile with the link over `transport`.
    pub fn with_transport(mut self, transport: Transport) -> Self {
        self.transport = transport;
        self
    }
}

/// How to start one target.
#[derive(Clone, Debug, Default)]
pub struct LaunchOptions {
    /// Pace virtual time by the wall clock (`align=on`) instead of lockstep icount.
    pub realtime: bool,
    /// File backing the emulated non-volatile memory (survives QEMU restarts).
    pub nv_file: Option<PathBuf>,
    /// Size of the non-volatile memory in bytes (power of two, 1 MiB when unset).
    pub nv_size: Option<u64>,
}

/// PIDs of every QEMU this process started and has not yet ended.
static CHILDREN: Mutex<BTreeSet<u32>> = Mutex::new(BTreeSet::new());
static SIGNAL_HANDLER: Once = Once::new();

fn kill_pid(pid: u32) {
    // SAFETY: kill(2) with a PID we spawned and have not reaped (it stays a zombie until we
    // wait, so the PID cannot have been reused).
    unsafe {
        libc::kill(pid as libc::pid_t, libc::SIGKILL);
    }
}

/// On Ctrl-C or SIGTERM: end every QEMU we started, by PID, then exit 130.
fn install_signal_handler() {
    SIGNAL_HANDLER.call_once(|| {
        let _ = ctrlc::set_handler(|| {
            if let Ok(children) = CHILDREN.lock() {
                for &pid in children.iter() {
                    kill_pid(pid);
                }
            }
            eprintln!("hil: interrupted; ended the QEMU processes it had started");
            std::process::exit(130);
        });
    });
}

/// Where a running QEMU's files are: its output log, QMP socket, serial socket and (with the
/// shared-memory transport) the link device's backing file.
#[derive(Clone, Debug)]
pub struct RunFiles {
    pub dir: PathBuf,
    pub log: PathBuf,
    pub qmp_socket: PathBuf,
    pub serial_socket: PathBuf,
    pub link_shm: PathBuf,
}

impl RunFiles {
    fn new() -> std::io::Result<Self> {
        static COUNTER: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        // Short path: a Unix socket path must stay under 108 bytes.
        let dir = std::env::temp_dir().join(format!("hil-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&dir)?;
        // In memory where the host has it: the link's rings are touched for every frame.
        let shm_dir = Path::new("/dev/shm");
        let link_shm = if shm_dir.is_dir() {
            shm_dir.join(format!("hil-{}-{n}-link", std::process::id()))
        } else {
            dir.join("link.shm")
        };
        Ok(Self {
            log: dir.join("qemu.log"),
            qmp_socket: dir.join("qmp.sock"),
            serial_socket: dir.join("serial.sock"),
            link_shm,
            dir,
        })
    }
}

/// A running (initially paused) QEMU. Dropping it ends the process by PID.
pub struct Qemu {
    child: Child,
    qmp: Qmp,
    files: RunFiles,
    transport: Transport,
}

impl Qemu {
    /// Start QEMU paused (`-S`) with `firmware` as its ROM. Connect to
    /// [`Qemu::serial_socket`] and wait for [`Qemu::wait_serial_connected`] before
    /// [`Qemu::resume`], so that no byte the target sends is lost.
    pub fn launch(
        profile: &QemuProfile,
        firmware: &Path,
        options: &LaunchOptions,
    ) -> Result<Self, QemuError> {
        let binary = find_on_path(&profile.binary).ok_or_else(|| QemuError::Missing {
            binary: profile.binary.clone(),
        })?;
        install_signal_handler();
        let files = RunFiles::new()?;
        let log = std::fs::File::create(&files.log)?;
        let mut cmd = Command::new(&binary);
        cmd.arg("-M")
            .arg(&profile.machine)
            .arg("-cpu")
            .arg(&profile.cpu)
            .arg("-m")
            .arg(profile.memory_mib.to_string())
            .arg("-bios")
            .arg(firmware)
            .arg("-icount")
            .arg(if options.realtime {
                &profile.icount_realtime
            } else {
                &profile.icount_lockstep
            })
            .arg("-S")
            .arg("-chardev")
            .arg(format!(
                "socket,id=s0,path={},server=on,wait=off",
                files.serial_socket.display()
            ))
            .args(["-serial", "chardev:s0"])
            .arg("-qmp")
            .arg(format!(
                "unix:{},server=on,wait=off",
                files.qmp_socket.display()
            ))
            .args(&profile.extra_args);
        if profile.transport == Transport::SharedMemory {
            crate::shm::MappedLink::create(&files.link_shm)?;
            cmd.arg("-object")
                .arg(format!(
                    "memory-backend-file,id=link,size={},mem-path={},share=on",
                    kernel_logic::shm_link::DEVICE_BYTES,
                    files.link_shm.display()
                ))
                .args(["-device", "ivshmem-plain,memdev=link"]);
        }
        if let Some(nv) = &options.nv_file {
            let size = options.nv_size.unwrap_or(1 << 20);
            cmd.arg("-object")
                .arg(format!(
                    "memory-backend-file,id=nv,size={size},mem-path={},share=on",
                    nv.display()
                ))
                .args(["-device", "ivshmem-plain,memdev=nv"]);
        }
        cmd.stdin(Stdio::null())
            .stdout(log.try_clone()?)
            .stderr(log);
        // SAFETY: only async-signal-safe calls between fork and exec.
        unsafe {
            cmd.pre_exec(|| {
                // Die with `hil`, even if it is killed with SIGKILL.
                libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL);
                // Own process group: a terminal's Ctrl-C reaches `hil`, which ends QEMU by PID.
                libc::setpgid(0, 0);
                Ok(())
            });
        }
        let mut child = cmd.spawn().map_err(|source| {
            let _ = std::fs::remove_file(&files.link_shm);
            QemuError::Spawn {
                binary: binary.display().to_string(),
                source,
            }
        })?;
        CHILDREN.lock().unwrap().insert(child.id());

        let qmp = match Qmp::connect(&files.qmp_socket, &mut child, &files.log) {
            Ok(qmp) => qmp,
            Err(e) => {
                end_child(&mut child);
                let _ = std::fs::remove_file(&files.link_shm);
                return Err(e);
            }
        };
        Ok(Self {
            child,
            qmp,
            files,
            transport: profile.transport,
        })
    }

    /// The link's transport.
    pub fn transport(&self) -> Transport {
        self.transport
    }

    /// The Unix socket QEMU listens on for the target's serial port (one connection).
    pub fn serial_socket(&self) -> &Path {
        &self.files.serial_socket
    }

    /// Wait until QEMU has accepted the connection to the serial socket (its chardev is no
    /// longer "disconnected"): only then does it deliver what the guest sends.
    pub fn wait_serial_connected(&mut self, timeout: Duration) -> Result<(), QemuError> {
        let deadline = Instant::now() + timeout;
        loop {
            let chardevs = self.qmp.execute("query-chardev", json!({}))?;
            let filename = chardevs
                .as_array()
                .into_iter()
                .flatten()
                .find(|c| c["label"] == "s0")
                .and_then(|c| c["filename"].as_str())
                .ok_or_else(|| QemuError::Qmp(format!("no chardev s0 in {chardevs}")))?;
            if !filename.starts_with("disconnected") {
                return Ok(());
            }
            if Instant::now() >= deadline {
                return Err(QemuError::Qmp(format!(
                    "QEMU did not accept the serial connection within {timeout:?} ({filename})"
                )));
            }
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    pub fn files(&self) -> &RunFiles {
        &self.files
    }

    /// Start (or continue) the guest CPU.
    pub fn resume(&mut self) -> Result<(), QemuError> {
        self.qmp.execute("cont", json!({})).map(drop)
    }

    /// Pause the guest CPU.
    pub fn pause(&mut self) -> Result<(), QemuError> {
        self.qmp.execute("stop", json!({})).map(drop)
    }

    /// Warm reset: QMP `system_reset`. RAM is kept; the target restarts at its reset vector.
    pub fn system_reset(&mut self) -> Result<(), QemuError> {
        self.qmp.execute("system_reset", json!({})).map(drop)
    }

    /// The guest CPU's registers (`info registers` through QMP's human monitor), as QEMU
    /// prints them: for diagnosing a target that stopped answering.
    pub fn cpu_registers(&mut self) -> Result<String, QemuError> {
        let text = self.qmp.execute(
            "human-monitor-command",
            json!({ "command-line": "info registers" }),
        )?;
        Ok(text.as_str().unwrap_or_default().to_string())
    }

    /// QMP events received so far (RESET, STOP, ...), in arrival order.
    pub fn events(&self) -> &[Value] {
        &self.qmp.events
    }

    /// Host CPU time (user and system) the QEMU process has used so far, from
    /// `/proc/<pid>/stat` (None where that is not readable).
    pub fn cpu_time(&self) -> Option<Duration> {
        process_cpu_time(self.child.id())
    }

    /// True while the QEMU process is running.
    pub fn is_running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }

    /// End the process now (power off), by PID.
    pub fn kill(mut self) {
        end_child(&mut self.child);
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        end_child(&mut self.child);
        let _ = std::fs::remove_file(&self.files.qmp_socket);
        let _ = std::fs::remove_file(&self.files.serial_socket);
        let _ = std::fs::remove_file(&self.files.link_shm);
    }
}

fn end_child(child: &mut Child) {
    let pid = child.id();
    if matches!(child.try_wait(), Ok(None)) {
        kill_pid(pid);
    }
    let _ = child.wait();
    if let Ok(mut children) = CHILDREN.lock() {
        children.remove(&pid);
    }
}

/// User plus system CPU time of process `pid` (fields 14 and 15 of `/proc/<pid>/stat`, in
/// clock ticks).
pub fn process_cpu_time(pid: u32) -> Option<Duration> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // The command name (field 2) is in parentheses and may contain spaces: count from after it.
    let rest = &stat[stat.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let utime: u64 = fields.get(11)?.parse().ok()?;
    let stime: u64 = fields.get(12)?.parse().ok()?;
    // SAFETY: sysconf has no preconditions.
    let ticks_per_second = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
    if ticks_per_second <= 0 {
        return None;
    }
    Some(Duration::from_secs_f64(
        (utime + stime) as f64 / ticks_per_second as f64,
    ))
}

fn find_on_path(binary: &str) -> Option<PathBuf> {
    if binary.contains('/') {
        let p = PathBuf::from(binary);
        return p.is_file().then_some(p);
    }
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|dir| dir.join(binary))
            .find(|p| p.is_file())
    })
}

fn log_tail(log: &Path) -> String {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(20)..].join("\n")
}

/// A QMP connection: one command at a time, events kept in arrival order.
struct Qmp {
    reader: BufReader<UnixStream>,
    writer: UnixStream,
    events: Vec<Value>,
}

impl Qmp {
    fn connect(socket: &Path, child: &mut Child, log: &Path) -> Result<Self, QemuError> {
        let deadline = Instant::now() + Duration::from_secs(20);
        let stream = loop {
            if let Ok(Some(status)) = child.try_wait() {
                return Err(QemuError::ExitedEarly {
                    status: status.to_string(),
                    log: log.to_path_buf(),
                    tail: log_tail(log),
                });
            }
            match UnixStream::connect(socket) {
                Ok(s) => break s,
                Err(_) if Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(20))
                }
                Err(e) => {
                    return Err(QemuError::Qmp(format!(
                        "no QMP socket at {} after 20 s: {e}",
                        socket.display()
                    )))
                }
            }
        };
        stream.set_read_timeout(Some(Duration::from_secs(20)))?;
        let mut qmp = Self {
            reader: BufReader::new(stream.try_clone()?),
            writer: stream,
            events: Vec::new(),
        };
        let greeting = qmp.read_message()?;
        if greeting.get("QMP").is_none() {
            return Err(QemuError::Qmp(format!("unexpected greeting {greeting}")));
        }
        qmp.execute("qmp_capabilities", json!({}))?;
        Ok(qmp)
    }

    fn read_message(&mut self) -> Result<Value, QemuError> {
        let mut line = String::new();
        if self.reader.read_line(&mut line)? == 0 {
            return Err(QemuError::Qmp("QEMU closed the QMP socket".into()));
        }
        serde_json::from_str(&line).map_err(|e| QemuError::Qmp(format!("bad JSON {line:?}: {e}")))
    }

    fn execute(&mut self, command: &str, arguments: Value) -> Result<Value, QemuError> {
        let request = json!({"execute": command, "arguments": arguments});
        writeln!(self.writer, "{request}")?;
        loop {
            let msg = self.read_message()?;
            if msg.get("event").is_some() {
                self.events.push(msg);
            } else if let Some(ret) = msg.get("return") {
                return Ok(ret.clone());
            } else if let Some(err) = msg.get("error") {
                return Err(QemuError::Qmp(format!("{command}: {err}")));
            }
        }
    }
}

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
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde::Deserialize;
use serde_json::{json, Value};

use crate::cleanup::{self, ScratchDir, ScratchFile};
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
    #[error("no QEMU profile {name:?}: the profiles built into hil are {}, and {} does not exist; name a profile file (a path ending in .toml) instead", BUILT_IN_PROFILES.map(|(n, _)| n).join(", "), .looked_at.display())]
    ProfileUnknown { name: String, looked_at: PathBuf },
    #[error("{path}: {message}")]
    ProfileInvalid { path: PathBuf, message: String },
    #[error("{0}")]
    Missing(#[from] QemuNotFound),
    #[error("could not start `{binary}`: {source}")]
    Spawn {
        binary: String,
        source: std::io::Error,
    },
    #[error("QEMU exited during start-up ({status}); the end of its output:\n{tail}")]
    ExitedEarly { status: String, tail: String },
    #[error("QMP: {0}")]
    Qmp(String),
    #[error("I/O error with QEMU: {0}")]
    Io(#[from] std::io::Error),
}

/// The profiles that ship in `qemu/`, built into `hil` so that a copied or installed `hil`
/// needs no source tree to find them: (name, TOML text).
pub const BUILT_IN_PROFILES: [(&str, &str); 2] = [
    ("rad750-proxy", include_str!("../../qemu/rad750-proxy.toml")),
    (
        "rad750-proxy-serial",
        include_str!("../../qemu/rad750-proxy-serial.toml"),
    ),
];

impl QemuProfile {
    /// A profile by name or by file. A name of a profile that ships with `hil`
    /// ([`BUILT_IN_PROFILES`], the files in `qemu/` when it was built) is that built-in copy,
    /// whatever the current checkout holds: the profile always matches the `hil` using it, and
    /// `cargo` rebuilds `hil` when a file in `qemu/` changes. A path (containing `/` or ending
    /// in `.toml`) is read from that file. Any other name is `qemu/<name>.toml` in the
    /// checkout ([`crate::repo_root`]), for profiles added locally. `HIL_TRANSPORT` then
    /// overrides the transport.
    pub fn load(name_or_path: &str) -> Result<Self, QemuError> {
        let is_path = name_or_path.ends_with(".toml") || name_or_path.contains('/');
        let built_in = BUILT_IN_PROFILES
            .iter()
            .find(|(name, _)| !is_path && *name == name_or_path);
        let (path, text) = match built_in {
            Some((name, text)) => (
                PathBuf::from(format!("qemu/{name}.toml (built into hil)")),
                text.to_string(),
            ),
            None => {
                let path = if is_path {
                    PathBuf::from(name_or_path)
                } else {
                    let path = repo_root()
                        .join("qemu")
                        .join(format!("{name_or_path}.toml"));
                    if !path.is_file() {
                        return Err(QemuError::ProfileUnknown {
                            name: name_or_path.to_string(),
                            looked_at: path,
                        });
                    }
                    path
                };
                let text =
                    std::fs::read_to_string(&path).map_err(|source| QemuError::ProfileRead {
                        path: path.clone(),
                        source,
                    })?;
                (path, text)
            }
        };
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

/// The environment variable that names the QEMU executable to run (a path, or a name looked
/// up on `PATH`), overriding the profile's `binary`.
pub const QEMU_ENV: &str = "HIL_QEMU";

/// The QEMU executable could not be found: what was asked for, where it was looked for, and
/// how to install it.
#[derive(Debug, thiserror::Error)]
#[error("{}", self.describe())]
pub struct QemuNotFound {
    /// The name or path looked for.
    pub binary: String,
    /// Where it came from: the profile's `binary`, or `HIL_QEMU`.
    pub named_by: String,
    /// The directories searched (empty when `binary` is a path).
    pub searched: Vec<PathBuf>,
}

impl QemuNotFound {
    fn describe(&self) -> String {
        let place = if self.searched.is_empty() {
            "there is no executable file at that path".to_string()
        } else {
            format!(
                "it is not an executable file in any directory on PATH (searched: {})",
                self.searched
                    .iter()
                    .map(|d| d.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        };
        format!(
            "QEMU `{}` ({}) was not found: {place}.\nhint: install QEMU for PowerPC, e.g. `sudo apt-get install -y qemu-system-ppc` (Debian/Ubuntu), or set {QEMU_ENV} to the path of a qemu-system-ppc",
            self.binary, self.named_by
        )
    }
}

/// The QEMU executable to run for `profile`: `HIL_QEMU` if set, else the profile's `binary`;
/// a name is looked up in the directories on `PATH`, a path (containing `/`) taken as it is.
pub fn find_qemu(profile: &QemuProfile) -> Result<PathBuf, QemuNotFound> {
    let (binary, named_by) = match std::env::var(QEMU_ENV) {
        Ok(value) if !value.is_empty() => (value, format!("from {QEMU_ENV}")),
        _ => (
            profile.binary.clone(),
            format!("the binary of QEMU profile {}", profile.name),
        ),
    };
    let path = std::env::var_os("PATH").unwrap_or_default();
    find_executable(&binary, &path).map_err(|searched| QemuNotFound {
        binary,
        named_by,
        searched,
    })
}

/// `binary` as `execvp` would find it in `path` (a `PATH` value; an empty entry is the current
/// directory), or the directories searched. A `binary` containing `/` is taken as it is.
fn find_executable(binary: &str, path: &std::ffi::OsStr) -> Result<PathBuf, Vec<PathBuf>> {
    use std::os::unix::fs::PermissionsExt;
    let executable = |p: &Path| {
        std::fs::metadata(p).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    };
    if binary.contains('/') {
        let p = PathBuf::from(binary);
        return if executable(&p) {
            Ok(p)
        } else {
            Err(Vec::new())
        };
    }
    let dirs: Vec<PathBuf> = std::env::split_paths(path)
        .map(|d| {
            if d.as_os_str().is_empty() {
                PathBuf::from(".")
            } else {
                d
            }
        })
        .collect();
    dirs.iter()
        .map(|d| d.join(binary))
        .find(|p| executable(p))
        .ok_or(dirs)
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

/// A running QEMU's temporary files, removed when it is dropped (see [`crate::cleanup`]): a
/// directory in the system's temporary directory with its output log, QMP socket and serial
/// socket, and (with the shared-memory transport) the link device's backing file.
#[derive(Debug)]
pub struct RunFiles {
    pub log: PathBuf,
    pub qmp_socket: PathBuf,
    pub serial_socket: PathBuf,
    /// The shared-memory link's file (created only with that transport).
    pub link_shm: PathBuf,
    /// Held to be removed on drop, before `dir` (the file may be inside it).
    _link_file: Option<ScratchFile>,
    dir: ScratchDir,
}

impl RunFiles {
    fn new(transport: Transport) -> std::io::Result<Self> {
        // Short names: a Unix socket path must stay under 108 bytes.
        let dir = ScratchDir::new("qemu")?;
        // In memory where the host has it: the link's rings are touched for every frame.
        let shm_dir = Path::new("/dev/shm");
        let link_file = match transport {
            Transport::SharedMemory if shm_dir.is_dir() => {
                Some(ScratchFile::new_in(shm_dir, "link")?)
            }
            Transport::SharedMemory => Some(ScratchFile::new_in(dir.path(), "link")?),
            Transport::Serial => None,
        };
        Ok(Self {
            log: dir.path().join("qemu.log"),
            qmp_socket: dir.path().join("qmp.sock"),
            serial_socket: dir.path().join("serial.sock"),
            link_shm: link_file
                .as_ref()
                .map_or_else(|| dir.path().join("link.shm"), |f| f.path().to_path_buf()),
            _link_file: link_file,
            dir,
        })
    }

    /// The directory that holds the log and the sockets.
    pub fn dir(&self) -> &Path {
        self.dir.path()
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
        let binary = find_qemu(profile)?;
        let files = RunFiles::new(profile.transport)?;
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
        let mut child = cmd.spawn().map_err(|source| QemuError::Spawn {
            binary: binary.display().to_string(),
            source,
        })?;
        cleanup::track_process(&child);

        let qmp = match Qmp::connect(&files.qmp_socket, &mut child, &files.log) {
            Ok(qmp) => qmp,
            Err(e) => {
                cleanup::end(&mut child);
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

    /// The last lines QEMU wrote to its standard output and error (its log file is temporary:
    /// errors quote this instead of naming the file).
    pub fn output_tail(&self) -> String {
        log_tail(&self.files.log)
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
        self.exit_status().is_none()
    }

    /// How the QEMU process ended, once it has.
    pub fn exit_status(&mut self) -> Option<std::process::ExitStatus> {
        cleanup::try_reap(&mut self.child)
    }

    /// End the process now (power off), by PID.
    pub fn kill(mut self) {
        cleanup::end(&mut self.child);
    }
}

impl Drop for Qemu {
    /// Ends the process; then its files go (the fields drop after this).
    fn drop(&mut self) {
        cleanup::end(&mut self.child);
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
            if let Some(status) = cleanup::try_reap(child) {
                return Err(QemuError::ExitedEarly {
                    status: status.to_string(),
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    #[test]
    fn every_profile_in_qemu_is_built_in_and_parses_under_its_own_name() {
        let dir = repo_root().join("qemu");
        let mut shipped: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| {
                let name = e.unwrap().file_name().to_string_lossy().into_owned();
                name.strip_suffix(".toml").map(str::to_string)
            })
            .collect();
        shipped.sort();
        let mut built_in: Vec<String> = BUILT_IN_PROFILES
            .iter()
            .map(|(n, _)| n.to_string())
            .collect();
        built_in.sort();
        assert_eq!(
            built_in, shipped,
            "qemu/*.toml and BUILT_IN_PROFILES differ"
        );
        for (name, text) in BUILT_IN_PROFILES {
            let profile: QemuProfile = toml::from_str(text).unwrap();
            assert_eq!(profile.name, name);
        }
    }

    #[test]
    fn a_profile_file_is_read_and_an_unknown_name_lists_the_built_in_ones() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("mine.toml");
        std::fs::write(
            &file,
            BUILT_IN_PROFILES[0]
                .1
                .replace("name = \"rad750-proxy\"", "name = \"mine\""),
        )
        .unwrap();
        assert_eq!(
            QemuProfile::load(file.to_str().unwrap()).unwrap().name,
            "mine"
        );
        let err = QemuProfile::load("no-such-profile")
            .unwrap_err()
            .to_string();
        assert!(err.contains("rad750-proxy, rad750-proxy-serial"), "{err}");
        assert!(err.contains("qemu/no-such-profile.toml"), "{err}");
    }

    #[test]
    fn the_first_executable_on_path_is_found_and_a_miss_lists_the_directories() {
        let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        let not_executable = a.path().join("qemu-test");
        std::fs::write(&not_executable, b"").unwrap();
        let executable = b.path().join("qemu-test");
        std::fs::write(&executable, b"").unwrap();
        std::fs::set_permissions(&executable, std::fs::Permissions::from_mode(0o755)).unwrap();
        let path = std::env::join_paths([a.path(), b.path()]).unwrap();
        assert_eq!(find_executable("qemu-test", &path), Ok(executable.clone()));
        assert_eq!(
            find_executable("qemu-other", &path),
            Err(vec![a.path().to_path_buf(), b.path().to_path_buf()])
        );
        assert_eq!(
            find_executable(executable.to_str().unwrap(), "".as_ref()),
            Ok(executable)
        );
        assert_eq!(
            find_executable(not_executable.to_str().unwrap(), &path),
            Err(Vec::new())
        );
    }
}

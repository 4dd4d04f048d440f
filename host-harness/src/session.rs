//! A session with one target: the target itself (a QEMU we started, or a real board on a serial
//! port), its link, and its decoded logs. Higher-level steps (handshake, ping, resets) live here
//! so that `hil run`, `hil bench` and the integration tests share them.
use std::time::{Duration, Instant};

use fsw_bridge::{
    HostToTarget, LinkCounters, ResetCause, ResetKind, TargetToHost, PROTOCOL_VERSION,
};

use crate::defmt_log::{LogDecoder, LogLine};
use crate::firmware::{build_id_hex, FirmwareImage};
use crate::link::{HostLink, LinkError};
use crate::qemu::{LaunchOptions, Qemu, QemuError, QemuProfile, Transport};

#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    #[error(transparent)]
    Qemu(#[from] QemuError),
    #[error(transparent)]
    Link(#[from] LinkError),
    #[error("the target said nothing it could be understood by within {} ({detail})", crate::time::fmt_wall(*waited))]
    Silent { waited: Duration, detail: String },
    #[error("protocol mismatch: the target speaks protocol v{target}, this hil speaks v{host}; build the firmware and hil from the same revision")]
    ProtocolMismatch { target: u16, host: u16 },
    #[error("firmware mismatch: the target runs build {target}, but the image given is build {expected}")]
    BuildMismatch { target: String, expected: String },
    #[error("expected {expected}, got {got}")]
    Unexpected { expected: String, got: String },
    #[error("the target panicked at {file}:{line}")]
    TargetPanic { file: String, line: u32 },
    #[error("this needs a QEMU target (not a serial device)")]
    NotQemu,
    #[error(
        "the target's QEMU (pid {pid}) ended ({status}): {what}; the end of its output: {tail:?}"
    )]
    QemuEnded {
        pid: u32,
        status: String,
        /// What failed because of it (a closed link, a silent target).
        what: String,
        tail: String,
    },
}

/// How long [`Session::qemu_ended`] gives a QEMU whose link closed to show that it exited.
pub const QEMU_EXIT_GRACE: Duration = Duration::from_millis(500);

/// What a Hello said.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Hello {
    pub build_id: [u8; 8],
    pub reset_cause: ResetCause,
    pub boot_count: u32,
    /// The kernel fault that caused the reset (reset cause KernelFault).
    pub kernel_fault: Option<fsw_bridge::KernelFault>,
}

/// One target under test.
pub struct Session {
    pub qemu: Option<Qemu>,
    pub link: HostLink,
    firmware: Option<FirmwareImage>,
    log: Option<LogDecoder>,
    /// Every decoded log line, in order.
    pub logs: Vec<LogLine>,
    /// Print log lines as they arrive.
    pub echo_logs: bool,
    /// Messages that arrived while a step waited for something else (telemetry, ...).
    pub unsolicited: Vec<TargetToHost>,
    /// Wall time from QEMU start (or port open) to now is measured from here.
    pub started: Instant,
    /// Human-readable name of the target, for messages.
    pub describe: String,
    /// The host's end of the reliable link for link checks ([`Session::recv`],
    /// [`Session::sync`]); missions run their own ([`crate::mission::link`]). Restarted at every
    /// Hello.
    endpoint: Option<Box<fsw_bridge::link::HostEndpoint>>,
    /// Messages the link delivered that nobody has taken yet.
    inbox: std::collections::VecDeque<TargetToHost>,
}

impl Session {
    /// Start QEMU paused, connect to its serial port, then let the CPU run: no byte is lost.
    pub fn boot_qemu(
        profile: &QemuProfile,
        firmware: &FirmwareImage,
        options: &LaunchOptions,
    ) -> Result<Self, SessionError> {
        let started = Instant::now();
        let mut qemu = Qemu::launch(profile, &firmware.elf, options)?;
        let link = match qemu.transport() {
            Transport::Serial => HostLink::connect_unix(qemu.serial_socket())?,
            Transport::SharedMemory => {
                HostLink::connect_shm(qemu.serial_socket(), &qemu.files().link_shm)?
            }
        };
        qemu.wait_serial_connected(Duration::from_secs(20))?;
        qemu.resume()?;
        let describe = format!(
            "{} (QEMU pid {}, link over {}, serial {})",
            profile.name,
            qemu.pid(),
            qemu.transport().name(),
            qemu.serial_socket().display(),
        );
        Ok(Self {
            qemu: Some(qemu),
            link,
            log: LogDecoder::new(&firmware.elf).ok(),
            firmware: Some(firmware.clone()),
            logs: Vec::new(),
            echo_logs: false,
            unsolicited: Vec::new(),
            started,
            describe,
            endpoint: None,
            inbox: Default::default(),
        })
    }

    /// Talk to a real target on a serial device. With `firmware`, its logs are decoded and its
    /// build id is checked.
    pub fn open_serial(
        path: &str,
        baud: u32,
        firmware: Option<&FirmwareImage>,
    ) -> Result<Self, SessionError> {
        let link = HostLink::open(path, baud)?;
        Ok(Self {
            qemu: None,
            link,
            log: firmware.and_then(|f| LogDecoder::new(&f.elf).ok()),
            firmware: firmware.cloned(),
            logs: Vec::new(),
            echo_logs: false,
            unsolicited: Vec::new(),
            started: Instant::now(),
            describe: format!("serial device {path}"),
            endpoint: None,
            inbox: Default::default(),
        })
    }

    /// The end of QEMU's output, when the target is emulated (for error messages: the log
    /// file itself is removed with the QEMU).
    pub fn qemu_output_tail(&self) -> Option<String> {
        self.qemu.as_ref().map(Qemu::output_tail)
    }

    /// If the target's QEMU has ended, that (the cause of `what`, a closed link or a silent
    /// target); None while it runs or for a serial target. A process being killed closes its
    /// sockets a moment before it can be reaped, so this waits up to [`QEMU_EXIT_GRACE`] for
    /// the exit to show.
    pub fn qemu_ended(&mut self, what: &str) -> Option<SessionError> {
        let qemu = self.qemu.as_mut()?;
        let deadline = Instant::now() + QEMU_EXIT_GRACE;
        let status = loop {
            match qemu.exit_status() {
                Some(status) => break status,
                None if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(5)),
                None => return None,
            }
        };
        Some(SessionError::QemuEnded {
            pid: qemu.pid(),
            status: status.to_string(),
            what: what.to_string(),
            tail: qemu.output_tail(),
        })
    }

    /// The next message that is not a log frame (logs are decoded and kept on the way).
    pub fn recv(&mut self, timeout: Duration) -> Result<TargetToHost, SessionError> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(msg) = self.inbox.pop_front() {
                return Ok(msg);
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(LinkError::Timeout(timeout).into());
            }
            // What the target queued travels on the reliable link in lockstep rounds.
            self.round(left).map_err(|e| match e {
                SessionError::Link(LinkError::Timeout(_)) => LinkError::Timeout(timeout).into(),
                e => e,
            })?;
        }
    }

    /// The next message the target sends outside the lockstep rounds (an expedited frame: a
    /// Hello, a Pong, a panic report, the kernel's last words before a reset), waiting up to
    /// `timeout`; logs among them are decoded and kept.
    pub fn recv_expedited(&mut self, timeout: Duration) -> Result<TargetToHost, SessionError> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let msg = self.link.recv(left)?;
            if let Some(msg) = self.take(msg)? {
                return Ok(msg);
            }
        }
    }

    /// Logs are decoded and kept, a panic report is an error, anything else is for the caller.
    fn take(&mut self, msg: TargetToHost) -> Result<Option<TargetToHost>, SessionError> {
        match msg {
            TargetToHost::Log { bytes } => {
                self.take_log(&bytes);
                Ok(None)
            }
            TargetToHost::Panic { file, line } => Err(SessionError::TargetPanic {
                file: String::from_utf8_lossy(&file).into_owned(),
                line,
            }),
            other => Ok(Some(other)),
        }
    }

    /// One lockstep round of the reliable link (no faults): the host's burst, then the
    /// target's answer up to its RoundEnd; what it delivers goes to `inbox`. A Hello restarts
    /// the link.
    fn round(&mut self, timeout: Duration) -> Result<(), SessionError> {
        use fsw_bridge::link::{HostEndpoint, LinkConfig, Received, Role};
        let endpoint = self.endpoint.get_or_insert_with(|| {
            Box::new(
                HostEndpoint::new(Role::Initiator, LinkConfig::DEFAULT)
                    .expect("the default link configuration is valid"),
            )
        });
        let mut burst: Vec<Vec<u8>> = Vec::new();
        let round = endpoint
            .produce_burst(&mut |f: &[u8]| burst.push(f.to_vec()))
            .round;
        for f in &burst {
            self.link.send_raw(f)?;
        }
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let frame = self.link.recv_frame(left)?;
            let decoded = self.link.decode(&frame);
            let Some(endpoint) = self.endpoint.as_mut() else {
                return Ok(());
            };
            match endpoint.on_frame(decoded, |_| true) {
                Received::Delivered { msg, .. } | Received::Expedited(msg) => {
                    if matches!(msg, TargetToHost::Hello { .. }) {
                        // The target restarted: so does the link.
                        self.endpoint = None;
                        self.inbox.push_back(msg);
                        return Ok(());
                    }
                    if let Some(msg) = self.take(msg)? {
                        self.inbox.push_back(msg);
                    }
                }
                Received::RoundEnd { round: r } if r == round => return Ok(()),
                _ => {}
            }
        }
    }

    /// Decode defmt log bytes the target sent, keeping (and echoing) the lines.
    pub fn take_log(&mut self, bytes: &[u8]) {
        let Some(decoder) = self.log.as_mut() else {
            return;
        };
        for line in decoder.feed(bytes) {
            if self.echo_logs {
                println!("  target: {line}");
            }
            self.logs.push(line);
        }
    }

    /// Wait for a Hello; refuse a protocol or firmware mismatch by name.
    pub fn expect_hello(&mut self, timeout: Duration) -> Result<Hello, SessionError> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let msg = match self.recv_expedited(left) {
                Ok(msg) => msg,
                Err(SessionError::Link(LinkError::Timeout(_))) => {
                    return Err(self.silent(timeout));
                }
                Err(e) => return Err(e),
            };
            if let Some(hello) = self.check_hello(&msg)? {
                // A new boot: the link starts over.
                self.endpoint = None;
                return Ok(hello);
            }
            self.unsolicited.push(msg);
        }
    }

    /// Everything the link delivered that nobody has taken with [`Session::recv`] yet.
    pub fn take_delivered(&mut self) -> Vec<TargetToHost> {
        self.inbox.drain(..).collect()
    }

    /// Link checks: run lockstep rounds of the reliable link (no faults) until both ends have
    /// nothing more to send, taking in what the target queued meanwhile: its logs (decoded and
    /// kept) and its messages (for [`Session::recv`]). At most `max_rounds` rounds, each
    /// answered within `timeout`.
    pub fn sync(&mut self, max_rounds: u32, timeout: Duration) -> Result<(), SessionError> {
        for _ in 0..max_rounds {
            self.round(timeout)?;
            if self.endpoint.as_ref().is_some_and(|e| e.is_all_settled()) {
                return Ok(());
            }
        }
        Ok(())
    }

    /// If `msg` is a Hello: what it said, or the protocol or firmware mismatch it shows.
    pub fn check_hello(&self, msg: &TargetToHost) -> Result<Option<Hello>, SessionError> {
        let TargetToHost::Hello {
            protocol_version,
            build_id,
            reset_cause,
            boot_count,
            kernel_fault,
        } = *msg
        else {
            return Ok(None);
        };
        if protocol_version != PROTOCOL_VERSION {
            return Err(SessionError::ProtocolMismatch {
                target: protocol_version,
                host: PROTOCOL_VERSION,
            });
        }
        if let Some(fw) = &self.firmware {
            if fw.build_id != build_id {
                return Err(SessionError::BuildMismatch {
                    target: build_id_hex(&build_id),
                    expected: build_id_hex(&fw.build_id),
                });
            }
        }
        Ok(Some(Hello {
            build_id,
            reset_cause,
            boot_count,
            kernel_fault,
        }))
    }

    fn silent(&self, waited: Duration) -> SessionError {
        let counters = self.link.host_counters();
        let mut detail = format!(
            "{} bytes received, {} frames decoded, {} rejected",
            self.link.bytes_received(),
            counters.frames_ok,
            counters.errors()
        );
        if let Some(tail) = self.qemu_output_tail() {
            detail.push_str(&format!("; the end of QEMU's output: {tail:?}"));
        }
        detail.push_str(&format!("; target: {}", self.describe));
        SessionError::Silent { waited, detail }
    }

    /// One ping round trip: returns the wall-clock round-trip time and the target's counters.
    pub fn ping(
        &mut self,
        seq: u32,
        timeout: Duration,
    ) -> Result<(Duration, LinkCounters), SessionError> {
        let sent = Instant::now();
        self.link.send(&HostToTarget::Ping { seq })?;
        let deadline = sent + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.recv_expedited(left)? {
                TargetToHost::Pong { seq: s, link } if s == seq => {
                    return Ok((sent.elapsed(), link))
                }
                other => self.unsolicited.push(other),
            }
        }
    }

    /// Warm reset through QMP `system_reset` (QEMU targets only).
    pub fn warm_reset_qmp(&mut self) -> Result<(), SessionError> {
        self.qemu
            .as_mut()
            .ok_or(SessionError::NotQemu)?
            .system_reset()?;
        Ok(())
    }

    /// Ask the target to reset itself over the link.
    pub fn request_reset(&mut self) -> Result<(), SessionError> {
        self.link.send(&HostToTarget::ResetRequest {
            kind: ResetKind::Warm,
        })?;
        Ok(())
    }
}

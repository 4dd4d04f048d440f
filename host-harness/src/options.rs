//! Settings from the command line that complete a scenario: where the target runs and what
//! `hil` prints. Shared by link checks ([`crate::run`]) and missions
//! ([`crate::mission::runner`]).
use std::path::PathBuf;

#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Talk to a real target on this serial device instead of QEMU.
    pub serial: Option<String>,
    pub baud: Option<u32>,
    /// Firmware ELF to boot (QEMU) or to decode logs with (serial). Default: build it.
    pub firmware: Option<PathBuf>,
    pub realtime: bool,
    /// Print the target's log lines as they arrive.
    pub echo_logs: bool,
    /// Print progress lines.
    pub verbose: bool,
    /// Run missions on the native target (the flight application compiled into hil).
    pub native: bool,
    /// Keep the emulated target's non-volatile memory image here after the run (default: it
    /// is a temporary file, gone when the run ends).
    pub keep_nv: Option<PathBuf>,
}

//! Decoding the target's defmt logs (carried in Log frames) against the firmware ELF.
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

use defmt_decoder::{DecodeError, Locations, StreamDecoder, Table};

/// One decoded log line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LogLine {
    /// Guest time since the target's last boot, as the target stamped it (e.g. "0.001234").
    pub timestamp: String,
    /// "INFO", "WARN", ...
    pub level: String,
    pub message: String,
    /// `file:line` of the log statement in the firmware source, when known.
    pub location: Option<String>,
}

impl std::fmt::Display for LogLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "[{:>12} {:<5}] {}",
            self.timestamp, self.level, self.message
        )?;
        if let Some(loc) = &self.location {
            write!(f, "  ({loc})")?;
        }
        Ok(())
    }
}

struct ParsedElf {
    table: Table,
    locations: Option<Locations>,
}

/// Tables are parsed once per ELF content and kept for the life of the process (decoders
/// borrow them). A rebuilt firmware at the same path is a different key.
fn parsed(elf: &Path) -> Result<&'static ParsedElf, String> {
    type Key = (PathBuf, usize, u64);
    static CACHE: OnceLock<Mutex<HashMap<Key, &'static ParsedElf>>> = OnceLock::new();
    let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let key = (elf.to_path_buf(), bytes.len(), fnv1a(&bytes));
    let mut cache = CACHE.get_or_init(Default::default).lock().unwrap();
    if let Some(p) = cache.get(&key) {
        return Ok(p);
    }
    let table = Table::parse(&bytes)
        .map_err(|e| format!("{}: defmt table: {e}", elf.display()))?
        .ok_or_else(|| format!("{}: no defmt data in this ELF", elf.display()))?;
    let locations = table.get_locations(&bytes).ok();
    let p: &'static ParsedElf = Box::leak(Box::new(ParsedElf { table, locations }));
    cache.insert(key, p);
    Ok(p)
}

fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// A stream decoder for one target's Log frames.
pub struct LogDecoder {
    elf: &'static ParsedElf,
    stream: Box<dyn StreamDecoder + Send + Sync + 'static>,
    /// Log frames that could not be decoded (e.g. cut by a reset).
    pub malformed: u64,
}

impl LogDecoder {
    pub fn new(elf: &Path) -> Result<Self, String> {
        let elf = parsed(elf)?;
        Ok(Self {
            elf,
            stream: elf.table.new_stream_decoder(),
            malformed: 0,
        })
    }

    /// Feed the bytes of one Log frame; returns the log lines they completed.
    pub fn feed(&mut self, bytes: &[u8]) -> Vec<LogLine> {
        self.stream.received(bytes);
        let mut lines = Vec::new();
        loop {
            match self.stream.decode() {
                Ok(frame) => {
                    let location = self.elf.locations.as_ref().and_then(|locs| {
                        locs.get(&frame.index()).map(|l| {
                            let file = l.file.display().to_string();
                            let short = file
                                .rsplit_once("/src/")
                                .map(|(_, tail)| format!("src/{tail}"))
                                .unwrap_or(file);
                            format!("{short}:{}", l.line)
                        })
                    });
                    lines.push(LogLine {
                        timestamp: frame
                            .display_timestamp()
                            .map(|t| t.to_string())
                            .unwrap_or_default(),
                        level: frame
                            .level()
                            .map(|l| l.as_str().to_uppercase())
                            .unwrap_or_else(|| "PRINT".into()),
                        message: frame.display_message().to_string(),
                        location,
                    });
                }
                Err(DecodeError::UnexpectedEof) => break,
                Err(DecodeError::Malformed) => {
                    self.malformed += 1;
                    // The rzcobs stream decoder drops the bad frame; keep going.
                }
            }
        }
        lines
    }
}

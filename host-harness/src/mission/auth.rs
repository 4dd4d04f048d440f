//! The ground's side of authenticated traffic (`sdls`, in the manner of CCSDS SDLS): the key a
//! mission signs with, its provisioning into the target's non-volatile memory before boot,
//! the host's own anti-replay sequence counter, and the deliberately bad messages scenarios
//! send to prove the target refuses them.
//!
//! Keys are 32 bytes, given as 64 hexadecimal digits (in a scenario's `[link] key`, or a key
//! file) or as a file of 32 raw bytes. Without one a mission uses [`TEST_KEY`], which is
//! public and for tests only. The key goes into the security area of the non-volatile memory
//! at [`NV_SECURITY_OFFSET`], right after the checkpoint areas, where the firmware's executive
//! partition and the native target read it.
use std::path::Path;

use fsw_bridge::{GroundCommand, HostToTarget, SecurityHeader, SecurityRefusal};
use sdls::Key;

/// The built-in test key (SPI 1): what missions sign with unless the scenario names a key.
/// It is in this source file, so it protects nothing: provision your own for a real board.
pub const TEST_KEY: Key = Key {
    spi: 1,
    bytes: *b"hil test key - not a secret (v1)",
};

/// Offset of the security area in non-volatile memory: after the checkpoint areas, whose size
/// is the warm-restart area's checkpoint part (the executive's `NV_SECURITY_OFFSET`).
pub const NV_SECURITY_OFFSET: usize =
    (kernel_config::WARM_AREA_SIZE - kernel_config::WARM_BOOT_RECORD_SIZE) as usize;
/// Bytes of the security area.
pub const NV_SECURITY_BYTES: usize = sdls::nv::SECURITY_AREA_BYTES;
/// Offset of the planner partition's security area (temporal uplinks, issue 13) in
/// non-volatile memory: at the end of its slice, after its checkpoint records. Provisioning
/// writes the same key into both areas; each has its own anti-replay counter.
pub const NV_PLANNER_SECURITY_OFFSET: usize = (kernel_config::system::PLANNER_NV.offset
    + kernel_config::system::PLANNER_NV_SECURITY_OFFSET)
    as usize;
/// Both security areas: the executive's, the planner's.
const AREAS: [usize; 2] = [NV_SECURITY_OFFSET, NV_PLANNER_SECURITY_OFFSET];

/// A key from 64 hexadecimal digits (whitespace and a leading `0x` ignored).
pub fn parse_key_hex(text: &str) -> Result<[u8; sdls::KEY_LEN], String> {
    let digits: String = text
        .trim()
        .trim_start_matches("0x")
        .chars()
        .filter(|c| !c.is_whitespace())
        .collect();
    if digits.len() != 2 * sdls::KEY_LEN || !digits.chars().all(|c| c.is_ascii_hexdigit()) {
        return Err(format!(
            "a key is {} hexadecimal digits (a 256-bit HMAC-SHA-256 key), not {:?}",
            2 * sdls::KEY_LEN,
            if digits.len() > 12 {
                format!("{}... ({} characters)", &digits[..8], digits.len())
            } else {
                digits.clone()
            }
        ));
    }
    let mut key = [0u8; sdls::KEY_LEN];
    for (i, byte) in key.iter_mut().enumerate() {
        *byte = u8::from_str_radix(&digits[2 * i..2 * i + 2], 16)
            .map_err(|e| format!("bad hexadecimal digit: {e}"))?;
    }
    Ok(key)
}

/// A key file: exactly 32 raw bytes, or 64 hexadecimal digits.
pub fn read_key_file(path: &Path) -> Result<[u8; sdls::KEY_LEN], String> {
    let bytes =
        std::fs::read(path).map_err(|e| format!("cannot read key file {}: {e}", path.display()))?;
    if bytes.len() == sdls::KEY_LEN {
        let mut key = [0u8; sdls::KEY_LEN];
        key.copy_from_slice(&bytes);
        return Ok(key);
    }
    let text = std::str::from_utf8(&bytes).map_err(|_| {
        format!(
            "key file {}: {} bytes, neither {} raw bytes nor hexadecimal text",
            path.display(),
            bytes.len(),
            sdls::KEY_LEN
        )
    })?;
    parse_key_hex(text).map_err(|e| format!("key file {}: {e}", path.display()))
}

/// Write `key`'s slot into a whole non-volatile memory image, in the executive's security
/// area and the planner's (the counter records stay: a new key starts its own counters at 0,
/// the same key keeps its counters).
pub fn provision_nv_image(nv: &mut [u8], key: &Key) -> Result<(), String> {
    let len = nv.len();
    for at in AREAS {
        let area = nv.get_mut(at..at + NV_SECURITY_BYTES).ok_or_else(|| {
            format!(
                "a non-volatile memory of {len} bytes has no room for the security area at {at:#x}"
            )
        })?;
        sdls::nv::provision(area, key).map_err(|_| "security area too small".to_string())?;
    }
    Ok(())
}

/// Provision `key` into the non-volatile memory file at `path` (QEMU's `ivshmem-plain`
/// backing file), creating it, or extending it with zeros, to `size` bytes first. Nothing
/// else in the file changes.
pub fn provision_nv_file(path: &Path, key: &Key, size: u64) -> Result<(), String> {
    use std::io::{Seek, SeekFrom, Write};
    let mut file = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .read(true)
        .write(true)
        .open(path)
        .map_err(|e| format!("cannot open {}: {e}", path.display()))?;
    let len = file
        .metadata()
        .map_err(|e| format!("{}: {e}", path.display()))?
        .len();
    let needed = (NV_PLANNER_SECURITY_OFFSET.max(NV_SECURITY_OFFSET) + NV_SECURITY_BYTES) as u64;
    if size.max(len) < needed {
        return Err(format!(
            "{}: {} bytes have no room for the security areas at {NV_SECURITY_OFFSET:#x} and {NV_PLANNER_SECURITY_OFFSET:#x}",
            path.display(),
            size.max(len)
        ));
    }
    if len < size {
        file.set_len(size)
            .map_err(|e| format!("cannot extend {}: {e}", path.display()))?;
    }
    for at in AREAS {
        file.seek(SeekFrom::Start(at as u64))
            .and_then(|_| file.write_all(&sdls::nv::key_slot(key)))
            .map_err(|e| format!("cannot write the key slot into {}: {e}", path.display()))?;
    }
    file.sync_all()
        .map_err(|e| format!("cannot write the key slot into {}: {e}", path.display()))
}

/// What the target holds in the security area of the non-volatile memory file at `path`: the
/// provisioned key's SPI and check, and the last accepted sequence number and holds.
pub fn describe_nv_file(path: &Path) -> Result<String, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let Some(area) = bytes.get(NV_SECURITY_OFFSET..NV_SECURITY_OFFSET + NV_SECURITY_BYTES) else {
        return Ok(format!(
            "{}: {} bytes, no security area (no key: authenticated traffic is refused)",
            path.display(),
            bytes.len()
        ));
    };
    let sa = sdls::SecurityAssociation::from_area(area);
    let planner = bytes
        .get(NV_PLANNER_SECURITY_OFFSET..NV_PLANNER_SECURITY_OFFSET + NV_SECURITY_BYTES)
        .map(|area| {
            let sa = sdls::SecurityAssociation::from_area(area);
            match sdls::nv::read_key_slot(area) {
                None => "; planner (temporal uplinks): no key provisioned".to_string(),
                Some(key) => format!(
                    "; planner (temporal uplinks): key SPI {} (check {:08x}), last accepted sequence {}",
                    key.spi,
                    key.check(),
                    sa.last_sequence()
                ),
            }
        })
        .unwrap_or_default();
    Ok(match sdls::nv::read_key_slot(area) {
        None => format!("{}: no key provisioned", path.display()),
        Some(key) => format!(
            "{}: key SPI {} (check {:08x}), last accepted sequence {}, ground holds {:#010x}{planner}",
            path.display(),
            key.spi,
            key.check(),
            sa.last_sequence(),
            sa.holds()
        ),
    })
}

/// The host's signing key and anti-replay counter: every uplink and ground command it sends
/// takes the next sequence number (from 1; the target's counter starts at 0).
#[derive(Clone, Debug)]
pub struct Signer {
    key: Key,
    next_sequence: u32,
}

impl Signer {
    pub fn new(key: Key) -> Self {
        Self {
            key,
            next_sequence: 1,
        }
    }

    pub fn key(&self) -> &Key {
        &self.key
    }

    /// Take the next sequence number without signing anything with it (an attack's: a
    /// number the target has not seen, never used again).
    pub fn burn_sequence(&mut self) -> u32 {
        self.take_sequence()
    }

    fn take_sequence(&mut self) -> u32 {
        let sequence = self.next_sequence;
        self.next_sequence = self.next_sequence.wrapping_add(1);
        sequence
    }

    /// `image` secured for uplink (header, image, MAC) with the next sequence number.
    pub fn sign_uplink(&mut self, image: &[u8]) -> (u32, Vec<u8>) {
        let sequence = self.take_sequence();
        (sequence, secure_uplink(&self.key, sequence, image))
    }

    /// A temporal planning task secured (header, task, MAC over the job and `config` too:
    /// `sdls::temporal`) with the next sequence number.
    pub fn sign_temporal(
        &mut self,
        job: u16,
        config: &fsw_bridge::temporal::TemporalConfig,
        task: &[u8],
    ) -> (u32, Vec<u8>) {
        let sequence = self.take_sequence();
        (
            sequence,
            secure_temporal(&self.key, sequence, job, config, task),
        )
    }

    /// `command` authenticated with the next sequence number.
    pub fn sign_command(&mut self, command: GroundCommand) -> (u32, HostToTarget) {
        let sequence = self.take_sequence();
        (
            sequence,
            authenticated_command(&self.key, sequence, command),
        )
    }
}

/// A temporal task secured with `key` and `sequence` for `job` and `config`.
pub fn secure_temporal(
    key: &Key,
    sequence: u32,
    job: u16,
    config: &fsw_bridge::temporal::TemporalConfig,
    task: &[u8],
) -> Vec<u8> {
    let mut out = vec![0u8; task.len() + sdls::uplink::OVERHEAD];
    let n = sdls::temporal::sign_into(key, sequence, job, config, task, &mut out)
        .expect("the buffer is sized for the secured task");
    out.truncate(n);
    out
}

/// `image` secured with `key` and `sequence`.
pub fn secure_uplink(key: &Key, sequence: u32, image: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; image.len() + sdls::uplink::OVERHEAD];
    let n = sdls::uplink::sign_into(key, sequence, image, &mut out)
        .expect("the buffer is sized for the image");
    out.truncate(n);
    out
}

/// A ground command message signed with `key` and `sequence`.
pub fn authenticated_command(key: &Key, sequence: u32, command: GroundCommand) -> HostToTarget {
    let header = SecurityHeader {
        spi: key.spi,
        sequence,
    };
    let mac = sdls::command_mac(key, &header, &command);
    HostToTarget::GroundCommand {
        header,
        command,
        mac: heapless::Vec::from_slice(&mac).expect("a MAC fits its field"),
    }
}

/// A deliberately bad authenticated message, and the refusal the target must answer it with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Attack {
    /// Properly signed, then one bit of the protected data flipped: `BadMac`.
    Forged,
    /// The last accepted message of its kind again, byte for byte: `Replay`.
    Replayed,
    /// Signed with another key under the provisioned key's SPI: `BadMac`.
    WrongKey,
    /// Signed with the right key under another SPI: `UnknownKey`.
    UnknownKey,
    /// Properly signed, then cut short (the uplink's last byte, or the command's MAC's last
    /// four): `Truncated`.
    Truncated,
}

impl Attack {
    pub const ALL: [Attack; 5] = [
        Attack::Forged,
        Attack::Replayed,
        Attack::WrongKey,
        Attack::UnknownKey,
        Attack::Truncated,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Attack::Forged => "forged",
            Attack::Replayed => "replayed",
            Attack::WrongKey => "wrong-key",
            Attack::UnknownKey => "unknown-key",
            Attack::Truncated => "truncated",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|a| a.name() == name)
    }

    /// The refusal the target owes this attack.
    pub fn expected(self) -> SecurityRefusal {
        match self {
            Attack::Forged | Attack::WrongKey => SecurityRefusal::BadMac,
            Attack::Replayed => SecurityRefusal::Replay,
            Attack::UnknownKey => SecurityRefusal::UnknownKey,
            Attack::Truncated => SecurityRefusal::Truncated,
        }
    }

    /// Another key than `key`, under the same SPI (every byte changed).
    fn wrong_key(key: &Key) -> Key {
        Key {
            spi: key.spi,
            bytes: key.bytes.map(|b| b ^ 0xa5),
        }
    }

    /// Another SPI than `key`'s, with the same key bytes.
    fn unknown_key(key: &Key) -> Key {
        Key {
            spi: key.spi.wrapping_add(1),
            bytes: key.bytes,
        }
    }

    /// The attack's secured uplink of `image`. `sequence` is a number the target has not
    /// accepted yet (for every attack but the replay, which resends `last_accepted`: the bytes
    /// of the last uplink it accepted).
    pub fn uplink(self, key: &Key, sequence: u32, image: &[u8], last_accepted: &[u8]) -> Vec<u8> {
        match self {
            Attack::Forged => {
                let mut bytes = secure_uplink(key, sequence, image);
                // A bit in the middle of the image.
                let at = sdls::uplink::HEADER_LEN + image.len() / 2;
                bytes[at] ^= 0x01;
                bytes
            }
            Attack::Replayed => last_accepted.to_vec(),
            Attack::WrongKey => secure_uplink(&Self::wrong_key(key), sequence, image),
            Attack::UnknownKey => secure_uplink(&Self::unknown_key(key), sequence, image),
            Attack::Truncated => {
                let mut bytes = secure_uplink(key, sequence, image);
                bytes.pop();
                bytes
            }
        }
    }

    /// The attack's ground command (see [`Self::uplink`]; a replay resends `last_accepted`).
    pub fn command(
        self,
        key: &Key,
        sequence: u32,
        command: GroundCommand,
        last_accepted: &HostToTarget,
    ) -> HostToTarget {
        match self {
            Attack::Forged => {
                let mut msg = authenticated_command(key, sequence, command);
                if let HostToTarget::GroundCommand { command, .. } = &mut msg {
                    *command = match *command {
                        GroundCommand::SetHold(h) => GroundCommand::SetHold(h ^ 1),
                        GroundCommand::ReleaseHold(h) => GroundCommand::ReleaseHold(h ^ 1),
                        GroundCommand::NoOp => GroundCommand::SetHold(0),
                    };
                }
                msg
            }
            Attack::Replayed => last_accepted.clone(),
            Attack::WrongKey => authenticated_command(&Self::wrong_key(key), sequence, command),
            Attack::UnknownKey => authenticated_command(&Self::unknown_key(key), sequence, command),
            Attack::Truncated => {
                let mut msg = authenticated_command(key, sequence, command);
                if let HostToTarget::GroundCommand { mac, .. } = &mut msg {
                    mac.truncate(mac.len() - 4);
                }
                msg
            }
        }
    }
}

/// The name of an `UplinkNak` reason code: a security refusal, a transfer error, or a
/// validation code.
pub fn uplink_reason_name(code: u16) -> String {
    use flight_app::uplink_reason;
    if let Some(reason) = SecurityRefusal::from_code(code) {
        return reason.name().to_string();
    }
    match code {
        uplink_reason::OUT_OF_SEQUENCE => "out-of-sequence".into(),
        uplink_reason::TOO_LARGE => "too-large".into(),
        uplink_reason::BUSY => "busy".into(),
        uplink_reason::BAD_TOTAL => "bad-total".into(),
        other => format!("validation code {other:#06x}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_keys_parse_and_bad_ones_say_what_a_key_is() {
        let hex = "00112233445566778899aabbccddeeff00112233445566778899AABBCCDDEEFF";
        let key = parse_key_hex(hex).unwrap();
        assert_eq!(key[..4], [0x00, 0x11, 0x22, 0x33]);
        assert_eq!(key[31], 0xff);
        assert_eq!(parse_key_hex(&format!(" 0x{hex}\n")).unwrap(), key);
        let err = parse_key_hex("abcd").unwrap_err();
        assert!(err.contains("64 hexadecimal digits"), "{err}");
        assert!(parse_key_hex(&hex.replace('0', "g")).is_err());
    }

    #[test]
    fn a_provisioned_nv_file_holds_the_key_at_the_executives_offset_and_keeps_the_rest() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("nv.bin");
        std::fs::write(&path, [0x5au8; 16]).unwrap();
        provision_nv_file(&path, &TEST_KEY, 1 << 20).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(bytes.len(), 1 << 20);
        assert_eq!(bytes[..16], [0x5a; 16], "bytes before the area are kept");
        let area = &bytes[NV_SECURITY_OFFSET..NV_SECURITY_OFFSET + NV_SECURITY_BYTES];
        assert_eq!(sdls::nv::read_key_slot(area), Some(TEST_KEY));
        let planner =
            &bytes[NV_PLANNER_SECURITY_OFFSET..NV_PLANNER_SECURITY_OFFSET + NV_SECURITY_BYTES];
        assert_eq!(sdls::nv::read_key_slot(planner), Some(TEST_KEY));
        let shown = describe_nv_file(&path).unwrap();
        assert!(
            shown.contains("key SPI 1") && shown.contains("planner (temporal uplinks): key SPI 1"),
            "{shown}"
        );
        // The offset is the executive's: right after the warm area's checkpoint part.
        assert_eq!(NV_SECURITY_OFFSET, 0x1_0000 - 64);
    }

    #[test]
    fn each_attack_is_refused_by_the_target_with_its_own_reason() {
        let image = b"a task network image".to_vec();
        let mut area = [0u8; NV_SECURITY_BYTES];
        sdls::nv::provision(&mut area, &TEST_KEY).unwrap();
        let mut sa = sdls::SecurityAssociation::from_area(&area);
        let mut signer = Signer::new(TEST_KEY);
        let (seq, accepted) = signer.sign_uplink(&image);
        assert!(sa.check_uplink(&accepted).is_ok());
        assert_eq!(
            sa.accept(seq, 0, None),
            Err(SecurityRefusal::CounterNotStored)
        );
        struct Mem<'a>(&'a mut [u8; NV_SECURITY_BYTES]);
        impl sdls::SecurityStore for Mem<'_> {
            fn read(&mut self, a: &mut [u8; NV_SECURITY_BYTES]) -> Result<(), sdls::StoreError> {
                a.copy_from_slice(self.0);
                Ok(())
            }
            fn write(&mut self, o: usize, b: &[u8]) -> Result<(), sdls::StoreError> {
                self.0[o..o + b.len()].copy_from_slice(b);
                Ok(())
            }
        }
        sa.accept(seq, 0, Some(&mut Mem(&mut area))).unwrap();
        for attack in Attack::ALL {
            let bytes = attack.uplink(&TEST_KEY, seq + 1, &image, &accepted);
            assert_eq!(
                sa.check_uplink(&bytes).map(|_| ()),
                Err(attack.expected()),
                "uplink {attack:?}"
            );
        }
        let (cseq, command) = signer.sign_command(GroundCommand::SetHold(2));
        let HostToTarget::GroundCommand { header, mac, .. } = &command else {
            unreachable!()
        };
        sa.check_command(header, &GroundCommand::SetHold(2), mac)
            .unwrap();
        sa.accept(cseq, 0b100, Some(&mut Mem(&mut area))).unwrap();
        for attack in Attack::ALL {
            let HostToTarget::GroundCommand {
                header,
                command: c,
                mac,
            } = attack.command(&TEST_KEY, cseq + 1, GroundCommand::SetHold(2), &command)
            else {
                unreachable!()
            };
            assert_eq!(
                sa.check_command(&header, &c, &mac),
                Err(attack.expected()),
                "command {attack:?}"
            );
        }
    }
}

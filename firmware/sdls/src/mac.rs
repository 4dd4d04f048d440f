//! The security trailer: HMAC-SHA-256 over a service byte, the security header and the
//! protected data, computed by the host and checked (in constant time) by the target.
//!
//! What a MAC covers, byte for byte (integers big-endian, as CCSDS sends them):
//!
//! | service       | MAC input                                                              |
//! |---------------|------------------------------------------------------------------------|
//! | uplink        | `0x01`, the image's security header (SPI, sequence, length), the image |
//! | ground command| `0x02`, SPI, sequence, [`command_bytes`]                                |
//! | temporal task | `0x03`, job, [`crate::temporal::config_bytes`], the secured task's header |
//! |               | (SPI, sequence, length), the compiled task ([`crate::temporal`])         |
use fsw_bridge::security::MAC_LEN;
use fsw_bridge::{GroundCommand, SecurityHeader};
use hmac::{Hmac, Mac};
use sha2::Sha256;

use crate::Key;

/// What a MAC protects: the first byte of its input, so that a tag made for one service is
/// never valid for another.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Service {
    Uplink = 1,
    GroundCommand = 2,
    /// A temporal planning task for the planner partition ([`crate::temporal`]).
    Temporal = 3,
}

pub(crate) type HmacSha256 = Hmac<Sha256>;

pub(crate) fn keyed(key: &[u8]) -> Option<HmacSha256> {
    // HMAC takes keys of any length, so this never fails; it is not unwrapped all the same.
    <HmacSha256 as Mac>::new_from_slice(key).ok()
}

/// HMAC-SHA-256 of the concatenation of `parts` under `key`.
pub fn tag(key: &[u8], parts: &[&[u8]]) -> [u8; MAC_LEN] {
    let mut out = [0; MAC_LEN];
    if let Some(mut mac) = keyed(key) {
        for part in parts {
            mac.update(part);
        }
        out.copy_from_slice(&mac.finalize().into_bytes());
    }
    out
}

/// True iff `mac` is the whole HMAC-SHA-256 of `parts` under `key`, compared in constant time.
pub fn verify(key: &[u8], parts: &[&[u8]], mac: &[u8]) -> bool {
    let Some(mut computed) = keyed(key) else {
        return false;
    };
    for part in parts {
        computed.update(part);
    }
    // `verify_slice` refuses a tag of another length and compares in constant time.
    computed.verify_slice(mac).is_ok()
}

/// Bytes of the SPI and sequence number as the MAC covers them.
pub const HEADER_BYTES: usize = 6;

/// The SPI and the sequence number, big-endian.
pub fn header_bytes(header: &SecurityHeader) -> [u8; HEADER_BYTES] {
    let mut out = [0; HEADER_BYTES];
    out[..2].copy_from_slice(&header.spi.to_be_bytes());
    out[2..].copy_from_slice(&header.sequence.to_be_bytes());
    out
}

/// Most bytes [`command_bytes`] gives.
pub const COMMAND_BYTES_MAX: usize = 2;

/// The canonical bytes of a ground command that its MAC covers: an opcode byte (0 NoOp,
/// 1 SetHold, 2 ReleaseHold) and the argument, if any. Fixed here rather than taken from the
/// wire encoding so that a change of serialisation can never change what was signed.
pub fn command_bytes(command: &GroundCommand) -> ([u8; COMMAND_BYTES_MAX], usize) {
    match *command {
        GroundCommand::NoOp => ([0, 0], 1),
        GroundCommand::SetHold(hold) => ([1, hold], 2),
        GroundCommand::ReleaseHold(hold) => ([2, hold], 2),
    }
}

/// The security trailer of a ground command.
pub fn command_mac(key: &Key, header: &SecurityHeader, command: &GroundCommand) -> [u8; MAC_LEN] {
    let (bytes, len) = command_bytes(command);
    tag(
        &key.bytes,
        &[
            &[Service::GroundCommand as u8],
            &header_bytes(header),
            &bytes[..len],
        ],
    )
}

/// True iff `mac` is the trailer [`command_mac`] gives under `key`.
pub fn verify_command_mac(
    key: &Key,
    header: &SecurityHeader,
    command: &GroundCommand,
    mac: &[u8],
) -> bool {
    let (bytes, len) = command_bytes(command);
    verify(
        &key.bytes,
        &[
            &[Service::GroundCommand as u8],
            &header_bytes(header),
            &bytes[..len],
        ],
        mac,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// RFC 4231, test case 2 (key "Jefe").
    #[test]
    fn the_tag_is_rfc_4231_hmac_sha_256() {
        let expected = [
            0x5b, 0xdc, 0xc1, 0x46, 0xbf, 0x60, 0x75, 0x4e, 0x6a, 0x04, 0x24, 0x26, 0x08, 0x95,
            0x75, 0xc7, 0x5a, 0x00, 0x3f, 0x08, 0x9d, 0x27, 0x39, 0x83, 0x9d, 0xec, 0x58, 0xb9,
            0x64, 0xec, 0x38, 0x43,
        ];
        let parts: [&[u8]; 2] = [b"what do ya want ", b"for nothing?"];
        assert_eq!(tag(b"Jefe", &parts), expected);
        assert!(verify(b"Jefe", &parts, &expected));
        assert!(!verify(b"Jefe", &parts, &expected[..31]));
        let mut flipped = expected;
        flipped[31] ^= 1;
        assert!(!verify(b"Jefe", &parts, &flipped));
    }

    #[test]
    fn a_command_mac_binds_the_service_the_header_and_the_command() {
        let key = Key {
            spi: 1,
            bytes: [7; 32],
        };
        let header = SecurityHeader {
            spi: 1,
            sequence: 5,
        };
        let mac = command_mac(&key, &header, &GroundCommand::SetHold(3));
        assert!(verify_command_mac(
            &key,
            &header,
            &GroundCommand::SetHold(3),
            &mac
        ));
        assert!(!verify_command_mac(
            &key,
            &header,
            &GroundCommand::ReleaseHold(3),
            &mac
        ));
        assert!(!verify_command_mac(
            &key,
            &header,
            &GroundCommand::SetHold(4),
            &mac
        ));
        let later = SecurityHeader {
            sequence: 6,
            ..header
        };
        assert!(!verify_command_mac(
            &key,
            &later,
            &GroundCommand::SetHold(3),
            &mac
        ));
        let other_key = Key {
            spi: 1,
            bytes: [8; 32],
        };
        assert!(!verify_command_mac(
            &other_key,
            &header,
            &GroundCommand::SetHold(3),
            &mac
        ));
        // The same bytes under the uplink service give another tag.
        let (bytes, len) = command_bytes(&GroundCommand::SetHold(3));
        let as_uplink = tag(
            &key.bytes,
            &[
                &[Service::Uplink as u8],
                &header_bytes(&header),
                &bytes[..len],
            ],
        );
        assert_ne!(as_uplink, mac);
    }
}

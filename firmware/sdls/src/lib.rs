//! Authenticated task-network uplinks and ground commands, in the manner of CCSDS SDLS
//! (355.0-B, authentication only): the protected data travels between a security header and a
//! security trailer, the target checks the trailer's MAC with a key held in its non-volatile
//! memory and refuses anything whose anti-replay sequence number it has seen before. The target
//! (`flight-app`) verifies with this crate and the host (`hil`) signs with it, so both compute
//! the same bytes. no_std, no heap, no panics on input.
//!
//! # Decisions
//!
//! - **Algorithm**: HMAC-SHA-256 (RustCrypto `hmac` 0.12 + `sha2` 0.10, no default features;
//!   both build for `powerpc-unknown-linux-gnu` without std), 32-byte keys, the full 32-byte
//!   tag as the trailer ([`fsw_bridge::security::MAC_LEN`]). The MAC is compared in constant
//!   time (`Mac::verify_slice`).
//! - **Security association**: one per board: one key slot with its security parameter index
//!   (SPI) and one anti-replay counter shared by uplinks and ground commands. The MAC input
//!   starts with a service byte ([`Service`]), so an uplink's MAC can never pass for a
//!   command's and the other way round.
//! - **Anti-replay**: a message is fresh iff its sequence number is greater than the last one
//!   accepted (gaps are allowed: the ground may burn numbers). The reliable link delivers in
//!   order, so no reordering window is needed. The check comes after the MAC (a forged
//!   message never learns or moves anything).
//! - **Order of checks** (each with its [`SecurityRefusal`]): no key provisioned (`NoKey`),
//!   shorter than header and trailer or than the announced length (`Truncated`), longer than
//!   announced (`BadLength`), SPI not the provisioned one (`UnknownKey`), MAC (`BadMac`),
//!   sequence number (`Replay`). Then the new counter is written to non-volatile memory
//!   (`CounterNotStored` if that fails) and only then does the message take effect, so a reset
//!   at any point can never make an accepted message acceptable again. A message refused by
//!   a security check changes nothing at all.
//! - **Where the data is**: an uplink protects the whole reassembled task-network image; its
//!   header and trailer travel in the chunks with it ([`uplink`]), and the target verifies after
//!   reassembly, before validation and loading. A ground command carries them as fields of
//!   `HostToTarget::GroundCommand`; its MAC covers [`command_bytes`].
//! - **Non-volatile memory** ([`nv`]): a key slot and two counter records (A/B, each with a
//!   CRC-32 and a generation number), in a 128-byte security area the integrator places after
//!   the checkpoint areas. A torn counter write leaves the other record whole. The counter
//!   records are bound to the key (a 32-bit key check): provisioning a new key starts a new
//!   association with its counter at 0; provisioning the same key again keeps the counter, so
//!   re-provisioning never re-opens old traffic to replay. The key slot stores the key check as
//!   provisioning computed it, so that a boot whose counter record carries that check need not
//!   hash the key (see [`SecurityAssociation::from_area`]: any other case is hashed as before).
//! - **No key, no traffic**: a board without non-volatile memory, or without a valid key slot,
//!   refuses every authenticated uplink and command with `NoKey`. There is no build option that
//!   accepts unauthenticated uplinks: `hil` provisions a key (the scenario's, or its built-in
//!   test key) before every boot, so nothing needs one.
//! - **Ground holds**: `SetHold(h)` / `ReleaseHold(h)` are recorded (a 32-bit mask, bit `h`) in
//!   the same counter record as the sequence number, so the counter and the command's effect
//!   are written by one record write: after a reset both are back, or neither moved.
#![no_std]
#![forbid(unsafe_code)]

pub mod association;
pub mod mac;
pub mod nv;
pub mod temporal;
pub mod uplink;

pub use association::{SecurityAssociation, SecurityStore, StoreError};
pub use fsw_bridge::security::{SecurityRefusal, MAC_LEN};
pub use mac::{command_bytes, command_mac, Service, COMMAND_BYTES_MAX};

/// Bytes of a key (HMAC-SHA-256 takes any length; ours are 256 bits).
pub const KEY_LEN: usize = 32;

/// A key and the security parameter index that names it.
#[derive(Clone, PartialEq, Eq)]
pub struct Key {
    pub spi: u16,
    pub bytes: [u8; KEY_LEN],
}

impl core::fmt::Debug for Key {
    /// Never prints the key itself.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "Key {{ spi: {}, check: {:08x} }}",
            self.spi,
            self.check()
        )
    }
}

impl Key {
    /// The key check stored with the counter records (and printed instead of the key): the
    /// first four bytes of HMAC-SHA-256(key, "sdls key check"), big-endian.
    pub fn check(&self) -> u32 {
        let tag = mac::tag(&self.bytes, &[b"sdls key check"]);
        u32::from_be_bytes([tag[0], tag[1], tag[2], tag[3]])
    }
}

//! The wire types of authenticated traffic, in the manner of CCSDS SDLS (355.0-B): a security
//! header (the security parameter index naming the key, and the anti-replay sequence number)
//! and a security trailer (the MAC) around the protected data, the ground commands that travel
//! that way, and the typed reasons the target gives for refusing them.
//!
//! Only the data lives here; computing and checking MACs, the key and the counters in
//! non-volatile memory are the `sdls` crate's (`firmware/sdls`), so this crate stays free of
//! cryptography. A task-network uplink carries its header and trailer inside the reassembled
//! image (`sdls::uplink` gives the byte layout); a ground command carries them as fields of
//! [`crate::HostToTarget::GroundCommand`].
use serde::{Deserialize, Serialize};

/// Bytes of the security trailer: a full HMAC-SHA-256 tag (no truncation).
pub const MAC_LEN: usize = 32;

/// Ground-hold flags the target keeps: `SetHold(h)` and `ReleaseHold(h)` take `h` below this.
pub const MAX_GROUND_HOLDS: u8 = 32;

/// SDLS security header: which security association (key) protects the data and its
/// anti-replay sequence number.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct SecurityHeader {
    /// Security parameter index: names the key (the target holds one, provisioned with its SPI).
    pub spi: u16,
    /// Anti-replay sequence number: the target accepts only numbers greater than the last one
    /// it accepted (gaps allowed), and stores the new one before acting.
    pub sequence: u32,
}

/// A command from the ground, authenticated ([`crate::HostToTarget::GroundCommand`]). New kinds
/// are appended at the end (postcard encodes the variant index; `sdls::command_bytes` gives
/// the bytes the MAC covers).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum GroundCommand {
    /// Does nothing but exercise the path: verified, counted, acknowledged.
    NoOp,
    /// Raise ground hold `h` (below [`MAX_GROUND_HOLDS`]). The autonomy has no hold flags yet:
    /// the target records the hold (in non-volatile memory, with the anti-replay counter) and
    /// acknowledges it.
    SetHold(u8),
    /// Release ground hold `h`.
    ReleaseHold(u8),
}

/// Why the target refused an authenticated uplink or ground command before acting on it.
/// Appended only (postcard encodes the variant index; [`SecurityRefusal::code`] is the
/// `UplinkNak` reason).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum SecurityRefusal {
    /// No key is provisioned (or the board has no non-volatile memory to hold one).
    NoKey,
    /// The security header names a key (SPI) the target does not hold.
    UnknownKey,
    /// Shorter than its security header and trailer, or than the length its header announces
    /// (an uplink), or a MAC shorter than [`MAC_LEN`].
    Truncated,
    /// The MAC does not match: forged or altered data, or signed with another key.
    BadMac,
    /// Authentic, but its sequence number is not greater than the last one accepted. (Once
    /// `u32::MAX` has been accepted every number is a replay: provision a new key.)
    Replay,
    /// Longer than the length its header announces (an uplink with trailing bytes).
    BadLength,
    /// Authentic and fresh, but the new anti-replay counter could not be written to
    /// non-volatile memory, so the target did not act on it (acting would allow a replay after
    /// a reset).
    CounterNotStored,
}

impl SecurityRefusal {
    /// Number of reasons (size of per-reason counters).
    pub const COUNT: usize = 7;

    /// Every reason, in index order.
    pub const ALL: [SecurityRefusal; SecurityRefusal::COUNT] = [
        SecurityRefusal::NoKey,
        SecurityRefusal::UnknownKey,
        SecurityRefusal::Truncated,
        SecurityRefusal::BadMac,
        SecurityRefusal::Replay,
        SecurityRefusal::BadLength,
        SecurityRefusal::CounterNotStored,
    ];

    /// First `UplinkNak` reason code of the security refusals (the transfer's own codes are
    /// 0xff01-0xff04, validation codes stay below 0xff00).
    pub const FIRST_CODE: u16 = 0xff10;

    /// Index into per-reason arrays.
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The `UplinkNak` reason code: [`Self::FIRST_CODE`] + index.
    pub const fn code(self) -> u16 {
        Self::FIRST_CODE + self as u16
    }

    /// The reason an `UplinkNak` code names, if it is a security refusal.
    pub fn from_code(code: u16) -> Option<Self> {
        let index = code.checked_sub(Self::FIRST_CODE)?;
        Self::ALL.get(usize::from(index)).copied()
    }

    /// Name for reports and scenario files.
    pub const fn name(self) -> &'static str {
        match self {
            SecurityRefusal::NoKey => "no-key",
            SecurityRefusal::UnknownKey => "unknown-key",
            SecurityRefusal::Truncated => "truncated",
            SecurityRefusal::BadMac => "bad-mac",
            SecurityRefusal::Replay => "replay",
            SecurityRefusal::BadLength => "bad-length",
            SecurityRefusal::CounterNotStored => "counter-not-stored",
        }
    }
}

/// Why the target refused a ground command ([`crate::TargetToHost::GroundCommandNak`]).
/// Appended only.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum CommandRefusal {
    /// Refused by the security checks: nothing was done and no counter moved.
    Security(SecurityRefusal),
    /// Authentic and fresh (its sequence number is spent), but the hold number is not below
    /// [`MAX_GROUND_HOLDS`]: nothing was done.
    HoldOutOfRange,
}

impl CommandRefusal {
    /// Name for reports.
    pub const fn name(self) -> &'static str {
        match self {
            CommandRefusal::Security(reason) => reason.name(),
            CommandRefusal::HoldOutOfRange => "hold-out-of-range",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refusal_codes_round_trip_and_stay_clear_of_the_transfer_codes() {
        for reason in SecurityRefusal::ALL {
            assert_eq!(SecurityRefusal::from_code(reason.code()), Some(reason));
            assert_eq!(SecurityRefusal::ALL[reason.index()], reason);
            assert!(reason.code() > 0xff04);
        }
        assert_eq!(SecurityRefusal::from_code(0xff04), None);
        assert_eq!(
            SecurityRefusal::from_code(SecurityRefusal::FIRST_CODE + SecurityRefusal::COUNT as u16),
            None
        );
    }
}

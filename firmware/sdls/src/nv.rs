//! The security area in non-volatile memory: where the key and the anti-replay counter live.
//! The integrator places it (the firmware and `hil` put it right after the checkpoint A/B
//! areas, at `NV_CHECKPOINT_BYTES`); offsets here are relative to its start.
//!
//! ```text
//! offset  bytes  record
//! 0       64     key slot      "SKEY", version 2, 0, SPI, key (32), key check (4), zeros (16),
//!                               CRC-32 of 0..60
//! 64      32     counter A     "SCTR", generation, last sequence, holds, key check, zeros (8),
//! 96      32     counter B                                               CRC-32 of 0..28
//! ```
//!
//! Integers are big-endian; the CRC is the link's CRC-32 (ISO-HDLC). A record whose magic or
//! CRC is wrong does not exist. Of the two counter records the valid one with the higher
//! generation is current; a write goes to the other slot with the generation one higher, so a
//! write torn by a reset leaves the current record whole. A counter record whose key check is
//! not the provisioned key's ([`crate::Key::check`]) belongs to an earlier key and counts as
//! absent (the new key's association starts at sequence 0, no holds).
//!
//! The key slot carries the key's check ([`crate::Key::check`], an HMAC-SHA-256 of four
//! compressions, about 19,000 instructions on the 750) as provisioning computed it, under the
//! slot's CRC, so that a boot need not hash the key again to match it with the counter record
//! (see [`crate::SecurityAssociation::from_area`]: a boot trusts the stored check only when it
//! is the counter record's, and computes it otherwise). A version 1 slot (no stored check,
//! bytes 40..60 zero) is still read; its check is computed at every boot.
use fsw_bridge::codec::LINK_CRC;

use crate::{Key, KEY_LEN};

/// Bytes of the security area.
pub const SECURITY_AREA_BYTES: usize = 128;
/// Bytes of the key slot, at offset 0.
pub const KEY_SLOT_BYTES: usize = 64;
/// Bytes of one counter record.
pub const COUNTER_RECORD_BYTES: usize = 32;
/// Offset of counter record A; B follows it.
pub const COUNTER_A_OFFSET: usize = KEY_SLOT_BYTES;
const _: () =
    assert!(COUNTER_A_OFFSET + 2 * COUNTER_RECORD_BYTES <= SECURITY_AREA_BYTES && KEY_LEN == 32);

const KEY_MAGIC: [u8; 4] = *b"SKEY";
/// The version provisioning writes: the slot carries the key check.
const KEY_VERSION: u8 = 2;
/// The version before the key check was stored (still read).
const KEY_VERSION_WITHOUT_CHECK: u8 = 1;
/// Where the key check is in a version 2 slot.
pub(crate) const KEY_CHECK_AT: usize = 8 + KEY_LEN;
const COUNTER_MAGIC: [u8; 4] = *b"SCTR";

fn crc_ok(record: &[u8]) -> bool {
    let (body, crc) = record.split_at(record.len() - 4);
    LINK_CRC.checksum(body).to_be_bytes() == crc
}

pub(crate) fn seal(record: &mut [u8]) {
    let at = record.len() - 4;
    let crc = LINK_CRC.checksum(&record[..at]);
    record[at..].copy_from_slice(&crc.to_be_bytes());
}

/// The key slot holding `key` and its check, as provisioning writes it (version 2).
pub fn key_slot(key: &Key) -> [u8; KEY_SLOT_BYTES] {
    let mut slot = [0u8; KEY_SLOT_BYTES];
    slot[0..4].copy_from_slice(&KEY_MAGIC);
    slot[4] = KEY_VERSION;
    slot[6..8].copy_from_slice(&key.spi.to_be_bytes());
    slot[8..8 + KEY_LEN].copy_from_slice(&key.bytes);
    slot[KEY_CHECK_AT..KEY_CHECK_AT + 4].copy_from_slice(&key.check().to_be_bytes());
    seal(&mut slot);
    slot
}

/// The key a key slot holds, if it is a valid one.
pub fn read_key_slot(slot: &[u8]) -> Option<Key> {
    read_key_slot_and_check(slot).map(|(key, _)| key)
}

/// The key a key slot holds and the key check stored with it (None in a version 1 slot), if
/// the slot is valid. The stored check is what provisioning computed; the slot's CRC covers it.
pub fn read_key_slot_and_check(slot: &[u8]) -> Option<(Key, Option<u32>)> {
    let slot = slot.get(..KEY_SLOT_BYTES)?;
    let version = slot[4];
    if slot[0..4] != KEY_MAGIC
        || (version != KEY_VERSION && version != KEY_VERSION_WITHOUT_CHECK)
        || !crc_ok(slot)
    {
        return None;
    }
    let mut bytes = [0u8; KEY_LEN];
    bytes.copy_from_slice(&slot[8..8 + KEY_LEN]);
    let c = &slot[KEY_CHECK_AT..KEY_CHECK_AT + 4];
    let check = (version == KEY_VERSION).then(|| u32::from_be_bytes([c[0], c[1], c[2], c[3]]));
    Some((
        Key {
            spi: u16::from_be_bytes([slot[6], slot[7]]),
            bytes,
        },
        check,
    ))
}

/// One anti-replay counter record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CounterRecord {
    /// Writes of counter records so far; the higher valid one is current.
    pub generation: u32,
    /// The last sequence number accepted (0: none yet).
    pub last_sequence: u32,
    /// Ground holds set (bit h: hold h).
    pub holds: u32,
    /// [`crate::Key::check`] of the key this counter belongs to.
    pub key_check: u32,
}

impl CounterRecord {
    pub fn encode(&self) -> [u8; COUNTER_RECORD_BYTES] {
        let mut out = [0u8; COUNTER_RECORD_BYTES];
        out[0..4].copy_from_slice(&COUNTER_MAGIC);
        out[4..8].copy_from_slice(&self.generation.to_be_bytes());
        out[8..12].copy_from_slice(&self.last_sequence.to_be_bytes());
        out[12..16].copy_from_slice(&self.holds.to_be_bytes());
        out[16..20].copy_from_slice(&self.key_check.to_be_bytes());
        seal(&mut out);
        out
    }

    /// The record `bytes` hold, if valid.
    pub fn decode(bytes: &[u8]) -> Option<Self> {
        let r = bytes.get(..COUNTER_RECORD_BYTES)?;
        if r[0..4] != COUNTER_MAGIC || !crc_ok(r) {
            return None;
        }
        let word = |at: usize| u32::from_be_bytes([r[at], r[at + 1], r[at + 2], r[at + 3]]);
        Some(Self {
            generation: word(4),
            last_sequence: word(8),
            holds: word(12),
            key_check: word(16),
        })
    }
}

/// Counter slot 0 (A) or 1 (B): its offset in the security area.
pub const fn counter_offset(slot: usize) -> usize {
    COUNTER_A_OFFSET + slot * COUNTER_RECORD_BYTES
}

/// The current counter record of `area` (a whole security area) and its slot, if either is
/// valid. Ties (never written by this crate) go to A.
pub fn current_counter(area: &[u8]) -> Option<(usize, CounterRecord)> {
    let a = area
        .get(counter_offset(0)..)
        .and_then(CounterRecord::decode);
    let b = area
        .get(counter_offset(1)..)
        .and_then(CounterRecord::decode);
    match (a, b) {
        (Some(a), Some(b)) if b.generation > a.generation => Some((1, b)),
        (Some(a), _) => Some((0, a)),
        (None, Some(b)) => Some((1, b)),
        (None, None) => None,
    }
}

/// Provision `key` into `area` (a whole security area): write its key slot. The counter
/// records are left alone: they count only for the key they were written under, so a new key
/// starts at sequence 0 and the same key keeps its counter.
pub fn provision(area: &mut [u8], key: &Key) -> Result<(), AreaTooSmall> {
    let slot = area.get_mut(..KEY_SLOT_BYTES).ok_or(AreaTooSmall)?;
    slot.copy_from_slice(&key_slot(key));
    Ok(())
}

/// The buffer given for a security area is smaller than [`SECURITY_AREA_BYTES`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AreaTooSmall;

#[cfg(test)]
mod tests {
    use super::*;

    const KEY: Key = Key {
        spi: 9,
        bytes: [3; 32],
    };

    #[test]
    fn a_provisioned_key_reads_back_and_any_damage_makes_it_absent() {
        let mut area = [0u8; SECURITY_AREA_BYTES];
        assert_eq!(read_key_slot(&area), None);
        provision(&mut area, &KEY).unwrap();
        assert_eq!(read_key_slot(&area), Some(KEY));
        for i in 0..KEY_SLOT_BYTES {
            let mut damaged = area;
            damaged[i] ^= 0x10;
            assert_eq!(read_key_slot(&damaged), None, "byte {i}");
        }
        assert_eq!(provision(&mut [0u8; 10], &KEY), Err(AreaTooSmall));
    }

    #[test]
    fn a_provisioned_slot_stores_the_key_check_and_a_version_1_slot_reads_without_it() {
        let slot = key_slot(&KEY);
        assert_eq!(slot[4], 2);
        assert_eq!(
            read_key_slot_and_check(&slot),
            Some((KEY, Some(KEY.check())))
        );
        // The slot an earlier provisioning wrote: version 1, zeros after the key.
        let mut v1 = slot;
        v1[4] = 1;
        v1[KEY_CHECK_AT..KEY_CHECK_AT + 4].fill(0);
        seal(&mut v1);
        assert_eq!(read_key_slot_and_check(&v1), Some((KEY, None)));
        assert_eq!(read_key_slot(&v1), Some(KEY));
        // Another version is no key.
        let mut v3 = slot;
        v3[4] = 3;
        seal(&mut v3);
        assert_eq!(read_key_slot_and_check(&v3), None);
    }

    #[test]
    fn the_valid_counter_record_with_the_higher_generation_is_current() {
        let mut area = [0u8; SECURITY_AREA_BYTES];
        assert_eq!(current_counter(&area), None);
        let record = |generation, last_sequence| CounterRecord {
            generation,
            last_sequence,
            holds: 1 << 3,
            key_check: 0xdead_beef,
        };
        area[counter_offset(0)..counter_offset(1)].copy_from_slice(&record(4, 40).encode());
        assert_eq!(current_counter(&area), Some((0, record(4, 40))));
        area[counter_offset(1)..counter_offset(2)].copy_from_slice(&record(5, 50).encode());
        assert_eq!(current_counter(&area), Some((1, record(5, 50))));
        // B torn: A is current again.
        area[counter_offset(1) + 9] ^= 1;
        assert_eq!(current_counter(&area), Some((0, record(4, 40))));
    }
}

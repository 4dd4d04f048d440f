//! The target's security association: the provisioned key and the anti-replay counter as read
//! from non-volatile memory at boot, the checks every authenticated message goes through, and
//! the counter write that must succeed before a message may take effect.
use fsw_bridge::security::MAC_LEN;
use fsw_bridge::{GroundCommand, SecurityHeader, SecurityRefusal};

use crate::nv::{self, CounterRecord, SECURITY_AREA_BYTES};
use crate::{mac, uplink, Key};

/// The security area could not be read or written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StoreError;

/// Where the security area lives: the target's non-volatile memory (through the kernel on the
/// board, a byte buffer natively). Offsets are relative to the area's start.
pub trait SecurityStore {
    /// Read the whole security area.
    fn read(&mut self, area: &mut [u8; SECURITY_AREA_BYTES]) -> Result<(), StoreError>;
    /// Write `bytes` at `offset`; Ok only once they are in non-volatile memory.
    fn write(&mut self, offset: usize, bytes: &[u8]) -> Result<(), StoreError>;
}

/// The key, the last accepted sequence number and the ground holds, as the target holds them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SecurityAssociation {
    key: Option<Key>,
    key_check: u32,
    last_sequence: u32,
    holds: u32,
    generation: u32,
    /// Counter slot holding the current record (the next write goes to the other).
    current_slot: Option<usize>,
}

impl Default for SecurityAssociation {
    fn default() -> Self {
        Self::none()
    }
}

impl SecurityAssociation {
    /// No key: every authenticated message is refused with `NoKey`.
    pub const fn none() -> Self {
        Self {
            key: None,
            key_check: 0,
            last_sequence: 0,
            holds: 0,
            generation: 0,
            current_slot: None,
        }
    }

    /// The association `store` holds (none without a store, or if it cannot be read).
    pub fn load(store: Option<&mut (dyn SecurityStore + '_)>) -> Self {
        let mut area = [0u8; SECURITY_AREA_BYTES];
        match store.map(|s| s.read(&mut area)) {
            Some(Ok(())) => Self::from_area(&area),
            _ => Self::none(),
        }
    }

    /// The association a security area's bytes hold.
    ///
    /// The counter record belongs to the key when its key check is the key's
    /// ([`Key::check`], an HMAC-SHA-256: about 19,000 instructions on the 750). The check
    /// stored in the key slot (under the slot's CRC, written by provisioning from the same key)
    /// is taken for it only when it is the counter record's: then the record is the key's and
    /// nothing needs hashing. Otherwise (a new key, a version 1 slot, no counter record) the
    /// check is computed and compared as before, so a stored check can never make a counter
    /// record count as absent (which would reopen old sequence numbers); the only way it could
    /// change the outcome is a slot whose CRC holds over a check that is not its key's (never
    /// written by provisioning), and then it could only keep a counter, never drop one.
    pub fn from_area(area: &[u8]) -> Self {
        let Some((key, stored_check)) = nv::read_key_slot_and_check(area) else {
            return Self::none();
        };
        let counter = nv::current_counter(area);
        let key_check = match (stored_check, counter) {
            (Some(stored), Some((_, record))) if record.key_check == stored => stored,
            _ => key.check(),
        };
        let mut sa = Self {
            key: Some(key),
            key_check,
            ..Self::none()
        };
        if let Some((slot, record)) = counter {
            // The slot is taken either way (the next write goes to the other one); a record of
            // an earlier key contributes nothing else.
            sa.current_slot = Some(slot);
            sa.generation = record.generation;
            if record.key_check == key_check {
                sa.last_sequence = record.last_sequence;
                sa.holds = record.holds;
            }
        }
        sa
    }

    pub fn has_key(&self) -> bool {
        self.key.is_some()
    }

    /// The SPI of the provisioned key.
    pub fn spi(&self) -> Option<u16> {
        self.key.as_ref().map(|k| k.spi)
    }

    /// The last sequence number accepted (0: none).
    pub fn last_sequence(&self) -> u32 {
        self.last_sequence
    }

    /// Ground holds set (bit h: hold h).
    pub fn holds(&self) -> u32 {
        self.holds
    }

    /// The provisioned key, whatever its SPI (`NoKey` without one).
    pub(crate) fn key_for_any(&self) -> Result<&Key, SecurityRefusal> {
        self.key.as_ref().ok_or(SecurityRefusal::NoKey)
    }

    pub(crate) fn key_for(&self, spi: u16) -> Result<&Key, SecurityRefusal> {
        match &self.key {
            None => Err(SecurityRefusal::NoKey),
            Some(key) if key.spi != spi => Err(SecurityRefusal::UnknownKey),
            Some(key) => Ok(key),
        }
    }

    pub(crate) fn fresh(&self, sequence: u32) -> Result<(), SecurityRefusal> {
        if sequence > self.last_sequence {
            Ok(())
        } else {
            Err(SecurityRefusal::Replay)
        }
    }

    /// Check a reassembled secured uplink (see [`crate::uplink`]); the header and the image if
    /// it is authentic and fresh. Nothing is stored: call [`Self::accept`] before loading it.
    pub fn check_uplink<'a>(
        &self,
        bytes: &'a [u8],
    ) -> Result<(SecurityHeader, &'a [u8]), SecurityRefusal> {
        if self.key.is_none() {
            return Err(SecurityRefusal::NoKey);
        }
        let secured = uplink::parse(bytes)?;
        let key = self.key_for(secured.header.spi)?;
        if !uplink::verify_mac(key, &secured) {
            return Err(SecurityRefusal::BadMac);
        }
        self.fresh(secured.header.sequence)?;
        Ok((secured.header, secured.image))
    }

    /// Check a ground command; Ok if it is authentic and fresh. Nothing is stored: call
    /// [`Self::accept`] before carrying it out.
    pub fn check_command(
        &self,
        header: &SecurityHeader,
        command: &GroundCommand,
        mac: &[u8],
    ) -> Result<(), SecurityRefusal> {
        if self.key.is_none() {
            return Err(SecurityRefusal::NoKey);
        }
        if mac.len() < MAC_LEN {
            return Err(SecurityRefusal::Truncated);
        }
        let key = self.key_for(header.spi)?;
        if !mac::verify_command_mac(key, header, command, mac) {
            return Err(SecurityRefusal::BadMac);
        }
        self.fresh(header.sequence)
    }

    /// Make `sequence` the last accepted sequence number and `holds` the ground holds: write
    /// the counter record to non-volatile memory first (into the slot that is not current, so
    /// a torn write leaves the current one whole), then take them. Call it after a check
    /// passed and before the message takes effect; on an error nothing changed and the message
    /// must not take effect.
    pub fn accept(
        &mut self,
        sequence: u32,
        holds: u32,
        store: Option<&mut (dyn SecurityStore + '_)>,
    ) -> Result<(), SecurityRefusal> {
        if self.key.is_none() {
            return Err(SecurityRefusal::NoKey);
        }
        self.fresh(sequence)?;
        let Some(store) = store else {
            return Err(SecurityRefusal::CounterNotStored);
        };
        let slot = match self.current_slot {
            Some(0) => 1,
            _ => 0,
        };
        let record = CounterRecord {
            generation: self.generation.wrapping_add(1),
            last_sequence: sequence,
            holds,
            key_check: self.key_check,
        };
        store
            .write(nv::counter_offset(slot), &record.encode())
            .map_err(|_| SecurityRefusal::CounterNotStored)?;
        self.current_slot = Some(slot);
        self.generation = record.generation;
        self.last_sequence = sequence;
        self.holds = holds;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::nv::SECURITY_AREA_BYTES;

    const KEY: Key = Key {
        spi: 7,
        bytes: [0x42; 32],
    };

    /// A security area in a byte array; `fail_writes` makes every write fail.
    struct Area {
        bytes: [u8; SECURITY_AREA_BYTES],
        fail_writes: bool,
        writes: usize,
    }

    impl Area {
        fn provisioned(key: &Key) -> Self {
            let mut bytes = [0u8; SECURITY_AREA_BYTES];
            nv::provision(&mut bytes, key).unwrap();
            Self {
                bytes,
                fail_writes: false,
                writes: 0,
            }
        }
    }

    impl SecurityStore for Area {
        fn read(&mut self, area: &mut [u8; SECURITY_AREA_BYTES]) -> Result<(), StoreError> {
            area.copy_from_slice(&self.bytes);
            Ok(())
        }
        fn write(&mut self, offset: usize, bytes: &[u8]) -> Result<(), StoreError> {
            if self.fail_writes {
                return Err(StoreError);
            }
            self.writes += 1;
            self.bytes
                .get_mut(offset..offset + bytes.len())
                .ok_or(StoreError)?
                .copy_from_slice(bytes);
            Ok(())
        }
    }

    fn secured(key: &Key, sequence: u32, image: &[u8]) -> std::vec::Vec<u8> {
        let mut out = std::vec![0u8; image.len() + uplink::OVERHEAD];
        let n = uplink::sign_into(key, sequence, image, &mut out).unwrap();
        out.truncate(n);
        out
    }

    #[test]
    fn uplinks_are_refused_with_their_typed_reason_in_the_documented_order() {
        let mut area = Area::provisioned(&KEY);
        let sa = SecurityAssociation::load(Some(&mut area));
        let good = secured(&KEY, 5, b"network");
        assert_eq!(
            sa.check_uplink(&good),
            Ok((
                SecurityHeader {
                    spi: 7,
                    sequence: 5
                },
                &b"network"[..]
            ))
        );
        // No key beats everything.
        assert_eq!(
            SecurityAssociation::none().check_uplink(&good),
            Err(SecurityRefusal::NoKey)
        );
        assert_eq!(
            SecurityAssociation::load(None).check_uplink(&good),
            Err(SecurityRefusal::NoKey)
        );
        assert_eq!(
            sa.check_uplink(&good[..good.len() - 1]),
            Err(SecurityRefusal::Truncated)
        );
        let mut long = good.clone();
        long.push(0);
        assert_eq!(sa.check_uplink(&long), Err(SecurityRefusal::BadLength));
        let other_spi = Key { spi: 8, ..KEY };
        assert_eq!(
            sa.check_uplink(&secured(&other_spi, 5, b"network")),
            Err(SecurityRefusal::UnknownKey)
        );
        let wrong_key = Key {
            bytes: [0x43; 32],
            ..KEY
        };
        assert_eq!(
            sa.check_uplink(&secured(&wrong_key, 5, b"network")),
            Err(SecurityRefusal::BadMac)
        );
        let mut forged = good.clone();
        forged[uplink::HEADER_LEN] ^= 1;
        assert_eq!(sa.check_uplink(&forged), Err(SecurityRefusal::BadMac));
        // Sequence 0 is never fresh (0 means "none accepted").
        assert_eq!(
            sa.check_uplink(&secured(&KEY, 0, b"network")),
            Err(SecurityRefusal::Replay)
        );
    }

    #[test]
    fn an_accepted_sequence_is_stored_first_and_every_number_up_to_it_is_then_a_replay() {
        let mut area = Area::provisioned(&KEY);
        let mut sa = SecurityAssociation::load(Some(&mut area));
        sa.accept(5, 0, Some(&mut area)).unwrap();
        assert_eq!(area.writes, 1);
        for seq in [1, 4, 5] {
            assert_eq!(
                sa.check_uplink(&secured(&KEY, seq, b"n")),
                Err(SecurityRefusal::Replay)
            );
        }
        assert!(sa.check_uplink(&secured(&KEY, 6, b"n")).is_ok());
        // What a reset finds in non-volatile memory is the same.
        let again = SecurityAssociation::load(Some(&mut area));
        assert_eq!(again, sa);
        assert_eq!(
            again.check_uplink(&secured(&KEY, 5, b"n")),
            Err(SecurityRefusal::Replay)
        );
        // Accepting an old number is refused too (defence in depth).
        assert_eq!(
            sa.accept(5, 0, Some(&mut area)),
            Err(SecurityRefusal::Replay)
        );
    }

    #[test]
    fn a_counter_that_cannot_be_stored_refuses_and_changes_nothing() {
        let mut area = Area::provisioned(&KEY);
        let mut sa = SecurityAssociation::load(Some(&mut area));
        area.fail_writes = true;
        let before = sa.clone();
        assert_eq!(
            sa.accept(3, 1, Some(&mut area)),
            Err(SecurityRefusal::CounterNotStored)
        );
        assert_eq!(sa, before);
        assert_eq!(
            sa.accept(3, 1, None),
            Err(SecurityRefusal::CounterNotStored)
        );
        assert_eq!(sa, before);
    }

    #[test]
    fn counter_writes_alternate_slots_so_a_torn_one_falls_back_to_the_previous() {
        let mut area = Area::provisioned(&KEY);
        let mut sa = SecurityAssociation::load(Some(&mut area));
        sa.accept(10, 0b1, Some(&mut area)).unwrap();
        sa.accept(20, 0b11, Some(&mut area)).unwrap();
        assert_eq!(nv::current_counter(&area.bytes).map(|(s, _)| s), Some(1));
        sa.accept(30, 0b111, Some(&mut area)).unwrap();
        // The write of 30 went to A; tear it: the restart has 20 and its holds.
        assert_eq!(nv::current_counter(&area.bytes).map(|(s, _)| s), Some(0));
        area.bytes[nv::counter_offset(0) + 10] ^= 0xff;
        let restarted = SecurityAssociation::load(Some(&mut area));
        assert_eq!(restarted.last_sequence(), 20);
        assert_eq!(restarted.holds(), 0b11);
        // Its next write must not overwrite the whole record (B): it goes to A.
        let mut restarted = restarted;
        restarted.accept(21, 0, Some(&mut area)).unwrap();
        assert_eq!(nv::current_counter(&area.bytes).map(|(s, _)| s), Some(0));
    }

    #[test]
    fn a_new_key_starts_a_new_counter_and_the_same_key_keeps_its_own() {
        let mut area = Area::provisioned(&KEY);
        let mut sa = SecurityAssociation::load(Some(&mut area));
        sa.accept(100, 0b100, Some(&mut area)).unwrap();
        // The same key provisioned again: the counter stays.
        nv::provision(&mut area.bytes, &KEY).unwrap();
        assert_eq!(
            SecurityAssociation::load(Some(&mut area)).last_sequence(),
            100
        );
        // A new key: sequence 0, no holds, and its counter moves on from there.
        let new_key = Key {
            bytes: [0x99; 32],
            ..KEY
        };
        nv::provision(&mut area.bytes, &new_key).unwrap();
        let mut fresh = SecurityAssociation::load(Some(&mut area));
        assert_eq!((fresh.last_sequence(), fresh.holds()), (0, 0));
        assert!(fresh.check_uplink(&secured(&new_key, 1, b"n")).is_ok());
        fresh.accept(1, 0, Some(&mut area)).unwrap();
        assert_eq!(
            SecurityAssociation::load(Some(&mut area)).last_sequence(),
            1
        );
    }

    /// The key slot of `key` with `check` stored in it (resealed), as no provisioning writes
    /// it unless `check` is the key's.
    fn slot_storing(key: &Key, check: u32) -> [u8; nv::KEY_SLOT_BYTES] {
        let mut slot = nv::key_slot(key);
        slot[nv::KEY_CHECK_AT..nv::KEY_CHECK_AT + 4].copy_from_slice(&check.to_be_bytes());
        nv::seal(&mut slot);
        slot
    }

    #[test]
    fn the_stored_key_check_is_taken_only_when_it_is_the_counters_so_it_never_drops_a_counter() {
        let mut area = Area::provisioned(&KEY);
        let mut sa = SecurityAssociation::load(Some(&mut area));
        sa.accept(100, 0b10, Some(&mut area)).unwrap();
        let load = |area: &mut Area| {
            let sa = SecurityAssociation::load(Some(area));
            (sa.last_sequence(), sa.holds())
        };
        // Provisioned (version 2): the stored check is the counter's.
        assert_eq!(load(&mut area), (100, 0b10));
        // A stored check that is not the key's nor the counter's: the check is computed, and
        // the counter is still the key's.
        area.bytes[..nv::KEY_SLOT_BYTES].copy_from_slice(&slot_storing(&KEY, 0x1234_5678));
        assert_eq!(load(&mut area), (100, 0b10));
        // A version 1 slot (no stored check): computed, the same.
        let mut v1 = nv::key_slot(&KEY);
        v1[4] = 1;
        v1[nv::KEY_CHECK_AT..nv::KEY_CHECK_AT + 4].fill(0);
        nv::seal(&mut v1);
        area.bytes[..nv::KEY_SLOT_BYTES].copy_from_slice(&v1);
        assert_eq!(load(&mut area), (100, 0b10));
        // The counter record written under it is bound to the key's real check.
        let mut sa = SecurityAssociation::load(Some(&mut area));
        sa.accept(101, 0b10, Some(&mut area)).unwrap();
        assert_eq!(
            nv::current_counter(&area.bytes).map(|(_, r)| r.key_check),
            Some(KEY.check())
        );
        // The only case where the stored check decides: a slot (never written by
        // provisioning) whose CRC holds over another key's check that is the counter's keeps
        // that counter: more sequence numbers refused, never an old one accepted again.
        let other = Key {
            bytes: [0x55; 32],
            ..KEY
        };
        area.bytes[..nv::KEY_SLOT_BYTES].copy_from_slice(&slot_storing(&other, KEY.check()));
        assert_eq!(load(&mut area), (101, 0b10));
        // Provisioned properly, the other key starts its own counter.
        nv::provision(&mut area.bytes, &other).unwrap();
        assert_eq!(load(&mut area), (0, 0));
    }

    #[test]
    fn commands_are_refused_with_their_typed_reasons() {
        let mut area = Area::provisioned(&KEY);
        let mut sa = SecurityAssociation::load(Some(&mut area));
        let header = SecurityHeader {
            spi: 7,
            sequence: 2,
        };
        let command = GroundCommand::SetHold(1);
        let mac = mac::command_mac(&KEY, &header, &command);
        assert_eq!(sa.check_command(&header, &command, &mac), Ok(()));
        assert_eq!(
            sa.check_command(&header, &command, &mac[..MAC_LEN - 1]),
            Err(SecurityRefusal::Truncated)
        );
        assert_eq!(
            sa.check_command(&header, &GroundCommand::SetHold(2), &mac),
            Err(SecurityRefusal::BadMac)
        );
        let other = SecurityHeader { spi: 3, ..header };
        assert_eq!(
            sa.check_command(&other, &command, &mac),
            Err(SecurityRefusal::UnknownKey)
        );
        assert_eq!(
            SecurityAssociation::none().check_command(&header, &command, &mac),
            Err(SecurityRefusal::NoKey)
        );
        sa.accept(2, 0b10, Some(&mut area)).unwrap();
        assert_eq!(
            sa.check_command(&header, &command, &mac),
            Err(SecurityRefusal::Replay)
        );
    }
}

//! The secured temporal planning task (issue 13, `fsw_bridge::temporal`): the byte string the
//! host cuts into `TemporalChunk`s and the planner partition reassembles, authenticates and
//! only then validates and plans.
//!
//! ```text
//! offset  bytes  field (big-endian)
//! 0       2      SPI: the key that signed it
//! 2       4      anti-replay sequence number
//! 6       4      L: bytes of the compiled task
//! 10      L      the compiled task (`temporal::Task`'s binary format)
//! 10+L    32     MAC: HMAC-SHA-256 over 0x03, the job (2 bytes), config_bytes(config) and
//!                bytes 0..10+L
//! ```
//!
//! The layout is the task-network uplink's ([`crate::uplink`]); what differs is the MAC's input:
//! the service byte [`Service::Temporal`] (a temporal task's tag never passes for a task
//! network's, nor the other way round), and the job number and the search configuration that
//! `TemporalBegin` carries outside the chunks, so that neither can be changed on the way
//! either (a changed expansion limit or dropped-goal mask would change the plan).
//!
//! The planner partition receives the task a chunk at a time and absorbs each into the MAC as
//! it arrives ([`TemporalMac`]): the check at the end costs one HMAC finalisation, and no window
//! has to hash the whole task (about 30 guest instructions a byte: an 18 KiB task hashed at
//! once would cost more than a planner window).
//!
//! Order of the checks ([`SecurityAssociation::check_temporal`]): no key (`NoKey`), shorter
//! than header and trailer or the announced length (`Truncated`), longer (`BadLength`), SPI
//! (`UnknownKey`), MAC (`BadMac`), sequence number (`Replay`): those of an uplink. Then the
//! caller stores the counter ([`SecurityAssociation::accept`]) before it takes the task.
use fsw_bridge::security::MAC_LEN;
use fsw_bridge::temporal::{TemporalConfig, TemporalDuplicates};
use fsw_bridge::{SecurityHeader, SecurityRefusal};
use hmac::Mac;

use crate::mac::{keyed, HmacSha256, Service};
use crate::uplink::{self, HEADER_LEN, OVERHEAD};
use crate::{Key, SecurityAssociation};

/// Bytes of [`config_bytes`].
pub const CONFIG_BYTES: usize = 23;

/// The canonical bytes of a search configuration that the MAC covers: every field in
/// declaration order, big-endian, booleans as 0/1, the duplicate rule as 0 Keep,
/// 1 PruneQuiescent, 2 PruneAll. Fixed here rather than taken from the wire encoding, so that
/// a change of serialisation can never change what was signed.
pub fn config_bytes(config: &TemporalConfig) -> [u8; CONFIG_BYTES] {
    let mut out = [0u8; CONFIG_BYTES];
    out[0..2].copy_from_slice(&config.max_steps.to_be_bytes());
    out[2] = u8::from(config.compression);
    out[3] = u8::from(config.preferred_operators);
    out[4] = u8::from(config.shed_when_full);
    out[5] = match config.duplicates {
        TemporalDuplicates::Keep => 0,
        TemporalDuplicates::PruneQuiescent => 1,
        TemporalDuplicates::PruneAll => 2,
    };
    out[6] = u8::from(config.duration_costs);
    out[7..15].copy_from_slice(&config.dropped_goals.to_be_bytes());
    out[15..19].copy_from_slice(&config.max_expansions.to_be_bytes());
    out[19..23].copy_from_slice(&config.max_windows.to_be_bytes());
    out
}

/// The configuration [`config_bytes`] gives those bytes for, if they are such bytes (the
/// planner partition keeps an accepted job's configuration this way, for a resume after a
/// warm reset).
pub fn config_from_bytes(b: &[u8; CONFIG_BYTES]) -> Option<TemporalConfig> {
    let flag = |x: u8| match x {
        0 => Some(false),
        1 => Some(true),
        _ => None,
    };
    let mut goals = [0u8; 8];
    goals.copy_from_slice(&b[7..15]);
    Some(TemporalConfig {
        max_steps: u16::from_be_bytes([b[0], b[1]]),
        compression: flag(b[2])?,
        preferred_operators: flag(b[3])?,
        shed_when_full: flag(b[4])?,
        duplicates: match b[5] {
            0 => TemporalDuplicates::Keep,
            1 => TemporalDuplicates::PruneQuiescent,
            2 => TemporalDuplicates::PruneAll,
            _ => return None,
        },
        duration_costs: flag(b[6])?,
        dropped_goals: u64::from_be_bytes(goals),
        max_expansions: u32::from_be_bytes([b[15], b[16], b[17], b[18]]),
        max_windows: u32::from_be_bytes([b[19], b[20], b[21], b[22]]),
    })
}

/// The MAC of a secured temporal task being received: keyed and primed with the service, the
/// job and the configuration at `TemporalBegin`, fed the covered bytes chunk by chunk.
#[derive(Clone)]
pub struct TemporalMac {
    mac: HmacSha256,
    /// Bytes the MAC covers: the announced length less the trailer.
    covered: u32,
    /// Bytes absorbed so far (from offset 0, in order).
    absorbed: u32,
    /// The offset the next chunk must start at.
    next: u32,
}

impl core::fmt::Debug for TemporalMac {
    /// Never prints the keyed state.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "TemporalMac {{ covered: {}, absorbed: {} }}",
            self.covered, self.absorbed
        )
    }
}

fn primed(key: &Key, job: u16, config: &TemporalConfig) -> Option<HmacSha256> {
    let mut mac = keyed(&key.bytes)?;
    mac.update(&[Service::Temporal as u8]);
    mac.update(&job.to_be_bytes());
    mac.update(&config_bytes(config));
    Some(mac)
}

impl TemporalMac {
    /// Absorb the chunk of the secured task at `offset`: its bytes before the trailer. Chunks
    /// must come in order from offset 0 (the planner partition refuses any other before it
    /// gets here); one out of order is not absorbed, and the MAC then fails.
    pub fn absorb(&mut self, offset: u32, bytes: &[u8]) {
        if offset != self.next {
            // Poisoned: the covered bytes can never all be absorbed now.
            self.next = u32::MAX;
            self.absorbed = u32::MAX;
            return;
        }
        let n = u32::try_from(bytes.len()).unwrap_or(u32::MAX);
        self.next = offset.saturating_add(n);
        let room = self.covered.saturating_sub(offset) as usize;
        let take = bytes.get(..room.min(bytes.len())).unwrap_or_default();
        self.mac.update(take);
        self.absorbed = self
            .absorbed
            .saturating_add(u32::try_from(take.len()).unwrap_or(u32::MAX));
    }
}

impl SecurityAssociation {
    /// Start the MAC of a secured temporal task of `len` bytes (the whole secured string) for
    /// job `job` with `config`: `NoKey` without a key. Nothing is checked or stored yet.
    pub fn begin_temporal(
        &self,
        job: u16,
        config: &TemporalConfig,
        len: u32,
    ) -> Result<TemporalMac, SecurityRefusal> {
        let key = self.key_for_any()?;
        let mac = primed(key, job, config).ok_or(SecurityRefusal::NoKey)?;
        Ok(TemporalMac {
            mac,
            covered: len.saturating_sub(MAC_LEN as u32),
            absorbed: 0,
            next: 0,
        })
    }

    /// Check a reassembled secured temporal task (`bytes`, every one absorbed into `mac` in
    /// order); its header and the compiled task if it is authentic and fresh. Nothing is
    /// stored: call [`Self::accept`] before taking it.
    pub fn check_temporal<'a>(
        &self,
        mac: TemporalMac,
        bytes: &'a [u8],
    ) -> Result<(SecurityHeader, &'a [u8]), SecurityRefusal> {
        self.key_for_any()?;
        let secured = uplink::parse(bytes)?;
        self.key_for(secured.header.spi)?;
        let complete = usize::try_from(mac.absorbed).ok() == Some(secured.covered.len())
            && mac.absorbed == mac.covered;
        if !complete || mac.mac.verify_slice(secured.mac).is_err() {
            return Err(SecurityRefusal::BadMac);
        }
        self.fresh(secured.header.sequence)?;
        Ok((secured.header, secured.image))
    }
}

/// Write the secured temporal task of `task` for job `job` with `config` (signed with `key`,
/// sequence number `sequence`) into `out`; returns its length ([`OVERHEAD`] more than the
/// task's).
pub fn sign_into(
    key: &Key,
    sequence: u32,
    job: u16,
    config: &TemporalConfig,
    task: &[u8],
    out: &mut [u8],
) -> Result<usize, uplink::TooLarge> {
    let length = u32::try_from(task.len()).map_err(|_| uplink::TooLarge)?;
    let end = task.len().checked_add(OVERHEAD).ok_or(uplink::TooLarge)?;
    let out = out.get_mut(..end).ok_or(uplink::TooLarge)?;
    out[0..2].copy_from_slice(&key.spi.to_be_bytes());
    out[2..6].copy_from_slice(&sequence.to_be_bytes());
    out[6..HEADER_LEN].copy_from_slice(&length.to_be_bytes());
    let task_end = HEADER_LEN + task.len();
    out[HEADER_LEN..task_end].copy_from_slice(task);
    let mut mac = primed(key, job, config).ok_or(uplink::TooLarge)?;
    mac.update(&out[..task_end]);
    out[task_end..].copy_from_slice(&mac.finalize().into_bytes());
    Ok(end)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use super::*;
    use crate::nv;

    const KEY: Key = Key {
        spi: 3,
        bytes: [0x6c; 32],
    };

    fn association() -> SecurityAssociation {
        let mut area = [0u8; nv::SECURITY_AREA_BYTES];
        nv::provision(&mut area, &KEY).unwrap();
        SecurityAssociation::from_area(&area)
    }

    fn signed(key: &Key, seq: u32, job: u16, config: &TemporalConfig, task: &[u8]) -> Vec<u8> {
        let mut out = std::vec![0u8; task.len() + OVERHEAD];
        let n = sign_into(key, seq, job, config, task, &mut out).unwrap();
        assert_eq!(n, out.len());
        out
    }

    /// Receive `bytes` in chunks of `chunk` bytes as the planner partition does, and check.
    fn receive(
        sa: &SecurityAssociation,
        job: u16,
        config: &TemporalConfig,
        bytes: &[u8],
        chunk: usize,
    ) -> Result<(SecurityHeader, Vec<u8>), SecurityRefusal> {
        let mut mac = sa.begin_temporal(job, config, bytes.len() as u32)?;
        for (i, c) in bytes.chunks(chunk).enumerate() {
            mac.absorb((i * chunk) as u32, c);
        }
        sa.check_temporal(mac, bytes).map(|(h, t)| (h, t.to_vec()))
    }

    #[test]
    fn a_signed_task_verifies_whatever_the_chunking_and_gives_back_its_header_and_task() {
        let sa = association();
        let config = TemporalConfig::DEFAULT;
        let task: Vec<u8> = (0..1000u32).map(|i| (i * 7) as u8).collect();
        let bytes = signed(&KEY, 9, 4, &config, &task);
        for chunk in [1, 31, 32, 128, 1041, 5000] {
            let (h, t) = receive(&sa, 4, &config, &bytes, chunk).unwrap();
            assert_eq!(
                h,
                SecurityHeader {
                    spi: 3,
                    sequence: 9
                }
            );
            assert_eq!(t, task, "chunks of {chunk}");
        }
    }

    #[test]
    fn a_changed_byte_job_or_configuration_fails_the_mac_and_the_order_is_the_uplinks() {
        let sa = association();
        let config = TemporalConfig::DEFAULT;
        let task = [0x11u8; 300];
        let bytes = signed(&KEY, 9, 4, &config, &task);
        for i in 0..bytes.len() {
            let mut forged = bytes.clone();
            forged[i] ^= 0x20;
            let r = receive(&sa, 4, &config, &forged, 128);
            if (6..10).contains(&i) {
                // The length field: the transfer is shorter or longer than it says.
                assert!(
                    matches!(
                        r,
                        Err(SecurityRefusal::Truncated | SecurityRefusal::BadLength)
                    ),
                    "byte {i}: {r:?}"
                );
            } else if i < 2 {
                assert_eq!(r, Err(SecurityRefusal::UnknownKey), "byte {i}");
            } else {
                assert_eq!(r, Err(SecurityRefusal::BadMac), "byte {i}");
            }
        }
        assert_eq!(
            receive(&sa, 5, &config, &bytes, 128),
            Err(SecurityRefusal::BadMac)
        );
        let changes: [fn(&mut TemporalConfig); 5] = [
            |c| c.max_expansions = 1,
            |c| c.dropped_goals = 1,
            |c| c.duplicates = TemporalDuplicates::PruneAll,
            |c| c.compression = false,
            |c| c.max_windows = 7,
        ];
        for change in changes {
            let mut other = config;
            change(&mut other);
            assert_ne!(config_bytes(&other), config_bytes(&config));
            assert_eq!(
                receive(&sa, 4, &other, &bytes, 128),
                Err(SecurityRefusal::BadMac)
            );
        }
        let wrong_key = Key {
            bytes: [0x6d; 32],
            ..KEY
        };
        assert_eq!(
            receive(
                &sa,
                4,
                &config,
                &signed(&wrong_key, 9, 4, &config, &task),
                128
            ),
            Err(SecurityRefusal::BadMac)
        );
        assert_eq!(
            receive(&SecurityAssociation::none(), 4, &config, &bytes, 128),
            Err(SecurityRefusal::NoKey)
        );
        assert_eq!(
            receive(&sa, 4, &config, &bytes[..bytes.len() - 1], 128),
            Err(SecurityRefusal::Truncated)
        );
        let mut long = bytes.clone();
        long.push(0);
        assert_eq!(
            receive(&sa, 4, &config, &long, 128),
            Err(SecurityRefusal::BadLength)
        );
        // Sequence 0 is never fresh.
        assert_eq!(
            receive(&sa, 4, &config, &signed(&KEY, 0, 4, &config, &task), 128),
            Err(SecurityRefusal::Replay)
        );
    }

    #[test]
    fn an_accepted_sequence_makes_the_same_task_a_replay_and_a_task_networks_tag_never_passes() {
        let mut area = [0u8; nv::SECURITY_AREA_BYTES];
        nv::provision(&mut area, &KEY).unwrap();
        struct Area<'a>(&'a mut [u8; nv::SECURITY_AREA_BYTES]);
        impl crate::SecurityStore for Area<'_> {
            fn read(
                &mut self,
                area: &mut [u8; nv::SECURITY_AREA_BYTES],
            ) -> Result<(), crate::StoreError> {
                area.copy_from_slice(self.0);
                Ok(())
            }
            fn write(&mut self, offset: usize, bytes: &[u8]) -> Result<(), crate::StoreError> {
                self.0[offset..offset + bytes.len()].copy_from_slice(bytes);
                Ok(())
            }
        }
        let mut store = Area(&mut area);
        let mut sa = SecurityAssociation::load(Some(&mut store));
        let config = TemporalConfig::DEFAULT;
        let task = [0x22u8; 200];
        let bytes = signed(&KEY, 12, 1, &config, &task);
        let (h, _) = receive(&sa, 1, &config, &bytes, 128).unwrap();
        sa.accept(h.sequence, sa.holds(), Some(&mut store)).unwrap();
        assert_eq!(
            receive(&sa, 1, &config, &bytes, 128),
            Err(SecurityRefusal::Replay)
        );
        // After a reset the counter read back refuses it too.
        let again = SecurityAssociation::load(Some(&mut store));
        assert_eq!(
            receive(&again, 1, &config, &bytes, 128),
            Err(SecurityRefusal::Replay)
        );
        // The same bytes signed as a task-network uplink: another service, another tag.
        let mut as_uplink = std::vec![0u8; task.len() + OVERHEAD];
        uplink::sign_into(&KEY, 13, &task, &mut as_uplink).unwrap();
        assert_eq!(
            receive(&again, 1, &config, &as_uplink, 128),
            Err(SecurityRefusal::BadMac)
        );
    }

    #[test]
    fn configuration_bytes_round_trip_and_bad_ones_are_none() {
        let configs = [
            TemporalConfig::DEFAULT,
            TemporalConfig {
                max_steps: 7,
                compression: false,
                preferred_operators: false,
                shed_when_full: false,
                duplicates: TemporalDuplicates::Keep,
                duration_costs: true,
                dropped_goals: 0x0102_0304_0506_0708,
                max_expansions: 99,
                max_windows: 12,
            },
            TemporalConfig {
                duplicates: TemporalDuplicates::PruneAll,
                ..TemporalConfig::DEFAULT
            },
        ];
        for c in configs {
            assert_eq!(config_from_bytes(&config_bytes(&c)), Some(c));
        }
        for (at, bad) in [(2, 2), (3, 9), (4, 0xff), (5, 3), (6, 2)] {
            let mut b = config_bytes(&TemporalConfig::DEFAULT);
            b[at] = bad;
            assert_eq!(config_from_bytes(&b), None, "byte {at} = {bad}");
        }
    }

    #[test]
    fn chunks_out_of_order_poison_the_mac() {
        let sa = association();
        let config = TemporalConfig::DEFAULT;
        let bytes = signed(&KEY, 2, 1, &config, &[5u8; 400]);
        let mut mac = sa.begin_temporal(1, &config, bytes.len() as u32).unwrap();
        mac.absorb(0, &bytes[..128]);
        mac.absorb(256, &bytes[256..384]);
        mac.absorb(128, &bytes[128..256]);
        mac.absorb(384, &bytes[384..]);
        assert_eq!(sa.check_temporal(mac, &bytes), Err(SecurityRefusal::BadMac));
    }
}

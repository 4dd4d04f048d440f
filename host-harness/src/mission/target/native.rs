//! The native target: the flight application (`firmware/flight-app`, the same code the
//! executive partition runs) and the target's end of the reliable link (what the I/O partition
//! runs) in this process, without the kernel and without QEMU. RAM is a fresh application per
//! boot; the warm-restart area and non-volatile memory are byte buffers that outlive resets
//! exactly as on the target. A mid-frame reset is modelled as a torn checkpoint write.
//!
//! The non-volatile memory has the board's layout: the checkpoint A/B areas in its first
//! `NV_CHECKPOINT_BYTES` (the executive partition's size), then the security area with the
//! key slot and the anti-replay counter records ([`crate::mission::auth::NV_SECURITY_OFFSET`]).
use std::collections::VecDeque;

use flight_app::{FlightApp, Memories, NoClock, SecurityStore, StoreError};
use fsw_bridge::codec::FrameDecoder;
use fsw_bridge::link::{LinkFrame, Received, Role, Service, SubmitError, TargetEndpoint};
use fsw_bridge::{HostToTarget, MissionTimeUs, ResetCause, TargetToHost};

use super::{Hello, MissionTarget, ResetLanding, TargetError};
use crate::defmt_log::LogLine;
use crate::mission::auth::{NV_SECURITY_BYTES, NV_SECURITY_OFFSET};
use crate::mission::link::service_of;
use crate::mission::rng::Rng;

/// Bytes of the warm-restart area given to the flight application (as on the target: the
/// checkpoint part of the area, the executive partition's slice then the planner's).
pub const WARM_AREA_BYTES: usize =
    (kernel_config::WARM_AREA_SIZE - kernel_config::WARM_BOOT_RECORD_SIZE) as usize;
/// The executive partition's slice of each memory's checkpoint part (as on the target).
const EXECUTIVE_SHARE_BYTES: usize = kernel_config::system::EXECUTIVE_WARM.len as usize;
/// Bytes of non-volatile memory given to the flight application (as on the target).
pub const NV_BYTES: usize = 1 << 20;
/// Bytes of non-volatile memory holding checkpoints (as on the target: the security area
/// follows them).
pub const NV_CHECKPOINT_BYTES: usize = NV_SECURITY_OFFSET;

/// The security area of the native non-volatile memory: a byte slice (a write is in "NV" once
/// it returns, as on the board).
struct SecurityArea<'a>(&'a mut [u8]);

impl SecurityStore for SecurityArea<'_> {
    fn read(&mut self, area: &mut [u8; NV_SECURITY_BYTES]) -> Result<(), StoreError> {
        area.copy_from_slice(self.0.get(..NV_SECURITY_BYTES).ok_or(StoreError)?);
        Ok(())
    }

    fn write(&mut self, offset: usize, bytes: &[u8]) -> Result<(), StoreError> {
        let end = offset.checked_add(bytes.len()).ok_or(StoreError)?;
        self.0
            .get_mut(offset..end)
            .ok_or(StoreError)?
            .copy_from_slice(bytes);
        Ok(())
    }
}

/// Split the native non-volatile memory as the executive partition uses it's board's: the
/// checkpoint areas, and the security area.
fn split_nv(nv: &mut [u8]) -> (&mut [u8], SecurityArea<'_>) {
    let (checkpoints, rest) = nv.split_at_mut(NV_CHECKPOINT_BYTES);
    (checkpoints, SecurityArea(&mut rest[..NV_SECURITY_BYTES]))
}

/// Build id the native target reports in its Hello.
pub const NATIVE_BUILD_ID: [u8; 8] = *b"native\0\0";

fn new_link() -> Box<TargetEndpoint> {
    Box::new(
        TargetEndpoint::new(Role::Responder, fsw_bridge::link::LinkConfig::DEFAULT)
            .expect("the default link configuration is valid"),
    )
}

/// The byte ranges (start, end) one frame's checkpoint wrote: warm-restart area, non-volatile.
type FrameWrites = (Option<(usize, usize)>, Option<(usize, usize)>);

/// Damage a [`NativeTarget`] does to its checkpoints at the next warm reset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CheckpointDamage {
    /// The reset lands while the last frame's checkpoint is written to the warm-restart area:
    /// the bytes that write covered are garbage from `offset_permille`/1000 of them on (the
    /// other slot is whole), and the non-volatile write of that frame never started (the
    /// record it wrote is invalidated, which restores exactly like the older record the slot
    /// would still hold). Garbage comes from `seed`. Only a frame's write can be torn: the
    /// checkpoint of an uplink is written before the uplink is acknowledged, so a reset after
    /// the acknowledgement and before the next frame's write finds nothing being written.
    TornWarm { offset_permille: u32, seed: u64 },
    /// The reset lands while the last frame's checkpoint is written to non-volatile memory
    /// (the warm write of that frame completed).
    TornNv { offset_permille: u32, seed: u64 },
    /// Test knob: every checkpoint is gone, in both warm slots and in NV. Recovery must fail;
    /// campaigns use it to prove their checks notice.
    DestroyAll,
}

/// The flight application in this process: what runs in the firmware's partitions, without
/// the kernel and without QEMU. RAM is a fresh `FlightApp` per boot; the warm-restart area and
/// non-volatile memory are byte buffers that outlive resets exactly as on the target.
pub struct NativeTarget {
    app: Box<FlightApp>,
    warm: Vec<u8>,
    nv: Vec<u8>,
    /// The target's end of the reliable link (what the I/O partition runs on the board).
    link: Box<TargetEndpoint>,
    decoder: FrameDecoder,
    /// Messages the application sent, waiting for room in the link's send window.
    outbox: VecDeque<TargetToHost>,
    boot_count: u32,
    next_cause: ResetCause,
    /// Damage to apply at the next warm reset (mid-frame resets, test knobs).
    pending_damage: Option<CheckpointDamage>,
    /// Mission time of the last grant delivered (for the damage log).
    last_grant: Option<fsw_bridge::MissionTimeUs>,
    /// The byte ranges the last frame's checkpoint wrote (warm, non-volatile), if the last
    /// checkpoint written was a frame's (None after an uplink's, or before any frame).
    last_frame_write: Option<FrameWrites>,
    damage_log: Vec<String>,
}

impl Default for NativeTarget {
    fn default() -> Self {
        Self::new()
    }
}

impl NativeTarget {
    pub fn new() -> Self {
        Self {
            app: new_app(),
            warm: vec![0; WARM_AREA_BYTES],
            nv: vec![0; NV_BYTES],
            link: new_link(),
            decoder: FrameDecoder::new(),
            outbox: VecDeque::new(),
            boot_count: 0,
            next_cause: ResetCause::PowerOn,
            pending_damage: None,
            last_grant: None,
            last_frame_write: None,
            damage_log: Vec::new(),
        }
    }

    /// Apply `damage` to the checkpoints at the next warm reset (once).
    pub fn damage_on_next_warm_reset(&mut self, damage: CheckpointDamage) {
        self.pending_damage = Some(damage);
    }

    /// What the damage applied so far did (one line per reset).
    pub fn damage_log(&self) -> &[String] {
        &self.damage_log
    }

    fn apply_damage(&mut self, damage: CheckpointDamage) {
        let frame = self
            .last_grant
            .map(crate::time::fmt_time)
            .unwrap_or_else(|| "-".into());
        let line = match damage {
            CheckpointDamage::DestroyAll => {
                self.warm.iter_mut().for_each(|b| *b = 0);
                self.nv[..NV_CHECKPOINT_BYTES].fill(0);
                "every checkpoint destroyed (warm slots A and B, non-volatile memory)".to_string()
            }
            CheckpointDamage::TornWarm { .. } | CheckpointDamage::TornNv { .. }
                if self.last_frame_write.is_none() =>
            {
                format!(
                    "reset after the frame at {frame}: no checkpoint write was in progress (the last one written was an uplink's, acknowledged already), nothing torn"
                )
            }
            CheckpointDamage::TornWarm {
                offset_permille,
                seed,
            } => {
                let (warm, nv) = self.last_frame_write.unwrap_or_default();
                let torn = tear_range(&mut self.warm, warm, offset_permille, seed);
                let nv = invalidate_range(&mut self.nv[..NV_CHECKPOINT_BYTES], nv);
                format!(
                    "reset during the warm checkpoint write of the frame at {frame}: {torn}; {nv}"
                )
            }
            CheckpointDamage::TornNv {
                offset_permille,
                seed,
            } => {
                let (_, nv) = self.last_frame_write.unwrap_or_default();
                let torn = tear_range(
                    &mut self.nv[..NV_CHECKPOINT_BYTES],
                    nv,
                    offset_permille,
                    seed,
                );
                format!("reset during the non-volatile checkpoint write of the frame at {frame}: {torn}")
            }
        };
        self.damage_log.push(line);
    }

    /// One message the link delivered, handed to the flight application as the executive
    /// partition does; what the application sends goes to the outbox.
    fn handle(&mut self, msg: HostToTarget) {
        if let HostToTarget::TimeGrant { now, .. } = msg {
            self.last_grant = Some(now);
        }
        // The partitions' control keys are the I/O partition's to route; this target has no
        // partitions, and its planner runs unthrottled (the reference): the planner budget
        // does not apply.
        if let HostToTarget::StateUpdate { key, .. } = msg {
            if key.0 == kernel_config::abi::control::PLANNER_BUDGET {
                return;
            }
        }
        let (checkpoints, mut security) = split_nv(&mut self.nv);
        let mut memories = Memories {
            warm: &mut self.warm,
            nv: Some(checkpoints),
            security: Some(&mut security),
        };
        let outbox = &mut self.outbox;
        let handled = self
            .app
            .handle(&msg, &mut memories, &mut NoClock, &mut |m| {
                outbox.push_back(m)
            });
        // What the checkpoint writes of this message covered, for the torn-write model.
        let writes = (self.app.take_warm_write(), self.app.take_nv_write());
        if writes != (None, None) {
            self.last_frame_write = match msg {
                HostToTarget::TimeGrant { .. } => Some(writes),
                _ => None,
            };
        }
        if !handled {
            if let HostToTarget::Ping { seq } = msg {
                self.outbox.push_back(TargetToHost::Pong {
                    seq,
                    link: self.decoder.counters(),
                });
            }
        }
    }
}

/// Overwrite the bytes of `range` (a checkpoint write) in `area` with garbage from
/// `offset_permille` of its length on.
fn tear_range(
    area: &mut [u8],
    range: Option<(usize, usize)>,
    offset_permille: u32,
    seed: u64,
) -> String {
    let Some((start, end)) = range.filter(|(s, e)| s < e && *e <= area.len()) else {
        return "that write had not started (nothing torn)".into();
    };
    let len = end - start;
    let offset = (len as u64 * u64::from(offset_permille.min(999)) / 1000) as usize;
    let mut rng = Rng::new(seed);
    for b in &mut area[start + offset..end] {
        *b = rng.next_u64() as u8;
    }
    format!(
        "slot {} torn from byte {offset} of the {len} the write covered",
        slot_of(area, start)
    )
}

/// Invalidate the record the write `range` made (its write never started: the slot's older
/// record would restore the same way as none, the other slot being newer).
fn invalidate_range(area: &mut [u8], range: Option<(usize, usize)>) -> String {
    let Some((start, _)) = range.filter(|(s, _)| s + 4 <= area.len()) else {
        return "no non-volatile write in that frame".into();
    };
    area[start..start + 4].fill(0);
    format!(
        "its non-volatile write (slot {}) never started",
        slot_of(area, start)
    )
}

/// "A" or "B": which half of an A/B checkpoint area byte `offset` is in.
fn slot_of(area: &[u8], offset: usize) -> &'static str {
    if offset < area.len() / 2 {
        "A"
    } else {
        "B"
    }
}

fn new_app() -> Box<FlightApp> {
    // FlightApp is large; build it in place on the heap rather than on the stack.
    let mut app: Box<std::mem::MaybeUninit<FlightApp>> = Box::new_uninit();
    app.write(FlightApp::with_executive_share(EXECUTIVE_SHARE_BYTES));
    // SAFETY: just initialised.
    unsafe { app.assume_init() }
}

impl MissionTarget for NativeTarget {
    fn describe(&self) -> String {
        "native (flight application compiled into hil, no QEMU)".into()
    }

    fn provision_key(&mut self, key: &sdls::Key) -> Result<(), TargetError> {
        crate::mission::auth::provision_nv_image(&mut self.nv, key).map_err(TargetError::Other)
    }

    fn boot(&mut self) -> Result<Hello, TargetError> {
        self.app = new_app();
        self.link = new_link();
        self.decoder = FrameDecoder::new();
        self.outbox.clear();
        self.boot_count += 1;
        let cause = std::mem::replace(&mut self.next_cause, ResetCause::Warm);
        let (checkpoints, mut security) = split_nv(&mut self.nv);
        let mut memories = Memories {
            warm: &mut self.warm,
            nv: Some(checkpoints),
            security: Some(&mut security),
        };
        let outbox = &mut self.outbox;
        self.app
            .boot(&mut memories, &mut NoClock, &mut |m| outbox.push_back(m));
        Ok(Hello {
            build_id: NATIVE_BUILD_ID,
            reset_cause: cause,
            boot_count: self.boot_count,
            kernel_fault: None,
        })
    }

    /// The I/O partition's part, in process: every frame of the host's burst through the
    /// target's end of the link, the delivered messages to the application in order, and at
    /// the RoundEnd the answering burst with what the application sent.
    fn round(&mut self, wire: &[Vec<u8>], round: u32) -> Result<Vec<Vec<u8>>, TargetError> {
        let mut answer = None;
        let mut delivered = Vec::new();
        for &byte in wire.iter().flatten() {
            let Some(frame) = self.decoder.push::<LinkFrame<HostToTarget>>(byte) else {
                continue;
            };
            match self.link.on_frame(frame, |_| true) {
                Received::Delivered { msg, .. } | Received::Expedited(msg) => delivered.push(msg),
                Received::RoundEnd { round } => answer = Some(round),
                _ => {}
            }
        }
        for msg in delivered {
            self.handle(msg);
        }
        let Some(answered) = answer else {
            return Err(TargetError::Other(format!(
                "the host's burst for round {round} had no RoundEnd"
            )));
        };
        let mut burst = Vec::new();
        while let Some(msg) = self.outbox.front() {
            let sent = match service_of(msg) {
                Service::Expedited => self
                    .link
                    .send_expedited(msg, &mut |f: &[u8]| burst.push(f.to_vec()))
                    .is_ok(),
                Service::Sequenced(vc) => match self.link.submit(vc, msg) {
                    Ok(_) => true,
                    // The window and its backlog are full: the rest waits for acknowledgements.
                    Err(SubmitError::Full) => break,
                    Err(_) => true,
                },
            };
            let _ = sent;
            self.outbox.pop_front();
        }
        let _ = answered;
        self.link
            .produce_burst(&mut |f: &[u8]| burst.push(f.to_vec()));
        Ok(burst)
    }

    fn warm_reset(&mut self, _at: MissionTimeUs) -> Result<ResetLanding, TargetError> {
        self.next_cause = ResetCause::Warm;
        if let Some(damage) = self.pending_damage.take() {
            self.apply_damage(damage);
        }
        Ok(ResetLanding::Now)
    }

    fn power_cycle(&mut self) -> Result<(), TargetError> {
        // RAM, including the warm-restart area, is gone; NV survives.
        self.warm.iter_mut().for_each(|b| *b = 0);
        self.boot_count = 0;
        self.next_cause = ResetCause::PowerOn;
        Ok(())
    }

    fn take_logs(&mut self) -> Vec<LogLine> {
        Vec::new()
    }

    fn counts_cycles(&self) -> bool {
        false
    }

    /// A torn checkpoint: the reset lands while the last frame's checkpoint is being written,
    /// to the warm-restart area (3 in 4) or to non-volatile memory, at a seeded offset.
    fn arm_mid_frame_reset(&mut self, seed: u64) {
        let mut rng = Rng::new(seed).fork(0x70);
        let offset_permille = rng.below(1000) as u32;
        let garbage = rng.next_u64();
        self.pending_damage = Some(if rng.below(4) < 3 {
            CheckpointDamage::TornWarm {
                offset_permille,
                seed: garbage,
            }
        } else {
            CheckpointDamage::TornNv {
                offset_permille,
                seed: garbage,
            }
        });
    }

    fn reset_notes(&self) -> Vec<String> {
        self.damage_log.clone()
    }
}

//! The restore choice at boot (issue 15): warm-restart area and non-volatile memory are written
//! under one sequence number per checkpoint, and boot takes the newest whole record of either
//! whose payload validates, comparing numbers with wrap-around as the A/B slot choice does.
use autonomy::checkpoint::{records, WarmRestartArea};
use autonomy::scenarios::{ATTITUDE_KEY, NADIR};
use flight_app::{
    BootOutcome, FlightApp, Memories, NoClock, SecurityStore, StoreError, MAX_UPLINK_BYTES,
};
use fsw_bridge::messages::UPLINK_CHUNK_MAX;
use fsw_bridge::{HostToTarget, MissionTimeUs, StateValue, TargetToHost};

const AREA: usize = 16 * 1024;
/// The executive's share of each memory (`FlightApp::new` splits them in half; the planner's
/// checkpoints are in the other half).
const EXEC: usize = AREA / 2;

fn new_app() -> Box<FlightApp> {
    Box::new(FlightApp::new())
}

fn send(app: &mut FlightApp, mem: &mut Memories<'_>, msg: &HostToTarget) -> Vec<TargetToHost> {
    let mut out = Vec::new();
    app.handle(msg, mem, &mut NoClock, &mut |m| out.push(m));
    out
}

fn grant(frame: u32, minutes: u64) -> HostToTarget {
    HostToTarget::TimeGrant {
        frame,
        now: MissionTimeUs::from_mins(minutes),
        until: MissionTimeUs::from_mins(minutes + 1),
    }
}

/// A security area holding `KEY` (the anti-replay counter and holds as a fresh board has them).
struct ProvisionedNv([u8; sdls::nv::SECURITY_AREA_BYTES]);

impl SecurityStore for ProvisionedNv {
    fn read(&mut self, area: &mut [u8; sdls::nv::SECURITY_AREA_BYTES]) -> Result<(), StoreError> {
        area.copy_from_slice(&self.0);
        Ok(())
    }
    fn write(&mut self, offset: usize, bytes: &[u8]) -> Result<(), StoreError> {
        self.0
            .get_mut(offset..offset + bytes.len())
            .ok_or(StoreError)?
            .copy_from_slice(bytes);
        Ok(())
    }
}

const KEY: sdls::Key = sdls::Key {
    spi: 3,
    bytes: [0x5c; 32],
};

/// Boots `app` on `mem` (still empty: it comes up cold) with `KEY` provisioned, and uplinks the
/// flyby secured with sequence number 1; the network must load.
fn uplink_flyby(app: &mut FlightApp, mem: &mut Memories<'_>) {
    let mut area = [0u8; sdls::nv::SECURITY_AREA_BYTES];
    sdls::nv::provision(&mut area, &KEY).unwrap();
    let mut store = ProvisionedNv(area);
    let mut mem = Memories {
        warm: &mut *mem.warm,
        nv: mem.nv.as_deref_mut(),
        security: Some(&mut store),
    };
    assert_eq!(
        app.boot(&mut mem, &mut NoClock, &mut |_| {}),
        BootOutcome::Cold
    );
    let network = autonomy::scenarios::flyby_network().unwrap();
    let mut image = vec![0u8; MAX_UPLINK_BYTES];
    let len = network.encode(&mut image).unwrap();
    let mut secured = vec![0u8; len + sdls::uplink::OVERHEAD];
    let len = sdls::uplink::sign_into(&KEY, 1, &image[..len], &mut secured).unwrap();
    let chunks: Vec<&[u8]> = secured[..len].chunks(UPLINK_CHUNK_MAX).collect();
    let mut out = Vec::new();
    for (seq, c) in chunks.iter().enumerate() {
        let msg = HostToTarget::UplinkChunk {
            seq: seq as u16,
            total: chunks.len() as u16,
            bytes: heapless::Vec::from_slice(c).unwrap(),
        };
        out = send(app, &mut mem, &msg);
    }
    assert_eq!(
        out.last(),
        Some(&TargetToHost::UplinkAck {
            seq: chunks.len() as u16
        })
    );
}

/// Checkpoint payloads of the flyby at 9:50 + `frames` minutes, one per frame.
fn flyby_payloads(frames: u64) -> Vec<Vec<u8>> {
    let (mut warm, mut nv) = (vec![0u8; AREA], vec![0u8; AREA]);
    let mut mem = Memories {
        warm: &mut warm,
        nv: Some(&mut nv),
        security: None,
    };
    let mut app = new_app();
    uplink_flyby(&mut app, &mut mem);
    (0..frames)
        .map(|f| {
            send(&mut app, &mut mem, &grant(f as u32, 590 + f));
            records(&mem.warm[..EXEC])[0].unwrap().payload.to_vec()
        })
        .collect()
}

/// Writes `payload` into the executive's share of `area` as a record with sequence number
/// `sequence`.
fn put(area: &mut [u8], sequence: u32, payload: &[u8]) {
    let area = &mut area[..EXEC];
    WarmRestartArea::new(area)
        .write_after(Some(sequence.wrapping_sub(1)), |buf| {
            buf[..payload.len()].copy_from_slice(payload);
            Some(payload.len())
        })
        .unwrap();
    assert_eq!(records(area)[0].unwrap().sequence, sequence);
}

fn boot(warm: &mut [u8], nv: &mut [u8]) -> (BootOutcome, Box<FlightApp>) {
    let mut app = new_app();
    let mut mem = Memories {
        warm,
        nv: Some(nv),
        security: None,
    };
    let outcome = app.boot(&mut mem, &mut NoClock, &mut |_| {});
    (outcome, app)
}

fn restored(outcome: BootOutcome) -> (&'static str, u32) {
    match outcome {
        BootOutcome::RestoredWarm(i) => ("warm", i.sequence),
        BootOutcome::RestoredNv(i) => ("nv", i.sequence),
        BootOutcome::Cold => ("cold", 0),
    }
}

#[test]
fn the_newer_memory_wins_across_the_sequence_number_wrap() {
    let payloads = flyby_payloads(2);
    let (older, newer) = (&payloads[0], &payloads[1]);
    // Non-volatile memory holds the newer checkpoint, numbered 0 after u32::MAX.
    let (mut warm, mut nv) = (vec![0u8; AREA], vec![0u8; AREA]);
    put(&mut warm, u32::MAX, older);
    put(&mut nv, 0, newer);
    let (outcome, app) = boot(&mut warm, &mut nv);
    assert_eq!(restored(outcome), ("nv", 0));
    assert_eq!(
        app.executive().executive().now(),
        MissionTimeUs::from_mins(591)
    );
    // And the other way round.
    let (mut warm, mut nv) = (vec![0u8; AREA], vec![0u8; AREA]);
    put(&mut warm, 0, newer);
    put(&mut nv, u32::MAX, older);
    assert_eq!(restored(boot(&mut warm, &mut nv).0), ("warm", 0));
    // Without a wrap the larger number is newer.
    let (mut warm, mut nv) = (vec![0u8; AREA], vec![0u8; AREA]);
    put(&mut warm, 7, older);
    put(&mut nv, 8, newer);
    assert_eq!(restored(boot(&mut warm, &mut nv).0), ("nv", 8));
}

#[test]
fn both_memories_carry_one_sequence_number_per_checkpoint_even_after_a_power_cycle() {
    let (mut warm, mut nv) = (vec![0u8; AREA], vec![0u8; AREA]);
    let newest = |area: &[u8]| records(&area[..EXEC])[0].map(|r| r.sequence);
    {
        let mut mem = Memories {
            warm: &mut warm,
            nv: Some(&mut nv),
            security: None,
        };
        let mut app = new_app();
        uplink_flyby(&mut app, &mut mem);
        for f in 0..5 {
            send(&mut app, &mut mem, &grant(f, 590 + u64::from(f)));
        }
    }
    // The uplink's, and two per frame (the executive's first and second windows).
    assert_eq!(newest(&warm), Some(11));
    assert_eq!(newest(&nv), Some(11));
    // Power cycle: the warm area is gone, the plan comes back from non-volatile memory.
    warm.fill(0);
    let (outcome, mut app) = boot(&mut warm, &mut nv);
    assert_eq!(restored(outcome), ("nv", 11));
    let mut mem = Memories {
        warm: &mut warm,
        nv: Some(&mut nv),
        security: None,
    };
    send(&mut app, &mut mem, &grant(5, 600));
    // The warm area continues the numbering instead of starting again at 1.
    assert_eq!(newest(mem.warm), Some(13));
    assert_eq!(newest(mem.nv.as_deref().unwrap()), Some(13));
}

#[test]
fn a_torn_non_volatile_write_after_a_power_cycle_does_not_hide_the_newer_warm_checkpoint() {
    let (mut warm, mut nv) = (vec![0u8; AREA], vec![0u8; AREA]);
    {
        let mut mem = Memories {
            warm: &mut warm,
            nv: Some(&mut nv),
            security: None,
        };
        let mut app = new_app();
        uplink_flyby(&mut app, &mut mem);
        for f in 0..40 {
            send(&mut app, &mut mem, &grant(f, 590 + u64::from(f)));
        }
    }
    warm.fill(0); // power cycle
    let (_, mut app) = boot(&mut warm, &mut nv);
    {
        let mut mem = Memories {
            warm: &mut warm,
            nv: Some(&mut nv),
            security: None,
        };
        for f in 40..43 {
            send(&mut app, &mut mem, &grant(f, 590 + u64::from(f)));
        }
    }
    // The last frame's non-volatile write is torn: its record is not whole.
    let torn = records(&nv[..EXEC])[0].unwrap();
    let at = usize::from(torn.slot) * (EXEC / 2) + 40;
    nv[at] ^= 0xff;
    assert_eq!(records(&nv[..EXEC])[0].unwrap().sequence, 86);
    assert_eq!(records(&warm[..EXEC])[0].unwrap().sequence, 87);
    // The warm area has the newest whole checkpoint: frame 42's second window's.
    let (outcome, app) = boot(&mut warm, &mut nv);
    assert_eq!(restored(outcome), ("warm", 87));
    assert_eq!(
        app.executive().executive().now(),
        MissionTimeUs::from_mins(590 + 42)
    );
}

#[test]
fn a_refused_record_falls_back_to_the_next_newest_of_either_memory() {
    let payloads = flyby_payloads(3);
    let mut refused = payloads[2].clone();
    refused.push(0); // CRC-valid once written, but bytes after the end: refused
    let (mut warm, mut nv) = (vec![0u8; AREA], vec![0u8; AREA]);
    put(&mut warm, 10, &payloads[0]);
    put(&mut warm, 12, &refused);
    put(&mut nv, 11, &payloads[1]);
    let (outcome, app) = boot(&mut warm, &mut nv);
    assert_eq!(restored(outcome), ("nv", 11));
    assert_eq!(
        app.executive().executive().now(),
        MissionTimeUs::from_mins(591)
    );
    // Nothing valid anywhere: cold, waiting for an uplink.
    let (mut warm, mut nv) = (vec![0u8; AREA], vec![0u8; AREA]);
    put(&mut warm, 12, &refused);
    put(&mut nv, 12, &refused);
    let (outcome, app) = boot(&mut warm, &mut nv);
    assert_eq!(outcome, BootOutcome::Cold);
    assert!(app.planner().partition().planner().entries().is_empty());
    assert_eq!(app.executive().executive().next_wakeup(), None);
}

#[test]
fn a_restored_application_runs_on_from_the_checkpoint_it_chose() {
    let payloads = flyby_payloads(2);
    let (mut warm, mut nv) = (vec![0u8; AREA], vec![0u8; AREA]);
    put(&mut warm, u32::MAX - 1, &payloads[0]);
    put(&mut warm, u32::MAX, &payloads[1]);
    let (outcome, mut app) = boot(&mut warm, &mut nv);
    assert_eq!(restored(outcome), ("warm", u32::MAX));
    let mut mem = Memories {
        warm: &mut warm,
        nv: Some(&mut nv),
        security: None,
    };
    send(
        &mut app,
        &mut mem,
        &HostToTarget::StateUpdate {
            key: ATTITUDE_KEY,
            value: StateValue::Enum(NADIR),
            timestamp: MissionTimeUs::from_mins(592),
        },
    );
    let out = send(&mut app, &mut mem, &grant(9, 592));
    assert!(matches!(
        out.last(),
        Some(TargetToHost::FrameDone { frame: 9, .. })
    ));
    // The next checkpoints are numbered across the wrap, in both memories: the frame's two,
    // and one more for the round that brought the planner (cold: its share is empty) up to
    // date.
    assert_eq!(records(&mem.warm[..EXEC])[0].unwrap().sequence, 2);
    assert_eq!(
        records(&mem.nv.as_deref().unwrap()[..EXEC])[0]
            .unwrap()
            .sequence,
        2
    );
}

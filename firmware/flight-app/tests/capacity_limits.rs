//! What bounds a network the application can carry at the lander capacities (issue 14 item 6):
//! the uplink buffer ([`MAX_UPLINK_BYTES`]) and a checkpoint slot of the warm-restart area.
//! Over either is an error value that reaches the host, never a crash: an uplink too large is
//! refused with `UplinkNak { reason: TOO_LARGE }` and the running network stays; a plan whose
//! checkpoint does not fit a slot is flown on, each failed write counted in the
//! `CHECKPOINT_WRITE_FAILURES` metric.
//!
//! `--nocapture` prints the sizes the README quotes.
use autonomy::scenarios::{synthetic_into, SyntheticShape};
use autonomy::{NetworkSpec, PlannerConfig};
use flight_app::{
    metric, uplink_reason, BootOutcome, FlightApp, Memories, NoClock, SecurityStore, StoreError,
    MAX_UPLINK_BYTES,
};
use fsw_bridge::messages::UPLINK_CHUNK_MAX;
use fsw_bridge::{HostToTarget, MissionTimeUs, TargetToHost, TelemetryEvent};

/// The target's checkpoint memory for the flight application: the executive partition's slice
/// of the warm-restart area (its A/B records; the planner partition has the rest).
const WARM_CHECKPOINT_BYTES: usize = kernel_config::system::EXECUTIVE_WARM.len as usize;
/// The whole checkpoint part of the warm-restart area: the executive's slice, then the
/// planner's.
const WARM_BYTES: usize = WARM_CHECKPOINT_BYTES + kernel_config::system::PLANNER_WARM.len as usize;

const KEY: sdls::Key = sdls::Key {
    spi: 3,
    bytes: [0x5c; 32],
};

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

fn new_app() -> Box<FlightApp> {
    let mut app: Box<std::mem::MaybeUninit<FlightApp>> = Box::new_uninit();
    app.write(FlightApp::with_executive_share(WARM_CHECKPOINT_BYTES));
    // SAFETY: just initialised.
    unsafe { app.assume_init() }
}

/// The benchmark's synthetic network of `tasks` tasks, in the uplink format (unsecured).
fn network(tasks: usize) -> Vec<u8> {
    network_of(SyntheticShape::bench(tasks))
}

fn secured(image: &[u8], sequence: u32) -> Vec<u8> {
    let mut out = vec![0u8; image.len() + sdls::uplink::OVERHEAD];
    let len = sdls::uplink::sign_into(&KEY, sequence, image, &mut out).unwrap();
    out.truncate(len);
    out
}

/// An application booted cold on `warm` with `KEY` provisioned.
struct Rig {
    app: Box<FlightApp>,
    warm: Vec<u8>,
    store: ProvisionedNv,
}

impl Rig {
    fn new(warm_bytes: usize) -> Self {
        let mut area = [0u8; sdls::nv::SECURITY_AREA_BYTES];
        sdls::nv::provision(&mut area, &KEY).unwrap();
        let mut rig = Self {
            app: new_app(),
            warm: vec![0u8; warm_bytes],
            store: ProvisionedNv(area),
        };
        let mut mem = Memories {
            warm: &mut rig.warm,
            nv: None,
            security: Some(&mut rig.store),
        };
        assert_eq!(
            rig.app.boot(&mut mem, &mut NoClock, &mut |_| {}),
            BootOutcome::Cold
        );
        rig
    }

    fn send(&mut self, msg: &HostToTarget) -> Vec<TargetToHost> {
        let mut mem = Memories {
            warm: &mut self.warm,
            nv: None,
            security: Some(&mut self.store),
        };
        let mut out = Vec::new();
        self.app
            .handle(msg, &mut mem, &mut NoClock, &mut |m| out.push(m));
        out
    }

    /// Sends `bytes` in chunks; returns everything the application answered.
    fn uplink(&mut self, bytes: &[u8]) -> Vec<TargetToHost> {
        let chunks: Vec<&[u8]> = bytes.chunks(UPLINK_CHUNK_MAX).collect();
        let total = u16::try_from(chunks.len()).unwrap();
        let mut out = Vec::new();
        for (seq, c) in chunks.iter().enumerate() {
            out.extend(self.send(&HostToTarget::UplinkChunk {
                seq: seq as u16,
                total,
                bytes: heapless::Vec::from_slice(c).unwrap(),
            }));
            if matches!(out.last(), Some(TargetToHost::UplinkNak { .. })) {
                break;
            }
        }
        out
    }

    fn loaded_tasks(&self) -> usize {
        self.app.executive().executive().network().tasks().len()
    }
}

fn checkpoint_failures(out: &[TargetToHost]) -> Vec<u64> {
    out.iter()
        .filter_map(|m| match m {
            TargetToHost::Telemetry(TelemetryEvent::Metric { id, value })
                if *id == metric::CHECKPOINT_WRITE_FAILURES =>
            {
                Some(*value)
            }
            _ => None,
        })
        .collect()
}

fn network_of(shape: SyntheticShape) -> Vec<u8> {
    let mut spec = Box::new(NetworkSpec::new(0, PlannerConfig::DEFAULT));
    synthetic_into(&mut spec, shape).unwrap();
    let mut image = vec![0u8; 1 << 21];
    let len = autonomy::uplink::encode_spec(&spec, &mut image).unwrap();
    image.truncate(len);
    image
}

fn slot_capacity() -> usize {
    autonomy::WarmRestartArea::new(&mut vec![0u8; WARM_CHECKPOINT_BYTES]).payload_capacity()
}

fn grant(rig: &mut Rig, frame: u32) -> Vec<TargetToHost> {
    let out = rig.send(&HostToTarget::TimeGrant {
        frame,
        now: MissionTimeUs::from_mins(u64::from(frame)),
        until: MissionTimeUs::from_mins(u64::from(frame) + 1),
    });
    assert!(
        out.iter()
            .any(|m| matches!(m, TargetToHost::FrameDone { frame: f, .. } if *f == frame)),
        "frame {frame} done"
    );
    out
}

/// Uplinks the light synthetic network of `tasks` tasks into a fresh application on the
/// target's warm-restart area and flies one frame (every task planned); returns the rig and
/// the checkpoint failures counted at the load and in the frame.
fn fly(tasks: usize) -> (Rig, Vec<u64>) {
    let mut rig = Rig::new(WARM_BYTES);
    let bytes = secured(&network(tasks), 1);
    assert!(
        bytes.len() <= MAX_UPLINK_BYTES,
        "{tasks} tasks fit the uplink buffer"
    );
    let mut out = rig.uplink(&bytes);
    let total = u16::try_from(bytes.len().div_ceil(UPLINK_CHUNK_MAX)).unwrap();
    assert!(out.contains(&TargetToHost::UplinkAck { seq: total }));
    assert_eq!(rig.loaded_tasks(), tasks);
    out.extend(grant(&mut rig, 0));
    let failures = checkpoint_failures(&out);
    (rig, failures)
}

#[test]
fn a_network_of_max_tasks_fits_the_uplink_buffer_and_its_checkpoint_is_counted_when_over_a_slot() {
    let image = network(autonomy::MAX_TASKS);
    println!(
        "uplink buffer {MAX_UPLINK_BYTES} bytes: {} light tasks are {} bytes ({} secured)",
        autonomy::MAX_TASKS,
        image.len(),
        image.len() + sdls::uplink::OVERHEAD
    );
    let (mut rig, failures) = fly(autonomy::MAX_TASKS);
    // Its planned state (36 KiB) is over a slot (16 KiB of the executive's 32 KiB slice):
    // every write fails and is counted, and the plan flies on.
    // The executive checkpoints at the load and in both of its windows of every frame.
    assert_eq!(failures, [1, 1, 1], "at the load and in frame 0");
    for frame in 1..4 {
        assert_eq!(checkpoint_failures(&grant(&mut rig, frame)), [1, 1]);
    }
    assert!(
        autonomy::checkpoint::records(&rig.warm[..WARM_CHECKPOINT_BYTES])
            .iter()
            .all(Option::is_none)
    );
    let mut state = vec![0u8; 1 << 20];
    let payload = rig
        .app
        .executive()
        .executive()
        .encode_state(&mut state)
        .unwrap();
    println!(
        "its planned state is {payload} bytes; a checkpoint slot holds {}",
        slot_capacity()
    );
    assert!(payload > slot_capacity());
}

#[test]
fn the_largest_network_whose_checkpoint_fits_a_slot_is_checkpointed_every_frame() {
    // Checkpoint sizes grow with the tasks: the largest that fits, by bisection.
    let fits = |n: usize| fly(n).1.is_empty();
    let (mut lo, mut hi) = (8, autonomy::MAX_TASKS);
    assert!(fits(lo) && !fits(hi));
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if fits(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    println!(
        "the largest light network whose planned state fits a checkpoint slot: {lo} tasks ({} uplink bytes)",
        network(lo).len()
    );
    let (mut rig, failures) = fly(lo);
    assert!(failures.is_empty());
    for frame in 1..4 {
        assert!(checkpoint_failures(&grant(&mut rig, frame)).is_empty());
    }
    assert!(
        autonomy::checkpoint::records(&rig.warm[..WARM_CHECKPOINT_BYTES])
            .iter()
            .any(Option::is_some)
    );
}

#[test]
fn an_uplink_over_the_buffer_is_refused_too_large_and_the_running_network_stays() {
    let (mut rig, _) = fly(32);
    // Every capacity at once: far over the buffer.
    let image = network_of(SyntheticShape::at_capacity());
    println!(
        "a network at every capacity (256 tasks of 16 constraints and 16 impacts, 64 timelines) is {} bytes",
        image.len()
    );
    let over = secured(&image, 2);
    assert!(over.len() > MAX_UPLINK_BYTES);
    let out = rig.uplink(&over);
    match out.last() {
        Some(TargetToHost::UplinkNak { seq, reason }) => {
            assert_eq!(*reason, uplink_reason::TOO_LARGE);
            assert_eq!(
                usize::from(*seq),
                MAX_UPLINK_BYTES.div_ceil(UPLINK_CHUNK_MAX)
            );
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(rig.loaded_tasks(), 32);
    assert!(checkpoint_failures(&grant(&mut rig, 1)).is_empty());
}

//! The application's unit tests, by subject (frames and telemetry, uplink and ground-command
//! security, boot from the memories), and the fixtures they share: a provisioned security
//! store, the signed flyby uplink, grants and metric extraction.

extern crate std;
use std::vec::Vec;

use super::*;

mod boot;
mod frames;
mod security;

fn grant(frame: u32, secs: u64) -> HostToTarget {
    HostToTarget::TimeGrant {
        frame,
        now: MissionTimeUs::from_secs(secs),
        until: MissionTimeUs::from_secs(secs + 1),
    }
}

fn metrics(out: &[TargetToHost], id: u16) -> Vec<u64> {
    out.iter()
        .filter_map(|m| match m {
            TargetToHost::Telemetry(TelemetryEvent::Metric { id: i, value }) if *i == id => {
                Some(*value)
            }
            _ => None,
        })
        .collect()
}

/// The key the tests provision.
const TEST_KEY: sdls::Key = sdls::Key {
    spi: 1,
    bytes: [0x11; 32],
};

/// A security area in memory; `fail_writes` makes every write fail.
#[derive(Clone)]
struct TestNv {
    area: [u8; sdls::nv::SECURITY_AREA_BYTES],
    fail_writes: bool,
}

impl TestNv {
    fn provisioned(key: &sdls::Key) -> Self {
        let mut area = [0u8; sdls::nv::SECURITY_AREA_BYTES];
        sdls::nv::provision(&mut area, key).unwrap();
        Self {
            area,
            fail_writes: false,
        }
    }
}

impl SecurityStore for TestNv {
    fn read(&mut self, area: &mut [u8; sdls::nv::SECURITY_AREA_BYTES]) -> Result<(), StoreError> {
        area.copy_from_slice(&self.area);
        Ok(())
    }
    fn write(&mut self, offset: usize, bytes: &[u8]) -> Result<(), StoreError> {
        if self.fail_writes {
            return Err(StoreError);
        }
        self.area
            .get_mut(offset..offset + bytes.len())
            .ok_or(StoreError)?
            .copy_from_slice(bytes);
        Ok(())
    }
}

fn flyby_image() -> Vec<u8> {
    let network = autonomy::scenarios::flyby_network().unwrap();
    let mut image = std::vec![0u8; MAX_UPLINK_BYTES];
    let len = network.encode(&mut image).unwrap();
    image.truncate(len);
    image
}

/// The flyby network secured with `key` and sequence number `sequence`.
fn signed_flyby(key: &sdls::Key, sequence: u32) -> Vec<u8> {
    let image = flyby_image();
    let mut out = std::vec![0u8; image.len() + sdls::uplink::OVERHEAD];
    let n = sdls::uplink::sign_into(key, sequence, &image, &mut out).unwrap();
    out.truncate(n);
    out
}

/// Send `secured` in chunks; everything the application answered.
fn send_uplink(app: &mut FlightApp, mem: &mut Memories<'_>, secured: &[u8]) -> Vec<TargetToHost> {
    let chunks: Vec<&[u8]> = secured.chunks(UPLINK_CHUNK_MAX).collect();
    let mut out: Vec<TargetToHost> = Vec::new();
    for (seq, c) in chunks.iter().enumerate() {
        let msg = HostToTarget::UplinkChunk {
            seq: seq as u16,
            total: chunks.len() as u16,
            bytes: heapless::Vec::from_slice(c).unwrap(),
        };
        app.handle(&msg, mem, &mut NoClock, &mut |m| out.push(m));
    }
    out
}

/// The verdict on a whole uplink: the reply with `seq == total`.
fn verdict(out: &[TargetToHost]) -> Option<&TargetToHost> {
    out.iter().rev().find(|m| {
        matches!(m, TargetToHost::UplinkNak { .. }) || matches!(m, TargetToHost::UplinkAck { .. })
    })
}

/// Boot `app` (which reads the key) and uplink the flyby with sequence number 1.
fn boot_and_uplink_flyby(app: &mut FlightApp, mem: &mut Memories<'_>) {
    app.boot(mem, &mut NoClock, &mut |_| {});
    let secured = signed_flyby(&TEST_KEY, 1);
    let total = secured.len().div_ceil(UPLINK_CHUNK_MAX) as u16;
    let out = send_uplink(app, mem, &secured);
    assert_eq!(out.last(), Some(&TargetToHost::UplinkAck { seq: total }));
}

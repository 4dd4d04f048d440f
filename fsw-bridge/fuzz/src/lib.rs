//! Fuzz target logic for the wire protocol, in plain functions shared by the libFuzzer
//! wrappers (`fuzz_targets/`) and the bounded run on stable (`fsw-bridge/tests/fuzz_bounded.rs`).
//!
//! * [`frame_decoder`]: any byte stream off the link, in both directions, and any payload
//!   behind a correct CRC.
//!
//! Seeds are in `seeds/<target>/` (encoded frames of every message kind; regenerate them with
//! `cargo run --manifest-path host-harness/fuzz/Cargo.toml --example seeds`).
use core::fmt::Debug;

use fsw_bridge::codec::{encode, FrameDecoder, WireMessage, MAX_FRAME_LEN, MAX_PAYLOAD_LEN};
use fsw_bridge::{HostToTarget, TargetToHost};

pub mod bounded;

/// The targets of this crate, by name.
pub const TARGETS: &[bounded::Target] = &[("frame_decoder", frame_decoder)];

/// Feeds `data` to the frame decoder of both directions as a raw byte stream, and again as the
/// payload of one frame with a correct CRC (so that the message decoder is reached without
/// forging a CRC-32). Every decoded message must re-encode and decode back equal, every frame
/// must get exactly one verdict, and the decoder's counters must add up to the verdicts.
pub fn frame_decoder(data: &[u8]) {
    check_stream::<HostToTarget>(data);
    check_stream::<TargetToHost>(data);

    let payload = &data[..data.len().min(MAX_PAYLOAD_LEN)];
    let mut frame = [0u8; MAX_FRAME_LEN];
    let n = encode(&RawPayload(payload), &mut frame).expect("a payload of MAX_PAYLOAD_LEN fits");
    for results in [
        check_stream::<HostToTarget>(&frame[..n]),
        check_stream::<TargetToHost>(&frame[..n]),
    ] {
        assert_eq!(results, 1, "one frame in, one verdict out");
    }
}

/// Feed `bytes` to a fresh decoder; every decoded message must re-encode and decode back equal,
/// and every verdict must be counted once. Returns the number of verdicts.
fn check_stream<M: WireMessage + PartialEq + Debug>(bytes: &[u8]) -> usize {
    let mut dec = FrameDecoder::new();
    let mut verdicts = 0;
    for &b in bytes {
        if let Some(result) = dec.push::<M>(b) {
            verdicts += 1;
            if let Ok(msg) = result {
                check_round_trip(msg);
            }
        }
    }
    let c = dec.counters();
    assert_eq!(c.frames_ok as usize + c.errors() as usize, verdicts);
    verdicts
}

fn check_round_trip<M: WireMessage + PartialEq + Debug>(msg: M) {
    let mut frame = [0u8; MAX_FRAME_LEN];
    let n = encode(&msg, &mut frame).expect("a decoded message re-encodes");
    let mut dec = FrameDecoder::new();
    let mut results = frame[..n].iter().filter_map(|&b| dec.push::<M>(b));
    match results.next() {
        Some(Ok(back)) => assert_eq!(back, msg),
        other => panic!("{msg:?} re-encoded to a frame that decodes as {other:?}"),
    }
    assert!(results.next().is_none(), "one frame decoded as several");
}

/// Serializes as its bytes verbatim: postcard writes a tuple of u8 with no length and no varints.
struct RawPayload<'a>(&'a [u8]);

impl serde::Serialize for RawPayload<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeTuple;
        let mut t = s.serialize_tuple(self.0.len())?;
        for b in self.0 {
            t.serialize_element(b)?;
        }
        t.end()
    }
}

// Fuzzes FrameDecoder for both directions. Run from fsw-bridge/fuzz/ (needs `cargo install cargo-fuzz`):
//     cargo +nightly fuzz run frame_decoder                         # until stopped or a crash
//     cargo +nightly fuzz run frame_decoder -- -max_total_time=60   # a short run
#![no_main]

use core::fmt::Debug;

use fsw_bridge::codec::{encode, FrameDecoder, WireMessage, MAX_FRAME_LEN, MAX_PAYLOAD_LEN};
use fsw_bridge::{HostToTarget, TargetToHost};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // The input as a raw byte stream off the link.
    check_stream::<HostToTarget>(data);
    check_stream::<TargetToHost>(data);

    // The input as a payload behind a correct CRC, so that the fuzzer reaches the message
    // decoder without having to forge a CRC-32.
    let payload = &data[..data.len().min(MAX_PAYLOAD_LEN)];
    let mut frame = [0u8; MAX_FRAME_LEN];
    let n = encode(&RawPayload(payload), &mut frame).expect("a payload of MAX_PAYLOAD_LEN fits");
    for results in [
        check_stream::<HostToTarget>(&frame[..n]),
        check_stream::<TargetToHost>(&frame[..n]),
    ] {
        assert_eq!(results, 1, "one frame in, one verdict out");
    }
});

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

// Fuzzes the link endpoint: whatever arrives, it must not panic and its window, ring and
// delivery counts must stay consistent. Run from fsw-bridge/fuzz/ (needs `cargo install
// cargo-fuzz`):
//     cargo +nightly fuzz run link_endpoint -- -max_total_time=60
//
// The input is a script. Each step starts with an opcode byte:
//   0       the next length byte's worth of bytes arrive raw (noise, damaged frames)
//   1       the same bytes arrive as the payload of a frame with a correct CRC, so that the
//           fuzzer reaches the link-frame decoder without forging a CRC-32
//   2       the endpoint produces its burst
//   3       a message is submitted (the next byte picks the VC and a Ping's sequence number)
//   4       the link is reset
//   5       the next byte sets whether the consumer has room
// The first byte picks the role: even the target (Responder), odd the host (Initiator).
#![no_main]

use core::fmt::Debug;

use fsw_bridge::codec::{encode, FrameDecoder, MAX_FRAME_LEN, MAX_PAYLOAD_LEN};
use fsw_bridge::link::{
    Endpoint, LinkConfig, LinkFrame, LinkMessage, Received, Role, TargetEndpoint,
    VirtualChannel, VC_COUNT,
};
use fsw_bridge::{HostToTarget, TargetToHost};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&role, script)) = data.split_first() else {
        return;
    };
    if role % 2 == 0 {
        let mut target = Box::new(
            TargetEndpoint::new(Role::Responder, LinkConfig::DEFAULT).expect("default config"),
        );
        play(&mut *target, script, |seq| TargetToHost::UplinkAck { seq });
    } else {
        let config = LinkConfig {
            window_width: 3,
            transmission_limit: 2,
            ..LinkConfig::DEFAULT
        };
        let mut host = Box::new(
            Endpoint::<HostToTarget, TargetToHost, 1024, 16>::new(Role::Initiator, config)
                .expect("valid config"),
        );
        play(&mut *host, script, |seq| HostToTarget::Ping { seq: seq.into() });
    }
});

fn play<Out, In, const R: usize, const Q: usize>(
    endpoint: &mut Endpoint<Out, In, R, Q>,
    mut script: &[u8],
    message: impl Fn(u16) -> Out,
) where
    Out: LinkMessage + Debug,
    In: LinkMessage + Debug,
{
    let mut decoder = FrameDecoder::new();
    let mut delivered = [0u32; VC_COUNT];
    let mut room = true;
    let window = usize::from(endpoint.config().window_width);
    while let Some((&op, rest)) = script.split_first() {
        script = rest;
        let mut arriving: Vec<u8> = Vec::new();
        match op % 6 {
            0 | 1 => {
                let Some((&len, rest)) = script.split_first() else {
                    return;
                };
                let len = usize::from(len).min(rest.len());
                let (bytes, rest) = rest.split_at(len);
                script = rest;
                if op % 6 == 0 {
                    arriving.extend_from_slice(bytes);
                } else {
                    let payload = &bytes[..bytes.len().min(MAX_PAYLOAD_LEN)];
                    let mut frame = [0u8; MAX_FRAME_LEN];
                    let n = encode(&RawPayload(payload), &mut frame).expect("payload fits");
                    arriving.extend_from_slice(&frame[..n]);
                }
            }
            2 => {
                let mut written = 0usize;
                endpoint.produce_burst(&mut |f: &[u8]| written += f.len());
                assert!(written > 0, "a burst always ends with RoundEnd");
            }
            3 => {
                let Some((&pick, rest)) = script.split_first() else {
                    return;
                };
                script = rest;
                let vc = VirtualChannel::ALL[usize::from(pick & 1)];
                let _ = endpoint.submit(vc, &message(u16::from(pick)));
            }
            4 => {
                endpoint.reset();
                delivered = [0; VC_COUNT];
            }
            _ => {
                let Some((&pick, rest)) = script.split_first() else {
                    return;
                };
                script = rest;
                room = pick % 2 == 0;
            }
        }
        for b in arriving {
            if let Some(result) = decoder.push::<LinkFrame<In>>(b) {
                if let Received::Delivered { vc, .. } = endpoint.on_frame(result, |_| room) {
                    delivered[vc.index()] += 1;
                }
            }
        }
        for vc in VirtualChannel::ALL {
            let fop = endpoint.fop(vc);
            assert!(fop.outstanding() <= window);
            assert!(fop.outstanding() + fop.backlog() <= Q);
            assert!(fop.ring_bytes_used() <= R);
            assert_eq!(fop.v_s(), fop.nn_r().wrapping_add(fop.outstanding() as u8));
            assert_eq!(endpoint.farm(vc).accepted_total(), delivered[vc.index()]);
        }
    }
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

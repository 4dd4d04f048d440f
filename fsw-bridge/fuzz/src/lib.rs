//! Fuzz target logic for the wire protocol, in plain functions shared by the libFuzzer
//! wrappers (`fuzz_targets/`) and the bounded run on stable (`fsw-bridge/tests/fuzz_bounded.rs`).
//!
//! * [`frame_decoder`]: any byte stream off the link, in both directions, and any payload
//!   behind a correct CRC, decoded as what travels on the link since protocol v2 (a
//!   [`LinkFrame`] of the direction's messages) and as a bare message (protocol v1's frames,
//!   which the host still recognises in a v1 target's Hello).
//! * [`link_endpoint`]: a link endpoint of either role fed any script of arriving bytes and
//!   frames, bursts, submissions, resets and a consumer with or without room: it must not
//!   panic, and its window, ring and delivery counts must stay consistent.
//!
//! Seeds are in `seeds/<target>/` (for the decoder: link frames of every kind carrying every
//! message kind, and whole bursts of a host and a target endpoint; for the endpoint: scripts in
//! which it talks with a real peer, in both roles; regenerate them with
//! `cargo run --manifest-path host-harness/fuzz/Cargo.toml --example seeds`).
use core::fmt::Debug;

use fsw_bridge::codec::{encode, FrameDecoder, WireMessage, MAX_FRAME_LEN, MAX_PAYLOAD_LEN};
use fsw_bridge::link::{
    Endpoint, LinkConfig, LinkFrame, LinkMessage, Received, Role, TargetEndpoint, VirtualChannel,
    VC_COUNT,
};
use fsw_bridge::{HostToTarget, TargetToHost};

pub mod bounded;

/// The targets of this crate, by name.
pub const TARGETS: &[bounded::Target] = &[
    ("frame_decoder", frame_decoder),
    ("link_endpoint", link_endpoint),
];

/// Feeds `data` to the frame decoder of both directions as a raw byte stream, and again as the
/// payload of one frame with a correct CRC (so that the message decoder is reached without
/// forging a CRC-32). Every decoded message must re-encode and decode back equal, every frame
/// must get exactly one verdict, and the decoder's counters must add up to the verdicts.
pub fn frame_decoder(data: &[u8]) {
    check_stream::<LinkFrame<HostToTarget>>(data);
    check_stream::<LinkFrame<TargetToHost>>(data);
    check_stream::<HostToTarget>(data);
    check_stream::<TargetToHost>(data);

    let payload = &data[..data.len().min(MAX_PAYLOAD_LEN)];
    let mut frame = [0u8; MAX_FRAME_LEN];
    let n = encode(&RawPayload(payload), &mut frame).expect("a payload of MAX_PAYLOAD_LEN fits");
    for results in [
        check_stream::<LinkFrame<HostToTarget>>(&frame[..n]),
        check_stream::<LinkFrame<TargetToHost>>(&frame[..n]),
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

/// Script opcodes of [`link_endpoint`] (the opcode byte modulo 6).
pub mod script {
    /// The next length byte's worth of bytes arrive raw (noise, damaged frames, whole frames).
    pub const RAW: u8 = 0;
    /// The same bytes arrive as the payload of a frame with a correct CRC, so that the fuzzer
    /// reaches the link-frame decoder without forging a CRC-32.
    pub const PAYLOAD: u8 = 1;
    /// The endpoint produces its burst.
    pub const BURST: u8 = 2;
    /// A message is submitted (the next byte picks the VC and the message's number).
    pub const SUBMIT: u8 = 3;
    /// The link is reset.
    pub const RESET: u8 = 4;
    /// The next byte sets whether the consumer has room (even: it has).
    pub const ROOM: u8 = 5;
}

/// What a [`link_endpoint`] script made the endpoint do.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkRun {
    /// Messages delivered per VC.
    pub delivered: [u32; VC_COUNT],
    /// Bursts produced.
    pub bursts: u32,
}

/// Fuzzes a link endpoint: whatever arrives, it must not panic and its window, ring and
/// delivery counts must stay consistent. The input's first byte picks the role (even: the
/// target, a Responder with the default configuration; odd: the host, an Initiator with a
/// window of 3 and a transmission limit of 2); the rest is a script of [`script`] steps.
pub fn link_endpoint(data: &[u8]) {
    run_link_script(data);
}

/// Runs a [`link_endpoint`] input; what the endpoint did.
pub fn run_link_script(data: &[u8]) -> LinkRun {
    let Some((&role, script)) = data.split_first() else {
        return LinkRun::default();
    };
    if role % 2 == 0 {
        let mut target = Box::new(
            TargetEndpoint::new(Role::Responder, LinkConfig::DEFAULT).expect("default config"),
        );
        play(&mut *target, script, |seq| TargetToHost::UplinkAck { seq })
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
        play(&mut *host, script, |seq| HostToTarget::Ping {
            seq: seq.into(),
        })
    }
}

fn play<Out, In, const R: usize, const Q: usize>(
    endpoint: &mut Endpoint<Out, In, R, Q>,
    mut script: &[u8],
    message: impl Fn(u16) -> Out,
) -> LinkRun
where
    Out: LinkMessage + Debug,
    In: LinkMessage + Debug,
{
    let mut decoder = FrameDecoder::new();
    let mut run = LinkRun::default();
    let mut room = true;
    let window = usize::from(endpoint.config().window_width);
    while let Some((&op, rest)) = script.split_first() {
        script = rest;
        let mut arriving: Vec<u8> = Vec::new();
        match op % 6 {
            script::RAW | script::PAYLOAD => {
                let Some((&len, rest)) = script.split_first() else {
                    break;
                };
                let len = usize::from(len).min(rest.len());
                let (bytes, rest) = rest.split_at(len);
                script = rest;
                if op % 6 == script::RAW {
                    arriving.extend_from_slice(bytes);
                } else {
                    let payload = &bytes[..bytes.len().min(MAX_PAYLOAD_LEN)];
                    let mut frame = [0u8; MAX_FRAME_LEN];
                    let n = encode(&RawPayload(payload), &mut frame).expect("payload fits");
                    arriving.extend_from_slice(&frame[..n]);
                }
            }
            script::BURST => {
                let mut written = 0usize;
                endpoint.produce_burst(&mut |f: &[u8]| written += f.len());
                assert!(written > 0, "a burst always ends with RoundEnd");
                run.bursts += 1;
            }
            script::SUBMIT => {
                let Some((&pick, rest)) = script.split_first() else {
                    break;
                };
                script = rest;
                let vc = VirtualChannel::ALL[usize::from(pick & 1)];
                let _ = endpoint.submit(vc, &message(u16::from(pick)));
            }
            script::RESET => {
                endpoint.reset();
                run.delivered = [0; VC_COUNT];
            }
            _ => {
                let Some((&pick, rest)) = script.split_first() else {
                    break;
                };
                script = rest;
                room = pick % 2 == 0;
            }
        }
        for b in arriving {
            if let Some(result) = decoder.push::<LinkFrame<In>>(b) {
                if let Received::Delivered { vc, .. } = endpoint.on_frame(result, |_| room) {
                    run.delivered[vc.index()] += 1;
                }
            }
        }
        for vc in VirtualChannel::ALL {
            let fop = endpoint.fop(vc);
            assert!(fop.outstanding() <= window);
            assert!(fop.outstanding() + fop.backlog() <= Q);
            assert!(fop.ring_bytes_used() <= R);
            assert_eq!(fop.v_s(), fop.nn_r().wrapping_add(fop.outstanding() as u8));
            assert_eq!(
                endpoint.farm(vc).accepted_total(),
                run.delivered[vc.index()]
            );
        }
    }
    run
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

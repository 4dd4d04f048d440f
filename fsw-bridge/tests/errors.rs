//! Everything that is not a clean frame: bit errors, garbage between frames, each DecodeError
//! kind and its counter, and arbitrary byte streams.
mod common;

use common::*;
use fsw_bridge::codec::{encode, DecodeError, FrameDecoder, WireMessage, MAX_FRAME_LEN};
use fsw_bridge::messages::{LOG_CHUNK_MAX, UPLINK_CHUNK_MAX};
use fsw_bridge::{
    CommandStatus, HostToTarget, LinkCounters, MissionTimeUs, ResetCause, StateKey, StateValue,
    TargetToHost, TelemetryEvent,
};
use proptest::collection::vec;
use proptest::prelude::*;

type Msg<M> = Result<M, DecodeError>;

fn h2t_samples() -> Vec<HostToTarget> {
    vec![
        HostToTarget::Ping { seq: 0 },
        HostToTarget::Ping { seq: 0x1234_5678 },
        HostToTarget::TimeGrant {
            frame: 7,
            now: MissionTimeUs::from_secs(3),
            until: MissionTimeUs::MAX,
        },
        HostToTarget::StateUpdate {
            key: StateKey(3),
            value: StateValue::Bool(true),
            timestamp: MissionTimeUs::ZERO,
        },
        HostToTarget::CommandResponse {
            id: 1,
            status: CommandStatus::Failed(0),
            data: None,
        },
        HostToTarget::UplinkChunk {
            seq: 0,
            total: 1,
            bytes: heapless::Vec::from_slice(&[0u8; UPLINK_CHUNK_MAX]).unwrap(),
        },
        HostToTarget::UplinkChunk {
            seq: 9,
            total: 10,
            bytes: (0..UPLINK_CHUNK_MAX).map(|i| i as u8).collect(),
        },
    ]
}

fn t2h_samples() -> Vec<TargetToHost> {
    vec![
        TargetToHost::Hello {
            protocol_version: fsw_bridge::PROTOCOL_VERSION,
            build_id: [0, 1, 2, 3, 0xfc, 0xfd, 0xfe, 0xff],
            reset_cause: ResetCause::Watchdog,
            boot_count: 1,
            kernel_fault: None,
        },
        TargetToHost::Hello {
            protocol_version: fsw_bridge::PROTOCOL_VERSION,
            build_id: [9; 8],
            reset_cause: ResetCause::KernelFault,
            boot_count: 3,
            kernel_fault: Some(fsw_bridge::KernelFault {
                vector: 0x700,
                pc: 0x1_2344,
                dar: 0,
            }),
        },
        TargetToHost::Pong {
            seq: 42,
            link: LinkCounters {
                frames_ok: 9,
                ..Default::default()
            },
        },
        TargetToHost::FrameDone {
            frame: 0,
            next_wakeup: None,
        },
        TargetToHost::Log {
            bytes: (0..LOG_CHUNK_MAX).map(|i| (i * 7) as u8).collect(),
        },
        TargetToHost::Telemetry(TelemetryEvent::Metric {
            id: 0,
            value: u64::MAX,
        }),
        TargetToHost::UplinkNak { seq: 0, reason: 0 },
    ]
}

/// Oks and Errs of a result list, separately.
fn split<M: Clone>(out: &[Msg<M>]) -> (Vec<M>, Vec<DecodeError>) {
    let oks = out
        .iter()
        .filter_map(|r| r.as_ref().ok().cloned())
        .collect();
    let errs = out
        .iter()
        .filter_map(|r| r.as_ref().err().copied())
        .collect();
    (oks, errs)
}

// ---------------------------------------------------------------------------------------------
// Single-bit errors.

/// Flip every bit of every sample's frame, one at a time, between two good frames (and once at
/// the very start of the stream): only the good frames come out, and the bad one is counted.
fn every_bit_flip_is_caught<M>(samples: &[M])
where
    M: WireMessage + Clone + PartialEq + core::fmt::Debug,
{
    let before = samples[0].clone();
    let after = samples[samples.len() - 1].clone();
    let (before_f, after_f) = (frame(&before), frame(&after));
    let mut flips = 0;
    for msg in samples {
        let good = frame(msg);
        for bit in 0..good.len() * 8 {
            let mut bad = good.clone();
            bad[bit / 8] ^= 1 << (bit % 8);
            flips += 1;

            for with_prefix in [true, false] {
                let mut stream = Vec::new();
                if with_prefix {
                    stream.extend_from_slice(&before_f);
                }
                stream.extend_from_slice(&bad);
                stream.extend_from_slice(&after_f);
                let (out, dec) = decode_all::<M>(&stream);
                let (oks, errs) = split(&out);
                let expected: Vec<M> = if with_prefix {
                    vec![before.clone(), after.clone()]
                } else {
                    vec![after.clone()]
                };
                let ctx = format!("{msg:?}, bit {bit}, prefix {with_prefix}: {out:?}");
                assert_eq!(oks, expected, "{ctx}");
                assert_eq!(out.last(), Some(&Ok(after.clone())), "{ctx}");
                assert!(!errs.is_empty(), "flip not reported: {ctx}");
                let c = dec.counters();
                assert_eq!(c.errors() as usize, errs.len(), "{ctx}");
                assert_eq!(c.frames_ok as usize, expected.len(), "{ctx}");
            }
        }
    }
    assert!(flips > 1000);
}

#[test]
fn every_bit_flip_is_caught_host_to_target() {
    every_bit_flip_is_caught(&h2t_samples());
}

#[test]
fn every_bit_flip_is_caught_target_to_host() {
    every_bit_flip_is_caught(&t2h_samples());
}

// ---------------------------------------------------------------------------------------------
// Garbage between frames.

fn garbage() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        // Anything, zeros included.
        vec(any::<u8>(), 0..64),
        // Zero-heavy.
        vec(prop_oneof![Just(0u8), Just(1u8), any::<u8>()], 0..32),
        // A run long enough to overflow the decoder.
        vec(1u8..=255, 200..700),
    ]
}

fn garbage_loses_no_frame<M>(msgs: &[M], gaps: &[Vec<u8>]) -> Result<(), TestCaseError>
where
    M: WireMessage + Clone + PartialEq + core::fmt::Debug,
{
    let mut stream = gaps[0].clone();
    for (msg, gap) in msgs.iter().zip(&gaps[1..]) {
        stream.extend_from_slice(&frame(msg));
        stream.extend_from_slice(gap);
    }
    let (out, dec) = decode_all::<M>(&stream);
    let (oks, errs) = split(&out);
    prop_assert_eq!(&oks, &msgs.to_vec());
    let c = dec.counters();
    prop_assert_eq!(c.frames_ok as usize, msgs.len());
    prop_assert_eq!(c.errors() as usize, errs.len());
    Ok(())
}

fn msgs_and_gaps<M: core::fmt::Debug + Clone>(
    msg: impl Strategy<Value = M>,
) -> impl Strategy<Value = (Vec<M>, Vec<Vec<u8>>)> {
    vec(msg, 0..8).prop_flat_map(|msgs| {
        let n = msgs.len();
        (Just(msgs), vec(garbage(), n + 1))
    })
}

// ---------------------------------------------------------------------------------------------
// Each error kind, counted under its own counter, followed by a good frame that still decodes.

fn expect_error<M>(bytes: &[u8], expected: DecodeError, count: fn(&mut LinkCounters) -> &mut u32)
where
    M: WireMessage + Clone + PartialEq + core::fmt::Debug,
    M: From<Probe>,
{
    let good: M = Probe.into();
    let mut stream = bytes.to_vec();
    stream.extend_from_slice(&frame(&good));
    let (out, dec) = decode_all::<M>(&stream);
    assert_eq!(out, vec![Err(expected), Ok(good)], "stream {bytes:02x?}");
    let mut counters = LinkCounters {
        frames_ok: 1,
        ..Default::default()
    };
    *count(&mut counters) = 1;
    assert_eq!(dec.counters(), counters, "stream {bytes:02x?}");
}

/// A known good message of each direction, sent after every bad frame.
struct Probe;
impl From<Probe> for HostToTarget {
    fn from(_: Probe) -> Self {
        HostToTarget::Ping { seq: 0xC0FFEE }
    }
}
impl From<Probe> for TargetToHost {
    fn from(_: Probe) -> Self {
        TargetToHost::UplinkAck { seq: 77 }
    }
}

fn crc_errors(c: &mut LinkCounters) -> &mut u32 {
    &mut c.crc_errors
}
fn oversize(c: &mut LinkCounters) -> &mut u32 {
    &mut c.oversize
}
fn unknown_type(c: &mut LinkCounters) -> &mut u32 {
    &mut c.unknown_type
}
fn truncated(c: &mut LinkCounters) -> &mut u32 {
    &mut c.truncated
}
fn malformed(c: &mut LinkCounters) -> &mut u32 {
    &mut c.malformed
}

#[test]
fn bad_crc_is_counted() {
    let payload = postcard_bytes(&HostToTarget::Ping { seq: 1 });
    let crc = fsw_bridge::codec::LINK_CRC.checksum(&payload);
    for wrong in [crc ^ 1, crc ^ 0x8000_0000, !crc, 0] {
        expect_error::<HostToTarget>(
            &raw_frame_with_crc(&payload, wrong),
            DecodeError::BadCrc,
            crc_errors,
        );
    }
    // A payload byte changed after the CRC was computed.
    let mut f = frame(&TargetToHost::UplinkNak {
        seq: 300,
        reason: 5,
    });
    f[3] ^= 0x10;
    expect_error::<TargetToHost>(&f, DecodeError::BadCrc, crc_errors);
}

#[test]
fn oversize_then_recovery() {
    // A long run without a delimiter is one Oversize, however long it is.
    for run in [MAX_FRAME_LEN, 300, 1000, 5000] {
        let mut stream = vec![0u8];
        stream.extend((0..run).map(|i| (i % 255 + 1) as u8));
        expect_error::<HostToTarget>(&stream, DecodeError::Oversize, oversize);
        expect_error::<TargetToHost>(&stream[1..], DecodeError::Oversize, oversize);
    }
}

#[test]
fn oversize_boundary_is_max_frame_len() {
    // Valid tag and CRC, padded with trailing bytes so that the frame is exactly MAX_FRAME_LEN
    // on the wire: it is decoded (and refused for its trailing bytes), not dropped.
    let mut payload = postcard_bytes(&HostToTarget::Ping { seq: 1 });
    let pad = |payload: &mut Vec<u8>, len: usize| payload.resize(len, 0x11);
    pad(&mut payload, MAX_FRAME_LEN - 2 - 1 - 4);
    let f = raw_frame(&payload);
    assert_eq!(f.len(), MAX_FRAME_LEN);
    expect_error::<HostToTarget>(&f, DecodeError::Malformed, malformed);
    // One byte more is oversize.
    pad(&mut payload, MAX_FRAME_LEN - 2 - 1 - 4 + 1);
    let f = raw_frame(&payload);
    assert_eq!(f.len(), MAX_FRAME_LEN + 1);
    expect_error::<HostToTarget>(&f, DecodeError::Oversize, oversize);
}

#[test]
fn unknown_type_is_counted() {
    let n = HostToTarget::VARIANT_COUNT;
    for tag in [n, n + 1, 0x7f] {
        expect_error::<HostToTarget>(
            &raw_frame(&[tag, 0, 0, 0]),
            DecodeError::UnknownType(tag),
            unknown_type,
        );
    }
    let n = TargetToHost::VARIANT_COUNT;
    expect_error::<TargetToHost>(&raw_frame(&[n]), DecodeError::UnknownType(n), unknown_type);
    // The tag is a varint: 200 is [0xc8, 0x01], 300 is [0xac, 0x02] (reported as 255), and a
    // padded (non-canonical) encoding of VARIANT_COUNT is still that tag.
    for (payload, tag) in [
        (vec![0xc8, 0x01], 200),
        (vec![0xac, 0x02], u8::MAX),
        (vec![0xff, 0xff, 0xff, 0xff, 0x0f], u8::MAX),
        (vec![0x80 | n, 0x00], n),
        (vec![0x80 | n, 0x80, 0x00], n),
    ] {
        expect_error::<TargetToHost>(
            &raw_frame(&payload),
            DecodeError::UnknownType(tag),
            unknown_type,
        );
    }
}

#[test]
fn padded_known_tag_decodes_like_postcard() {
    // postcard accepts a padded varint for the tag as for any other integer; so does the codec.
    let payload = [0x80 | 6, 0x00, 0x05]; // UplinkAck, tag 6 in two bytes, seq 5
    assert_eq!(
        postcard::from_bytes::<TargetToHost>(&payload),
        Ok(TargetToHost::UplinkAck { seq: 5 })
    );
    assert_eq!(
        decode_one::<TargetToHost>(&raw_frame(&payload)),
        Ok(TargetToHost::UplinkAck { seq: 5 })
    );
}

#[test]
fn truncated_is_counted() {
    // Too short to hold a CRC (decoded length 0..=4).
    for len in 0..=4 {
        let raw: Vec<u8> = (1..=len).collect();
        expect_error::<HostToTarget>(
            &stuffed_frame(&reference_cobs(&raw)),
            DecodeError::Truncated,
            truncated,
        );
    }
    // Four bytes that happen to be the CRC of the empty payload are still no frame.
    let empty_crc = fsw_bridge::codec::LINK_CRC.checksum(&[]);
    expect_error::<TargetToHost>(
        &raw_frame_with_crc(&[], empty_crc),
        DecodeError::Truncated,
        truncated,
    );
    // Bad COBS: a code byte pointing past the end of the frame.
    for stuffed in [
        &[0x05, 0x01, 0x02][..],
        &[0x02],
        &[0x03, 0x11, 0x22, 0x33, 0x44, 0x55, 0x07],
    ] {
        expect_error::<HostToTarget>(&stuffed_frame(stuffed), DecodeError::Truncated, truncated);
    }
    // Correct CRC, but the payload ends inside a field.
    for payload in [
        &[0x00][..],                        // Ping without its seq
        &[0x00, 0x80],                      // Ping, seq varint cut short
        &[0x80],                            // the tag itself cut short
        &[0x04, 0x00, 0x00, 0x0a, 1, 2, 3], // UplinkChunk: 10 bytes announced, 3 sent
    ] {
        expect_error::<HostToTarget>(&raw_frame(payload), DecodeError::Truncated, truncated);
    }
}

#[test]
fn malformed_is_counted() {
    let h2t: &[&[u8]] = &[
        &[0x02, 0x00, 0x01, 0x02, 0x00],       // StateUpdate, Bool(2)
        &[0x03, 0x00, 0x00, 0x02],             // CommandResponse, data Option tag 2
        &[0x03, 0x00, 0x03, 0x00],             // CommandResponse, CommandStatus variant 3
        &[0x05, 0x05],                         // ResetRequest, ResetKind variant 5
        &[0x00, 0xff, 0xff, 0xff, 0xff, 0x7f], // Ping, seq varint too long for a u32
        &[0x00, 0x05, 0x00],                   // Ping { seq: 5 } and a trailing byte
        &[0xff, 0xff, 0xff, 0xff, 0xff, 0x01], // tag varint longer than a u32
    ];
    for payload in h2t {
        expect_error::<HostToTarget>(&raw_frame(payload), DecodeError::Malformed, malformed);
    }
    // Log announcing one byte more than its capacity.
    let mut log = vec![0x04, LOG_CHUNK_MAX as u8 + 1];
    log.extend(std::iter::repeat_n(0x33, LOG_CHUNK_MAX + 1));
    let t2h: &[&[u8]] = &[
        &[0x02, 0x00, 0x02, 0x00], // FrameDone, next_wakeup Option tag 2
        &[0x00, 0x01, 0, 0, 0, 0, 0, 0, 0, 0, 0x05, 0x01, 0x00], // Hello, ResetCause 5 (there are 5)
        &[0x05, 0x05, 0x00, 0x00], // Telemetry, TelemetryEvent variant 5 (there are 5)
        &log,
    ];
    for payload in t2h {
        expect_error::<TargetToHost>(&raw_frame(payload), DecodeError::Malformed, malformed);
    }
}

// ---------------------------------------------------------------------------------------------
// Properties over arbitrary input.

/// Run `bytes` through a decoder; every result is counted once, and every accepted message
/// re-encodes to a frame that decodes to the same message.
fn decode_consistently<M>(bytes: &[u8]) -> Result<Vec<Msg<M>>, TestCaseError>
where
    M: WireMessage + Clone + PartialEq + core::fmt::Debug,
{
    let (out, dec) = decode_all::<M>(bytes);
    let c = dec.counters();
    prop_assert_eq!((c.frames_ok + c.errors()) as usize, out.len());
    for msg in out.iter().filter_map(|r| r.as_ref().ok()) {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(msg, &mut buf).expect("an accepted message re-encodes");
        prop_assert_eq!(decode_one::<M>(&buf[..n]), Ok(msg.clone()));
    }
    Ok(out)
}

fn stream_bytes() -> impl Strategy<Value = Vec<u8>> {
    vec(prop_oneof![3 => any::<u8>(), 1 => Just(0u8)], 0..1500)
}

/// Payloads that look like messages: small tags, lots of zeros and varint continuation bytes.
fn payload_bytes() -> impl Strategy<Value = Vec<u8>> {
    vec(
        prop_oneof![
            4 => 0u8..12,
            1 => Just(0x80u8),
            1 => Just(0xffu8),
            2 => any::<u8>(),
        ],
        0..200,
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn garbage_between_frames_loses_nothing_h2t((msgs, gaps) in msgs_and_gaps(host_to_target())) {
        garbage_loses_no_frame(&msgs, &gaps)?;
    }

    #[test]
    fn garbage_between_frames_loses_nothing_t2h((msgs, gaps) in msgs_and_gaps(target_to_host())) {
        garbage_loses_no_frame(&msgs, &gaps)?;
    }

    /// Arbitrary byte streams: no panic, consistent counters.
    #[test]
    fn arbitrary_streams_never_panic(bytes in stream_bytes()) {
        decode_consistently::<HostToTarget>(&bytes)?;
        decode_consistently::<TargetToHost>(&bytes)?;
    }

    /// Arbitrary payloads behind a correct CRC reach the message decoder: no panic, and the
    /// verdict is never a framing error.
    #[test]
    fn arbitrary_payloads_never_panic(payload in payload_bytes()) {
        let f = raw_frame(&payload);
        for out in [
            decode_consistently::<HostToTarget>(&f)?.into_iter().map(|r| r.map(|_| ())).collect::<Vec<_>>(),
            decode_consistently::<TargetToHost>(&f)?.into_iter().map(|r| r.map(|_| ())).collect(),
        ] {
            prop_assert_eq!(out.len(), 1);
            prop_assert!(!matches!(out[0], Err(DecodeError::BadCrc) | Err(DecodeError::Oversize)));
        }
    }

    /// Every strict prefix of a valid message, behind a correct CRC, is Truncated; the message
    /// with bytes appended is Malformed.
    #[test]
    fn cut_messages_are_truncated_and_padded_ones_malformed(
        msg in target_to_host(),
        extra in vec(any::<u8>(), 1..8),
    ) {
        let payload = postcard_bytes(&msg);
        for cut in 0..payload.len() {
            prop_assert_eq!(
                decode_one::<TargetToHost>(&raw_frame(&payload[..cut])),
                Err(DecodeError::Truncated),
                "cut at {}", cut
            );
        }
        let mut padded = payload.clone();
        padded.extend_from_slice(&extra);
        prop_assert_eq!(decode_one::<TargetToHost>(&raw_frame(&padded)), Err(DecodeError::Malformed));
    }

    /// Decoders carry no state from one frame to the next: splitting the stream anywhere and
    /// feeding the parts in turn gives the same results as feeding it whole.
    #[test]
    fn byte_at_a_time_has_no_hidden_state(
        msgs in vec(host_to_target(), 1..6),
        noise in vec(any::<u8>(), 0..64),
    ) {
        let mut stream = noise.clone();
        for m in &msgs {
            stream.extend(frame(m));
            stream.extend_from_slice(&noise);
        }
        let (whole, _) = decode_all::<HostToTarget>(&stream);
        let mut dec = FrameDecoder::default();
        let mut parts = Vec::new();
        for chunk in stream.chunks(7) {
            parts.extend(feed::<HostToTarget>(&mut dec, chunk));
        }
        prop_assert_eq!(whole, parts);
    }
}

//! The link envelope on the wire: every `LinkFrame` variant survives the codec, the largest
//! instance of each (an AD frame around the largest message of either direction) fits
//! `MAX_PAYLOAD_LEN`, the CLCW's two-byte layout, a Report's constant length, and which
//! service, virtual channel and class each message gets.
mod common;

use common::largest::*;
use common::link_strategies::*;
use common::*;
use fsw_bridge::codec::{encode, DecodeError, FrameDecoder, WireMessage, MAX_PAYLOAD_LEN};
use fsw_bridge::link::{
    downlink_service, uplink_service, Clcw, Directive, LinkFrame, LinkMessage, LinkReport,
    MessageClass, Service, VirtualChannel, VC_COUNT,
};
use fsw_bridge::{HostToTarget, MissionTimeUs, TargetToHost, TelemetryEvent};
use proptest::prelude::*;

/// Encode, then decode with a fresh decoder: exactly the frame comes back.
fn round_trip<M: WireMessage + PartialEq + Clone + core::fmt::Debug>(
    frame: &LinkFrame<M>,
) -> Result<(), TestCaseError> {
    let bytes = common::frame(frame);
    let out: Vec<_> = {
        let mut dec = FrameDecoder::new();
        bytes
            .iter()
            .filter_map(|&b| dec.push::<LinkFrame<M>>(b))
            .collect()
    };
    prop_assert_eq!(out, vec![Ok(frame.clone())]);
    // A borrowed message encodes to the same bytes (what the endpoint sends).
    if let LinkFrame::Ad { vc, ns, msg } = frame {
        let borrowed = LinkFrame::Ad {
            vc: *vc,
            ns: *ns,
            msg,
        };
        prop_assert_eq!(common::frame(&borrowed), bytes);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn every_uplink_link_frame_round_trips(frame in link_frames(host_to_target)) {
        round_trip(&frame)?;
    }

    #[test]
    fn every_downlink_link_frame_round_trips(frame in link_frames(target_to_host)) {
        round_trip(&frame)?;
    }

    /// Whatever it says, a Report has the same length (its round aside): the native and the
    /// emulated target's reports are then equally exposed to byte corruption.
    #[test]
    fn a_report_has_a_fixed_length_for_its_round(a in reports(), b in reports()) {
        let b = LinkReport { round: a.round, ..b };
        let len = |r: &LinkReport| postcard_bytes(&LinkFrame::<()>::Report(*r)).len();
        prop_assert_eq!(len(&a), len(&b));
    }
}

#[test]
fn the_largest_instance_of_every_frame_kind_fits_the_payload() {
    fn check<M: serde::Serialize + core::fmt::Debug>(frame: &LinkFrame<M>) {
        let len = postcard_bytes(frame).len();
        assert!(
            len <= MAX_PAYLOAD_LEN,
            "{len} bytes > {MAX_PAYLOAD_LEN}: {frame:?}"
        );
        let mut out = [0u8; fsw_bridge::codec::MAX_FRAME_LEN];
        encode(frame, &mut out).expect("fits a frame");
    }
    let mut largest_ad = 0;
    for i in 0..H2T_VARIANTS {
        let frame = LinkFrame::Ad {
            vc: VirtualChannel::Instrument,
            ns: u8::MAX,
            msg: largest_h2t(i),
        };
        check(&frame);
        check(&LinkFrame::Bd(largest_h2t(i)));
        largest_ad = largest_ad.max(postcard_bytes(&frame).len());
    }
    for i in 0..T2H_VARIANTS {
        let frame = LinkFrame::Ad {
            vc: VirtualChannel::Instrument,
            ns: u8::MAX,
            msg: largest_t2h(i),
        };
        check(&frame);
        check(&LinkFrame::Bd(largest_t2h(i)));
        largest_ad = largest_ad.max(postcard_bytes(&frame).len());
    }
    let full_clcw = Clcw {
        report_value: u8::MAX,
        lockout: true,
        wait: true,
        retransmit: true,
        farm_b_counter: 3,
    };
    check(&LinkFrame::<()>::Report(LinkReport {
        round: u32::MAX,
        clcw: [full_clcw; VC_COUNT],
        sent_vs: [u8::MAX; VC_COUNT],
        backlog: [true; VC_COUNT],
        lost: true,
    }));
    check(&LinkFrame::<()>::Bc {
        round: u32::MAX,
        directive: Directive::SetVr {
            vc: VirtualChannel::Instrument,
            vr: u8::MAX,
        },
    });
    check(&LinkFrame::<()>::RoundEnd { round: u32::MAX });
    // The envelope costs 3 bytes over the bare message (tag, VC, N(S)).
    assert_eq!(
        largest_ad,
        postcard_bytes(&largest_h2t(8)).len() + 3,
        "the largest AD frame wraps the largest temporal task chunk"
    );
    // Two bytes over the largest task-network chunk: a job and a 32-bit offset instead of
    // two 16-bit counts.
    assert_eq!(
        postcard_bytes(&largest_h2t(8)).len(),
        postcard_bytes(&largest_h2t(4)).len() + 2
    );
}

#[test]
fn variant_count_is_the_number_of_frame_kinds() {
    assert_eq!(<LinkFrame<HostToTarget> as WireMessage>::VARIANT_COUNT, 5);
    // A payload with tag 5 and a valid CRC is an unknown type, not malformed.
    let bytes = raw_frame(&[5, 0]);
    let mut dec = FrameDecoder::new();
    let out: Vec<_> = bytes
        .iter()
        .filter_map(|&b| dec.push::<LinkFrame<HostToTarget>>(b))
        .collect();
    assert_eq!(out, vec![Err(DecodeError::UnknownType(5))]);
}

#[test]
fn a_clcw_is_two_bytes_n_r_then_flags_and_unknown_flag_bits_are_refused() {
    let clcw = Clcw {
        report_value: 0x42,
        lockout: true,
        wait: false,
        retransmit: true,
        farm_b_counter: 2,
    };
    assert_eq!(postcard_bytes(&clcw), vec![0x42, 0b1_0101]);
    assert_eq!(
        postcard::from_bytes::<Clcw>(&[0x42, 0b1_0101]).unwrap(),
        clcw
    );
    assert!(postcard::from_bytes::<Clcw>(&[0x42, 0b10_0000]).is_err());
    // Inside a frame with a valid CRC an unknown flag is a malformed frame.
    let mut payload = postcard_bytes(&LinkFrame::<()>::Report(LinkReport::default()));
    // Tag, round 0 (one byte), the Mission CLCW's N(R), then its flags.
    let flags_at = 3;
    assert_eq!(payload[flags_at], 0, "the default CLCW has no flag set");
    payload[flags_at] = 0x80;
    let bytes = raw_frame(&payload);
    let mut dec = FrameDecoder::new();
    let out: Vec<_> = bytes
        .iter()
        .filter_map(|&b| dec.push::<LinkFrame<TargetToHost>>(b))
        .collect();
    assert_eq!(out, vec![Err(DecodeError::Malformed)]);
}

#[test]
fn every_uplink_message_has_its_service_and_class() {
    use fsw_bridge::link::VirtualChannel::Mission;
    let expected = [
        (Service::Expedited, MessageClass::LinkCheck),
        (Service::Sequenced(Mission), MessageClass::TimeGrant),
        (Service::Sequenced(Mission), MessageClass::StateUpdate),
        (Service::Sequenced(Mission), MessageClass::CommandResponse),
        (Service::Sequenced(Mission), MessageClass::UplinkChunk),
        (Service::Sequenced(Mission), MessageClass::ResetRequest),
        (Service::Sequenced(Mission), MessageClass::GroundCommand),
    ];
    for (i, (service, class)) in expected.into_iter().enumerate() {
        let msg = largest_h2t(i);
        assert_eq!(uplink_service(&msg), service, "{msg:?}");
        assert_eq!(msg.class(), class, "{msg:?}");
    }
}

#[test]
fn every_downlink_message_has_its_service_and_class() {
    use fsw_bridge::link::VirtualChannel::{Instrument, Mission};
    let expected = [
        (Service::Expedited, MessageClass::Hello),
        (Service::Expedited, MessageClass::LinkCheck),
        (Service::Sequenced(Mission), MessageClass::FrameDone),
        (Service::Sequenced(Mission), MessageClass::CommandDispatch),
        (Service::Sequenced(Instrument), MessageClass::Log),
        // largest_t2h's telemetry is a plan modification.
        (Service::Sequenced(Mission), MessageClass::Telemetry),
        (Service::Sequenced(Mission), MessageClass::UplinkReply),
        (Service::Sequenced(Mission), MessageClass::UplinkReply),
        (Service::Expedited, MessageClass::Panic),
        (
            Service::Sequenced(Mission),
            MessageClass::GroundCommandReply,
        ),
        (
            Service::Sequenced(Mission),
            MessageClass::GroundCommandReply,
        ),
    ];
    for (i, (service, class)) in expected.into_iter().enumerate() {
        let msg = largest_t2h(i);
        assert_eq!(downlink_service(&msg), service, "{msg:?}");
        assert_eq!(msg.class(), class, "{msg:?}");
    }
    let at = MissionTimeUs(5);
    let telemetry = |event| TargetToHost::Telemetry(event);
    let cases = [
        (
            TelemetryEvent::TaskTransition {
                task: 1,
                from: 0,
                to: 1,
                at,
            },
            Service::Sequenced(Mission),
            MessageClass::Telemetry,
        ),
        (
            TelemetryEvent::HealthMonitor {
                partition: 1,
                kind: 2,
                address: 0,
                action: 3,
            },
            Service::Sequenced(Instrument),
            MessageClass::HealthEvent,
        ),
        (
            TelemetryEvent::Metric {
                id: 0x1000,
                value: 9,
            },
            Service::Sequenced(Instrument),
            MessageClass::Metric,
        ),
        (
            TelemetryEvent::Metric {
                id: fsw_bridge::dictionary::app::GROUND_HOLDS,
                value: 9,
            },
            Service::Sequenced(Mission),
            MessageClass::Metric,
        ),
        // An id the dictionary does not know is instrumentation, never the Mission stream.
        (
            TelemetryEvent::Metric {
                id: 0x0fff,
                value: 9,
            },
            Service::Sequenced(Instrument),
            MessageClass::Metric,
        ),
    ];
    for (event, service, class) in cases {
        let msg = telemetry(event);
        assert_eq!(downlink_service(&msg), service, "{msg:?}");
        assert_eq!(msg.class(), class, "{msg:?}");
    }
}

#[test]
fn class_indices_and_names_are_distinct() {
    for (i, class) in MessageClass::ALL.iter().enumerate() {
        assert_eq!(class.index(), i);
    }
    let mut names: Vec<_> = MessageClass::ALL.iter().map(|c| c.name()).collect();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), MessageClass::COUNT);
}

//! Every variant of both message enums survives encode -> decode, the largest instance of each
//! fits in a frame, the wire format is exactly `0, COBS(postcard ++ CRC-32 LE), 0`, and
//! `WireMessage::VARIANT_COUNT` is the real number of variants.
mod common;

use common::largest::*;
use common::*;
use fsw_bridge::codec::{
    encode, EncodeError, FrameDecoder, WireMessage, MAX_FRAME_LEN, MAX_PAYLOAD_LEN,
};
use fsw_bridge::messages::UPLINK_CHUNK_MAX;
use fsw_bridge::{HostToTarget, LinkCounters, ResetKind, TargetToHost};
use proptest::prelude::*;

fn assert_round_trip<M>(msg: &M)
where
    M: WireMessage + PartialEq + Clone + core::fmt::Debug,
{
    let f = frame(msg);
    assert!(f.len() <= MAX_FRAME_LEN);
    // Exact wire format, against an independent COBS and the CRC computed here.
    assert_eq!(f, raw_frame(&postcard_bytes(msg)), "wire format of {msg:?}");
    let mut dec = FrameDecoder::new();
    let out = feed::<M>(&mut dec, &f);
    assert_eq!(out, vec![Ok(msg.clone())]);
    assert_eq!(
        dec.counters(),
        LinkCounters {
            frames_ok: 1,
            ..Default::default()
        }
    );
}

macro_rules! round_trip_props {
    ($($name:ident: $strategy:expr;)*) => {
        proptest! {
            #![proptest_config(ProptestConfig::with_cases(64))]
            $(
                #[test]
                fn $name(msg in $strategy) {
                    assert_round_trip(&msg);
                }
            )*
        }
    };
}

round_trip_props! {
    round_trip_ping: ping();
    round_trip_time_grant: time_grant();
    round_trip_state_update: state_update();
    round_trip_command_response: command_response();
    round_trip_uplink_chunk: uplink_chunk();
    round_trip_reset_request: reset_request();
    round_trip_hello: hello();
    round_trip_pong: pong();
    round_trip_frame_done: frame_done();
    round_trip_command_dispatch: command_dispatch();
    round_trip_log: log();
    round_trip_telemetry: telemetry();
    round_trip_uplink_ack: uplink_ack();
    round_trip_uplink_nak: uplink_nak();
    round_trip_panic: panic_report();
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Back-to-back frames on one decoder all come out, in order.
    #[test]
    fn streams_round_trip(
        h2t in proptest::collection::vec(host_to_target(), 0..12),
        t2h in proptest::collection::vec(target_to_host(), 0..12),
    ) {
        let bytes: Vec<u8> = h2t.iter().flat_map(frame).collect();
        let (out, dec) = decode_all::<HostToTarget>(&bytes);
        prop_assert_eq!(out, h2t.iter().cloned().map(Ok).collect::<Vec<_>>());
        prop_assert_eq!(dec.counters().frames_ok as usize, h2t.len());
        prop_assert_eq!(dec.counters().errors(), 0);

        let bytes: Vec<u8> = t2h.iter().flat_map(frame).collect();
        let (out, dec) = decode_all::<TargetToHost>(&bytes);
        prop_assert_eq!(out, t2h.iter().cloned().map(Ok).collect::<Vec<_>>());
        prop_assert_eq!(dec.counters().frames_ok as usize, t2h.len());
        prop_assert_eq!(dec.counters().errors(), 0);
    }

    /// The hand-built "largest" instances really are the largest of their variant.
    #[test]
    fn no_instance_exceeds_the_largest(h in host_to_target(), t in target_to_host()) {
        let largest = largest_h2t(h2t_index(&h));
        prop_assert!(postcard_bytes(&h).len() <= postcard_bytes(&largest).len(), "{:?}", h);
        let largest = largest_t2h(t2h_index(&t));
        prop_assert!(postcard_bytes(&t).len() <= postcard_bytes(&largest).len(), "{:?}", t);
    }
}

#[test]
fn largest_instances_fit_in_a_frame() {
    fn check<M: WireMessage + PartialEq + Clone + core::fmt::Debug>(msg: M) {
        let payload = postcard_bytes(&msg);
        assert!(
            payload.len() <= MAX_PAYLOAD_LEN,
            "{msg:?}: {} bytes",
            payload.len()
        );
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(&msg, &mut buf).unwrap_or_else(|e| panic!("{msg:?}: {e:?}"));
        assert!(n <= MAX_FRAME_LEN);
        assert_round_trip(&msg);
    }
    for i in 0..usize::from(HostToTarget::VARIANT_COUNT) {
        check(largest_h2t(i));
    }
    for i in 0..usize::from(TargetToHost::VARIANT_COUNT) {
        check(largest_t2h(i));
    }
    // The biggest message today; a change here is a change of the frame budget.
    assert_eq!(
        postcard_bytes(&largest_h2t(4)).len(),
        1 + 3 + 3 + 2 + UPLINK_CHUNK_MAX
    );
}

/// Every reset kind, including the mid-frame ones, has its own tag and survives the link; the
/// kinds added later keep the tags of the older ones (append-only).
#[test]
fn every_reset_kind_round_trips_with_its_tag() {
    let kinds = [
        (ResetKind::Warm, vec![0x05, 0x00]),
        (
            ResetKind::WarmAfterTicks { ticks: 20_000 },
            vec![0x05, 0x01, 0xa0, 0x9c, 0x01],
        ),
        (
            ResetKind::WarmDuringCheckpointWrite { permille: 999 },
            vec![0x05, 0x02, 0xe7, 0x07],
        ),
    ];
    for (kind, payload) in kinds {
        let msg = HostToTarget::ResetRequest { kind };
        assert_eq!(postcard_bytes(&msg), payload, "{kind:?}");
        assert_round_trip(&msg);
    }
}

/// VARIANT_COUNT against the declaration order: the instance of variant i is tagged i, and the
/// last one is tagged VARIANT_COUNT - 1.
#[test]
fn variant_count_matches_declared_variants() {
    fn check<M: WireMessage + core::fmt::Debug>(
        largest: impl Fn(usize) -> M,
        index: impl Fn(&M) -> usize,
    ) {
        let n = usize::from(M::VARIANT_COUNT);
        for i in 0..n {
            let msg = largest(i);
            assert_eq!(index(&msg), i);
            assert_eq!(usize::from(postcard_bytes(&msg)[0]), i, "tag of {msg:?}");
        }
        let last = largest(n - 1);
        assert_eq!(postcard_bytes(&last)[0], M::VARIANT_COUNT - 1);
    }
    check(largest_h2t, h2t_index);
    check(largest_t2h, t2h_index);
}

/// VARIANT_COUNT against what serde actually accepts, independent of any list kept here: tag
/// VARIANT_COUNT - 1 followed by zeros decodes (all-zero fields are valid), tag VARIANT_COUNT is
/// refused by the derived Deserialize.
#[test]
fn variant_count_matches_serde() {
    fn check<M: WireMessage>() {
        let n = M::VARIANT_COUNT;
        let mut payload = [0u8; 64];
        payload[0] = n - 1;
        assert!(
            postcard::take_from_bytes::<M>(&payload).is_ok(),
            "tag {} refused",
            n - 1
        );
        payload[0] = n;
        assert_eq!(
            postcard::take_from_bytes::<M>(&payload).err(),
            Some(postcard::Error::SerdeDeCustom),
            "tag {n} accepted: VARIANT_COUNT is too small"
        );
    }
    check::<HostToTarget>();
    check::<TargetToHost>();
}

#[test]
fn encode_reports_small_output_and_large_payload() {
    let msg = largest_t2h(4);
    let f = frame(&msg);
    let mut exact = vec![0u8; f.len()];
    assert_eq!(encode(&msg, &mut exact), Ok(f.len()));
    assert_eq!(exact, f);
    let mut short = vec![0u8; f.len() - 1];
    assert_eq!(encode(&msg, &mut short), Err(EncodeError::OutputTooSmall));

    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(&RawPayload(vec![0x5a; MAX_PAYLOAD_LEN]), &mut buf).unwrap();
    assert!(n <= MAX_FRAME_LEN);
    assert_eq!(
        encode(&RawPayload(vec![0x5a; MAX_PAYLOAD_LEN + 1]), &mut buf),
        Err(EncodeError::PayloadTooLarge)
    );
    // The largest payload of zeros (every byte stuffed) still fits too.
    let n = encode(&RawPayload(vec![0; MAX_PAYLOAD_LEN]), &mut buf).unwrap();
    assert!(n <= MAX_FRAME_LEN);
    assert_eq!(buf[..n].to_vec(), raw_frame(&[0; MAX_PAYLOAD_LEN]));
}

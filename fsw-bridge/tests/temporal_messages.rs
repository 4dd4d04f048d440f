//! The temporal planning messages (issue 13): every kind round-trips through the frame codec,
//! and the largest instance of each fits where it travels: a frame, the I/O partition's port to
//! the planner (host to target) and the planner's port to the I/O partition (target to host).
mod common;

use common::largest::*;
use common::*;
use fsw_bridge::codec::MAX_PAYLOAD_LEN;
use fsw_bridge::link::{downlink_service, uplink_service, Service, VirtualChannel};
use fsw_bridge::{HostToTarget, TargetToHost};
use proptest::prelude::*;

/// `kernel_config::system::ROUTED_MESSAGE_SIZE` and `OUTBOUND_MESSAGE_SIZE` (this crate does
/// not depend on the configuration; `tests/tests/capacities.rs`-style checks there hold the
/// two equal).
const ROUTED_MESSAGE_SIZE: usize = 160;
const OUTBOUND_MESSAGE_SIZE: usize = 64;
// A message that fits the routed port fits a frame.
const _: () = assert!(ROUTED_MESSAGE_SIZE <= MAX_PAYLOAD_LEN);

#[test]
fn the_largest_temporal_uplink_messages_fit_a_frame_and_the_routed_port() {
    for i in [7, 8] {
        let msg = largest_h2t(i);
        let n = postcard_bytes(&msg).len();
        assert!(n <= ROUTED_MESSAGE_SIZE, "{msg:?}: {n} bytes");
        assert_eq!(decoded::<HostToTarget>(&frame(&msg)), msg);
        assert_eq!(
            uplink_service(&msg),
            Service::Sequenced(VirtualChannel::Mission)
        );
    }
}

#[test]
fn every_largest_temporal_report_fits_the_planners_outbound_port() {
    for i in 0..TEMPORAL_REPORT_KINDS {
        let msg = TargetToHost::Temporal(largest_temporal_report(i));
        let n = postcard_bytes(&msg).len();
        assert!(n <= OUTBOUND_MESSAGE_SIZE, "{msg:?}: {n} bytes");
        assert_eq!(decoded::<TargetToHost>(&frame(&msg)), msg);
        // Reports travel exactly once and in order: the plan is a Mission message.
        assert_eq!(
            downlink_service(&msg),
            Service::Sequenced(VirtualChannel::Mission)
        );
    }
    // The statistics are the largest report (the one `largest_t2h` uses).
    let stats = postcard_bytes(&TargetToHost::Temporal(largest_temporal_report(3))).len();
    for i in 0..TEMPORAL_REPORT_KINDS {
        let n = postcard_bytes(&TargetToHost::Temporal(largest_temporal_report(i))).len();
        assert!(n <= stats);
    }
}

#[test]
fn a_report_names_its_job() {
    for i in 0..TEMPORAL_REPORT_KINDS {
        assert_eq!(largest_temporal_report(i).job(), u16::MAX);
    }
}

fn decoded<M: fsw_bridge::codec::WireMessage + core::fmt::Debug>(bytes: &[u8]) -> M {
    decode_one::<M>(bytes).expect("decodes")
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn temporal_messages_round_trip(
        begin in temporal_begin(),
        chunk in temporal_chunk(),
        report in temporal_report(),
    ) {
        prop_assert_eq!(decoded::<HostToTarget>(&frame(&begin)), begin);
        prop_assert_eq!(decoded::<HostToTarget>(&frame(&chunk)), chunk);
        prop_assert!(postcard_bytes(&report).len() <= OUTBOUND_MESSAGE_SIZE);
        let is_temporal = matches!(report, TargetToHost::Temporal(_));
        prop_assert!(is_temporal);
        prop_assert_eq!(decoded::<TargetToHost>(&frame(&report)), report);
    }
}

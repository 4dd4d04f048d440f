//! The endpoint as a whole: opening both directions, rounds and what is applied at their end,
//! stale control frames, resets, "link lost" with the sequence numbers both ways, settledness,
//! the busy consumer, expedited messages, configuration checks and the target's memory cost;
//! and no input at all (frames of any content, garbage bytes) makes an endpoint panic or
//! break its invariants.
mod common;

use std::fmt::Debug;

use common::link_strategies::link_frames;
use common::{host_to_target, target_to_host};
use proptest::prelude::*;

use fsw_bridge::codec::FrameDecoder;
use fsw_bridge::link::{
    Clcw, ConfigError, Directive, Discard, Endpoint, FopState, LinkConfig, LinkFrame, LinkMessage,
    LinkReport, LostReason, MessageClass, Received, Role, TargetEndpoint, VirtualChannel,
    TARGET_ENDPOINT_BYTES_MAX, VC_COUNT,
};
use fsw_bridge::{HostToTarget, MissionTimeUs, StateKey, StateValue, TargetToHost, TelemetryEvent};

type Host = Endpoint<HostToTarget, TargetToHost, 4096, 64>;
type Target = Endpoint<TargetToHost, HostToTarget, 4096, 64>;

const MISSION: VirtualChannel = VirtualChannel::Mission;
const INSTRUMENT: VirtualChannel = VirtualChannel::Instrument;

fn update(i: u16) -> HostToTarget {
    HostToTarget::StateUpdate {
        key: StateKey(i),
        value: StateValue::Int(i64::from(i)),
        timestamp: MissionTimeUs::from_secs(u64::from(i)),
    }
}

fn transition(i: u16) -> TargetToHost {
    TargetToHost::Telemetry(TelemetryEvent::TaskTransition {
        task: i,
        from: 0,
        to: 1,
        at: MissionTimeUs::from_secs(u64::from(i)),
    })
}

fn log(i: u8) -> TargetToHost {
    TargetToHost::Log {
        bytes: heapless::Vec::from_slice(&[i; 10]).unwrap(),
    }
}

/// The frames of one burst, decoded.
fn produce<Out, In, const R: usize, const Q: usize>(
    endpoint: &mut Endpoint<Out, In, R, Q>,
) -> Vec<LinkFrame<Out>>
where
    Out: LinkMessage + Debug,
    In: LinkMessage,
{
    let mut bytes = Vec::new();
    endpoint.produce_burst(&mut |f: &[u8]| bytes.extend_from_slice(f));
    let mut decoder = FrameDecoder::new();
    bytes
        .iter()
        .filter_map(|&b| decoder.push::<LinkFrame<Out>>(b))
        .map(|r| r.expect("valid frames"))
        .collect()
}

/// Feed frames; returns what each amounted to.
fn feed<Out, In, const R: usize, const Q: usize>(
    endpoint: &mut Endpoint<Out, In, R, Q>,
    frames: impl IntoIterator<Item = LinkFrame<In>>,
) -> Vec<Received<In>>
where
    Out: LinkMessage,
    In: LinkMessage,
{
    frames
        .into_iter()
        .map(|f| endpoint.on_frame(Ok(f), |_| true))
        .collect()
}

fn delivered<M: Clone>(received: &[Received<M>]) -> Vec<(VirtualChannel, M)> {
    received
        .iter()
        .filter_map(|r| match r {
            Received::Delivered { vc, msg } => Some((*vc, msg.clone())),
            _ => None,
        })
        .collect()
}

/// One round without faults, except the frames the filters reject. Returns what the target
/// and the host received.
fn exchange(
    host: &mut Host,
    target: &mut Target,
    mut keep_up: impl FnMut(&LinkFrame<HostToTarget>) -> bool,
    mut keep_down: impl FnMut(&LinkFrame<TargetToHost>) -> bool,
) -> (Vec<Received<HostToTarget>>, Vec<Received<TargetToHost>>) {
    let up: Vec<_> = produce(host)
        .into_iter()
        .filter(|f| matches!(f, LinkFrame::RoundEnd { .. }) || keep_up(f))
        .collect();
    let at_target = feed(target, up);
    assert!(matches!(at_target.last(), Some(Received::RoundEnd { .. })));
    let down: Vec<_> = produce(target)
        .into_iter()
        .filter(|f| matches!(f, LinkFrame::RoundEnd { .. }) || keep_down(f))
        .collect();
    let at_host = feed(host, down);
    (at_target, at_host)
}

fn pair() -> (Host, Target) {
    (
        Host::new(Role::Initiator, LinkConfig::DEFAULT).unwrap(),
        Target::new(Role::Responder, LinkConfig::DEFAULT).unwrap(),
    )
}

fn all<M>(_: &M) -> bool {
    true
}

/// A pair after its opening rounds: the host's channels open in round 1 (the target's answer
/// confirms them), the target's in round 2 (the host's next report confirms them).
fn open_pair() -> (Host, Target) {
    let (mut host, mut target) = pair();
    exchange(&mut host, &mut target, all, all);
    for vc in VirtualChannel::ALL {
        assert_eq!(host.fop(vc).state(), FopState::Active);
        assert_eq!(target.fop(vc).state(), FopState::Initiating);
    }
    exchange(&mut host, &mut target, all, all);
    for vc in VirtualChannel::ALL {
        assert_eq!(host.fop(vc).state(), FopState::Active);
        assert_eq!(target.fop(vc).state(), FopState::Active);
    }
    (host, target)
}

#[test]
fn both_ends_open_their_channels_in_the_first_round_and_carry_data_from_the_second() {
    let (mut host, mut target) = pair();
    host.submit(MISSION, &update(1)).unwrap();
    target.submit(MISSION, &transition(1)).unwrap();

    let up = produce(&mut host);
    let directives: Vec<Directive> = up
        .iter()
        .filter_map(|f| match f {
            LinkFrame::Bc {
                round: 1,
                directive,
            } => Some(*directive),
            _ => None,
        })
        .collect();
    assert_eq!(
        directives,
        vec![
            Directive::Unlock { vc: MISSION },
            Directive::SetVr { vc: MISSION, vr: 0 },
            Directive::Unlock { vc: INSTRUMENT },
            Directive::SetVr {
                vc: INSTRUMENT,
                vr: 0
            },
        ]
    );
    assert!(!up.iter().any(|f| matches!(f, LinkFrame::Ad { .. })));
    let reports = up
        .iter()
        .filter(|f| matches!(f, LinkFrame::Report(_)))
        .count();
    assert_eq!(reports, usize::from(LinkConfig::DEFAULT.report_copies));
    assert_eq!(up.last(), Some(&LinkFrame::RoundEnd { round: 1 }));

    let at_target = feed(&mut target, up);
    assert_eq!(at_target.last(), Some(&Received::RoundEnd { round: 1 }));
    assert!(!target.farm(MISSION).is_locked_out(), "opened by the host");
    let down = produce(&mut target);
    assert!(!down.iter().any(|f| matches!(f, LinkFrame::Ad { .. })));
    assert_eq!(down.last(), Some(&LinkFrame::RoundEnd { round: 1 }));
    feed(&mut host, down);
    assert_eq!(host.fop(MISSION).state(), FopState::Active);

    let (at_target, at_host) = exchange(&mut host, &mut target, all, all);
    assert_eq!(delivered(&at_target), vec![(MISSION, update(1))]);
    assert_eq!(delivered(&at_host), vec![(MISSION, transition(1))]);
    assert_eq!(host.round(), 2);
    assert_eq!(target.round(), 2);
}

#[test]
fn virtual_channels_have_independent_sequence_numbers_and_order() {
    let (mut host, mut target) = open_pair();
    for i in 0..3 {
        target.submit(MISSION, &transition(i)).unwrap();
        target.submit(INSTRUMENT, &log(i as u8)).unwrap();
    }
    // Lose every Instrument frame this round: the Mission stream is not held up by it.
    let (_, at_host) = exchange(&mut host, &mut target, all, |f| {
        !matches!(f, LinkFrame::Ad { vc: INSTRUMENT, .. })
    });
    assert_eq!(
        delivered(&at_host),
        (0..3).map(|i| (MISSION, transition(i))).collect::<Vec<_>>()
    );
    let (_, at_host) = exchange(&mut host, &mut target, all, all);
    assert_eq!(
        delivered(&at_host),
        (0..3)
            .map(|i| (INSTRUMENT, log(i as u8)))
            .collect::<Vec<_>>()
    );
    assert_eq!(host.farm(MISSION).v_r(), 3);
    assert_eq!(host.farm(INSTRUMENT).v_r(), 3);
}

#[test]
fn a_lost_tail_is_asked_for_at_once_from_the_peers_v_s() {
    let (mut host, mut target) = open_pair();
    for i in 0..4 {
        host.submit(MISSION, &update(i)).unwrap();
    }
    // Frames 2 and 3 lost; the report (with V(S) = 4) arrives.
    let (at_target, _) = exchange(
        &mut host,
        &mut target,
        |f| !matches!(f, LinkFrame::Ad { ns: 2 | 3, .. }),
        all,
    );
    assert_eq!(delivered(&at_target).len(), 2);
    assert_eq!(target.stats().received[0].missing_tail_detected, 1);
    assert!(target.report(0).clcw[0].retransmit);
    let (at_target, _) = exchange(&mut host, &mut target, all, all);
    assert_eq!(
        delivered(&at_target),
        vec![(MISSION, update(2)), (MISSION, update(3))]
    );
    assert_eq!(host.stats().sent[0].retransmit_requests, 1);
    assert_eq!(host.stats().sent[0].t1_expiries, 0);
}

#[test]
fn a_report_or_directive_counts_only_at_the_round_end_of_its_own_round() {
    let (mut host, mut target) = open_pair();
    host.submit(MISSION, &update(0)).unwrap();
    let up = produce(&mut host); // frame 0 sent
    let now = host.round();
    feed(&mut target, up);
    let down = produce(&mut target);
    // Deliver the target's fresh Report, then a RoundEnd of the previous round: a stale
    // doorbell for the initiator, so nothing is applied yet.
    let report = down
        .iter()
        .find(|f| matches!(f, LinkFrame::Report(_)))
        .unwrap()
        .clone();
    let r = feed(
        &mut host,
        [report.clone(), LinkFrame::RoundEnd { round: now - 1 }],
    );
    assert_eq!(
        r[1],
        Received::Discarded(Discard::StaleRoundEnd { round: now - 1 })
    );
    assert_eq!(host.fop(MISSION).outstanding(), 1);
    // An older report after the fresh one does not replace it.
    let old = LinkFrame::Report(LinkReport {
        round: now - 1,
        ..LinkReport::default()
    });
    let r = feed(&mut host, [old, LinkFrame::RoundEnd { round: now }]);
    assert_eq!(r[0], Received::Discarded(Discard::StaleControl));
    assert_eq!(
        host.fop(MISSION).outstanding(),
        0,
        "the fresh report applied"
    );

    // A report of another round alone is discarded at the round end, unapplied.
    host.submit(MISSION, &update(1)).unwrap();
    produce(&mut host);
    let now = host.round();
    let applied = host.stats().reports_applied;
    let stale_before = host.stats().stale_control_frames;
    let stale = LinkFrame::Report(LinkReport {
        round: now - 1,
        clcw: [Clcw {
            report_value: 2,
            ..Clcw::default()
        }; VC_COUNT],
        ..LinkReport::default()
    });
    feed(&mut host, [stale, LinkFrame::RoundEnd { round: now }]);
    assert_eq!(host.stats().reports_applied, applied);
    assert_eq!(host.stats().stale_control_frames, stale_before + 1);
    assert_eq!(
        host.fop(MISSION).outstanding(),
        1,
        "not acknowledged by a stale report"
    );

    // A directive of another round is never executed.
    let mut target = Target::new(Role::Responder, LinkConfig::DEFAULT).unwrap();
    feed(
        &mut target,
        [
            LinkFrame::Bc {
                round: 6,
                directive: Directive::Unlock { vc: MISSION },
            },
            LinkFrame::RoundEnd { round: 7 },
        ],
    );
    assert!(target.farm(MISSION).is_locked_out());
    feed(
        &mut target,
        [
            LinkFrame::Bc {
                round: 8,
                directive: Directive::Unlock { vc: MISSION },
            },
            LinkFrame::RoundEnd { round: 8 },
        ],
    );
    assert!(!target.farm(MISSION).is_locked_out());
}

#[test]
fn a_frame_from_before_a_reset_is_never_accepted_after_it() {
    let (mut host, mut target) = open_pair();
    host.submit(MISSION, &update(100)).unwrap();
    // The host's old-session frame N(S) = 0 is held back (by the channel, or in a UART FIFO).
    let old_burst = produce(&mut host);
    let stale_ad = old_burst
        .iter()
        .find(|f| matches!(f, LinkFrame::Ad { ns: 0, .. }))
        .unwrap()
        .clone();
    // The target reboots and says Hello; the host resets on it.
    target.reset();
    host.reset();
    host.submit(MISSION, &update(1)).unwrap();
    let up = produce(&mut host); // the host's opening round
    let mut frames = vec![stale_ad.clone()];
    frames.extend(up);
    let r = feed(&mut target, frames);
    assert_eq!(
        r[0],
        Received::Discarded(Discard::InLockout { vc: MISSION, ns: 0 })
    );
    feed(&mut host, produce(&mut target));
    // Even arriving after the channel is open again, the old frame is just a duplicate.
    let (at_target, _) = exchange(&mut host, &mut target, all, all);
    assert_eq!(delivered(&at_target), vec![(MISSION, update(1))]);
    let r = feed(&mut target, [stale_ad]);
    assert_eq!(
        r[0],
        Received::Discarded(Discard::Duplicate { vc: MISSION, ns: 0 })
    );
}

#[test]
fn the_transmission_limit_ends_in_link_lost_naming_the_sequence_numbers_both_ways() {
    let config = LinkConfig {
        transmission_limit: 5,
        ..LinkConfig::DEFAULT
    };
    let mut host = Host::new(Role::Initiator, config).unwrap();
    let mut target = Target::new(Role::Responder, config).unwrap();
    exchange(&mut host, &mut target, all, all);
    for i in 0..3 {
        host.submit(MISSION, &update(i)).unwrap();
    }
    for i in 0..2 {
        target.submit(MISSION, &transition(i)).unwrap();
    }
    target.submit(INSTRUMENT, &log(0)).unwrap();
    exchange(&mut host, &mut target, all, all);
    exchange(&mut host, &mut target, all, all);
    assert!(host.is_all_settled());

    // The uplink dies: only RoundEnd gets through.
    host.submit(MISSION, &update(3)).unwrap();
    let mut rounds = 0;
    while host.lost().is_none() {
        exchange(&mut host, &mut target, |_| false, all);
        rounds += 1;
        assert!(rounds <= 10, "never declared lost");
    }
    assert_eq!(
        rounds, 6,
        "five transmissions (the limit), lost when a sixth was due"
    );
    let lost = *host.lost().unwrap();
    assert_eq!(
        lost.reason,
        LostReason::TransmissionLimit { vc: MISSION, ns: 3 }
    );
    assert_eq!(lost.sent_acknowledged, [3, 0]);
    assert_eq!(lost.sent_acknowledged_total, [3, 0]);
    assert_eq!(lost.received, [2, 1]);
    assert_eq!(lost.received_total, [2, 1]);
    let text = lost.to_string();
    assert!(text.contains("mission frame N(S)=3"), "{text}");
    assert!(
        text.contains(
            "mission: sent acknowledged up to N(R)=3 (3 frames), received up to V(R)=2 (2 frames)"
        ),
        "{text}"
    );
    assert!(text.contains("instrument: sent acknowledged up to N(R)=0 (0 frames), received up to V(R)=1 (1 frames)"), "{text}");
    // Lost is sticky: nothing more is accepted, and bursts carry only the Report and RoundEnd.
    assert_eq!(
        host.submit(MISSION, &update(9)),
        Err(fsw_bridge::link::SubmitError::LinkLost)
    );
    let burst = produce(&mut host);
    assert!(burst
        .iter()
        .all(|f| matches!(f, LinkFrame::Report(_) | LinkFrame::RoundEnd { .. })));
    assert!(!host.is_settled(MISSION));
}

#[test]
fn a_target_that_declares_the_link_lost_says_so_and_the_host_ends_too() {
    let config = LinkConfig {
        transmission_limit: 4,
        ..LinkConfig::DEFAULT
    };
    let mut host = Host::new(Role::Initiator, config).unwrap();
    let mut target = Target::new(Role::Responder, config).unwrap();
    exchange(&mut host, &mut target, all, all);
    exchange(&mut host, &mut target, all, all);
    // The downlink's Instrument frames never get through; everything else does.
    target.submit(INSTRUMENT, &log(0)).unwrap();
    let mut rounds = 0;
    while target.lost().is_none() {
        exchange(&mut host, &mut target, all, |f| {
            !matches!(f, LinkFrame::Ad { vc: INSTRUMENT, .. })
        });
        rounds += 1;
        assert!(rounds <= 10, "the target never declared the link lost");
    }
    // The answer in which it gave up carries its Report, which says so: the host ends at that
    // round's end, instead of waiting for traffic that will never come.
    let lost = *host
        .lost()
        .expect("the host learned of the loss from the Report");
    assert_eq!(lost.reason, LostReason::PeerLost);
    assert!(lost.to_string().contains("the peer declared the link lost"));
}

#[test]
fn reset_counts_unacknowledged_messages_as_lost_to_reset_by_channel_and_class() {
    let (mut host, mut target) = open_pair();
    for i in 0..4 {
        target.submit(MISSION, &transition(i)).unwrap();
    }
    target.submit(INSTRUMENT, &log(1)).unwrap();
    exchange(&mut host, &mut target, all, all); // sent, not yet acknowledged
    target.submit(MISSION, &transition(9)).unwrap(); // not even sent
    target.reset();
    let stats = target.stats();
    assert_eq!(stats.sent[0].lost_to_reset, 5);
    assert_eq!(stats.sent[1].lost_to_reset, 1);
    assert_eq!(stats.class(MessageClass::Telemetry).lost_to_reset, 5);
    assert_eq!(stats.class(MessageClass::Log).lost_to_reset, 1);
    assert_eq!(stats.resets, 1);
    for vc in VirtualChannel::ALL {
        assert_eq!(target.fop(vc).state(), FopState::Initiating);
        assert_eq!((target.fop(vc).nn_r(), target.fop(vc).v_s()), (0, 0));
        assert!(target.farm(vc).is_locked_out());
        assert_eq!(target.farm(vc).v_r(), 0);
    }
    assert_eq!(target.round(), 0);
    assert!(target.lost().is_none());
}

#[test]
fn settled_means_acknowledged_both_ways_with_a_report_from_the_round_that_just_ended() {
    let (mut host, mut target) = open_pair();
    assert!(host.is_all_settled(), "opened, nothing to send");
    host.submit(MISSION, &update(0)).unwrap();
    assert!(!host.is_settled(MISSION), "queued");
    assert!(host.is_settled(INSTRUMENT), "channels are independent");
    exchange(&mut host, &mut target, all, all);
    assert!(host.is_settled(MISSION), "acknowledged in the answer");

    target.submit(MISSION, &transition(0)).unwrap();
    // The target's reports are lost: the host has the message but cannot know that it has
    // everything the target sent.
    let (_, at_host) = exchange(&mut host, &mut target, all, |f| {
        !matches!(f, LinkFrame::Report(_))
    });
    assert_eq!(delivered(&at_host), vec![(MISSION, transition(0))]);
    assert!(!host.is_settled(MISSION));
    assert!(
        !target.is_settled(MISSION),
        "the host's acknowledgement is still on its way"
    );
    exchange(&mut host, &mut target, all, all);
    assert!(host.is_settled(MISSION));
    assert!(
        target.is_settled(MISSION),
        "acknowledged by the host's next report"
    );
}

#[test]
fn the_report_carries_v_s_and_the_backlog_per_channel() {
    let config = LinkConfig {
        window_width: 2,
        ..LinkConfig::DEFAULT
    };
    let mut host = Host::new(Role::Initiator, config).unwrap();
    let mut target = Target::new(Role::Responder, config).unwrap();
    exchange(&mut host, &mut target, all, all);
    for i in 0..5 {
        target.submit(INSTRUMENT, &log(i)).unwrap();
    }
    feed(&mut target, produce(&mut host));
    let down = produce(&mut target);
    let report = down
        .iter()
        .find_map(|f| match f {
            LinkFrame::Report(r) => Some(*r),
            _ => None,
        })
        .unwrap();
    assert_eq!(report.sent_vs, [0, 2]);
    assert_eq!(report.backlog, [false, true]);
    feed(&mut host, down);
    assert!(
        !host.is_settled(INSTRUMENT),
        "the peer still has messages waiting"
    );
}

#[test]
fn a_busy_consumer_delays_delivery_without_loss_duplication_or_link_loss() {
    let config = LinkConfig {
        transmission_limit: 3,
        ..LinkConfig::DEFAULT
    };
    let mut host = Host::new(Role::Initiator, config).unwrap();
    let mut target = Target::new(Role::Responder, config).unwrap();
    exchange(&mut host, &mut target, all, all);
    for i in 0..6 {
        host.submit(MISSION, &update(i)).unwrap();
    }
    let mut got = Vec::new();
    for round in 0..12 {
        // The consumer takes one message every third round, and only the first offered.
        let mut room = round % 3 == 0;
        let up = produce(&mut host);
        for frame in up {
            if let Received::Delivered { msg, .. } = target.on_frame(Ok(frame), |_| {
                let r = room;
                room = false;
                r
            }) {
                got.push(msg);
            }
        }
        feed(&mut host, produce(&mut target));
        assert!(host.lost().is_none(), "round {round}");
    }
    assert_eq!(got, (0..4).map(update).collect::<Vec<_>>());
    assert!(target.stats().received[0].refused_busy > 0);
    assert!(host.stats().sent[0].peer_busy > 0);
}

#[test]
fn expedited_messages_bypass_sequence_control_and_lockout() {
    let mut target = Target::new(Role::Responder, LinkConfig::DEFAULT).unwrap();
    assert!(target.farm(MISSION).is_locked_out());
    let r = feed(
        &mut target,
        [
            LinkFrame::Bd(HostToTarget::Ping { seq: 7 }),
            LinkFrame::Bd(HostToTarget::Ping { seq: 7 }),
        ],
    );
    assert_eq!(
        r,
        vec![
            Received::Expedited(HostToTarget::Ping { seq: 7 }),
            Received::Expedited(HostToTarget::Ping { seq: 7 })
        ],
        "no sequence control: a duplicate is delivered again"
    );
    assert_eq!(target.stats().expedited_received, 2);
    assert_eq!(target.farm(MISSION).clcw().farm_b_counter, 2);
    let mut out = [0u8; 256];
    let n = target
        .encode_expedited(
            &TargetToHost::Pong {
                seq: 7,
                link: Default::default(),
            },
            &mut out,
        )
        .unwrap();
    let mut decoder = FrameDecoder::new();
    let frames: Vec<_> = out[..n]
        .iter()
        .filter_map(|&b| decoder.push::<LinkFrame<TargetToHost>>(b))
        .collect();
    assert_eq!(
        frames,
        vec![Ok(LinkFrame::Bd(TargetToHost::Pong {
            seq: 7,
            link: Default::default()
        }))]
    );
    assert_eq!(target.stats().class(MessageClass::LinkCheck).sent, 1);
}

#[test]
fn a_decoder_rejection_is_counted_for_the_link() {
    let mut target = Target::new(Role::Responder, LinkConfig::DEFAULT).unwrap();
    let r = target.on_frame(Err(fsw_bridge::codec::DecodeError::BadCrc), |_| true);
    assert_eq!(
        r,
        Received::Discarded(Discard::Rejected(fsw_bridge::codec::DecodeError::BadCrc))
    );
    assert_eq!(target.stats().frames_rejected, 1);
}

#[test]
fn configurations_out_of_range_are_refused() {
    let base = LinkConfig::DEFAULT;
    let cases = [
        (
            LinkConfig {
                window_width: 0,
                ..base
            },
            ConfigError::WindowWidth,
        ),
        (
            LinkConfig {
                window_width: fsw_bridge::link::MAX_WINDOW_WIDTH + 1,
                ..base
            },
            ConfigError::WindowWidth,
        ),
        (
            LinkConfig {
                transmission_limit: 0,
                ..base
            },
            ConfigError::TransmissionLimit,
        ),
        (
            LinkConfig {
                t1_rounds: 0,
                ..base
            },
            ConfigError::T1Rounds,
        ),
        (
            LinkConfig {
                report_copies: 0,
                ..base
            },
            ConfigError::ReportCopies,
        ),
    ];
    for (config, error) in cases {
        assert_eq!(
            Host::new(Role::Initiator, config).err().map(|_| ()),
            Some(()),
            "{config:?}"
        );
        assert_eq!(config.validate(), Err(error));
    }
}

#[test]
fn the_target_endpoint_fits_its_memory_budget() {
    let bytes = core::mem::size_of::<TargetEndpoint>();
    println!("TargetEndpoint: {bytes} bytes");
    assert!(
        bytes <= TARGET_ENDPOINT_BYTES_MAX,
        "TargetEndpoint is {bytes} bytes, budget {TARGET_ENDPOINT_BYTES_MAX}"
    );
    // The rings are most of it: the rest (FARMs, round state, counters) stays small.
    let rings = 2 * fsw_bridge::link::TARGET_RING_BYTES;
    assert!(
        bytes - rings <= 1536,
        "{} bytes besides the rings",
        bytes - rings
    );
}

/// One thing that can happen to an endpoint.
#[derive(Clone, Debug)]
enum Step<In, Out> {
    /// A frame of any content arrives intact.
    Frame(LinkFrame<In>),
    /// Bytes arrive (a damaged frame, noise).
    Garbage(Vec<u8>),
    /// The endpoint's turn to send.
    Burst,
    Submit(VirtualChannel, Out),
    Reset,
}

fn steps<In, Out, SI, SO>(
    incoming: fn() -> SI,
    outgoing: fn() -> SO,
) -> impl Strategy<Value = Vec<Step<In, Out>>>
where
    In: Clone + Debug + 'static,
    Out: Clone + Debug + 'static,
    SI: Strategy<Value = In> + 'static,
    SO: Strategy<Value = Out> + 'static,
{
    let step = prop_oneof![
        8 => link_frames(incoming).prop_map(Step::Frame),
        2 => proptest::collection::vec(any::<u8>(), 0..80).prop_map(Step::Garbage),
        3 => Just(Step::Burst),
        4 => (
            prop_oneof![Just(MISSION), Just(INSTRUMENT)],
            outgoing().boxed()
        )
            .prop_map(|(vc, msg)| Step::Submit(vc, msg)),
        1 => Just(Step::Reset),
    ];
    proptest::collection::vec(step, 0..150)
}

/// Play `steps` on `endpoint`, checking its invariants after each.
fn play<Out, In, const R: usize, const Q: usize>(
    endpoint: &mut Endpoint<Out, In, R, Q>,
    steps: Vec<Step<In, Out>>,
) -> Result<(), TestCaseError>
where
    Out: LinkMessage + Debug,
    In: LinkMessage + Debug,
{
    let mut decoder = FrameDecoder::new();
    let window = usize::from(endpoint.config().window_width);
    let mut delivered = [0u32; VC_COUNT];
    for step in steps {
        let mut bytes = Vec::new();
        match step {
            Step::Frame(frame) => bytes = common::frame(&frame),
            Step::Garbage(garbage) => bytes = garbage,
            Step::Burst => {
                let mut written = 0usize;
                endpoint.produce_burst(&mut |f: &[u8]| written += f.len());
                prop_assert!(written > 0, "a burst always ends with RoundEnd");
            }
            Step::Submit(vc, msg) => {
                let _ = endpoint.submit(vc, &msg);
            }
            Step::Reset => {
                endpoint.reset();
                delivered = [0; VC_COUNT];
            }
        }
        for b in bytes {
            if let Some(result) = decoder.push::<LinkFrame<In>>(b) {
                if let Received::Delivered { vc, .. } = endpoint.on_frame(result, |_| true) {
                    delivered[vc.index()] += 1;
                }
            }
        }
        for vc in VirtualChannel::ALL {
            let fop = endpoint.fop(vc);
            prop_assert!(fop.outstanding() <= window);
            prop_assert!(fop.outstanding() + fop.backlog() <= Q);
            prop_assert!(fop.ring_bytes_used() <= R);
            prop_assert_eq!(fop.v_s(), fop.nn_r().wrapping_add(fop.outstanding() as u8));
            prop_assert_eq!(endpoint.farm(vc).accepted_total(), delivered[vc.index()]);
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn no_input_makes_the_target_endpoint_panic_or_break_its_invariants(
        steps in steps(host_to_target, target_to_host),
    ) {
        let mut target = TargetEndpoint::new(Role::Responder, LinkConfig::DEFAULT).unwrap();
        play(&mut target, steps)?;
    }

    #[test]
    fn no_input_makes_the_host_endpoint_panic_or_break_its_invariants(
        steps in steps(target_to_host, host_to_target),
    ) {
        let mut host = Host::new(Role::Initiator, LinkConfig {
            window_width: 3,
            transmission_limit: 2,
            ..LinkConfig::DEFAULT
        }).unwrap();
        play(&mut host, steps)?;
    }
}

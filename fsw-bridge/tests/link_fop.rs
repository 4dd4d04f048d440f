//! FOP-1, rule by rule, driven directly: opening the channel, the sliding window and the
//! backlog, acknowledgements, invalid CLCWs, the retransmit flag, T1 in rounds, the
//! transmission limit (COP-1's count on the first frame, restarted by acknowledgements), the
//! wait flag, lockout, and reset.
use fsw_bridge::codec::{encode, FrameDecoder};
use fsw_bridge::link::stats::{ClassStats, SendStats};
use fsw_bridge::link::{
    Clcw, Directive, Fop, FopState, LinkConfig, LinkFrame, LostReason, MessageClass, SubmitError,
    VirtualChannel,
};
use fsw_bridge::messages::UPLINK_CHUNK_MAX;
use fsw_bridge::HostToTarget;

const VC: VirtualChannel = VirtualChannel::Mission;

type TestFop = Fop<4096, 64>;

struct Harness<const R: usize, const Q: usize> {
    fop: Fop<R, Q>,
    config: LinkConfig,
    stats: SendStats,
    classes: [ClassStats; MessageClass::COUNT],
    round: u32,
}

fn ping(seq: u32) -> HostToTarget {
    HostToTarget::Ping { seq }
}

fn clcw(report_value: u8) -> Clcw {
    Clcw {
        report_value,
        ..Clcw::default()
    }
}

impl<const R: usize, const Q: usize> Harness<R, Q> {
    fn new(config: LinkConfig) -> Self {
        Self {
            fop: Fop::new(VC),
            config,
            stats: SendStats::default(),
            classes: [ClassStats::default(); MessageClass::COUNT],
            round: 0,
        }
    }

    /// Opened: the directives went out and the peer confirmed V(R) = 0.
    fn opened(config: LinkConfig) -> Self {
        let mut h = Self::new(config);
        let burst = h.transmit().expect("not lost");
        assert_eq!(burst.len(), 2, "Unlock and Set V(R)");
        assert_eq!(h.round_end(Some(clcw(0))), None);
        assert_eq!(h.fop.state(), FopState::Active);
        h
    }

    fn submit(&mut self, msg: &HostToTarget) -> Result<u8, SubmitError> {
        self.fop.submit(
            MessageClass::LinkCheck,
            |ns, buf| encode(&LinkFrame::Ad { vc: VC, ns, msg }, buf),
            &mut self.stats,
        )
    }

    fn submit_pings(&mut self, seqs: core::ops::Range<u32>) {
        for seq in seqs {
            self.submit(&ping(seq)).expect("room");
        }
    }

    /// One burst's frames for this VC, decoded; Err if the link is lost.
    fn transmit(&mut self) -> Result<Vec<LinkFrame<HostToTarget>>, LostReason> {
        self.round += 1;
        let mut bytes = Vec::new();
        let lost = self.fop.transmit(
            self.round,
            &self.config,
            &mut |f: &[u8]| bytes.extend_from_slice(f),
            &mut self.stats,
            &mut self.classes,
        );
        if let Some(reason) = lost {
            assert!(bytes.is_empty(), "nothing is sent when the link is lost");
            return Err(reason);
        }
        let mut decoder = FrameDecoder::new();
        Ok(bytes
            .iter()
            .filter_map(|&b| decoder.push::<LinkFrame<HostToTarget>>(b))
            .map(|r| r.expect("the FOP writes valid frames"))
            .collect())
    }

    /// N(S) of the AD frames of one burst.
    fn transmit_ns(&mut self) -> Vec<u8> {
        self.transmit()
            .expect("not lost")
            .into_iter()
            .map(|f| match f {
                LinkFrame::Ad { ns, vc, .. } => {
                    assert_eq!(vc, VC);
                    ns
                }
                other => panic!("expected only AD frames, got {other:?}"),
            })
            .collect()
    }

    fn round_end(&mut self, clcw: Option<Clcw>) -> Option<LostReason> {
        self.fop.on_round_end(clcw, &self.config, &mut self.stats)
    }
}

fn config() -> LinkConfig {
    LinkConfig::DEFAULT
}

#[test]
fn opens_with_unlock_and_set_v_r_and_sends_no_data_until_the_peer_confirms() {
    let mut h = Harness::<4096, 64>::new(config());
    h.submit_pings(0..3);
    for _ in 0..2 {
        let burst = h.transmit().unwrap();
        assert_eq!(
            burst,
            vec![
                LinkFrame::Bc {
                    round: h.round,
                    directive: Directive::Unlock { vc: VC }
                },
                LinkFrame::Bc {
                    round: h.round,
                    directive: Directive::SetVr { vc: VC, vr: 0 }
                },
            ]
        );
        // No report, or a report that still shows lockout: not open yet.
        h.round_end(if h.round == 1 {
            None
        } else {
            Some(Clcw {
                lockout: true,
                ..clcw(0)
            })
        });
        assert_eq!(h.fop.state(), FopState::Initiating);
    }
    // A CLCW with V(R) other than NN(R) does not confirm either.
    h.transmit().unwrap();
    h.round_end(Some(clcw(9)));
    assert_eq!(h.fop.state(), FopState::Initiating);
    h.transmit().unwrap();
    h.round_end(Some(clcw(0)));
    assert_eq!(h.fop.state(), FopState::Active);
    assert_eq!(h.transmit_ns(), vec![0, 1, 2]);
    assert_eq!(h.stats.unlocks_sent, 4);
    assert_eq!(h.stats.set_vr_sent, 4);
}

#[test]
fn opening_gives_up_after_the_transmission_limit() {
    let mut h = Harness::<4096, 64>::new(LinkConfig {
        transmission_limit: 3,
        ..config()
    });
    for _ in 0..3 {
        h.transmit().unwrap();
        h.round_end(None);
    }
    assert_eq!(h.transmit(), Err(LostReason::InitiationFailed { vc: VC }));
}

#[test]
fn the_window_limits_unacknowledged_frames_and_the_rest_waits_in_the_backlog() {
    let mut h = Harness::<4096, 64>::opened(LinkConfig {
        window_width: 4,
        t1_rounds: 10,
        ..config()
    });
    h.submit_pings(0..10);
    assert_eq!(h.transmit_ns(), vec![0, 1, 2, 3]);
    assert_eq!(h.fop.outstanding(), 4);
    assert_eq!(h.fop.backlog(), 6);
    assert_eq!(
        h.transmit_ns(),
        Vec::<u8>::new(),
        "window full, no acknowledgement"
    );
    h.round_end(Some(clcw(2)));
    assert_eq!(h.fop.nn_r(), 2);
    assert_eq!(h.transmit_ns(), vec![4, 5], "two acknowledged, two new");
    h.round_end(Some(clcw(6)));
    assert_eq!(h.transmit_ns(), vec![6, 7, 8, 9]);
    assert_eq!(h.stats.first_transmissions, 10);
    assert_eq!(h.stats.retransmissions, 0);
    assert_eq!(h.stats.acknowledged, 6);
}

#[test]
fn a_full_ring_refuses_with_full_by_slots_and_by_bytes() {
    let mut h = Harness::<4096, 4>::opened(config());
    h.submit_pings(0..4);
    assert_eq!(h.submit(&ping(4)), Err(SubmitError::Full));
    assert_eq!(h.stats.submitted, 4);
    assert_eq!(h.stats.refused_full, 1);

    // 512 bytes hold three full uplink chunks (about 140 bytes each), not four.
    let mut h = Harness::<512, 64>::opened(config());
    let chunk = HostToTarget::UplinkChunk {
        seq: 1,
        total: 2,
        bytes: heapless::Vec::from_slice(&[0x5a; UPLINK_CHUNK_MAX]).unwrap(),
    };
    for _ in 0..3 {
        h.submit(&chunk).expect("room");
    }
    assert_eq!(h.submit(&chunk), Err(SubmitError::Full));
    // A small message still fits in the bytes left.
    assert!(h.submit(&ping(1)).is_ok());
    // Acknowledging frames frees their bytes.
    assert_eq!(h.transmit_ns(), vec![0, 1, 2, 3]);
    h.round_end(Some(clcw(2)));
    h.submit(&chunk).expect("room after acknowledgement");
}

#[test]
fn frames_wrapping_around_the_ring_go_out_intact() {
    let mut h = Harness::<600, 64>::opened(LinkConfig {
        t1_rounds: 10,
        ..config()
    });
    let chunk = |seq| HostToTarget::UplinkChunk {
        seq,
        total: 100,
        bytes: heapless::Vec::from_slice(&[seq as u8; 100]).unwrap(),
    };
    let mut next = 0u16;
    let mut acked = 0u8;
    let mut wrapped = false;
    for _ in 0..12 {
        while h.submit(&chunk(next)).is_ok() {
            next += 1;
        }
        let burst = h.transmit().unwrap();
        for frame in &burst {
            let LinkFrame::Ad { ns, msg, .. } = frame else {
                panic!("{frame:?}")
            };
            // N(S) counts the submitted chunks, so the chunk number follows from it.
            assert_eq!(msg, &chunk(*ns as u16));
        }
        // Acknowledge two frames per round, so the ring never empties and frames wrap.
        acked = acked.wrapping_add(2).min(h.fop.v_s());
        h.round_end(Some(clcw(acked)));
        wrapped |= h.fop.ring_bytes_used() > 0 && next > 5;
    }
    assert!(
        wrapped && next > 20,
        "the ring was reused with frames in it"
    );
}

#[test]
fn an_acknowledgement_outside_nn_r_to_v_s_is_counted_and_ignored() {
    let mut h = Harness::<4096, 64>::opened(LinkConfig {
        t1_rounds: 10,
        ..config()
    });
    h.submit_pings(0..4);
    assert_eq!(h.transmit_ns(), vec![0, 1, 2, 3]);
    h.round_end(Some(clcw(5))); // beyond V(S) = 4
    h.round_end(Some(clcw(250))); // behind NN(R) = 0
                                  // An invalid CLCW's retransmit flag is ignored too.
    h.round_end(Some(Clcw {
        retransmit: true,
        ..clcw(200)
    }));
    assert_eq!(h.stats.invalid_clcws, 3);
    assert_eq!(h.fop.nn_r(), 0);
    assert_eq!(h.fop.outstanding(), 4);
    assert_eq!(h.transmit_ns(), Vec::<u8>::new());
    h.round_end(Some(clcw(4))); // exactly V(S): everything acknowledged
    assert_eq!(h.fop.outstanding(), 0);
    assert!(h.fop.is_settled());
}

#[test]
fn the_retransmit_flag_resends_every_unacknowledged_frame_in_order() {
    let mut h = Harness::<4096, 64>::opened(LinkConfig {
        window_width: 5,
        t1_rounds: 10,
        ..config()
    });
    h.submit_pings(0..7);
    assert_eq!(h.transmit_ns(), vec![0, 1, 2, 3, 4]);
    h.round_end(Some(Clcw {
        retransmit: true,
        ..clcw(2)
    }));
    // Go-back-N from N(R) = 2, then the two new frames the acknowledgement made room for.
    assert_eq!(h.transmit_ns(), vec![2, 3, 4, 5, 6]);
    assert_eq!(h.stats.retransmit_requests, 1);
    assert_eq!(h.stats.retransmissions, 3);
    assert_eq!(
        h.classes[MessageClass::LinkCheck.index()].retransmissions,
        3
    );
    assert_eq!(h.classes[MessageClass::LinkCheck.index()].sent, 7);
}

#[test]
fn t1_resends_after_the_configured_rounds_without_acknowledgement() {
    let mut h = Harness::<4096, 64>::opened(LinkConfig {
        t1_rounds: 2,
        ..config()
    });
    h.submit_pings(0..2);
    assert_eq!(h.transmit_ns(), vec![0, 1]);
    h.round_end(None); // one round without a report
    assert_eq!(h.transmit_ns(), Vec::<u8>::new());
    h.round_end(Some(clcw(0))); // a report that acknowledges nothing: still waiting
    assert_eq!(h.transmit_ns(), vec![0, 1], "T1 expired after two rounds");
    assert_eq!(h.stats.t1_expiries, 1);
    // With nothing outstanding T1 never fires.
    h.round_end(Some(clcw(2)));
    h.round_end(None);
    h.round_end(None);
    assert_eq!(h.transmit_ns(), Vec::<u8>::new());
    assert_eq!(h.stats.t1_expiries, 1);
}

#[test]
fn the_default_t1_resends_at_the_end_of_every_round_that_left_frames_unacknowledged() {
    let mut h = Harness::<4096, 64>::opened(config());
    h.submit_pings(0..3);
    assert_eq!(h.transmit_ns(), vec![0, 1, 2]);
    // The tail was lost and the peer never saw our report: it acknowledges 0 only, no flag.
    h.round_end(Some(clcw(1)));
    assert_eq!(h.transmit_ns(), vec![1, 2]);
}

#[test]
fn the_transmission_limit_counts_transmissions_of_the_first_unacknowledged_frame() {
    let limit = 4;
    let mut h = Harness::<4096, 64>::opened(LinkConfig {
        transmission_limit: limit,
        ..config()
    });
    h.submit_pings(0..3);
    let mut transmissions_of_0 = 0;
    let lost = loop {
        match h.transmit() {
            Ok(burst) => {
                transmissions_of_0 += burst
                    .iter()
                    .filter(|f| matches!(f, LinkFrame::Ad { ns: 0, .. }))
                    .count();
                h.round_end(None);
            }
            Err(reason) => break reason,
        }
    };
    assert_eq!(transmissions_of_0, usize::from(limit));
    assert_eq!(lost, LostReason::TransmissionLimit { vc: VC, ns: 0 });
}

#[test]
fn an_acknowledgement_restarts_the_transmission_count() {
    let mut h = Harness::<4096, 64>::opened(LinkConfig {
        transmission_limit: 3,
        ..config()
    });
    h.submit_pings(0..3);
    h.transmit().unwrap(); // 1st transmission of frame 0
    for _ in 0..2 {
        h.round_end(None);
        h.transmit().unwrap(); // 2nd and 3rd
    }
    assert_eq!(h.fop.head_transmissions(), 3);
    // Frame 0 gets through: frame 1 becomes first with a fresh count, although it was
    // already sent three times (COP-1: the count belongs to the queue, not the frame).
    h.round_end(Some(Clcw {
        retransmit: true,
        ..clcw(1)
    }));
    assert_eq!(h.fop.head_transmissions(), 1);
    assert_eq!(h.transmit_ns(), vec![1, 2]);
    h.round_end(None);
    assert_eq!(h.transmit_ns(), vec![1, 2]);
    h.round_end(None);
    assert!(h.transmit().is_err(), "frame 1 sent 3 times as first frame");
}

#[test]
fn the_wait_flag_retransmits_without_counting_toward_the_limit() {
    let mut h = Harness::<4096, 64>::opened(LinkConfig {
        transmission_limit: 2,
        ..config()
    });
    h.submit_pings(0..2);
    h.transmit().unwrap();
    for _ in 0..10 {
        h.round_end(Some(Clcw {
            wait: true,
            retransmit: true,
            ..clcw(0)
        }));
        assert_eq!(
            h.transmit_ns(),
            vec![0, 1],
            "the busy peer is offered the frames again"
        );
    }
    assert_eq!(h.stats.peer_busy, 10);
    assert_eq!(h.fop.head_transmissions(), 1);
}

#[test]
fn a_lockout_report_sends_unlock_alone_and_gives_up_after_the_limit() {
    let mut h = Harness::<4096, 64>::opened(LinkConfig {
        transmission_limit: 2,
        ..config()
    });
    h.submit_pings(0..3);
    assert_eq!(h.transmit_ns(), vec![0, 1, 2]);
    // Lockout with a valid N(R): frame 0 was accepted before the receiver locked out.
    assert_eq!(
        h.round_end(Some(Clcw {
            lockout: true,
            ..clcw(1)
        })),
        None
    );
    assert_eq!(h.fop.nn_r(), 1, "the acknowledgement still counts");
    let burst = h.transmit().unwrap();
    assert_eq!(
        burst,
        vec![LinkFrame::Bc {
            round: h.round,
            directive: Directive::Unlock { vc: VC }
        }],
        "no AD frame while the receiver is locked out"
    );
    // Unlocked: the receiver asks for the rest.
    h.round_end(Some(Clcw {
        retransmit: true,
        ..clcw(1)
    }));
    assert_eq!(h.transmit_ns(), vec![1, 2]);
    // Lockout that does not end.
    let locked = Some(Clcw {
        lockout: true,
        ..clcw(1)
    });
    assert_eq!(h.round_end(locked), None);
    h.transmit().unwrap();
    assert_eq!(h.round_end(locked), None);
    h.transmit().unwrap();
    assert_eq!(h.round_end(locked), Some(LostReason::Lockout { vc: VC }));
    assert_eq!(h.stats.lockouts_reported, 4);
}

#[test]
fn reset_flushes_the_queue_as_lost_to_reset_and_reopens_from_zero() {
    let mut h = Harness::<4096, 64>::opened(config());
    h.submit_pings(0..5);
    h.transmit_ns();
    h.round_end(Some(clcw(2)));
    h.fop.reset(&mut h.stats, &mut h.classes);
    assert_eq!(h.stats.lost_to_reset, 3);
    assert_eq!(h.classes[MessageClass::LinkCheck.index()].lost_to_reset, 3);
    assert_eq!(h.fop.state(), FopState::Initiating);
    assert_eq!((h.fop.nn_r(), h.fop.v_s(), h.fop.outstanding()), (0, 0, 0));
    h.submit_pings(10..11);
    let burst = h.transmit().unwrap();
    assert!(matches!(
        burst[..],
        [
            LinkFrame::Bc {
                directive: Directive::Unlock { .. },
                ..
            },
            LinkFrame::Bc {
                directive: Directive::SetVr { vr: 0, .. },
                ..
            }
        ]
    ));
    h.round_end(Some(clcw(0)));
    let burst = h.transmit().unwrap();
    assert_eq!(
        burst,
        vec![LinkFrame::Ad {
            vc: VC,
            ns: 0,
            msg: ping(10)
        }]
    );
}

#[test]
fn sequence_numbers_wrap_modulo_256() {
    let mut h = Harness::<4096, 64>::opened(LinkConfig {
        t1_rounds: 10,
        ..config()
    });
    let mut expected = 0u8;
    for round in 0..40u32 {
        h.submit_pings(round * 10..round * 10 + 10);
        let ns = h.transmit_ns();
        for n in &ns {
            assert_eq!(*n, expected);
            expected = expected.wrapping_add(1);
        }
        h.round_end(Some(clcw(expected)));
    }
    assert_eq!(h.fop.acknowledged_total(), 400);
    assert_eq!(h.fop.nn_r(), (400 % 256) as u8);
    let _: TestFop = Fop::new(VC);
}

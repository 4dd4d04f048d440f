//! FARM-1, rule by rule: accept in sequence, positive window sets the retransmit flag, negative
//! window discards silently, outside both locks out until Unlock, a full consumer sets wait,
//! Set V(R) is refused in lockout, and a lost tail shows in the peer's V(S).
use fsw_bridge::link::{AdVerdict, Farm, FARM_NEGATIVE_WINDOW, FARM_POSITIVE_WINDOW};

/// A FARM opened by the peer (Unlock) at V(R) = `vr`.
fn open_at(vr: u8) -> Farm {
    let mut farm = Farm::new();
    farm.on_unlock();
    assert!(farm.on_set_vr(vr));
    farm
}

#[test]
fn starts_in_lockout_and_accepts_nothing_until_unlocked() {
    let mut farm = Farm::new();
    assert!(farm.is_locked_out());
    assert!(farm.clcw().lockout);
    assert_eq!(farm.on_ad(0, || true), AdVerdict::DiscardedInLockout);
    assert_eq!(farm.v_r(), 0);
    farm.on_unlock();
    assert!(!farm.clcw().lockout);
    assert_eq!(farm.on_ad(0, || true), AdVerdict::Accepted);
    assert_eq!(farm.v_r(), 1);
}

#[test]
fn accepts_exactly_the_expected_sequence_number_and_moves_v_r() {
    let mut farm = open_at(250);
    for ns in [250u8, 251, 252, 253, 254, 255, 0, 1] {
        assert_eq!(farm.on_ad(ns, || true), AdVerdict::Accepted, "N(S) {ns}");
    }
    assert_eq!(farm.v_r(), 2, "V(R) wraps modulo 256");
    assert_eq!(farm.accepted_total(), 8);
    assert_eq!(farm.clcw().report_value, 2);
}

#[test]
fn positive_window_discards_and_sets_the_retransmit_flag_until_the_gap_is_filled() {
    let mut farm = open_at(10);
    assert_eq!(farm.on_ad(11, || true), AdVerdict::OutOfSequence);
    assert_eq!(farm.v_r(), 10);
    assert!(farm.clcw().retransmit);
    // The far edge of the positive window is still "ahead", not lockout.
    assert_eq!(
        farm.on_ad(10u8.wrapping_add(FARM_POSITIVE_WINDOW - 1), || true),
        AdVerdict::OutOfSequence
    );
    assert!(!farm.is_locked_out());
    assert_eq!(farm.on_ad(10, || true), AdVerdict::Accepted);
    assert!(
        !farm.clcw().retransmit,
        "accepting the missing frame clears it"
    );
}

#[test]
fn negative_window_discards_silently() {
    let mut farm = open_at(5);
    for ns in 5..9u8 {
        assert_eq!(farm.on_ad(ns, || true), AdVerdict::Accepted);
    }
    let before = farm.clcw();
    assert_eq!(farm.on_ad(8, || true), AdVerdict::Duplicate);
    assert_eq!(farm.on_ad(5, || true), AdVerdict::Duplicate);
    // The far edge of the negative window, across the wrap.
    assert_eq!(
        farm.on_ad(9u8.wrapping_sub(FARM_NEGATIVE_WINDOW), || true),
        AdVerdict::Duplicate
    );
    assert_eq!(farm.clcw(), before, "no flag, no V(R) change");
}

#[test]
fn outside_both_windows_enters_lockout_until_an_unlock() {
    let mut farm = open_at(100);
    // One past the positive window.
    assert_eq!(
        farm.on_ad(100u8.wrapping_add(FARM_POSITIVE_WINDOW), || true),
        AdVerdict::EnteredLockout
    );
    assert!(farm.clcw().lockout);
    assert_eq!(farm.on_ad(100, || true), AdVerdict::DiscardedInLockout);
    assert_eq!(farm.v_r(), 100);
    // Set V(R) is not executed in lockout (COP-1: unlock first), only counted.
    let counter = farm.clcw().farm_b_counter;
    assert!(!farm.on_set_vr(0));
    assert_eq!(farm.v_r(), 100);
    assert_eq!(farm.clcw().farm_b_counter, (counter + 1) & 3);
    farm.on_unlock();
    assert!(!farm.is_locked_out());
    assert_eq!(farm.v_r(), 100, "Unlock keeps V(R)");
    assert_eq!(farm.on_ad(100, || true), AdVerdict::Accepted);

    // One past the negative window locks out too.
    let mut farm = open_at(100);
    assert_eq!(
        farm.on_ad(100u8.wrapping_sub(FARM_NEGATIVE_WINDOW + 1), || true),
        AdVerdict::EnteredLockout
    );
}

#[test]
fn a_full_consumer_sets_wait_and_the_next_accepted_frame_clears_it() {
    let mut farm = open_at(0);
    assert_eq!(farm.on_ad(0, || false), AdVerdict::RefusedBusy);
    assert_eq!(farm.v_r(), 0, "the refused frame is not accepted");
    let clcw = farm.clcw();
    assert!(clcw.wait && clcw.retransmit);
    // Frames after it are out of sequence while it is missing.
    assert_eq!(farm.on_ad(1, || true), AdVerdict::OutOfSequence);
    assert_eq!(farm.on_ad(0, || true), AdVerdict::Accepted);
    let clcw = farm.clcw();
    assert!(!clcw.wait && !clcw.retransmit);
}

#[test]
fn the_consumer_is_asked_only_for_an_in_sequence_frame() {
    let mut farm = open_at(3);
    let mut asked = 0;
    farm.on_ad(4, || {
        asked += 1;
        true
    });
    farm.on_ad(2, || {
        asked += 1;
        true
    });
    assert_eq!(asked, 0);
    farm.on_ad(3, || {
        asked += 1;
        true
    });
    assert_eq!(asked, 1);
}

#[test]
fn unlock_clears_wait_and_retransmit_and_set_v_r_moves_the_window() {
    let mut farm = open_at(0);
    farm.on_ad(0, || false);
    farm.on_unlock();
    let clcw = farm.clcw();
    assert!(!clcw.wait && !clcw.retransmit && !clcw.lockout);
    assert!(farm.on_set_vr(77));
    assert_eq!(farm.v_r(), 77);
    assert_eq!(farm.on_ad(77, || true), AdVerdict::Accepted);
}

#[test]
fn a_peer_v_s_ahead_of_v_r_means_a_lost_tail_and_asks_for_retransmission() {
    let mut farm = open_at(20);
    assert!(!farm.on_peer_sent(20), "nothing missing");
    assert!(!farm.clcw().retransmit);
    assert!(farm.on_peer_sent(23));
    assert!(farm.clcw().retransmit);
    // A V(S) behind V(R) (an old report) or in lockout asks for nothing.
    let mut farm = open_at(20);
    assert!(!farm.on_peer_sent(19));
    assert!(!farm.clcw().retransmit);
    let mut locked = Farm::new();
    assert!(!locked.on_peer_sent(5));
}

#[test]
fn the_farm_b_counter_counts_bd_and_bc_frames_modulo_four() {
    let mut farm = Farm::new();
    for _ in 0..5 {
        farm.on_expedited();
    }
    assert_eq!(farm.clcw().farm_b_counter, 1);
    farm.on_unlock();
    farm.on_set_vr(0);
    assert_eq!(farm.clcw().farm_b_counter, 3);
}

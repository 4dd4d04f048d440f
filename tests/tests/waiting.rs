//! The target waiting for the host under qemu-system-ppc: when nothing in the module has work
//! until the host sends something, the kernel stops the schedule and the guest dozes with no
//! timer armed, which under `-icount sleep=off` costs the host no CPU; the link's receive
//! interrupt brings it back. Input arriving faster than a partition takes it is held back, not
//! lost. Each over both link transports (the serial line, the shared-memory link).
use std::time::{Duration, Instant};

use fsw_bridge::{HostToTarget, MissionTimeUs, StateKey, StateValue, TargetToHost, TelemetryEvent};
use hil::qemu::Transport;
use hil::session::Session;
use hil_tests::{boot_over, PATIENCE, TRANSPORTS};
use kernel_config::abi::{control, metric};
use kernel_config::system::PORT_IO_TO_EXECUTIVE;

/// How long the idle target is watched.
const IDLE_WATCH: Duration = Duration::from_secs(2);

fn state_update(key: u16, value: StateValue) -> HostToTarget {
    HostToTarget::StateUpdate {
        key: StateKey(key),
        value,
        timestamp: MissionTimeUs::ZERO,
    }
}

/// Receive until a message `want` picks arrives; everything else goes to `unsolicited`.
fn wait_for<T>(target: &mut Session, what: &str, want: impl Fn(&TargetToHost) -> Option<T>) -> T {
    let deadline = Instant::now() + PATIENCE;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let msg = target
            .recv(left)
            .unwrap_or_else(|e| panic!("waiting for {what}: {e}"));
        if let Some(value) = want(&msg) {
            return value;
        }
        target.unsolicited.push(msg);
    }
}

fn metric_value(target: &mut Session, id: u16) -> u64 {
    wait_for(target, &format!("metric {id:#x}"), |m| match m {
        TargetToHost::Telemetry(TelemetryEvent::Metric { id: i, value }) if *i == id => {
            Some(*value)
        }
        _ => None,
    })
}

#[test]
fn a_target_waiting_for_the_host_costs_no_host_cpu() {
    for transport in TRANSPORTS {
        waiting_costs_no_host_cpu(transport);
    }
}

fn waiting_costs_no_host_cpu(transport: Transport) {
    let mut target = boot_over(transport);
    target.expect_hello(PATIENCE).unwrap();
    // Answered only once the boot is through; then nothing in the module has work.
    target.ping(1, PATIENCE).unwrap();
    let qemu = target.qemu.as_ref().unwrap();
    let before = qemu.cpu_time().expect("QEMU's CPU time from /proc");
    std::thread::sleep(IDLE_WATCH);
    let used = qemu.cpu_time().unwrap() - before;
    // A schedule that kept running would keep one host core busy (about IDLE_WATCH of CPU):
    // under sleep=off QEMU jumps to each window start as soon as the guest idles.
    assert!(
        used < IDLE_WATCH / 20,
        "{transport:?}: QEMU used {used:?} of CPU in {IDLE_WATCH:?} while the target waited for the host"
    );
    // And it still answers at once.
    target.ping(2, PATIENCE).unwrap();
    target
        .link
        .send(&state_update(control::REQUEST_METRICS, StateValue::Int(0)))
        .unwrap();
    let parks = metric_value(&mut target, metric::PARKS);
    assert!(
        parks >= 2,
        "{transport:?}: the schedule was stopped {parks} times"
    );
    let shared_memory = metric_value(&mut target, metric::LINK_TRANSPORT);
    assert_eq!(
        shared_memory,
        u64::from(transport == Transport::SharedMemory)
    );
}

#[test]
fn the_kernel_counts_what_it_received_and_lost_nothing() {
    for transport in TRANSPORTS {
        counts_what_it_received(transport);
    }
}

fn counts_what_it_received(transport: Transport) {
    let mut target = boot_over(transport);
    target.expect_hello(PATIENCE).unwrap();
    for seq in 0..20 {
        target.ping(seq, PATIENCE).unwrap();
    }
    // Writes before the request (the request is the next one).
    let sent_before_request = target
        .link
        .transcript()
        .iter()
        .filter(|entry| matches!(entry, hil::link::TranscriptEntry::Sent(_)))
        .count();
    target
        .link
        .send(&state_update(control::REQUEST_METRICS, StateValue::Int(0)))
        .unwrap();
    let received = metric_value(&mut target, metric::LINK_RX_BYTES);
    let lost = metric_value(&mut target, metric::LINK_RX_LOST);
    let ring_full = metric_value(&mut target, metric::LINK_RX_RING_FULL);
    let ring_errors = metric_value(&mut target, metric::LINK_RING_ERRORS);
    // The kernel took its figures at some point after the request arrived; the rounds that
    // brought them in may have reached it before that point or not. So the count is at least
    // what the host had sent up to the request and at most all it sent; over shared memory,
    // where a write lands whole, it is the host's count at the end of one of its writes from
    // the request on (a byte lost or counted twice would match none of them).
    let transcript = target.link.transcript();
    let writes: Vec<usize> = transcript
        .iter()
        .filter_map(|entry| match entry {
            hil::link::TranscriptEntry::Sent(bytes) => Some(bytes.len()),
            _ => None,
        })
        .collect();
    let totals: Vec<usize> = writes
        .iter()
        .scan(0, |sum, n| {
            *sum += n;
            Some(*sum)
        })
        .skip(sent_before_request)
        .collect();
    let received = received as usize;
    let within = totals.first().is_some_and(|&first| first <= received)
        && totals.last().is_some_and(|&last| received <= last);
    let whole_writes = transport == Transport::Serial || totals.contains(&received);
    assert!(
        within && whole_writes,
        "{transport:?}: the kernel received {received} bytes; the host had sent one of {totals:?}"
    );
    assert_eq!((lost, ring_full, ring_errors), (0, 0, 0), "{transport:?}");
}

#[test]
fn a_burst_larger_than_a_port_reaches_the_executive_whole() {
    for transport in TRANSPORTS {
        burst_reaches_the_executive_whole(transport);
    }
}

fn burst_reaches_the_executive_whole(transport: Transport) {
    let mut target = boot_over(transport);
    target.expect_hello(PATIENCE).unwrap();
    target.ping(1, PATIENCE).unwrap();
    // Several times the depth of the port to the executive (8), in one write: the I/O
    // partition holds what does not fit until the executive has made room.
    let updates = 20u64;
    let depth = u64::from(kernel_config::system::PRODUCT.ports[PORT_IO_TO_EXECUTIVE].depth);
    assert!(updates > 2 * depth);
    let mut burst = Vec::new();
    for i in 0..updates {
        let mut frame = [0u8; fsw_bridge::codec::MAX_FRAME_LEN];
        let msg = state_update(100, StateValue::Int(i as i64));
        let n =
            fsw_bridge::codec::encode(&fsw_bridge::link::LinkFrame::Bd(&msg), &mut frame).unwrap();
        burst.extend_from_slice(&frame[..n]);
    }
    target.link.send_raw(&burst).unwrap();
    // The grant completes the batch; the executive handles it at its next window start.
    target
        .link
        .send(&HostToTarget::TimeGrant {
            frame: 0,
            now: MissionTimeUs(1_000_000),
            until: MissionTimeUs(2_000_000),
        })
        .unwrap();
    wait_for(&mut target, "FrameDone", |m| {
        matches!(m, TargetToHost::FrameDone { frame: 0, .. }).then_some(())
    });
    target
        .link
        .send(&state_update(control::SYSCALL_BENCH, StateValue::Unknown))
        .unwrap();
    let handled = metric_value(&mut target, metric::EXECUTIVE_STATE_UPDATES);
    assert_eq!(
        handled, updates,
        "{transport:?}: state updates the executive handled"
    );
    let rejected: Vec<_> = target
        .logs
        .iter()
        .filter(|l| l.message.contains("refused"))
        .map(|l| l.message.clone())
        .collect();
    assert!(rejected.is_empty(), "{rejected:?}");
}

//! The channel between the partitions when it is full: the frame's own message always finds
//! its place, late if the log is full of messages not yet acknowledged, so the planner always
//! answers a frame (a messages fuzz finding, 599b3ddd: a frame whose 64 task reports filled the
//! executive's log was never answered, and its grant got no `FrameDone`).
use autonomy::partitioned::*;
use fsw_bridge::MissionTimeUs;

/// Records nothing: the executive holds no network, so its passes output nothing.
struct Quiet;

impl autonomy::Outputs for Quiet {
    fn dispatch(&mut self, _id: u32, _opcode: fsw_bridge::Opcode, _args: &fsw_bridge::CommandArgs) {
    }
    fn telemetry(&mut self, _event: fsw_bridge::TelemetryEvent) {}
}

/// What the executive sends after its checkpoint, handed to the planner.
fn executive_to_planner(executive: &mut ExecutivePartition, planner: &mut PlannerPartition) {
    executive.checkpointed();
    executive.transmit(&mut |w| {
        planner.receive(w);
        true
    });
}

/// What the planner sends after its checkpoint, handed to the executive.
fn planner_to_executive(planner: &mut PlannerPartition, executive: &mut ExecutivePartition) {
    planner.checkpointed();
    planner.transmit(&mut |w| {
        executive.receive(w);
        true
    });
}

#[test]
fn a_frame_message_that_finds_the_log_full_goes_after_the_next_acknowledgement() {
    let mut executive = Box::new(ExecutivePartition::new());
    let mut planner = Box::new(PlannerPartition::new());
    // Frames the planner never hears of: nothing is acknowledged, the log fills with their
    // messages, and the last frame's finds no room.
    let frames = MAX_TO_PLANNER_IN_FLIGHT as u32 + 1;
    for frame in 1..=frames {
        executive.first_window(frame, MissionTimeUs(u64::from(frame) * 10_000), &mut Quiet);
    }
    assert_eq!(executive.to_planner().room(), 0);
    executive_to_planner(&mut executive, &mut planner);
    // The planner answers the newest frame it heard of, not the last one.
    let status = planner.window(1_000u32).expect("a frame to answer");
    assert_eq!(status.frame, frames - 1);
    planner_to_executive(&mut planner, &mut executive);
    assert!(
        !executive.planner_answered(),
        "frame {frames} not heard yet"
    );
    // The acknowledgement made room: the last frame's message went into the log, and the
    // next transmission brings it to the planner, which answers it.
    executive_to_planner(&mut executive, &mut planner);
    let status = planner.window(1_000u32).expect("the last frame, late");
    assert_eq!(status.frame, frames);
    planner_to_executive(&mut planner, &mut executive);
    assert!(executive.planner_answered());
}

#[test]
fn the_planner_keeps_its_last_place_for_the_status_and_waits_when_it_has_none() {
    let mut planner = Box::new(PlannerPartition::new());
    let frame = |seq: u32| Wire::Message {
        seq,
        message: PlannerInput::Frame {
            frame: seq,
            now: MissionTimeUs(u64::from(seq) * 10_000),
        },
    };
    // Frames answered, their statuses never acknowledged: the planner's log fills.
    let capacity = MAX_TO_EXECUTIVE_IN_FLIGHT as u32;
    for seq in 1..=capacity {
        planner.receive(frame(seq));
        assert_eq!(planner.window(1_000u32).map(|s| s.frame), Some(seq));
    }
    assert_eq!(planner.to_executive().room(), 0);
    // With no place for a status the window waits, keeping the frame, and refuses nothing.
    planner.receive(frame(capacity + 1));
    assert!(planner.window(1_000u32).is_none());
    assert!(
        planner.frame_pending(),
        "the frame is kept for a later window"
    );
    assert_eq!(planner.to_executive().refused, 0);
    // Once the executive acknowledges, the next window answers it.
    planner.receive(Wire::Ack { upto: capacity });
    assert_eq!(
        planner.window(1_000u32).map(|s| s.frame),
        Some(capacity + 1)
    );
}

//! The autonomy core split over two partitions (`autonomy::partitioned`): the same decisions as
//! the single core when the planner finishes in its window; a throttled planner that commits
//! later in mission time while the executive keeps its every-frame schedule; and a warm reset
//! at any point of either partition's frame (inside checkpoint writes and with messages in the
//! ports included) that restores a consistent pair.
mod common;

use std::collections::BTreeSet;

use autonomy::partitioned::*;
use autonomy::*;
use common::*;
use fsw_bridge::MissionTimeUs;

/// A reset to make inside a frame: in the `frame`-th frame (counted from 0), at `point`; with
/// `torn`, in the middle of the checkpoint write that follows `point` instead.
#[derive(Clone, Copy, Debug)]
struct MidFrameReset {
    frame: u64,
    point: Point,
    torn: bool,
    recovery_us: u64,
}

struct Env<'a> {
    executive_area: &'a mut Vec<u8>,
    planner_area: &'a mut Vec<u8>,
    /// Reset when the frame reaches this point (or tear the checkpoint after it).
    reset: Option<(Point, bool)>,
    last_point: Option<Point>,
}

impl FrameEnv for Env<'_> {
    fn checkpoint(
        &mut self,
        side: Side,
        executive: &ExecutivePartition,
        planner: &PlannerPartition,
    ) -> bool {
        let area = match side {
            Side::Executive => &mut *self.executive_area,
            Side::Planner => &mut *self.planner_area,
        };
        let write = |bytes: &mut [u8]| {
            let mut area = WarmRestartArea::new(bytes);
            match side {
                Side::Executive => area.write_record(|buf| executive.encode_state(buf)),
                Side::Planner => area.write_record(|buf| planner.encode_state(buf)),
            }
            .expect("checkpoint fits")
        };
        let tear = matches!(self.reset, Some((p, true)) if Some(p) == self.last_point);
        if tear {
            // The reset comes half-way through the write: half of the record's bytes land.
            let mut whole = area.clone();
            let written = write(&mut whole);
            let (start, end) = written.bytes;
            let half = start + (end - start) / 2;
            area[start..half].copy_from_slice(&whole[start..half]);
            return false;
        }
        write(area);
        true
    }

    fn proceed(&mut self, point: Point) -> bool {
        self.last_point = Some(point);
        !matches!(self.reset, Some((p, false)) if p == point)
    }
}

/// Lockstep runner for the two partitions: the fake spacecraft, one warm-restart area per
/// partition, every decision recorded.
struct PairSim {
    executive: Box<ExecutivePartition>,
    planner: Box<PlannerPartition>,
    sc: FakeSpacecraft,
    executive_area: Vec<u8>,
    planner_area: Vec<u8>,
    out: Recorder,
    budget: u32,
    now: MissionTimeUs,
    frames: u64,
    /// (mission time, the frame's report) of every frame that ran to its end.
    log: Vec<(MissionTimeUs, Frame)>,
    /// Frames in which the executive ran both windows.
    executive_frames: u64,
    mid_frame: Option<MidFrameReset>,
    /// Where the mid-frame reset landed and the frame it interrupted.
    landed: Option<(Point, MissionTimeUs)>,
    /// (planner's view, executive's tasks) after every planner transmission that was followed
    /// by the executive's second window.
    views: Vec<(BTreeSet<u16>, BTreeSet<u16>)>,
    /// At the next reset, the planner's warm-restart area is lost too.
    lose_planner_area: bool,
}

impl PairSim {
    fn new(network: TaskNetwork, start: MissionTimeUs, budget: u32) -> Self {
        let mut executive = Box::new(ExecutivePartition::new());
        let planner = Box::new(PlannerPartition::new());
        // The planner gets the network through the channel, from the first frame on; the
        // executive checkpoints a network as soon as it has loaded it (as the flight
        // application does).
        executive.load_network(&network).expect("loads");
        let mut executive_area = vec![0u8; WARM_AREA_LEN];
        executive
            .checkpoint_to(&mut WarmRestartArea::new(&mut executive_area))
            .expect("fits");
        // (Marked checkpointed: what it pushed may go.)
        Self {
            executive,
            planner,
            sc: FakeSpacecraft::new(start),
            executive_area,
            planner_area: vec![0u8; WARM_AREA_LEN],
            out: Recorder::default(),
            budget,
            now: start,
            frames: 0,
            log: Vec::new(),
            executive_frames: 0,
            mid_frame: None,
            landed: None,
            views: Vec::new(),
            lose_planner_area: false,
        }
    }

    fn flyby(budget: u32) -> Self {
        Self::new(flyby_network(), hm(9, 50), budget)
    }

    /// The instances the planner believes the executive holds, and those it holds.
    fn views(&self) -> (BTreeSet<u16>, BTreeSet<u16>) {
        let planner = self
            .planner
            .planner()
            .entries()
            .iter()
            .filter(|e| matches!(e.state, TaskState::Committed | TaskState::Running))
            .map(|e| e.instance)
            .collect();
        let executive = self
            .executive
            .control()
            .executive()
            .entries()
            .iter()
            .map(|e| e.instance)
            .collect();
        (planner, executive)
    }

    /// Runs one frame at `t`; a mid-frame reset due in it resets the module.
    fn frame_at(&mut self, t: MissionTimeUs) {
        self.now = t;
        self.out.now = t;
        self.sc.deliver(t, &mut *self.executive);
        let reset = self
            .mid_frame
            .filter(|r| r.frame == self.frames)
            .map(|r| (r.point, r.torn));
        let mut env = Env {
            executive_area: &mut self.executive_area,
            planner_area: &mut self.planner_area,
            reset,
            last_point: None,
        };
        // The planner's view is compared with the executive's right after the commits arrive.
        struct Watch<'a, 'b> {
            env: &'a mut Env<'b>,
            at_planner_sent: bool,
        }
        impl FrameEnv for Watch<'_, '_> {
            fn checkpoint(
                &mut self,
                side: Side,
                executive: &ExecutivePartition,
                planner: &PlannerPartition,
            ) -> bool {
                self.env.checkpoint(side, executive, planner)
            }
            fn proceed(&mut self, point: Point) -> bool {
                if point == Point::PlannerSent {
                    self.at_planner_sent = true;
                }
                self.env.proceed(point)
            }
        }
        let mut watch = Watch {
            env: &mut env,
            at_planner_sent: false,
        };
        let result = run_frame(
            &mut self.executive,
            &mut self.planner,
            self.frames as u32 + 1,
            t,
            self.budget,
            &mut self.out,
            &mut watch,
        );
        let reached_planner_sent = watch.at_planner_sent;
        self.frames += 1;
        for (id, opcode, args) in std::mem::take(&mut self.out.dispatches) {
            self.sc.on_dispatch(t, id, opcode, &args);
        }
        match result {
            Ok(frame) => {
                self.executive_frames += 1;
                self.log.push((t, frame));
                if reached_planner_sent {
                    // Checked at the frame's end too: the second window takes commits only.
                    self.views.push(self.views());
                }
            }
            Err(Interrupted(point)) => {
                let r = self.mid_frame.take().expect("a reset was planned");
                self.landed = Some((point, t));
                self.reset(Reset {
                    at: t,
                    recovery_us: r.recovery_us,
                });
            }
        }
    }

    fn next_wakeup(&self) -> Option<MissionTimeUs> {
        self.log.last().and_then(|(_, f)| f.next_wakeup)
    }

    fn run(&mut self, end: MissionTimeUs, resets: &[Reset]) {
        let mut resets = resets.to_vec();
        self.frame_at(self.now);
        loop {
            let mut next = [self.next_wakeup(), self.sc.next_event()]
                .into_iter()
                .flatten()
                .min();
            if let Some(r) = resets.first() {
                if next.is_none_or(|n| r.at <= n) {
                    next = Some(r.at);
                }
            }
            let Some(next) = next else { break };
            if next > end {
                break;
            }
            if let Some(r) = resets.first().copied() {
                if r.at == next {
                    resets.remove(0);
                    self.reset(r);
                    continue;
                }
            }
            assert!(next >= self.now, "time went backwards");
            assert!(self.frames < 200_000, "runaway at {}", fmt_time(next));
            self.frame_at(next);
        }
    }

    /// Warm reset of the whole module: both partitions lose their RAM; each restores its own
    /// newest whole checkpoint; the state buffer is published again.
    fn reset(&mut self, r: Reset) {
        self.sc.reset(r.at);
        *self.executive = ExecutivePartition::new();
        *self.planner = PlannerPartition::new();
        if std::mem::take(&mut self.lose_planner_area) {
            self.planner_area.fill(0);
        }
        let restart = r.at.saturating_add(r.recovery_us);
        self.executive
            .restore_from(&WarmRestartArea::new(&mut self.executive_area))
            .expect("the executive's whole checkpoint survives");
        // A planner that never checkpointed starts cold: nothing it received was acknowledged,
        // so the executive sends it all again.
        match self
            .planner
            .restore_from(&WarmRestartArea::new(&mut self.planner_area))
        {
            Ok(_) | Err(SideRestoreError::NoRecord) => {}
            Err(e) => panic!("the planner's whole checkpoint does not restore: {e:?}"),
        }
        self.sc.publish_all(&mut *self.executive);
        self.frame_at(restart);
    }
}

/// The flyby plus `extra` one-minute downlinks from 11:00 that share one antenna and must go in
/// the reverse of the order the planner tries them (downlink k needs `extra - 1 - k` done
/// before it starts): a planner load in which a scheduling pass places one downlink, so a cycle
/// takes about three windows per downlink with one job per window.
fn loaded_flyby(extra: u16) -> TaskNetwork {
    let mut spec = common::flyby_spec();
    let antenna = spec.timelines.len() as u8;
    let mut timeline = spec.timelines[usize::from(TL_INSTRUMENT)].clone();
    timeline.name = Name::try_from("Antenna").unwrap();
    spec.timelines.push(timeline.clone()).unwrap();
    let chain = spec.timelines.len() as u8;
    timeline.name = Name::try_from("Downlinked").unwrap();
    timeline.kind = TimelineKind::Cumulative {
        initial: 0,
        min: 0,
        max: i64::from(extra),
    };
    spec.timelines.push(timeline).unwrap();
    let request = spec
        .tasks
        .iter()
        .find(|t| t.id == ID_REQUEST)
        .unwrap()
        .clone();
    for k in 0..extra {
        let mut t = request.clone();
        t.id = 100 + k;
        t.name = Name::try_from(format!("Downlink {k}").as_str()).unwrap();
        t.priority = 60;
        t.duration_us = MIN;
        t.min_duration_us = MIN;
        t.earliest_start = hm(11, 0);
        t.latest_start = hm(12, 0);
        t.latest_end = MissionTimeUs::MAX;
        t.constraints.clear();
        t.impacts.clear();
        t.impacts
            .push(ImpactSpec {
                when: ImpactWhen::Maintain,
                timeline: antenna,
                effect: Effect::Claim,
                start_offset_us: 0,
                end_offset_us: 0,
            })
            .unwrap();
        t.impacts
            .push(ImpactSpec {
                when: ImpactWhen::Post,
                timeline: chain,
                effect: Effect::Add(1),
                start_offset_us: 0,
                end_offset_us: 0,
            })
            .unwrap();
        t.constraints
            .push(ConstraintSpec {
                when: ConstraintWhen::Pre,
                timeline: chain,
                require: Requirement::Range {
                    min: i64::from(extra - 1 - k),
                    max: i64::from(extra),
                },
                start_offset_us: 0,
                end_offset_us: 0,
            })
            .unwrap();
        spec.tasks.push(t).unwrap();
    }
    TaskNetwork::from_spec(spec).expect("the loaded flyby validates")
}

/// The points followed by a checkpoint write, which a reset can tear.
fn tearable(point: Point) -> bool {
    matches!(
        point,
        Point::ExecutiveFirstWindow | Point::PlannerWindow | Point::ExecutiveSecondWindow
    )
}

fn single(resets: &[Reset]) -> Vec<Decision> {
    let mut sim = Sim::flyby();
    sim.run(hm(11, 30), resets);
    sim.out.decisions
}

/// The `Restored` plan modification names the checkpoint record restored; the two partitions
/// number their records on their own (the executive writes two per frame), so that number is
/// not a decision.
fn without_record_numbers(mut decisions: Vec<Decision>) -> Vec<Decision> {
    for d in &mut decisions {
        if let Decision::Modification { kind, template, .. } = d {
            if *kind == PlanModificationKind::Restored as u8 {
                *template = 0;
            }
        }
    }
    decisions
}

fn paired(budget: u32, resets: &[Reset]) -> PairSim {
    let mut sim = PairSim::flyby(budget);
    sim.run(hm(11, 30), resets);
    sim
}

fn early_reset() -> Vec<Reset> {
    vec![Reset {
        at: hm(10, 30),
        recovery_us: 3 * MIN,
    }]
}

#[test]
fn an_unthrottled_planner_in_its_own_partition_decides_exactly_as_the_single_core() {
    for resets in [vec![], early_reset()] {
        let reference = without_record_numbers(single(&resets));
        let mut sim = paired(u32::MAX, &resets);
        sim.out.decisions = without_record_numbers(std::mem::take(&mut sim.out.decisions));
        assert!(reference.len() > 20, "the flyby decides things");
        assert_eq!(
            sim.out.decisions, reference,
            "resets {resets:?}: the split core decides as the single core"
        );
        assert!(
            sim.log.iter().all(|(_, f)| !f.planner.pending),
            "an unlimited planner finishes in its window"
        );
    }
}

#[test]
fn a_throttled_planner_commits_later_in_mission_time_while_the_executive_runs_every_frame() {
    // One validity check per window (one job: a placement or a repair): the loaded flyby's
    // planning needs many windows.
    let mut sim = PairSim::new(loaded_flyby(26), hm(9, 50), 1);
    sim.run(hm(12, 30), &early_reset());
    let pending_frames = sim.log.iter().filter(|(_, f)| f.planner.pending).count();
    assert!(
        pending_frames > 50,
        "planning spans {pending_frames} frames with work pending, want > 50"
    );
    // While the planner has work pending, mission time advances one major frame per grant.
    for pair in sim.log.windows(2) {
        let ((t0, f0), (t1, _)) = (pair[0], pair[1]);
        if f0.planner.pending {
            assert_eq!(f0.next_wakeup, Some(MissionTimeUs(t0.0 + MAJOR_FRAME_US)));
            assert!(t1.0 <= t0.0 + MAJOR_FRAME_US, "granted on time");
        }
    }
    // Every frame ran both executive windows, whatever the planner did.
    assert_eq!(sim.executive_frames, sim.log.len() as u64);
    // The latency of a cycle is the mission time its frames took.
    let latencies: Vec<u64> = sim
        .log
        .iter()
        .filter_map(|(_, f)| f.planner.cycle_latency_us)
        .collect();
    let max = latencies.iter().copied().max().unwrap_or(0);
    eprintln!(
        "{pending_frames} frames with planning pending; cycle latencies (µs of mission time): {latencies:?}"
    );
    assert!(
        max >= 50 * MAJOR_FRAME_US,
        "the longest cycle took {max} µs of mission time"
    );
    // The spacecraft still gets its flyby, later.
    let mut reference = PairSim::new(loaded_flyby(26), hm(9, 50), u32::MAX);
    reference.run(hm(12, 30), &early_reset());
    let reference = reference.out.decisions;
    let completed = |d: &[Decision]| {
        d.iter()
            .filter(|d| {
                matches!(
                    d,
                    Decision::Transition {
                        to: TaskState::Completed,
                        ..
                    }
                )
            })
            .count()
    };
    assert!(completed(&sim.out.decisions) > 0);
    assert_ne!(
        sim.out.decisions, reference,
        "throttling changes when things happen"
    );
    // The executive's view and the planner's agree at every frame.
    for (planner, executive) in &sim.views {
        assert_eq!(planner, executive);
    }
}

#[test]
fn a_warm_reset_at_any_point_of_either_partition_restores_a_consistent_pair() {
    // Frames of the nominal run around the early reset's time, where tasks are in flight.
    let nominal = paired(u32::MAX, &[]);
    let frames: Vec<u64> = nominal
        .log
        .iter()
        .enumerate()
        .filter(|(_, (t, _))| *t >= hm(10, 0) && *t <= hm(10, 50))
        .map(|(i, _)| i as u64)
        .collect();
    assert!(frames.len() >= 5, "{} frames in the window", frames.len());
    let mut runs = 0;
    let mut resent = 0u64;
    let mut duplicates = 0u64;
    for &frame in frames.iter().step_by(2) {
        for point in Point::ALL {
            for torn in [false, true] {
                if torn && !tearable(point) {
                    continue;
                }
                let mut sim = PairSim::flyby(u32::MAX);
                sim.mid_frame = Some(MidFrameReset {
                    frame,
                    point,
                    torn,
                    recovery_us: 3 * MIN,
                });
                sim.run(hm(11, 30), &[]);
                let what = format!("frame {frame}, point {point:?}, torn {torn}");
                assert!(sim.landed.is_some(), "{what}: the reset landed");
                for (i, (planner, executive)) in sim.views.iter().enumerate() {
                    assert_eq!(
                        planner, executive,
                        "{what}: view {i}: the planner's commits are the executive's tasks"
                    );
                }
                // Nothing is lost or applied twice: the planner knows every task the
                // executive finished, and in the end neither holds a task.
                let (planner, executive) = sim.views();
                assert!(
                    planner.is_empty() && executive.is_empty(),
                    "{what}: idle at the end"
                );
                let requested_flyby_done = sim.out.decisions.iter().any(|d| {
                    matches!(d, Decision::Transition { task, to: TaskState::Completed, .. }
                        if *task == ID_REQUEST)
                });
                assert!(requested_flyby_done, "{what}: the flyby request completes");
                resent += u64::from(sim.executive.to_planner().resent)
                    + u64::from(sim.planner.to_executive().resent);
                duplicates += u64::from(sim.executive.from_planner().duplicates)
                    + u64::from(sim.planner.from_executive().duplicates);
                runs += 1;
            }
        }
    }
    assert!(runs >= 30, "{runs} runs");
    // Some resets caught messages the receiver had not checkpointed: they went again, and the
    // receiver dropped those it had.
    eprintln!(
        "{runs} runs: {resent} messages sent again on a Resume, {duplicates} duplicates dropped"
    );
    assert!(duplicates > 0, "no duplicate was dropped in {runs} runs");
}

#[test]
fn a_reset_while_the_network_streams_to_the_planner_loses_nothing() {
    // The loaded flyby's image takes more than one frame's share of the channel.
    let network = loaded_flyby(26);
    let mut image = vec![0u8; MAX_NETWORK_IMAGE];
    let len = network.encode(&mut image).unwrap();
    assert!(
        len > MAX_CHUNKS_PER_FRAME * NETWORK_CHUNK_BYTES,
        "the image ({len} bytes) streams over several frames"
    );
    let mut runs = 0;
    for frame in 0..3 {
        for point in Point::ALL {
            for torn in [false, true] {
                if torn && !tearable(point) {
                    continue;
                }
                let mut sim = PairSim::new(network.clone(), hm(9, 50), u32::MAX);
                sim.mid_frame = Some(MidFrameReset {
                    frame,
                    point,
                    torn,
                    recovery_us: MIN,
                });
                sim.run(hm(12, 30), &[]);
                let what = format!("frame {frame}, point {point:?}, torn {torn}");
                assert!(sim.landed.is_some(), "{what}: the reset landed");
                assert_eq!(
                    sim.planner.network(),
                    sim.executive.network(),
                    "{what}: the planner has the executive's network"
                );
                assert_eq!(sim.planner.refused_networks, 0, "{what}");
                for (planner, executive) in &sim.views {
                    assert_eq!(planner, executive, "{what}");
                }
                let downlinks_done = sim
                    .out
                    .decisions
                    .iter()
                    .filter(|d| {
                        matches!(d, Decision::Transition { task, to: TaskState::Completed, .. }
                            if *task >= 100)
                    })
                    .count();
                assert_eq!(downlinks_done, 26, "{what}: every downlink completes");
                runs += 1;
            }
        }
    }
    assert_eq!(runs, 36);
}

#[test]
fn a_commit_planned_for_another_network_is_dropped_and_counted() {
    let mut executive = Box::new(ExecutivePartition::new());
    executive.load_network(&flyby_network()).unwrap();
    let commit = Commit {
        instance: ID_GNC_NADIR,
        def: 0,
        start: hm(10, 0),
        end: hm(10, 15),
        served: autonomy::interface::NO_SERVED,
        window: None,
    };
    executive.receive(Wire::Message {
        seq: 1,
        message: ExecutiveInput::Commit {
            generation: 7,
            commit,
        },
    });
    assert_eq!(executive.stats.stale_commits, 1);
    assert!(executive.control().executive().entries().is_empty());
    executive.receive(Wire::Message {
        seq: 2,
        message: ExecutiveInput::Commit {
            generation: 1,
            commit,
        },
    });
    assert_eq!(executive.control().executive().entries().len(), 1);
    // A message sent again is applied once.
    executive.receive(Wire::Message {
        seq: 2,
        message: ExecutiveInput::Commit {
            generation: 1,
            commit,
        },
    });
    assert_eq!(executive.control().executive().entries().len(), 1);
    assert_eq!(executive.from_planner().duplicates, 1);
}

#[test]
fn an_image_larger_than_the_partitions_exchange_is_refused() {
    let mut executive = Box::new(ExecutivePartition::new());
    let mut image = vec![0u8; 4 * MAX_NETWORK_IMAGE];
    let len = flyby_network().encode(&mut image).unwrap();
    image.truncate(len);
    assert!(executive.load_uplink(&image).is_ok());
    // A valid network whose image is larger than the partitions exchange: refused as too
    // large, and nothing loaded.
    let mut spec = Box::new(NetworkSpec::new(0, PlannerConfig::DEFAULT));
    autonomy::scenarios::synthetic_into(
        &mut spec,
        autonomy::scenarios::SyntheticShape {
            constraints: 4,
            impacts: 4,
            timelines: autonomy::scenarios::SYNTHETIC_BASE_TIMELINES + 4,
            ..autonomy::scenarios::SyntheticShape::bench(MAX_TASKS)
        },
    )
    .unwrap();
    let mut big = vec![0u8; 1 << 21];
    let len = autonomy::uplink::encode_spec(&spec, &mut big).unwrap();
    big.truncate(len);
    assert!(
        len > MAX_NETWORK_IMAGE,
        "the image ({len} bytes) is too large"
    );
    autonomy::uplink::validate_uplink(&big).expect("a valid network");
    let mut too_large = Box::new(ExecutivePartition::new());
    assert_eq!(too_large.load_uplink(&big), Err(LoadError::TooLarge));
    assert!(!too_large.loaded() && !too_large.transferring());
}

#[test]
fn a_planner_that_comes_up_without_its_checkpoint_is_sent_the_network_again() {
    let mut sim = PairSim::flyby(u32::MAX);
    sim.lose_planner_area = true;
    sim.run(hm(11, 30), &early_reset());
    assert_eq!(sim.executive.stats.resyncs, 1, "one resynchronisation");
    assert_eq!(sim.planner.network(), sim.executive.network());
    assert_eq!(sim.planner.refused_networks, 0);
    // The planner plans afresh and the mission goes on: the turn to Earth still happens.
    let earth_done = sim.out.decisions.iter().any(|d| {
        matches!(d, Decision::Transition { task, to: TaskState::Completed, at, .. }
            if *task == ID_GNC_EARTH && *at > hm(10, 30))
    });
    assert!(
        earth_done,
        "the mission goes on after the planner lost its state"
    );
    // Nothing planned for the lost state was executed: commits of the old generation were
    // dropped, if any came.
    let (planner, executive) = sim.views();
    assert!(
        planner.is_empty() && executive.is_empty(),
        "idle at the end"
    );
}

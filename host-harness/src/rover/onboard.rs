//! Where the rover mission's onboard side runs: the planner partition of the emulated RAD750
//! (one QEMU for the whole run, events and reports over the link), or the same plug-in code
//! (`flight_app::TemporalApp` with its `rover_mission`) in this process, natively. Either way
//! the host only sends events (the world and the time) and receives the mission's decisions.
use fsw_bridge::temporal::{RoverEvent, RoverReport, TemporalConfig, TemporalReport};
use fsw_bridge::{HostToTarget, TargetToHost};

use flight_app::rover_mission::RoverMission;
use flight_app::{
    Memories, NoClock, PlannerPlugin, PluginWindow, SecurityStore, StoreError, TemporalApp,
    TemporalStorage, MAX_TEMPORAL_PLAN_ACTIONS, MAX_TEMPORAL_TASK_BYTES, TEMPORAL_ARENA_BYTES,
};
use temporal::PlannedAction;

use crate::mission::auth::{Signer, TEST_KEY};

/// Frames granted for one event's answer at most (an attempt of 2,500 expansions takes about
/// 700 frames).
const MAX_FRAMES_PER_EVENT: u32 = 20_000;

/// Where the onboard side runs.
pub enum Backend {
    /// The plug-in in this process (no clock: its costs are 0).
    Native(Box<NativeOnboard>),
    /// The planner partition of an emulated target.
    Emulated(Box<crate::plan_emulated::EmulatedPlanner>),
}

impl Backend {
    pub fn native() -> Self {
        Backend::Native(Box::new(NativeOnboard::new()))
    }

    pub fn emulated(&self) -> bool {
        matches!(self, Backend::Emulated(_))
    }

    /// `start` for a new job, then `task` uplinked (signed) as that job: the mission's Ready
    /// (or its refusal). Returns the job.
    pub fn start(
        &mut self,
        task: &[u8],
        start: RoverEvent,
    ) -> Result<(u16, Vec<RoverReport>), String> {
        match self {
            Backend::Native(n) => n.start(task, start),
            Backend::Emulated(e) => e
                .rover_start(task, start, MAX_FRAMES_PER_EVENT)
                .map_err(|e| e.to_string()),
        }
    }

    /// One event, and the mission's answer (its last report last).
    pub fn event(&mut self, job: u16, event: RoverEvent) -> Result<Vec<RoverReport>, String> {
        match self {
            Backend::Native(n) => n.event(job, event),
            Backend::Emulated(e) => e
                .rover_event(job, event, MAX_FRAMES_PER_EVENT)
                .map_err(|e| e.to_string()),
        }
    }

    /// Health-monitor events of the target since boot (an overrun of the planner's window).
    pub fn health_events(&self) -> Vec<String> {
        match self {
            Backend::Native(_) => Vec::new(),
            Backend::Emulated(e) => e.health_events.clone(),
        }
    }
}

/// A security area in memory with the host's test key (natively, the uplink is checked as on
/// the target).
struct MemoryStore([u8; sdls::nv::SECURITY_AREA_BYTES]);

impl SecurityStore for MemoryStore {
    fn read(&mut self, area: &mut [u8; sdls::nv::SECURITY_AREA_BYTES]) -> Result<(), StoreError> {
        area.copy_from_slice(&self.0);
        Ok(())
    }
    fn write(&mut self, offset: usize, bytes: &[u8]) -> Result<(), StoreError> {
        self.0
            .get_mut(offset..offset + bytes.len())
            .ok_or(StoreError)?
            .copy_from_slice(bytes);
        Ok(())
    }
}

/// The plug-in in this process, with the target's task buffer and arena sizes.
pub struct NativeOnboard {
    app: TemporalApp<'static>,
    task: *mut [u8],
    arena: *mut [u32],
    signer: Signer,
    next_job: u16,
}

fn native_mission() -> &'static mut RoverMission {
    Box::leak(Box::new(
        RoverMission::new().expect("an empty network is consistent"),
    ))
}

impl NativeOnboard {
    fn new() -> Self {
        let plan =
            Box::leak(vec![PlannedAction::default(); MAX_TEMPORAL_PLAN_ACTIONS].into_boxed_slice());
        let mut app = TemporalApp::new(plan);
        let mut area = [0u8; sdls::nv::SECURITY_AREA_BYTES];
        sdls::nv::provision(&mut area, &TEST_KEY).expect("the area holds a key");
        app.secure(Some(Box::leak(Box::new(MemoryStore(area)))));
        app.fly_rover_in(native_mission);
        let task = Box::into_raw(vec![0u8; MAX_TEMPORAL_TASK_BYTES].into_boxed_slice());
        let arena = Box::into_raw(vec![0u32; TEMPORAL_ARENA_BYTES / 4].into_boxed_slice());
        let mut n = Self {
            app,
            task,
            arena,
            signer: Signer::new(TEST_KEY),
            next_job: 1,
        };
        n.give_storage();
        n
    }

    fn give_storage(&mut self) {
        if !self.app.needs_storage() {
            return;
        }
        // SAFETY: as in the planner partition: `needs_storage` says the plug-in holds no
        // reference into the buffers (the search that borrowed them ended), and nothing else
        // refers to them; they live as long as the plug-in (leaked with it on drop).
        let storage = unsafe {
            TemporalStorage {
                task: &mut *self.task,
                arena: &mut *self.arena,
            }
        };
        self.app.give_storage(storage);
    }

    /// Hand `msg` to the plug-in, then run windows (no CPU limit) and take its reports until the
    /// mission's last answer.
    fn exchange(&mut self, msgs: &[HostToTarget]) -> Result<Vec<RoverReport>, String> {
        let mut out: Vec<TargetToHost> = Vec::new();
        for msg in msgs {
            self.give_storage();
            let mut sink = |m: TargetToHost| out.push(m);
            self.app.handle(msg, &mut sink);
        }
        let mut warm = [0u8; 0];
        let mut reports = Vec::new();
        let mut refused = None;
        for _ in 0..1_000_000u32 {
            let mut sink = |m: TargetToHost| out.push(m);
            self.app.report(usize::MAX, &mut sink);
            for m in out.drain(..) {
                match m {
                    TargetToHost::Temporal(TemporalReport::Rover { report, .. }) => {
                        reports.push(report)
                    }
                    TargetToHost::Temporal(TemporalReport::Refused { reason, .. }) => {
                        refused = Some(format!("{reason:?}"))
                    }
                    _ => {}
                }
            }
            if let Some(r) = refused {
                return Err(format!("the plug-in refused the task: {r}"));
            }
            if reports.last().is_some_and(RoverReport::is_last) {
                return Ok(reports);
            }
            if !self.app.planning_pending() {
                return Err("the mission did not answer".into());
            }
            self.give_storage();
            let mut memories = Memories {
                warm: &mut warm,
                nv: None,
                security: None,
            };
            let mut sink = |m: TargetToHost| out.push(m);
            let mut w = PluginWindow {
                memories: &mut memories,
                fetch: None,
                clock: &mut NoClock,
                downlink: &mut sink,
                until: None,
                hard_until: None,
            };
            self.app.window(&mut w);
        }
        Err("the mission did not answer in a million windows".into())
    }

    fn start(&mut self, task: &[u8], start: RoverEvent) -> Result<(u16, Vec<RoverReport>), String> {
        let job = self.next_job;
        self.next_job = self.next_job.wrapping_add(1).max(1);
        let (_, secured) = self
            .signer
            .sign_temporal(job, &TemporalConfig::DEFAULT, task);
        let mut msgs = vec![HostToTarget::Rover { job, event: start }];
        msgs.extend(crate::plan_emulated::EmulatedPlanner::job_messages(
            job,
            &secured,
            TemporalConfig::DEFAULT,
        ));
        Ok((job, self.exchange(&msgs)?))
    }

    fn event(&mut self, job: u16, event: RoverEvent) -> Result<Vec<RoverReport>, String> {
        self.exchange(&[HostToTarget::Rover { job, event }])
    }
}

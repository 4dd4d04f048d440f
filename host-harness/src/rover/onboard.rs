//! Where the rover mission's onboard side runs: the planner partition of the emulated RAD750
//! (one QEMU for the whole run, events and reports over the link), or the same plug-in code
//! (`flight_app::TemporalApp` with its `rover_mission`) in this process, natively. Either way
//! the host only sends events (the world and the time) and receives the mission's decisions.
use fsw_bridge::temporal::{RoverEvent, RoverReport, TemporalConfig, TemporalReport};
use fsw_bridge::{HostToTarget, TargetToHost};

use flight_app::rover_mission::checkpoint::RoverCheckpoint;
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
pub enum Place {
    /// The plug-in in this process (no clock: its costs are 0).
    Native(Box<NativeOnboard>),
    /// The planner partition of an emulated target.
    Emulated(Box<crate::plan_emulated::EmulatedPlanner>),
}

/// Where the onboard side runs, the events it took (to send again after a reset of the
/// planner partition) and the resets injected ([`ResetAt`]).
pub struct Backend {
    pub place: Place,
    log: Vec<(Input, Vec<RoverReport>)>,
    reset_at: Option<ResetAt>,
    /// The resets that landed and how the mission took up again.
    pub resumes: Vec<Resume>,
    /// The target's health-monitor events, each with the event in whose answer it came.
    pub health_during: Vec<String>,
    /// Natively: the executive partition's side of the dispatch decisions, run beside the
    /// mission and set against it poll for poll (None: not run).
    pub exec_shadow: Option<Box<super::exec_shadow::ExecShadow>>,
}

/// One input of the mission: a host event, or (when the executive decides) what the executive
/// told it (a start it took, a replan it asks for).
#[derive(Clone, Copy, Debug)]
enum Input {
    Event(RoverEvent),
    Exec(flight_app::FromExecutive),
}

/// A reset of the planner partition injected in the answer to an event: event `event`
/// (counted from 0 after the mission's Ready), after `after` frames of its answer (windows
/// natively), once the planner partition has run `planner_ticks` ticks of CPU in that frame
/// (emulated: a warm reset, `ResetKind::PlannerAfterTicks`; natively the plug-in is made anew
/// over the same memories, as the partition's restart does).
#[derive(Clone, Copy, Debug)]
pub struct ResetAt {
    pub event: usize,
    pub after: u32,
    pub planner_ticks: u32,
    /// Natively only (tests): damage the memories the reset keeps (the rover checkpoint, the
    /// task buffer) before the restart.
    pub damage: Option<Damage>,
}

/// What a test does to the memories a reset keeps: the rover checkpoint and the task buffer.
pub type Damage = fn(&mut RoverCheckpoint, &mut [u8]);

/// A reset that landed and the mission's resumption.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Resume {
    /// The event whose answer the reset interrupted (from 0 after Ready).
    pub during_event: usize,
    /// The checkpoint held the state after this many events.
    pub resumed_after: u32,
    /// Events sent again whose answers had come before the reset (each answered the same).
    pub replayed: usize,
    /// The planner partition's CPU taking the mission up, timebase ticks (0 natively).
    pub restore_ticks: u32,
}

/// A report without its costs (the decisions only).
pub fn decision_of(r: &RoverReport) -> RoverReport {
    let mut r = *r;
    match &mut r {
        RoverReport::Attempt {
            build_ticks,
            planning_ticks,
            ..
        } => {
            *build_ticks = 0;
            *planning_ticks = 0;
        }
        RoverReport::NewPlan { network_ticks, .. } => *network_ticks = 0,
        RoverReport::Dispatch { poll_ticks, .. } | RoverReport::Wait { poll_ticks, .. } => {
            *poll_ticks = 0
        }
        _ => {}
    }
    r
}

impl Backend {
    fn at(place: Place) -> Self {
        Self {
            place,
            log: Vec::new(),
            reset_at: None,
            resumes: Vec::new(),
            health_during: Vec::new(),
            exec_shadow: None,
        }
    }

    pub fn native() -> Self {
        Self::at(Place::Native(Box::new(NativeOnboard::new())))
    }

    /// The planner partition of `target`.
    pub fn on_target(target: crate::plan_emulated::EmulatedPlanner) -> Self {
        Self::at(Place::Emulated(Box::new(target)))
    }

    /// The plug-in in this process, if it is there.
    pub fn native_onboard(&mut self) -> Option<&mut NativeOnboard> {
        match &mut self.place {
            Place::Native(n) => Some(n),
            Place::Emulated(_) => None,
        }
    }

    /// The emulated target, if it is one.
    pub fn target(&mut self) -> Option<&mut crate::plan_emulated::EmulatedPlanner> {
        match &mut self.place {
            Place::Emulated(e) => Some(e),
            Place::Native(_) => None,
        }
    }

    pub fn emulated(&self) -> bool {
        matches!(self.place, Place::Emulated(_))
    }

    /// Inject a reset of the planner partition in the mission started next ([`ResetAt`]).
    pub fn reset_at(&mut self, at: ResetAt) {
        self.reset_at = Some(at);
    }

    /// One event's answer, with a reset armed in it if `reset`: None if the reset landed.
    fn answer(
        &mut self,
        job: u16,
        event: RoverEvent,
        reset: Option<ResetAt>,
    ) -> Result<Option<Vec<RoverReport>>, String> {
        match &mut self.place {
            Place::Native(n) => n.event_with_reset(job, event, reset.map(|r| (r.after, r.damage))),
            Place::Emulated(e) => e
                .rover_event_with_reset(
                    job,
                    event,
                    reset.map(|r| (r.after, r.planner_ticks)),
                    MAX_FRAMES_PER_EVENT,
                )
                .map_err(|e| e.to_string()),
        }
    }

    /// After a reset landed in the answer to event `during`: the mission's word on its
    /// checkpoint, then the events after it sent again (each must answer as before), then
    /// event `during`'s answer.
    fn resume(
        &mut self,
        job: u16,
        during: usize,
        event: RoverEvent,
    ) -> Result<Vec<RoverReport>, String> {
        let said = match &mut self.place {
            Place::Native(n) => n.exchange(&[])?,
            Place::Emulated(e) => e
                .rover_answer(job, MAX_FRAMES_PER_EVENT)
                .map_err(|e| e.to_string())?,
        };
        let (resumed_after, restore_ticks) = match said.last() {
            Some(RoverReport::Resumed {
                events,
                restore_ticks,
                ..
            }) => (*events, *restore_ticks),
            other => {
                return Err(format!(
                    "the mission was not taken up again after the reset: {other:?}"
                ))
            }
        };
        let from = resumed_after as usize;
        if from > during {
            return Err(format!(
                "the checkpoint is after {from} events, but only {during} were answered"
            ));
        }
        for i in from..during {
            let (input, before) = self.log[i].clone();
            let (ev, again) = match (input, &mut self.place) {
                (Input::Event(ev), _) => (
                    format!("{ev:?}"),
                    self.answer(job, ev, None)?
                        .ok_or("a reset landed that was not armed")?,
                ),
                (Input::Exec(what), Place::Native(n)) => {
                    (format!("{what:?}"), n.tell_mission(what)?)
                }
                (Input::Exec(_), Place::Emulated(_)) => {
                    return Err("the executive decides natively only".into())
                }
            };
            let same = |v: &[RoverReport]| v.iter().map(decision_of).collect::<Vec<_>>();
            if same(&again) != same(&before) {
                return Err(format!(
                    "event {i} ({ev:?}) sent again after the reset was answered otherwise: {again:?}, before: {before:?}"
                ));
            }
        }
        self.resumes.push(Resume {
            during_event: during,
            resumed_after,
            replayed: during - from,
            restore_ticks,
        });
        self.answer(job, event, None)?
            .ok_or_else(|| "a reset landed that was not armed".to_string())
    }

    /// `start` for a new job, then `task` uplinked (signed) as that job: the mission's Ready
    /// (or its refusal). Returns the job.
    pub fn start(
        &mut self,
        task: &[u8],
        start: RoverEvent,
    ) -> Result<(u16, Vec<RoverReport>), String> {
        self.log.clear();
        match &mut self.place {
            Place::Native(n) => n.start(task, start),
            Place::Emulated(e) => e
                .rover_start(task, start, MAX_FRAMES_PER_EVENT)
                .map_err(|e| e.to_string()),
        }
    }

    /// One event, and the mission's answer (its last report last). A reset of the planner
    /// partition armed in it ([`Self::reset_at`]) is injected, and the mission taken up again
    /// from its checkpoint before the answer is returned.
    pub fn event(&mut self, job: u16, event: RoverEvent) -> Result<Vec<RoverReport>, String> {
        let during = self.log.len();
        let health = self.health_events().len();
        let reset = self.reset_at.filter(|r| r.event == during);
        if let (Some(shadow), Place::Native(n)) = (self.exec_shadow.as_mut(), &mut self.place) {
            if shadow.decides {
                if let Some((answer, input)) = n.executive_answer(shadow, &event)? {
                    shadow.after(&n.app, &event, &answer);
                    if let Some((what, reports)) = input {
                        self.log.push((Input::Exec(what), reports));
                    }
                    return Ok(answer);
                }
                shadow.ended(&event);
            } else {
                shadow.before(&n.app, &event);
            }
        }
        let answer = match self.answer(job, event, reset)? {
            Some(answer) => answer,
            None => {
                self.reset_at = None;
                self.resume(job, during, event)?
            }
        };
        for h in self.health_events().get(health..).unwrap_or_default() {
            let last = answer.last();
            self.health_during.push(format!(
                "{h} in the answer to event {during} ({event:?}): {last:?}"
            ));
        }
        if let (Some(shadow), Place::Native(n)) = (self.exec_shadow.as_mut(), &self.place) {
            shadow.after(&n.app, &event, &answer);
        }
        self.log.push((Input::Event(event), answer.clone()));
        Ok(answer)
    }

    /// Health-monitor events of the target since boot (an overrun of the planner's window).
    pub fn health_events(&self) -> Vec<String> {
        match &self.place {
            Place::Native(_) => Vec::new(),
            Place::Emulated(e) => e.health_events.clone(),
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
    /// What a reset keeps besides the buffers: the rover checkpoint and the security area.
    checkpoint: *mut RoverCheckpoint,
    store: *mut MemoryStore,
    signer: Signer,
    next_job: u16,
    /// Tests: while the mission is taken up again after a restart, every window's share is
    /// too small for more than its first piece (a clock that ticks at every reading), so the
    /// restore is divided across as many windows as it has pieces.
    pub one_piece_restores: bool,
    /// The windows each restore took (one a restore unless `one_piece_restores`).
    pub restore_windows: Vec<u32>,
}

/// A clock that ticks at every reading (the native windows of [`NativeOnboard::one_piece_restores`]).
struct TickClock(u64);

impl flight_app::CpuClock for TickClock {
    fn ticks(&mut self) -> u64 {
        self.0 += 1;
        self.0
    }
}

fn native_mission() -> &'static mut RoverMission {
    Box::leak(Box::new(
        RoverMission::new().expect("an empty network is consistent"),
    ))
}

impl NativeOnboard {
    fn new() -> Self {
        let mut area = [0u8; sdls::nv::SECURITY_AREA_BYTES];
        sdls::nv::provision(&mut area, &TEST_KEY).expect("the area holds a key");
        let task = Box::into_raw(vec![0u8; MAX_TEMPORAL_TASK_BYTES].into_boxed_slice());
        let arena = Box::into_raw(vec![0u32; TEMPORAL_ARENA_BYTES / 4].into_boxed_slice());
        let mut n = Self {
            app: TemporalApp::new(&mut []),
            task,
            arena,
            checkpoint: Box::into_raw(Box::new(RoverCheckpoint::new())),
            store: Box::into_raw(Box::new(MemoryStore(area))),
            signer: Signer::new(TEST_KEY),
            next_job: 1,
            one_piece_restores: false,
            restore_windows: Vec::new(),
        };
        n.restart();
        n
    }

    /// The plug-in made anew over the same memories, as the planner partition's (re)start
    /// does: the task buffer, the arena, the rover checkpoint and the security area are kept;
    /// the rover mission's memory is not (a restart takes the mission up from its checkpoint).
    pub fn restart(&mut self) {
        self.restart_damaged(None)
    }

    /// [`Self::restart`], with `damage` done to the memories it keeps in between.
    pub fn restart_damaged(&mut self, damage: Option<Damage>) {
        // The old plug-in goes first: it held the only references into the memories.
        self.app = TemporalApp::new(&mut []);
        if let Some(damage) = damage {
            // SAFETY: no plug-in refers to the memories now; they are leaked (live on).
            unsafe { damage(&mut *self.checkpoint, &mut *self.task) };
        }
        let plan =
            Box::leak(vec![PlannedAction::default(); MAX_TEMPORAL_PLAN_ACTIONS].into_boxed_slice());
        self.app = TemporalApp::new(plan);
        // SAFETY: the old plug-in, which held the only references into these memories, was
        // just dropped; they are leaked (live as long as the plug-in).
        unsafe {
            self.app.secure(Some(&mut *self.store));
            self.app.fly_rover_in(native_mission);
            self.app.keep_rover_in(&mut *self.checkpoint);
        }
        self.give_storage();
        if self.app.resume_rover() {
            self.restore_windows.push(0);
        }
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
        self.exchange_until(msgs, None)
            .map(|r| r.expect("no reset was armed"))
    }

    /// [`Self::exchange`], with the plug-in restarted after `reset_after` windows if given
    /// (None returned: the reset happened).
    fn exchange_until(
        &mut self,
        msgs: &[HostToTarget],
        reset_after: Option<(u32, Option<Damage>)>,
    ) -> Result<Option<Vec<RoverReport>>, String> {
        let mut windows = 0u32;
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
            if let Some((_, damage)) = reset_after.filter(|r| r.0 == windows) {
                self.restart_damaged(damage);
                return Ok(None);
            }
            if reports.last().is_some_and(RoverReport::is_last) {
                return Ok(Some(reports));
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
            let resuming = self.app.rover_resuming();
            let divided = resuming && self.one_piece_restores;
            let (mut ticking, mut no_clock) = (TickClock(0), NoClock);
            let clock: &mut dyn flight_app::CpuClock =
                if divided { &mut ticking } else { &mut no_clock };
            let mut w = PluginWindow {
                memories: &mut memories,
                fetch: None,
                clock,
                downlink: &mut sink,
                until: divided.then_some(1),
                hard_until: None,
            };
            self.app.window(&mut w);
            if resuming {
                if let Some(n) = self.restore_windows.last_mut() {
                    *n += 1;
                }
            }
            windows += 1;
        }
        Err("the mission did not answer in a million windows".into())
    }

    /// A poll's answer from the executive's side (None: it holds no plan, the mission
    /// answers), and what it told the mission with the mission's reports (its start applied,
    /// its replan made: the mission's inputs).
    #[allow(clippy::type_complexity)]
    fn executive_answer(
        &mut self,
        shadow: &mut super::exec_shadow::ExecShadow,
        event: &RoverEvent,
    ) -> Result<
        Option<(
            Vec<RoverReport>,
            Option<(flight_app::FromExecutive, Vec<RoverReport>)>,
        )>,
        String,
    > {
        use flight_app::rover_exec::ExecAnswer;
        use flight_app::FromExecutive;
        let RoverEvent::Poll { now_ms } = *event else {
            return Ok(None);
        };
        let Some(answer) = shadow.decide(&self.app, now_ms) else {
            return Ok(None);
        };
        Ok(Some(match answer {
            ExecAnswer::Report(r @ RoverReport::Dispatch { step, at_ms, .. }) => {
                let what = FromExecutive::Started { step, at_ms };
                let said = self.tell_mission(what)?;
                if let Some(m) = said.first() {
                    return Err(format!("the mission did not take the start {r:?}: {m:?}"));
                }
                (vec![r], Some((what, said)))
            }
            ExecAnswer::Report(r) => (vec![r], None),
            ExecAnswer::Refused(reason) => (vec![RoverReport::Refused { reason }], None),
            ExecAnswer::Replan { at_ms, why } => {
                let what = FromExecutive::Replan { at_ms, why };
                let said = self.tell_mission(what)?;
                (said.clone(), Some((what, said)))
            }
        }))
    }

    /// What the executive tells the mission, and the mission's reports (none for a start it
    /// takes; a replan's, through its attempts' windows).
    fn tell_mission(
        &mut self,
        what: flight_app::FromExecutive,
    ) -> Result<Vec<RoverReport>, String> {
        self.give_storage();
        if !self.app.rover_from_executive(what) {
            return Err(format!("no mission to take {what:?}"));
        }
        match what {
            flight_app::FromExecutive::Started { .. } => {
                let mut out = Vec::new();
                self.app
                    .report(usize::MAX, &mut |m: TargetToHost| out.push(m));
                Ok(out
                    .into_iter()
                    .filter_map(|m| match m {
                        TargetToHost::Temporal(TemporalReport::Rover { report, .. }) => {
                            Some(report)
                        }
                        _ => None,
                    })
                    .collect())
            }
            flight_app::FromExecutive::Replan { .. } => self.exchange(&[]),
        }
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

    fn event_with_reset(
        &mut self,
        job: u16,
        event: RoverEvent,
        reset_after: Option<(u32, Option<Damage>)>,
    ) -> Result<Option<Vec<RoverReport>>, String> {
        self.exchange_until(&[HostToTarget::Rover { job, event }], reset_after)
    }
}

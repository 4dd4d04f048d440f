//! A small recorder of what a lander run did, for the long-mission reports
//! ([`crate::report`], `hil lander run --report DIR`): every dispatched primitive with its
//! span and outcome, retries, replans and ground halts, the battery's charge and the data on
//! board over time, and each downlink's products per tier.
//!
//! A [`Recording`] installs a trace for the current thread while it lives; the simulation's
//! loop ([`super::run`], and whatever else drives the same loop) tells it what happens from
//! four places (the loop's top, after each executor step, after each dispatch, after the
//! loop) through `with`, which does nothing when no recording is in force. Installing it
//! this way keeps the simulation's signature and loop as they are: one line per place. The
//! recorder only reads the world and the executor's counters: a run with it decides exactly as
//! one without (`host-harness/tests/lander_report.rs` checks the `RunResult`s are equal). It is
//! a child module of `sim` so that it can read the world's private state without widening it.
//! One recording holds one run.
use std::cell::RefCell;

use lander::executor::{Directive, ExecStats, Outcome, TaskResult};
use lander::htn::{PrimitiveSpec, Tier};
use serde::{Deserialize, Serialize};

use super::{tier_index, FailureClass, RunConfig, RunResult, World};
use crate::scenario::Scenario;

/// The battery's charge and the data on board at one time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Sample {
    pub at_us: u64,
    pub battery_mj: u64,
    /// Bytes of the products on board plus the seismometer's data not yet made a product.
    pub onboard_bytes: u64,
}

/// One dispatch of a primitive, as it happened.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PrimitiveRecord {
    pub chain: u16,
    pub primitive: u8,
    /// The primitive's kind (`ExcavateSite`, `Downlink`, ...).
    pub kind: String,
    pub site: Option<u8>,
    pub target: Option<u8>,
    pub start_us: u64,
    pub end_us: u64,
    /// `succeeded`, `failed` (a failure code) or `faulted`.
    pub result: String,
    /// The failure drawn for this dispatch, if one was.
    pub failure: Option<FailureClass>,
    /// The executor retried the primitive that failed before it (flexible execution).
    pub retry: bool,
    pub energy_mj: u64,
}

/// A span of mission time (a ground halt: from the halt to the ground's answer on board, or
/// the run's end).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Span {
    pub start_us: u64,
    pub end_us: u64,
}

/// A product a downlink carried.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SentProduct {
    pub kind: String,
    pub tier: Tier,
    pub bytes: u64,
    pub value_milli: u64,
    pub site: Option<u8>,
    pub target: Option<u8>,
    /// Part of a product too large for one downlink, the rest still on board (its value
    /// counts when the last part is down).
    #[serde(default)]
    pub segment: bool,
}

/// One downlink with its products per tier (Critical, Decisional, Mandatory, Residual).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DownlinkTrace {
    /// Its index in [`RunResult::downlinks`].
    pub index: usize,
    pub start_us: u64,
    pub end_us: u64,
    /// When its data reached Earth (transmission end plus the light time): its utility counts
    /// from then.
    pub received_us: u64,
    pub bytes_per_tier: [u64; 4],
    pub products_per_tier: [u32; 4],
    pub value_milli_per_tier: [u64; 4],
    pub products: Vec<SentProduct>,
}

/// What the reports need of a run.
#[derive(Serialize, Deserialize, Default)]
pub struct Trace {
    pub horizon_us: u64,
    pub light_us: u64,
    /// Earth in view, clipped to the horizon.
    pub earth_in_view: Vec<Span>,
    pub samples: Vec<Sample>,
    pub primitives: Vec<PrimitiveRecord>,
    /// When a replan started (the executor's replan counter rose).
    pub replans: Vec<u64>,
    pub ground_halts: Vec<Span>,
    pub downlinks: Vec<DownlinkTrace>,
    #[serde(skip)]
    state: State,
    /// Called with the mission time after each step and with None at the run's end (a
    /// progress bar).
    #[serde(skip)]
    progress: Option<Progress>,
}

type Progress = Box<dyn FnMut(Option<u64>) + Send + Sync>;

#[derive(Default)]
struct State {
    /// The current step's time (the loop's top).
    step_at: u64,
    stats: ExecStats,
    retry_pending: bool,
    halt_open: Option<u64>,
    sent_seen: usize,
    /// The products on board when a downlink was dispatched: (identity, [`sent_part`]).
    onboard_before: Vec<(ProductKey, u64)>,
    downlinks_seen: usize,
    drops_seen: usize,
}

impl std::fmt::Debug for Trace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Trace")
            .field("samples", &self.samples.len())
            .field("primitives", &self.primitives.len())
            .field("replans", &self.replans.len())
            .field("ground_halts", &self.ground_halts.len())
            .field("downlinks", &self.downlinks.len())
            .finish()
    }
}

/// The part of a product on board already downlinked: a product larger than one downlink goes
/// down in parts (`Product::sent_bytes`), and a downlink's per-tier volume counts the parts
/// (`host-harness/tests/lander_report.rs` checks the sums).
fn sent_part(p: &super::Product) -> u64 {
    p.sent_bytes
}

/// What identifies a product on board: kind, tier, creation time, site and target.
type ProductKey = (String, usize, u64, Option<u8>, Option<u8>);

fn key(p: &super::Product) -> ProductKey {
    (
        p.kind.clone(),
        tier_index(p.tier),
        p.created_us,
        p.site,
        p.target,
    )
}

/// The increase of a counter since `last` (a rebuilt executor starts again from zero).
fn rise(now: u32, last: u32) -> u32 {
    if now >= last {
        now - last
    } else {
        now
    }
}

impl Trace {
    /// An empty trace for a run of `s`.
    pub fn new(s: &Scenario) -> Self {
        let earth = super::EarthSchedule::from_scenario(s);
        let horizon = super::horizon_us(s);
        let mut earth_in_view = Vec::new();
        let mut t = 0;
        while t < horizon && earth.period_us > 0 {
            earth_in_view.push(Span {
                start_us: t,
                end_us: (t + earth.in_view_us).min(horizon),
            });
            t += earth.period_us;
        }
        Self {
            horizon_us: horizon,
            light_us: s.comms.light_time_min * super::MIN_US,
            earth_in_view,
            ..Self::default()
        }
    }

    /// Calls `f` with the mission time after every executor step, and with None when the run
    /// ends.
    pub fn on_progress(&mut self, f: impl FnMut(Option<u64>) + Send + Sync + 'static) {
        self.progress = Some(Box::new(f));
    }

    fn sample(&mut self, world: &World) {
        self.drops(world);
        let onboard = world
            .stored
            .iter()
            .map(|p| p.bytes - sent_part(p))
            .sum::<u64>()
            + world.volume(Tier::Residual, world.seismo_bytes);
        let sample = Sample {
            at_us: world.now,
            battery_mj: world.battery_mj,
            onboard_bytes: onboard,
        };
        match self.samples.last_mut() {
            Some(last) if last.at_us == sample.at_us => *last = sample,
            _ => self.samples.push(sample),
        }
    }

    /// Exogenous drops since the last sample, each as two points at its time (before and
    /// after), the charge before it from the background load since the last sample (constant
    /// between two samples: only a dispatch switches the seismometer).
    fn drops(&mut self, world: &World) {
        while self.state.drops_seen < world.next_drop {
            let k = self.state.drops_seen;
            self.state.drops_seen += 1;
            let (Some(&(at, mj, to)), Some(&last)) = (world.drops.get(k), self.samples.last())
            else {
                continue;
            };
            if at <= last.at_us || at > world.now {
                continue;
            }
            let dt = at - last.at_us;
            let drain = (u128::from(world.load_mw()) * u128::from(dt) / 1_000_000) as u64;
            let before = last.battery_mj.saturating_sub(drain);
            let after = to.map_or(before.saturating_sub(mj), |to| before.min(to));
            let grown = if world.seismo_on {
                let bytes = (u128::from(world.seismo_bytes_per_h) * u128::from(dt)
                    / u128::from(super::HOUR_US)) as u64;
                world.volume(Tier::Residual, bytes)
            } else {
                0
            };
            for battery_mj in [before, after] {
                self.samples.push(Sample {
                    at_us: at,
                    battery_mj,
                    onboard_bytes: last.onboard_bytes + grown,
                });
            }
        }
    }

    fn close_halt(&mut self, now: u64) {
        if let Some(start) = self.state.halt_open.take() {
            self.ground_halts.push(Span {
                start_us: start,
                end_us: now,
            });
        }
    }

    /// At the top of the simulation's loop: the state the next step observes.
    pub(super) fn loop_top(&mut self, world: &World) {
        self.state.step_at = world.now;
        self.sample(world);
    }

    /// After an executor step (and the replans it charged): the executor's counters and the
    /// directive.
    pub(super) fn step(&mut self, world: &World, directive: &Directive, stats: &ExecStats) {
        let at = self.state.step_at;
        // A halt lasts until the step that brings the ground's answer.
        self.close_halt(at);
        self.sample(world);
        let last = std::mem::replace(&mut self.state.stats, *stats);
        if rise(stats.retries, last.retries) > 0 {
            self.state.retry_pending = true;
        }
        for _ in 0..rise(stats.replans, last.replans) {
            self.replans.push(at);
        }
        match directive {
            Directive::HaltedForGround { .. } => self.state.halt_open = Some(world.now),
            Directive::Dispatch { kind, .. } if super::is_downlink(*kind) => {
                self.state.onboard_before = world
                    .stored
                    .iter()
                    .map(|p| (key(p), sent_part(p)))
                    .collect();
            }
            _ => {}
        }
        if let Some(f) = self.progress.as_mut() {
            f(Some(world.now));
        }
    }

    /// After a dispatch of `spec` that started at `start`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn dispatched(
        &mut self,
        world: &World,
        chain: u16,
        primitive: u8,
        spec: &PrimitiveSpec,
        start: u64,
        outcome: &Outcome,
        class: u8,
    ) {
        let failure = match class {
            0 => Some(FailureClass::FlexibleExecution),
            1 => Some(FailureClass::Replan),
            2 => Some(FailureClass::Ground),
            _ => None,
        };
        self.primitives.push(PrimitiveRecord {
            chain,
            primitive,
            kind: format!("{:?}", spec.kind),
            site: spec.site,
            target: spec.target,
            start_us: start,
            end_us: world.now,
            result: match outcome.result {
                TaskResult::Succeeded => "succeeded",
                TaskResult::Failed => "failed",
                TaskResult::Faulted => "faulted",
            }
            .into(),
            failure,
            retry: std::mem::take(&mut self.state.retry_pending),
            energy_mj: outcome.energy_mj,
        });
        // A downlink record appeared: the products sent since the last one are its.
        if world.downlinks.len() > self.state.downlinks_seen {
            self.state.downlinks_seen = world.downlinks.len();
            let index = world.downlinks.len() - 1;
            let record = &world.downlinks[index];
            let mut d = DownlinkTrace {
                index,
                start_us: record.start_us,
                end_us: record.end_us,
                received_us: record.end_us + world.light_us,
                bytes_per_tier: [0; 4],
                products_per_tier: [0; 4],
                value_milli_per_tier: [0; 4],
                products: Vec::new(),
            };
            // The products it sent whole (less any parts earlier downlinks sent).
            for p in &world.sent[self.state.sent_seen.min(world.sent.len())..] {
                let i = tier_index(p.tier);
                let bytes = p.bytes - sent_part(p);
                d.bytes_per_tier[i] += bytes;
                d.products_per_tier[i] += 1;
                d.value_milli_per_tier[i] += p.value_milli;
                d.products.push(SentProduct {
                    kind: p.kind.clone(),
                    tier: p.tier,
                    bytes,
                    value_milli: p.value_milli,
                    site: p.site,
                    target: p.target,
                    segment: false,
                });
            }
            // Parts of products still on board (larger than one downlink).
            for p in &world.stored {
                let before = self
                    .state
                    .onboard_before
                    .iter()
                    .find(|(k, _)| *k == key(p))
                    .map_or(0, |x| x.1);
                let part = sent_part(p).saturating_sub(before);
                if part > 0 {
                    let i = tier_index(p.tier);
                    d.bytes_per_tier[i] += part;
                    d.products.push(SentProduct {
                        kind: p.kind.clone(),
                        tier: p.tier,
                        bytes: part,
                        value_milli: 0,
                        site: p.site,
                        target: p.target,
                        segment: true,
                    });
                }
            }
            self.downlinks.push(d);
        }
        self.state.sent_seen = world.sent.len();
        self.state.onboard_before.clear();
        self.sample(world);
    }

    /// After the run's loop.
    pub(super) fn end(&mut self, world: &World) {
        self.close_halt(world.now);
        self.sample(world);
        if let Some(mut f) = self.progress.take() {
            f(None);
        }
    }
}

thread_local! {
    /// The trace of this thread's run while a [`Recording`] is in force.
    static RECORDER: RefCell<Option<Trace>> = const { RefCell::new(None) };
}

/// Gives the recording in force on this thread, if any, to `f` (the simulation's hooks).
pub(super) fn with(f: impl FnOnce(&mut Trace)) {
    RECORDER.with(|r| {
        // (A progress callback that runs a simulation itself is not recorded.)
        if let Ok(mut r) = r.try_borrow_mut() {
            if let Some(t) = r.as_mut() {
                f(t);
            }
        }
    });
}

/// While it lives, the simulation run on this thread is recorded into its trace; dropped
/// without [`Recording::finish`] (an error), the trace is discarded. Recordings nest: the
/// outer one is restored at the end of the inner.
pub struct Recording {
    /// The recording this one replaced (None once restored).
    outer: Option<Option<Trace>>,
}

impl Recording {
    pub fn start(trace: Trace) -> Self {
        Self {
            outer: Some(RECORDER.with(|r| r.replace(Some(trace)))),
        }
    }

    /// Ends the recording: its trace.
    pub fn finish(mut self) -> Trace {
        let outer = self.outer.take().flatten();
        RECORDER.with(|r| r.replace(outer)).unwrap_or_default()
    }
}

impl Drop for Recording {
    fn drop(&mut self) {
        if let Some(outer) = self.outer.take() {
            RECORDER.with(|r| r.replace(outer));
        }
    }
}

/// Runs one mission of `s` under `config` with a recorder: the same [`RunResult`] as
/// [`super::run`], and the trace.
pub fn run_traced(s: &Scenario, config: &RunConfig) -> Result<(RunResult, Trace), String> {
    let recording = Recording::start(Trace::new(s));
    let result = super::run(s, config)?;
    Ok((result, recording.finish()))
}

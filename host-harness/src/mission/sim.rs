//! The simulated spacecraft: subsystems advanced with mission time that publish state-buffer
//! updates and answer dispatched commands after modelled durations.
//!
//! - GNC: a GncAttain command makes the attitude TURNING at once and, after the slew, the
//!   commanded attitude (the command's first argument), answered Ok then. After a reset the
//!   attitude is UNKNOWN until the next completed slew (fault protection does not restore it).
//! - Power: battery energy drawn by a hotel load and by commanded activities, published every
//!   `publish_every`; activity loads carry seeded noise.
//! - Instruments: data volume produced by commanded activities.
//! - Thermal: a heater command warms the instrument from `cold` to `warm` over `warmup`.
//! - Any other command is answered Ok after `response_delay`.
//!
//! Everything is deterministic for a given configuration and seed.
use std::collections::BTreeMap;

use super::rng::Rng;
use crate::scenario::mission::SpacecraftConfig;
use crate::tasknet::{CompiledNetwork, TimelineKindName};
use crate::time::{parse_duration, TimeText};
use fsw_bridge::{
    CommandArgs, CommandStatus, HostToTarget, MissionTimeUs, Opcode, StateKey, StateValue,
};

/// A configuration problem, naming the field.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfigError {
    pub field: String,
    pub message: String,
}

fn cfg_err(field: &str, message: impl Into<String>) -> ConfigError {
    ConfigError {
        field: field.to_string(),
        message: message.into(),
    }
}

#[derive(Clone, Debug)]
struct Gnc {
    key: StateKey,
    attain: Opcode,
    slew_us: u64,
    turning: u16,
    after_reset: u16,
    value_count: u16,
}

#[derive(Clone, Debug)]
struct Activity {
    opcode: Opcode,
    per_hour: i64,
    duration_us: u64,
}

#[derive(Clone, Debug)]
struct Power {
    key: StateKey,
    hotel_per_hour: i64,
    loads: Vec<Activity>,
    noise_permille: i64,
    bias_permille: i64,
    publish_us: u64,
}

#[derive(Clone, Debug)]
struct Instrument {
    key: StateKey,
    activity: Activity,
}

#[derive(Clone, Debug)]
struct Thermal {
    key: StateKey,
    heater: Opcode,
    warmup_us: u64,
    warm: i64,
}

#[derive(Clone, Debug)]
enum Pending {
    State(StateKey, StateValue),
    Response(u32, CommandStatus),
    PublishBattery,
}

/// A running activity that draws energy or produces data linearly over its duration.
#[derive(Clone, Debug)]
struct Flow {
    key: StateKey,
    per_hour: i64,
    start: MissionTimeUs,
    end: MissionTimeUs,
    /// Sign: -1 draws (battery), +1 produces (data volume).
    sign: i64,
}

/// What to do with one dispatched command (decided by the fault injector).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CommandFate {
    /// Carried out as modelled.
    Nominal,
    /// Answered with this status right away, nothing else happens.
    Answer(CommandStatus),
    /// Never answered.
    Silent,
    /// Accepted and answered Ok when it would have completed, but it has no effect: no state
    /// changes, no energy drawn, no data produced (a subsystem that reports success and does
    /// nothing).
    NoEffect,
    /// Carried out and answered Ok, but the state it sets ends at this value instead of the
    /// commanded one (a GNC that settles at the wrong attitude).
    WrongState(StateValue),
}

/// The simulated spacecraft.
#[derive(Clone, Debug)]
pub struct Spacecraft {
    gnc: Option<Gnc>,
    power: Option<Power>,
    instruments: Vec<Instrument>,
    thermal: Option<Thermal>,
    response_delay_us: u64,
    pending: Vec<(MissionTimeUs, u64, Pending)>,
    order: u64,
    /// Current value of every published state.
    state: BTreeMap<StateKey, (StateValue, MissionTimeUs)>,
    /// Integer accumulators for cumulative states, in the state's unit times 3.6e9 (per-hour
    /// rates over microseconds stay exact).
    flows: Vec<Flow>,
    base: BTreeMap<StateKey, i64>,
    base_at: BTreeMap<StateKey, MissionTimeUs>,
    rng: Rng,
}

const US_PER_HOUR: i64 = 3_600_000_000;

impl Spacecraft {
    /// Build the spacecraft from its configuration, resolving names against the network.
    pub fn new(
        config: &SpacecraftConfig,
        net: &CompiledNetwork,
        start: MissionTimeUs,
        seed: u64,
    ) -> Result<Self, ConfigError> {
        let dur =
            |field: &str, text: &TimeText| parse_duration(text).map_err(|m| cfg_err(field, m));
        // A published timeline of the kind the subsystem's values have: enumerated values go
        // to a state timeline, integer quantities to a cumulative one (the target reads a
        // value of the other type as UNKNOWN).
        let timeline_of = |field: &str, name: &str, kind: TimelineKindName| {
            let tl = net.timeline(name).ok_or_else(|| {
                cfg_err(
                    field,
                    format!("no timeline named {name:?} in the task network"),
                )
            })?;
            let key = tl.state_key.ok_or_else(|| {
                cfg_err(
                    field,
                    format!("{name:?} has no state_key in the task network: the spacecraft cannot publish it"),
                )
            })?;
            if tl.kind != kind {
                return Err(cfg_err(
                    field,
                    format!(
                        "{name:?} is a {} timeline, but this subsystem publishes {} values (a {} timeline's): the target would read every one as UNKNOWN",
                        tl.kind.name(),
                        if kind == TimelineKindName::State { "enumerated" } else { "integer" },
                        kind.name()
                    ),
                ));
            }
            Ok((key, tl.values.clone()))
        };
        let state_timeline =
            |field: &str, name: &str| timeline_of(field, name, TimelineKindName::State);
        let quantity_timeline =
            |field: &str, name: &str| timeline_of(field, name, TimelineKindName::Cumulative);
        let value_code = |field: &str, values: &[String], name: &str| {
            values
                .iter()
                .position(|v| v == name)
                .map(|i| i as u16)
                .ok_or_else(|| {
                    cfg_err(
                        field,
                        format!(
                            "{name:?} is not a value of this timeline (values: {})",
                            values.join(", ")
                        ),
                    )
                })
        };
        let mut sc = Self {
            gnc: None,
            power: None,
            instruments: Vec::new(),
            thermal: None,
            response_delay_us: match &config.response_delay {
                Some(d) => dur("spacecraft.response_delay", d)?,
                None => 0,
            },
            pending: Vec::new(),
            order: 0,
            state: BTreeMap::new(),
            flows: Vec::new(),
            base: BTreeMap::new(),
            base_at: BTreeMap::new(),
            rng: Rng::new(seed).fork(0x5c),
        };
        if let Some(g) = &config.gnc {
            let (key, values) = state_timeline("spacecraft.gnc.attitude", &g.attitude)?;
            let initial = value_code("spacecraft.gnc.initial", &values, &g.initial)?;
            sc.gnc = Some(Gnc {
                key,
                attain: Opcode(g.attain_opcode),
                slew_us: dur("spacecraft.gnc.slew", &g.slew)?,
                turning: value_code("spacecraft.gnc.turning", &values, &g.turning)?,
                after_reset: value_code("spacecraft.gnc.after_reset", &values, &g.after_reset)?,
                value_count: values.len() as u16,
            });
            sc.set(key, StateValue::Enum(initial), start);
        }
        if let Some(p) = &config.power {
            let (key, _) = quantity_timeline("spacecraft.power.battery", &p.battery)?;
            let mut loads = Vec::new();
            for (i, l) in p.loads.iter().enumerate() {
                loads.push(Activity {
                    opcode: Opcode(l.opcode),
                    per_hour: l.per_hour,
                    duration_us: dur(
                        &format!("spacecraft.power.loads[{i}].duration"),
                        &l.duration,
                    )?,
                });
            }
            let publish_us = match &p.publish_every {
                Some(d) => dur("spacecraft.power.publish_every", d)?,
                None => 60_000_000,
            };
            if publish_us == 0 {
                return Err(cfg_err(
                    "spacecraft.power.publish_every",
                    "must be longer than 0",
                ));
            }
            sc.power = Some(Power {
                key,
                hotel_per_hour: p.hotel_per_hour,
                loads,
                noise_permille: i64::from(p.noise_percent) * 10,
                bias_permille: i64::from(p.bias_percent) * 10,
                publish_us,
            });
            sc.base.insert(key, p.initial * US_PER_HOUR);
            sc.base_at.insert(key, start);
            sc.set(key, StateValue::Int(p.initial), start);
            sc.push(start.saturating_add(publish_us), Pending::PublishBattery);
        }
        for (i, inst) in config.instruments.iter().enumerate() {
            let field = format!("spacecraft.instruments[{i}]");
            let (key, _) = quantity_timeline(&format!("{field}.data_volume"), &inst.data_volume)?;
            sc.instruments.push(Instrument {
                key,
                activity: Activity {
                    opcode: Opcode(inst.opcode),
                    per_hour: inst.per_hour,
                    duration_us: dur(&format!("{field}.duration"), &inst.duration)?,
                },
            });
            sc.base.entry(key).or_insert(0);
            sc.base_at.entry(key).or_insert(start);
            sc.set(key, StateValue::Int(0), start);
        }
        if let Some(t) = &config.thermal {
            let (key, _) = quantity_timeline("spacecraft.thermal.temperature", &t.temperature)?;
            sc.thermal = Some(Thermal {
                key,
                heater: Opcode(t.heater_opcode),
                warmup_us: dur("spacecraft.thermal.warmup", &t.warmup)?,
                warm: t.warm,
            });
            sc.set(key, StateValue::Int(t.cold), start);
        }
        Ok(sc)
    }

    fn push(&mut self, at: MissionTimeUs, p: Pending) {
        self.order += 1;
        self.pending.push((at, self.order, p));
    }

    fn set(&mut self, key: StateKey, value: StateValue, at: MissionTimeUs) {
        self.state.insert(key, (value, at));
    }

    /// The earliest mission time at which something happens by itself.
    pub fn next_event(&self) -> Option<MissionTimeUs> {
        self.pending.iter().map(|p| p.0).min()
    }

    /// The current value of a state.
    pub fn state(&self, key: StateKey) -> Option<StateValue> {
        self.state.get(&key).map(|s| s.0)
    }

    /// Value of a cumulative quantity at `now`, from its base and the flows so far.
    fn cumulative(&self, key: StateKey, now: MissionTimeUs) -> i64 {
        let base = self.base.get(&key).copied().unwrap_or(0);
        let base_at = self.base_at.get(&key).copied().unwrap_or(now);
        let mut scaled = base;
        if let Some(p) = &self.power {
            if p.key == key {
                let dt = now.0.saturating_sub(base_at.0) as i64;
                scaled -= p.hotel_per_hour * dt;
            }
        }
        for f in self.flows.iter().filter(|f| f.key == key) {
            let from = f.start.max(base_at);
            let to = f.end.min(now);
            if to > from {
                scaled += f.sign * f.per_hour * (to.0 - from.0) as i64;
            }
        }
        scaled.div_euclid(US_PER_HOUR)
    }

    /// A command arrived at `now`.
    pub fn on_dispatch(
        &mut self,
        now: MissionTimeUs,
        id: u32,
        opcode: Opcode,
        args: &CommandArgs,
        fate: CommandFate,
    ) {
        let wrong = match fate {
            CommandFate::Silent => return,
            CommandFate::Answer(status) => {
                self.push(now, Pending::Response(id, status));
                return;
            }
            CommandFate::NoEffect => {
                let done = match &self.gnc {
                    Some(g) if g.attain == opcode => g.slew_us,
                    _ => self.response_delay_us,
                };
                self.push(
                    now.saturating_add(done),
                    Pending::Response(id, CommandStatus::Ok),
                );
                return;
            }
            CommandFate::WrongState(value) => Some(value),
            CommandFate::Nominal => None,
        };
        let mut answered = false;
        if let Some(g) = self.gnc.clone() {
            if opcode == g.attain {
                let target = args.first().copied().unwrap_or(-1);
                if target < 0 || target >= i32::from(g.value_count) {
                    self.push(now, Pending::Response(id, CommandStatus::Rejected));
                    return;
                }
                self.push(now, Pending::State(g.key, StateValue::Enum(g.turning)));
                let done = now.saturating_add(g.slew_us);
                let reached = wrong.unwrap_or(StateValue::Enum(target as u16));
                self.push(done, Pending::State(g.key, reached));
                self.push(done, Pending::Response(id, CommandStatus::Ok));
                answered = true;
            }
        }
        if let Some(p) = self.power.clone() {
            for load in p.loads.iter().filter(|l| l.opcode == opcode) {
                let noise = self.rng.noise_permille(p.noise_permille);
                let per_hour = load.per_hour * (1000 + p.bias_permille + noise) / 1000;
                self.flows.push(Flow {
                    key: p.key,
                    per_hour: per_hour.max(0),
                    start: now,
                    end: now.saturating_add(load.duration_us),
                    sign: -1,
                });
            }
        }
        for inst in self.instruments.clone() {
            if inst.activity.opcode == opcode {
                self.flows.push(Flow {
                    key: inst.key,
                    per_hour: inst.activity.per_hour,
                    start: now,
                    end: now.saturating_add(inst.activity.duration_us),
                    sign: 1,
                });
                let end = now.saturating_add(inst.activity.duration_us);
                self.push(end, Pending::State(inst.key, StateValue::Int(0)));
            }
        }
        if let Some(t) = self.thermal.clone() {
            if opcode == t.heater {
                self.push(
                    now.saturating_add(t.warmup_us),
                    Pending::State(t.key, wrong.unwrap_or(StateValue::Int(t.warm))),
                );
            }
        }
        if !answered {
            self.push(
                now.saturating_add(self.response_delay_us),
                Pending::Response(id, CommandStatus::Ok),
            );
        }
    }

    /// Everything due at or before `now`, as messages for the target, in time then issue order.
    pub fn due(&mut self, now: MissionTimeUs) -> Vec<HostToTarget> {
        let mut out = Vec::new();
        // Handling an event may schedule another one that is also due (a periodic publication
        // falling behind `now`): take them in time order until none is left.
        loop {
            self.pending.sort_by_key(|p| (p.0, p.1));
            if self.pending.first().is_none_or(|p| p.0 > now) {
                break;
            }
            let (at, _, p) = self.pending.remove(0);
            self.handle_due(at, p, &mut out);
        }
        out
    }

    fn handle_due(&mut self, at: MissionTimeUs, p: Pending, out: &mut Vec<HostToTarget>) {
        {
            match p {
                Pending::State(key, value) => {
                    // Cumulative states are recomputed from their flows when published.
                    let value = if self.base.contains_key(&key) {
                        StateValue::Int(self.cumulative(key, at))
                    } else {
                        value
                    };
                    self.set(key, value, at);
                    out.push(HostToTarget::StateUpdate {
                        key,
                        value,
                        timestamp: at,
                    });
                }
                Pending::Response(id, status) => out.push(HostToTarget::CommandResponse {
                    id,
                    status,
                    data: None,
                }),
                Pending::PublishBattery => {
                    if let Some(p) = self.power.clone() {
                        let value = StateValue::Int(self.cumulative(p.key, at));
                        self.set(p.key, value, at);
                        out.push(HostToTarget::StateUpdate {
                            key: p.key,
                            value,
                            timestamp: at,
                        });
                        self.push(at.saturating_add(p.publish_us), Pending::PublishBattery);
                    }
                }
            }
        }
    }

    /// A flight-software reset at `at`: fault protection drops every command in progress, and
    /// the attitude is no longer known. Energy keeps draining (the hotel load does not stop).
    pub fn reset(&mut self, at: MissionTimeUs) {
        self.pending
            .retain(|p| matches!(p.2, Pending::PublishBattery));
        // Activities in progress stop where they are.
        for f in &mut self.flows {
            f.end = f.end.min(at);
        }
        if let Some(g) = &self.gnc {
            let (key, value) = (g.key, StateValue::Enum(g.after_reset));
            self.set(key, value, at);
        }
    }

    /// The whole state buffer at `now`, as published to a target that just (re)started: each
    /// value with the time it took that value (cumulative quantities are sampled now).
    pub fn publish_all(&mut self, now: MissionTimeUs) -> Vec<HostToTarget> {
        self.publish(now, false)
    }

    /// The whole state buffer at `now` as a fresh measurement (the scenario's republication
    /// cadence): every value stamped now, so that it renews the value's age on the target (a
    /// value older than its timeline's staleness bound reads UNKNOWN there).
    pub fn republish_all(&mut self, now: MissionTimeUs) -> Vec<HostToTarget> {
        self.publish(now, true)
    }

    fn publish(&mut self, now: MissionTimeUs, measured_now: bool) -> Vec<HostToTarget> {
        let keys: Vec<StateKey> = self.state.keys().copied().collect();
        keys.into_iter()
            .map(|key| {
                let (value, timestamp) = if self.base.contains_key(&key) {
                    let v = StateValue::Int(self.cumulative(key, now));
                    self.set(key, v, now);
                    (v, now)
                } else if measured_now {
                    (self.state[&key].0, now)
                } else {
                    self.state[&key]
                };
                HostToTarget::StateUpdate {
                    key,
                    value,
                    timestamp,
                }
            })
            .collect()
    }

    /// An exogenous change of a state (scenario event): published at `at`.
    pub fn override_state(&mut self, key: StateKey, value: StateValue, at: MissionTimeUs) {
        if let (Some(base), StateValue::Int(v)) = (self.base.get_mut(&key), value) {
            *base = v * US_PER_HOUR;
            // Flows and hotel load count from the new base on (see `cumulative`).
            self.base_at.insert(key, at);
        }
        self.set(key, value, at);
        self.push(at, Pending::State(key, value));
    }

    /// A sudden change of a cumulative quantity by `delta` (e.g. a battery drop) at `at`.
    pub fn add_to(&mut self, key: StateKey, delta: i64, at: MissionTimeUs) -> Result<(), String> {
        if !self.base.contains_key(&key) {
            return Err(
                "only simulated cumulative states (battery, data volume) can change by an amount"
                    .into(),
            );
        }
        let now_value = self.cumulative(key, at);
        self.override_state(key, StateValue::Int(now_value + delta), at);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::mission::{ActivityLoad, GncConfig, PowerConfig};

    /// GncAttitude (state, key 1), Battery and Data (cumulative, keys 2 and 3), Heater (a
    /// planner-only state timeline).
    fn names() -> CompiledNetwork {
        crate::tasknet::compile_str(
            "[network]\nid = 1\n\
             [[timeline]]\nname = \"GncAttitude\"\nkind = \"state\"\nvalues = [\"INERTIAL\", \"TURNING\", \"NADIR\", \"UNKNOWN\"]\nstate_key = 1\n\
             [[timeline]]\nname = \"Battery\"\nkind = \"cumulative\"\ninitial = 0\nmin = -1000000\nmax = 1000000\nstate_key = 2\n\
             [[timeline]]\nname = \"Data\"\nkind = \"cumulative\"\ninitial = 0\nmin = 0\nmax = 1000000\nstate_key = 3\n\
             [[timeline]]\nname = \"Heater\"\nkind = \"state\"\nvalues = [\"OFF\", \"ON\"]\n",
            "names.toml",
        )
        .unwrap()
    }

    fn gnc_config() -> SpacecraftConfig {
        SpacecraftConfig {
            gnc: Some(GncConfig {
                attitude: "GncAttitude".into(),
                attain_opcode: 0x10,
                slew: "15min".into(),
                initial: "INERTIAL".into(),
                turning: "TURNING".into(),
                after_reset: "UNKNOWN".into(),
            }),
            ..Default::default()
        }
    }

    const MIN: u64 = 60_000_000;

    #[test]
    fn a_slew_turns_then_reaches_the_commanded_attitude_and_answers() {
        let mut sc = Spacecraft::new(&gnc_config(), &names(), MissionTimeUs(0), 1).unwrap();
        let args = CommandArgs::from_slice(&[2]).unwrap();
        sc.on_dispatch(
            MissionTimeUs(MIN),
            7,
            Opcode(0x10),
            &args,
            CommandFate::Nominal,
        );
        let now = sc.due(MissionTimeUs(MIN));
        assert_eq!(
            now,
            vec![HostToTarget::StateUpdate {
                key: StateKey(1),
                value: StateValue::Enum(1),
                timestamp: MissionTimeUs(MIN)
            }]
        );
        assert_eq!(sc.next_event(), Some(MissionTimeUs(16 * MIN)));
        let done = sc.due(MissionTimeUs(16 * MIN));
        assert_eq!(done.len(), 2);
        assert!(matches!(
            done[1],
            HostToTarget::CommandResponse {
                id: 7,
                status: CommandStatus::Ok,
                ..
            }
        ));
        assert_eq!(sc.state(StateKey(1)), Some(StateValue::Enum(2)));
    }

    #[test]
    fn a_reset_drops_the_slew_and_leaves_the_attitude_unknown() {
        let mut sc = Spacecraft::new(&gnc_config(), &names(), MissionTimeUs(0), 1).unwrap();
        let args = CommandArgs::from_slice(&[2]).unwrap();
        sc.on_dispatch(
            MissionTimeUs(0),
            1,
            Opcode(0x10),
            &args,
            CommandFate::Nominal,
        );
        sc.due(MissionTimeUs(0));
        sc.reset(MissionTimeUs(5 * MIN));
        assert_eq!(sc.next_event(), None);
        let all = sc.publish_all(MissionTimeUs(8 * MIN));
        assert!(matches!(
            all[0],
            HostToTarget::StateUpdate {
                value: StateValue::Enum(3),
                ..
            }
        ));
    }

    #[test]
    fn injected_fates_override_the_model() {
        let mut sc = Spacecraft::new(&gnc_config(), &names(), MissionTimeUs(0), 1).unwrap();
        let args = CommandArgs::from_slice(&[2]).unwrap();
        sc.on_dispatch(
            MissionTimeUs(0),
            1,
            Opcode(0x10),
            &args,
            CommandFate::Answer(CommandStatus::Failed(3)),
        );
        sc.on_dispatch(
            MissionTimeUs(0),
            2,
            Opcode(0x10),
            &args,
            CommandFate::Silent,
        );
        let out = sc.due(MissionTimeUs(0));
        assert_eq!(
            out,
            vec![HostToTarget::CommandResponse {
                id: 1,
                status: CommandStatus::Failed(3),
                data: None
            }]
        );
        assert_eq!(sc.next_event(), None);
    }

    #[test]
    fn battery_drains_by_hotel_load_and_activities_and_can_drop() {
        let config = SpacecraftConfig {
            power: Some(PowerConfig {
                battery: "Battery".into(),
                initial: 1000,
                hotel_per_hour: 60,
                loads: vec![ActivityLoad {
                    opcode: 0x20,
                    per_hour: 120,
                    duration: "30min".into(),
                }],
                noise_percent: 0,
                bias_percent: 0,
                publish_every: Some("10min".into()),
            }),
            ..Default::default()
        };
        let mut sc = Spacecraft::new(&config, &names(), MissionTimeUs(0), 1).unwrap();
        sc.on_dispatch(
            MissionTimeUs(0),
            1,
            Opcode(0x20),
            &CommandArgs::new(),
            CommandFate::Nominal,
        );
        sc.due(MissionTimeUs(0));
        let out = sc.due(MissionTimeUs(60 * MIN));
        // 10 min publishes; at 60 min: 1000 - 60 (hotel) - 60 (30 min at 120/h) = 880.
        let last = out
            .iter()
            .rev()
            .find_map(|m| match m {
                HostToTarget::StateUpdate {
                    key: StateKey(2),
                    value: StateValue::Int(v),
                    ..
                } => Some(*v),
                _ => None,
            })
            .unwrap();
        assert_eq!(last, 880);
        sc.add_to(StateKey(2), -300, MissionTimeUs(60 * MIN))
            .unwrap();
        let out = sc.due(MissionTimeUs(60 * MIN));
        assert!(out.contains(&HostToTarget::StateUpdate {
            key: StateKey(2),
            value: StateValue::Int(580),
            timestamp: MissionTimeUs(60 * MIN)
        }));
    }

    #[test]
    fn unknown_names_are_reported_by_field() {
        let mut config = gnc_config();
        config.gnc.as_mut().unwrap().initial = "SIDEWAYS".into();
        let err = Spacecraft::new(&config, &names(), MissionTimeUs(0), 1).unwrap_err();
        assert_eq!(err.field, "spacecraft.gnc.initial");
        assert!(err.message.contains("SIDEWAYS"), "{err:?}");
    }

    #[test]
    fn a_subsystem_publishing_into_a_timeline_of_the_other_type_is_refused() {
        // Integer battery values into a state timeline: the target would read UNKNOWN.
        let config = SpacecraftConfig {
            power: Some(PowerConfig {
                battery: "GncAttitude".into(),
                initial: 100,
                hotel_per_hour: 1,
                loads: Vec::new(),
                noise_percent: 0,
                bias_percent: 0,
                publish_every: None,
            }),
            ..Default::default()
        };
        let err = Spacecraft::new(&config, &names(), MissionTimeUs(0), 1).unwrap_err();
        assert_eq!(err.field, "spacecraft.power.battery");
        assert!(err.message.contains("is a state timeline"), "{err:?}");
        assert!(err.message.contains("UNKNOWN"), "{err:?}");
        // Enumerated attitudes into a cumulative timeline.
        let mut config = gnc_config();
        config.gnc.as_mut().unwrap().attitude = "Battery".into();
        let err = Spacecraft::new(&config, &names(), MissionTimeUs(0), 1).unwrap_err();
        assert_eq!(err.field, "spacecraft.gnc.attitude");
        assert!(err.message.contains("is a cumulative timeline"), "{err:?}");
        // A planner-only timeline has no state key to publish under.
        config.gnc.as_mut().unwrap().attitude = "Heater".into();
        let err = Spacecraft::new(&config, &names(), MissionTimeUs(0), 1).unwrap_err();
        assert!(err.message.contains("no state_key"), "{err:?}");
    }
}

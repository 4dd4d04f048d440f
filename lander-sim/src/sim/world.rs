//! The simulated world's behaviour: its set-up from a scenario, how it carries out the
//! executor's directives and advances time, energy, products, comms and the ground (the
//! types and the model summary are in the parent module).
use super::*;

impl World {
    pub fn new(s: &Scenario, model: &HtnModel, seed: u64, prescient: bool) -> Self {
        let earth = EarthSchedule::from_scenario(s);
        let horizon = horizon_us(s);
        // Quakes: a schedule drawn up front, so every strategy sees the same ones.
        let mut rq = Rng::stream(seed, Stream::Quakes);
        let per_h = ppm(s.seismometer.quakes_per_h);
        let quakes = (0..horizon / HOUR_US)
            .filter_map(|h| {
                rq.chance_ppm(per_h)
                    .then_some(h * HOUR_US + rq.below(HOUR_US))
            })
            .collect();
        // Science: per site positive or negative, strengths per target; fixed ones override.
        let mut rs = Rng::stream(seed, Stream::Science);
        let p_pos = ppm(s.science.p_site_positive);
        let mut outcomes: Vec<Vec<(bool, u64)>> = (0..s.mission.sites)
            .map(|_| {
                let positive = rs.chance_ppm(p_pos);
                (0..s.mission.targets_per_site)
                    .map(|_| (positive, if positive { 500 + rs.below(501) } else { 0 }))
                    .collect()
            })
            .collect();
        for t in &s.science.targets {
            if let Some(o) = outcomes
                .get_mut(usize::from(t.site))
                .and_then(|site| site.get_mut(usize::from(t.target)))
            {
                *o = (t.positive, milli(t.strength).clamp(0, 1_000) as u64);
            }
        }
        let th = &s.thermal;
        let h = milli(th.heating_fraction).clamp(0, 1_000) as u64;
        let heat_milli = (1_000 - h)
            + h * th.operating_k.saturating_sub(th.ambient_k)
                / th.operating_k.saturating_sub(th.baseline_k).max(1);
        let excavation_prior_us = model
            .primitives
            .iter()
            .find(|p| p.kind == PrimitiveKind::ExcavateSite)
            .map_or(6 * HOUR_US, |p| p.duration_us);
        let required_mcm = s.sampling.required_depth_cm * 1_000;
        let rate_mcm_per_h = s
            .sampling
            .rate_cm_per_h
            .map(|r| (r * 1_000.0).round() as u64)
            .or_else(|| {
                Some(
                    (u128::from(required_mcm) * u128::from(HOUR_US)
                        / u128::from(excavation_prior_us.max(1))) as u64,
                )
            });
        let capacity = s.mission.battery_wh * WH_MJ;
        let mut drops: Vec<(u64, u64, Option<u64>)> = s
            .power
            .drops
            .iter()
            .map(|d| {
                (
                    d.at_h * HOUR_US,
                    d.wh * WH_MJ,
                    d.to_soc.map(|x| mul_ppm(capacity, u64::from(ppm(x)))),
                )
            })
            .collect();
        let volume = |x: f64| milli(x).max(0) as u64;
        drops.sort_unstable();
        let f = &s.failures;
        Self {
            earth,
            now: 0,
            battery_mj: start_charge_mj(s),
            dead: false,
            hotel_mw: s.power.hotel_w * 1_000,
            seismo_mw: s.power.seismometer_w * 1_000,
            seismo_on: false,
            seismo_bytes_per_h: s.seismometer.bytes_per_h,
            seismo_bytes: 0,
            seismo_value_milli_per_mb: milli(s.seismometer.value_per_mb).max(0) as u64,
            quakes,
            quake_bytes: s.seismometer.quake_bytes,
            quake_value: s.seismometer.quake_value,
            next_quake: 0,
            drops,
            next_drop: 0,
            volume_milli: [
                volume(s.data.critical),
                volume(s.data.decisional),
                volume(s.data.mandatory),
                volume(s.data.residual),
            ],
            hold_ready: None,
            holds_set: 0,
            holds_released: 0,
            stored: Vec::new(),
            sent: Vec::new(),
            trench_mcm: vec![0; usize::from(s.mission.sites)],
            required_mcm,
            depth_limit_mcm: (0..s.mission.sites)
                .map(|i| {
                    s.sampling
                        .depth_limit_cm
                        .get(usize::from(i))
                        .copied()
                        .unwrap_or(0)
                        * 1_000
                })
                .collect(),
            rate_mcm_per_h,
            rate_sd_milli: if prescient {
                0
            } else {
                milli(s.sampling.rate_sd)
            },
            collapse_ppm_per_h: if prescient {
                0
            } else {
                ppm(s.sampling.collapse_per_h)
            },
            collapse_mcm: s.sampling.collapse_cm * 1_000,
            arm: None,
            instrument: None,
            outcomes,
            negative_value_milli: milli(s.science.negative_value).clamp(0, 1_000) as u64,
            heat_milli,
            blocks: Vec::new(),
            resolved: Vec::new(),
            comm_energy_by_sol: Vec::new(),
            light_us: s.comms.light_time_min * MIN_US,
            rate_bps: s.comms.rate_bps,
            overhead_us: s.comms.overhead_min * MIN_US,
            thermal_limit_us: s.comms.thermal_limit_h * HOUR_US,
            per_downlink_mj: s.comms.per_downlink_wh * WH_MJ,
            per_sol_mj: s.comms.per_sol_wh * WH_MJ,
            radio_mw: s.comms.radio_w * 1_000,
            ground_response_us: s.ground.response_h * HOUR_US,
            p_fail: if prescient { 0 } else { ppm(f.p_fail) },
            p_fe: ppm(f.p_fe),
            p_replan: ppm(f.p_replan),
            failed_fraction_ppm: u64::from(ppm(f.failed_attempt_fraction)),
            replan_block_us: f.replan_block_min * MIN_US,
            bias_milli: if prescient { 0 } else { milli(s.energy.bias) },
            sd_milli: if prescient { 0 } else { milli(s.energy.sd) },
            rng_fail: Rng::stream(seed, Stream::Failures),
            rng_energy: Rng::stream(seed, Stream::Energy),
            rng_sampling: Rng::stream(seed, Stream::Sampling),
            downlinks: Vec::new(),
            commanded: None,
        }
    }

    /// The link as the autonomy is told it (rate, overhead, thermal limit, radio, allowances).
    pub fn comms_model(&self) -> lander::comms::CommsModel {
        lander::comms::CommsModel {
            rate_bps: self.rate_bps.max(1),
            overhead_us: self.overhead_us,
            thermal_limit_us: self.thermal_limit_us,
            radio_power_mw: self.radio_mw,
            per_downlink_mj: self.per_downlink_mj,
            per_sol_mj: self.per_sol_mj,
            sol_us: SOL_US,
        }
    }

    /// The products onboard as the autonomy measures them (most urgent and oldest first, at
    /// most the downlink manager's capacity).
    pub fn onboard_products(&self) -> Vec<lander::downlink::DataProduct> {
        let mut out: Vec<_> = self
            .stored
            .iter()
            .map(|p| lander::downlink::DataProduct {
                size_bytes: p.bytes - p.sent_bytes,
                value: p.value_milli / 1_000,
                created_at: MissionTimeUs(p.created_us),
                tier: p.tier,
            })
            .collect();
        out.sort_by_key(|p| (tier_index(p.tier), p.created_at));
        out.truncate(lander::capacity::MAX_DATA_PRODUCTS);
        out
    }

    /// A product's volume in this world.
    pub(super) fn volume(&self, tier: Tier, bytes: u64) -> u64 {
        mul_milli(bytes, self.volume_milli[tier_index(tier)])
    }

    /// Whether a ground hold is in force.
    pub fn hold_in_force(&self) -> bool {
        self.hold_ready.is_some()
    }

    /// A downlink with ground hold ended: a hold is in force until the ground has seen its data
    /// for `response_h` and an uplink carries the release.
    pub(super) fn set_hold(&mut self) {
        self.holds_set += 1;
        let received = self.downlinks.last().map(|d| d.end_us + self.light_us);
        // Only a downlink that carried data gives the ground something to release on.
        let ready = match received {
            Some(r) if self.downlinks.last().is_some_and(|d| d.bytes > 0) => {
                r + self.ground_response_us
            }
            _ => u64::MAX,
        };
        self.hold_ready = Some(ready);
    }

    /// An uplink started at `start`: it releases the hold if the ground's release was ready
    /// when it was sent (a light time before).
    pub(super) fn uplink(&mut self, start: u64) {
        if let Some(ready) = self.hold_ready {
            if ready.saturating_add(self.light_us) <= start {
                self.hold_ready = None;
                self.holds_released += 1;
            }
        }
    }

    pub(super) fn load_mw(&self) -> u64 {
        self.hotel_mw + if self.seismo_on { self.seismo_mw } else { 0 }
    }

    /// Drains `mj` from the battery; false (and dead) when it runs out.
    pub fn spend(&mut self, mj: u64) -> bool {
        if mj >= self.battery_mj && mj > 0 {
            self.battery_mj = 0;
            self.dead = true;
            return false;
        }
        self.battery_mj -= mj;
        true
    }

    /// Advances the clock to `to` (never back): the background load drains, the seismometer
    /// records, quakes and exogenous drops happen. False when the battery runs out on the way
    /// (the clock then stops when it did).
    pub fn advance(&mut self, to: u64) -> bool {
        while self.now < to && !self.dead {
            let next_drop = self.drops.get(self.next_drop).map(|d| d.0);
            let next_quake = self.quakes.get(self.next_quake).copied();
            let stop = [next_drop, next_quake]
                .into_iter()
                .flatten()
                .filter(|&t| t > self.now && t <= to)
                .min()
                .unwrap_or(to);
            let dt = stop - self.now;
            let load = self.load_mw();
            let drain = (u128::from(load) * u128::from(dt) / 1_000_000) as u64;
            if drain >= self.battery_mj && drain > 0 {
                // Dies part-way.
                let t = (u128::from(self.battery_mj) * 1_000_000 / u128::from(load.max(1))) as u64;
                self.now += t.min(dt);
                self.battery_mj = 0;
                self.dead = true;
                return false;
            }
            self.battery_mj -= drain;
            if self.seismo_on {
                self.seismo_bytes += (u128::from(self.seismo_bytes_per_h) * u128::from(dt)
                    / u128::from(HOUR_US)) as u64;
            }
            self.now = stop;
            while let Some(&(t, mj, to)) = self.drops.get(self.next_drop) {
                if t > self.now {
                    break;
                }
                self.next_drop += 1;
                let loss = to.map_or(mj, |to| self.battery_mj.saturating_sub(to));
                if loss > 0 && !self.spend(loss) {
                    return false;
                }
            }
            while let Some(&t) = self.quakes.get(self.next_quake) {
                if t > self.now {
                    break;
                }
                self.next_quake += 1;
                if self.seismo_on {
                    self.stored.push(Product {
                        kind: "quake".into(),
                        tier: Tier::Decisional,
                        bytes: self.volume(Tier::Decisional, self.quake_bytes),
                        value_milli: self.quake_value * 1_000,
                        created_us: t,
                        received_us: None,
                        site: None,
                        target: None,
                        sent_bytes: 0,
                    });
                }
            }
        }
        !self.dead
    }

    /// Whether the preconditions of `spec` hold now.
    pub fn preconditions(&self, spec: &PrimitiveSpec) -> bool {
        let blocked = self.blocks.iter().any(|b| {
            b.kind == spec.kind
                && b.site == spec.site
                && b.target == spec.target
                && self.now < b.until
        });
        if blocked {
            return false;
        }
        match spec.kind {
            PrimitiveKind::CollectSample | PrimitiveKind::FindCollectionTargets => spec
                .site
                .and_then(|s| self.trench_mcm.get(usize::from(s)))
                .is_some_and(|&d| d >= self.required_mcm),
            _ => true,
        }
    }

    /// The energy noise factor of one dispatch, in thousandths.
    pub(super) fn energy_factor(&mut self) -> u64 {
        let z = self.rng_energy.normal_milli();
        (1_000 + self.bias_milli + self.sd_milli * z / 1_000).max(0) as u64
    }

    /// Excavation of `site`: (duration, energy scale in thousandths of the prior, reached).
    pub(super) fn excavate(&mut self, site: u8, prior_us: u64) -> (u64, u64, bool) {
        let i = usize::from(site);
        let have = self.trench_mcm.get(i).copied().unwrap_or(0);
        if have >= self.required_mcm {
            // The trench is there: a look, minutes.
            return (6 * MIN_US, 1, true);
        }
        let limit = self.depth_limit_mcm.get(i).copied().unwrap_or(0);
        let mean = self.rate_mcm_per_h.unwrap_or(10_000).max(1);
        let z = self.rng_sampling.normal_milli();
        let rate = ((mean as i64) * (1_000 + self.rate_sd_milli * z / 1_000) / 1_000)
            .max(mean as i64 / 10)
            .max(1) as u64;
        // Dig in steps of 6 minutes.
        let step_us = 6 * MIN_US;
        let per_step = rate / 10;
        let collapse_ppm = self.collapse_ppm_per_h / 10;
        let mut depth = have;
        let mut t = 0u64;
        let max_t = 10 * prior_us.max(HOUR_US);
        let reached = loop {
            if depth >= self.required_mcm {
                break true;
            }
            if (limit > 0 && depth >= limit) || t >= max_t {
                break false;
            }
            t += step_us;
            depth += per_step.max(1);
            if limit > 0 {
                depth = depth.min(limit);
            }
            if collapse_ppm > 0 && self.rng_sampling.chance_ppm(collapse_ppm) {
                depth = depth.saturating_sub(self.collapse_mcm);
            }
        };
        if let Some(d) = self.trench_mcm.get_mut(i) {
            *d = depth;
        }
        // Energy scales with the digging time against the prior's.
        let scale = (u128::from(t) * 1_000 / u128::from(prior_us.max(1))) as u64;
        (t, scale, reached)
    }

    pub(super) fn product(&mut self, spec: &PrimitiveSpec) {
        let Some(p) = spec.product else { return };
        let mut value = p.value * 1_000;
        if spec.kind == PrimitiveKind::ScienceAnalyze {
            if let Some((site, target)) = self.instrument {
                if let Some(&(positive, strength)) = self
                    .outcomes
                    .get(usize::from(site))
                    .and_then(|s| s.get(usize::from(target)))
                {
                    value = if positive {
                        mul_milli(value, 1_000 + strength)
                    } else {
                        mul_milli(value, self.negative_value_milli)
                    };
                }
            }
        }
        let (site, target) = if spec.kind == PrimitiveKind::ScienceAnalyze {
            self.instrument.unzip()
        } else {
            (spec.site, spec.target)
        };
        self.stored.push(Product {
            kind: format!("{:?}", spec.kind),
            tier: p.tier,
            bytes: self.volume(p.tier, p.size_bytes),
            value_milli: value,
            created_us: self.now,
            received_us: None,
            site,
            target,
            sent_bytes: 0,
        });
    }

    pub(super) fn biosignature(&self) -> Option<Biosignature> {
        let (site, target) = self.instrument?;
        let &(positive, _) = self
            .outcomes
            .get(usize::from(site))?
            .get(usize::from(target))?;
        Some(if positive {
            Biosignature::Positive
        } else {
            Biosignature::Negative
        })
    }

    /// A downlink: waits for Earth if it must, transmits, realises the products' value.
    /// Returns the time it took and false if the battery ran out.
    pub(super) fn downlink(
        &mut self,
        planned_us: u64,
        energy_mj: u64,
        payload: &[lander::downlink::DataProduct],
    ) -> (u64, bool) {
        let dispatched = self.now;
        if !self.advance(self.earth.next_in_view(self.now)) {
            return (self.now - dispatched, false);
        }
        let start = self.now;
        let view_end = self.earth.view_end(start);
        let tx_start = start + self.overhead_us;
        let mut tx_end = (start + planned_us)
            .min(view_end)
            .min(tx_start + self.thermal_limit_us)
            .max(tx_start);
        // Energy allowances: per downlink and per sol (of the radio's power).
        let sol = (start / SOL_US) as usize;
        if self.comm_energy_by_sol.len() <= sol {
            self.comm_energy_by_sol.resize(sol + 1, 0);
        }
        let sol_left = self.per_sol_mj.saturating_sub(self.comm_energy_by_sol[sol]);
        let allowance = self.per_downlink_mj.min(sol_left);
        let max_tx = (u128::from(allowance) * 1_000_000 / u128::from(self.radio_mw.max(1))) as u64;
        tx_end = tx_end.min(tx_start + max_tx);
        let tx_us = tx_end - tx_start;
        self.comm_energy_by_sol[sol] +=
            (u128::from(self.radio_mw) * u128::from(tx_us) / 1_000_000) as u64;
        // The seismometer's continuous data so far becomes a product.
        if self.seismo_bytes > 0 {
            let bytes = std::mem::take(&mut self.seismo_bytes);
            self.stored.push(Product {
                kind: "seismic".into(),
                tier: Tier::Residual,
                bytes: self.volume(Tier::Residual, bytes),
                value_milli: (u128::from(bytes) * u128::from(self.seismo_value_milli_per_mb)
                    / 1_000_000) as u64,
                created_us: start,
                received_us: None,
                site: None,
                target: None,
                sent_bytes: 0,
            });
        }
        let mut capacity = (u128::from(self.rate_bps) * u128::from(tx_us) / 8_000_000) as u64;
        // The autonomy's assignment first, then the rest by tier and age.
        let assigned = |p: &Product| {
            payload.iter().any(|a| {
                a.created_at.0 == p.created_us
                    && a.tier == p.tier
                    && a.size_bytes == p.bytes - p.sent_bytes
            })
        };
        self.stored
            .sort_by_key(|p| (!assigned(p), tier_index(p.tier), p.created_us));
        let mut record = DownlinkRecord {
            dispatched_us: dispatched,
            start_us: tx_start,
            end_us: tx_end,
            bytes: 0,
            per_tier: [0; 4],
            value_milli: 0,
        };
        let mut kept = Vec::new();
        // A product larger than any one downlink can carry goes down over several.
        let largest = self.comms_model();
        let largest = largest.capacity_of(largest.max_duration_us());
        for mut p in std::mem::take(&mut self.stored) {
            let left = p.bytes - p.sent_bytes;
            if left > largest && left > capacity && capacity > 0 {
                p.sent_bytes += capacity;
                record.bytes += capacity;
                capacity = 0;
                kept.push(p);
            } else if left <= capacity {
                capacity -= left;
                record.bytes += left;
                record.per_tier[tier_index(p.tier)] += 1;
                record.value_milli += p.value_milli;
                p.received_us = Some(tx_end + self.light_us);
                self.sent.push(p);
            } else {
                kept.push(p);
            }
        }
        self.stored = kept;
        self.downlinks.push(record);
        let ok = self.advance(start + planned_us) && self.spend(energy_mj);
        (self.now - dispatched, ok)
    }

    /// Carries out one dispatch of `spec` (chain, primitive) predicted at `expected_us`.
    pub(super) fn execute(
        &mut self,
        chain: u16,
        primitive: u8,
        spec: &PrimitiveSpec,
    ) -> (Outcome, u8) {
        let start = self.now;
        let commanded = self.commanded.take();
        let factor = self.energy_factor();
        let heat = if is_heated(spec.kind) {
            self.heat_milli
        } else {
            1_000
        };
        let mut duration = mul_milli(spec.duration_us, heat);
        let mut energy = mul_milli(mul_milli(spec.energy_mj, factor), heat);
        // Failure draw (one per dispatch, from its own stream).
        let drawn = draw_failure(&mut self.rng_fail, self.p_fail, self.p_fe, self.p_replan);
        let resolved_at = self.resolved.iter().position(|r| *r == (chain, primitive));
        let class = if let Some(i) = resolved_at {
            self.resolved.swap_remove(i);
            None
        } else {
            drawn.map(|c| c as u8)
        };
        let mut biosignature = None;
        let result = if let Some(class) = class {
            duration = mul_ppm(duration, self.failed_fraction_ppm);
            energy = mul_ppm(energy, self.failed_fraction_ppm);
            self.resolved.push((chain, primitive));
            if class == 1 {
                self.blocks.push(Block {
                    kind: spec.kind,
                    site: spec.site,
                    target: spec.target,
                    until: start + duration + self.replan_block_us,
                });
            }
            let ok = self.advance(start + duration) && self.spend(energy);
            let _ = ok;
            if class == 2 {
                TaskResult::Faulted
            } else {
                TaskResult::Failed
            }
        } else if is_downlink(spec.kind) {
            // The commanded duration (sized by the autonomy to its data); energy scales.
            let (commanded, payload) = commanded.unwrap_or((duration, Vec::new()));
            energy =
                (u128::from(energy) * u128::from(commanded) / u128::from(duration.max(1))) as u64;
            duration = commanded;
            let _ = self.downlink(duration, energy, &payload);
            TaskResult::Succeeded
        } else {
            let mut result = TaskResult::Succeeded;
            match spec.kind {
                PrimitiveKind::ExcavateSite => {
                    let site = spec.site.unwrap_or(0);
                    let (t, scale, reached) = self.excavate(site, spec.duration_us);
                    duration = mul_milli(t, heat);
                    energy = mul_milli(mul_milli(spec.energy_mj, factor), heat);
                    energy = mul_milli(energy, scale);
                    if !reached {
                        // The site cannot be dug (depth limit): blocked for good.
                        self.blocks.push(Block {
                            kind: spec.kind,
                            site: spec.site,
                            target: spec.target,
                            until: u64::MAX,
                        });
                        result = TaskResult::Failed;
                    }
                }
                PrimitiveKind::CollectSample => {
                    self.arm = spec.site.zip(spec.target);
                }
                PrimitiveKind::TransportSample => {
                    self.instrument = self.arm.take();
                }
                PrimitiveKind::StartSeismometer => self.seismo_on = true,
                PrimitiveKind::StopSeismometer => self.seismo_on = false,
                _ => {}
            }
            let ok = self.advance(start + duration) && self.spend(energy);
            if ok && result == TaskResult::Succeeded {
                if spec.kind == PrimitiveKind::ScienceAnalyze {
                    biosignature = self.biosignature();
                }
                self.product(spec);
            }
            result
        };
        (
            Outcome {
                result,
                duration_us: self.now - start,
                energy_mj: energy,
                biosignature,
            },
            class.map_or(u8::MAX, |c| c),
        )
    }

    /// A ground answer to a halt at `now`: when it arrives on board.
    pub fn ground_answer_at(&self, now: u64) -> u64 {
        let seen = self.earth.next_in_view(now) + self.light_us;
        let uplink = self.earth.next_uplink(seen + self.ground_response_us);
        uplink + self.light_us
    }

    /// The ground resolves the halted primitive's problem: its blocks go.
    pub(super) fn ground_fix(&mut self, spec: Option<&PrimitiveSpec>) {
        if let Some(spec) = spec {
            self.blocks.retain(|b| {
                !(b.kind == spec.kind && b.site == spec.site && b.target == spec.target)
                    || b.until == u64::MAX
            });
        }
    }
}

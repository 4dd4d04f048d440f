//! A reference RSM-1-like model built in code (seed 000 II.B.2, Figs. 2-4, 8), for the tests and
//! the measurements: three sites of three targets each, a preamble, sampling chains (excavate,
//! find targets, prepare the arm, collect, transport, analyse, communicate raw or compressed,
//! with a ground hold unless fully autonomous), panoramas, and exogenous uplinks once per
//! Earth-in-view period. Batches: 0 uplinks, 1 preamble, 2 sampling, 3 panoramas. Phases:
//! 0 preamble (first sol), 1 surface operations.
//!
//! The numbers are illustrative, not the project's: each sampling chain carries its own
//! excavation (the model does not yet share one excavation between the samples of a site), and
//! energies and sizes are round figures chosen so that the battery cannot pay for everything.
use heapless::Vec;

use autonomy::Name;
use fsw_bridge::MissionTimeUs;

use crate::assessor::{ScienceContext, SiteRecord, TargetRecord};
use crate::downlink::DownlinkOpportunity;
use crate::htn::*;
use crate::placement::TimelinePlacement;
use crate::utility::{Rank, RankedUtility, Score};

/// A list in the model was full (cannot happen at the configured capacities).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CapacityExceeded;

pub const SEC_US: u64 = 1_000_000;
pub const HOUR_US: u64 = 3_600 * SEC_US;
/// A Europa sol (about 85 hours); Earth is in view for 42 hours of every 84.
pub const SOL_US: u64 = 85 * HOUR_US;
pub const EARTH_PERIOD_US: u64 = 84 * HOUR_US;
pub const EARTH_IN_VIEW_US: u64 = 42 * HOUR_US;
/// 1 Wh in mJ.
pub const WH_MJ: u64 = 3_600_000;

const PHASE_PREAMBLE: u8 = 0;
const PHASE_SURFACE: u8 = 1;

/// Options of the reference model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rsm1Options {
    pub sites: u8,
    pub targets_per_site: u8,
    pub panoramas: u8,
    /// Exogenous uplinks, one per Earth-in-view period from the start.
    pub uplinks: u8,
}

impl Rsm1Options {
    pub const FULL: Self = Self {
        sites: 3,
        targets_per_site: 3,
        panoramas: 4,
        uplinks: 6,
    };
}

fn name(s: &str) -> Result<Name, CapacityExceeded> {
    Name::try_from(s).map_err(|_| CapacityExceeded)
}

fn score(ten_thousandths: u32) -> Score {
    Score::new(ten_thousandths.min(10_000)).unwrap_or(Score::ZERO)
}

struct Builder {
    model: HtnModel,
}

impl Builder {
    /// One row of the model's primitive table (the arguments are its columns).
    #[allow(clippy::too_many_arguments)]
    fn primitive(
        &mut self,
        kind: PrimitiveKind,
        site: Option<u8>,
        target: Option<u8>,
        hours_tenths: u64,
        energy_wh: u64,
        utility: RankedUtility,
        product: Option<ProductSpec>,
    ) -> Result<u8, CapacityExceeded> {
        let index = u8::try_from(self.model.primitives.len()).map_err(|_| CapacityExceeded)?;
        self.model
            .primitives
            .push(PrimitiveSpec {
                kind,
                site,
                target,
                duration_us: hours_tenths * HOUR_US / 10,
                energy_mj: energy_wh * WH_MJ,
                utility,
                product,
            })
            .map_err(|_| CapacityExceeded)?;
        Ok(index)
    }

    fn parent(
        &mut self,
        id: u16,
        label: &str,
        top_level: bool,
        batch: u8,
        fixed_start: Option<MissionTimeUs>,
        decompositions: &[Decomposition],
    ) -> Result<u8, CapacityExceeded> {
        let index = u8::try_from(self.model.parents.len()).map_err(|_| CapacityExceeded)?;
        self.model
            .parents
            .push(ParentSpec {
                id,
                name: name(label)?,
                top_level,
                batch,
                fixed_start,
                decompositions: Vec::from_slice(decompositions).map_err(|_| CapacityExceeded)?,
            })
            .map_err(|_| CapacityExceeded)?;
        Ok(index)
    }
}

fn decomposition(
    steps: &[Step],
    phases: PhaseMask,
    mode: ModeUse,
    waits: bool,
) -> Result<Decomposition, CapacityExceeded> {
    Ok(Decomposition {
        steps: Vec::from_slice(steps).map_err(|_| CapacityExceeded)?,
        phases,
        mode,
        waits_for_ground_release: waits,
    })
}

/// The reference model.
pub fn model(options: Rsm1Options) -> Result<HtnModel, CapacityExceeded> {
    model_with_drains(options, 0)
}

/// The reference model with `drains` backlog downlinks: top-level tasks of their own batch (4,
/// after the panoramas) that only prepare the antenna and downlink (the raw downlink, 3 h),
/// creating no data. They carry data already onboard or planned that the plan's own
/// downlinks cannot (a product larger than one downlink after the rate fell, or a backlog);
/// the downlink manager's placement ([`crate::comms::DataPlacement`]) admits one only when it
/// downlinks required data that would otherwise stay onboard, and values it by that.
pub fn model_with_drains(options: Rsm1Options, drains: u8) -> Result<HtnModel, CapacityExceeded> {
    use PrimitiveKind as K;
    let mut b = Builder {
        model: HtnModel::default(),
    };
    let none = RankedUtility::ZERO;
    let comm = |s| RankedUtility::single(Rank::Default, score(s));
    // Shared primitives.
    let find_sites = b.primitive(
        K::FindExcavationSites,
        None,
        None,
        20,
        40,
        RankedUtility::single(Rank::PreExcavation, score(5_000)),
        Some(ProductSpec {
            size_bytes: 5_000_000,
            tier: Tier::Decisional,
            value: 20,
        }),
    )?;
    let start_seismo = b.primitive(K::StartSeismometer, None, None, 5, 5, none, None)?;
    let panorama = b.primitive(
        K::TakeMonoPanorama,
        None,
        None,
        10,
        30,
        RankedUtility::single(Rank::Default, score(2_000)),
        Some(ProductSpec {
            size_bytes: 20_000_000,
            tier: Tier::Residual,
            value: 10,
        }),
    )?;
    let prep_hga = b.primitive(K::PrepareHgaComm, None, None, 5, 20, none, None)?;
    let downlink_raw = b.primitive(K::Downlink, None, None, 30, 150, comm(9_000), None)?;
    let downlink_compressed = b.primitive(K::Downlink, None, None, 10, 60, comm(6_000), None)?;
    let downlink_gh_raw = b.primitive(
        K::DownlinkWithGroundHold,
        None,
        None,
        30,
        150,
        comm(9_000),
        None,
    )?;
    let downlink_gh_compressed = b.primitive(
        K::DownlinkWithGroundHold,
        None,
        None,
        10,
        60,
        comm(6_000),
        None,
    )?;
    let uplink = b.primitive(K::Uplink, None, None, 10, 20, none, None)?;
    let prep_arm = b.primitive(K::PrepareArm, None, None, 5, 15, none, None)?;
    let transport = b.primitive(K::TransportSample, None, None, 5, 20, none, None)?;
    let analyze_raw = b.primitive(
        K::ScienceAnalyze,
        None,
        None,
        40,
        120,
        RankedUtility::single(Rank::PostCollection, score(3_000)),
        Some(ProductSpec {
            size_bytes: 40_000_000,
            tier: Tier::Mandatory,
            value: 100,
        }),
    )?;
    let analyze_compressed = b.primitive(
        K::ScienceAnalyze,
        None,
        None,
        40,
        120,
        RankedUtility::single(Rank::PostCollection, score(3_000)),
        Some(ProductSpec {
            size_bytes: 10_000_000,
            tier: Tier::Mandatory,
            value: 60,
        }),
    )?;
    let _hotel = b.primitive(K::HotelLoad, None, None, 0, 0, none, None)?;
    let _seismo_on = b.primitive(K::SeismometerOn, None, None, 0, 0, none, None)?;
    let _discard = b.primitive(K::DiscardSample, None, None, 5, 10, none, None)?;
    let _stop_seismo = b.primitive(K::StopSeismometer, None, None, 5, 5, none, None)?;

    let surface = PhaseMask::only(PHASE_SURFACE);
    // Nested: communicate (raw or compressed; with a ground hold unless fully autonomous).
    let communicate_raw = b.parent(
        900,
        "communicate raw",
        false,
        2,
        None,
        &[
            decomposition(
                &[
                    Step::Primitive(analyze_raw),
                    Step::Primitive(prep_hga),
                    Step::Primitive(downlink_raw),
                ],
                surface,
                ModeUse::FullyAutonomous,
                false,
            )?,
            decomposition(
                &[
                    Step::Primitive(analyze_raw),
                    Step::Primitive(prep_hga),
                    Step::Primitive(downlink_gh_raw),
                ],
                surface,
                ModeUse::GroundInTheLoop,
                false,
            )?,
        ],
    )?;
    let communicate_compressed = b.parent(
        901,
        "communicate compressed",
        false,
        2,
        None,
        &[
            decomposition(
                &[
                    Step::Primitive(analyze_compressed),
                    Step::Primitive(prep_hga),
                    Step::Primitive(downlink_compressed),
                ],
                surface,
                ModeUse::FullyAutonomous,
                false,
            )?,
            decomposition(
                &[
                    Step::Primitive(analyze_compressed),
                    Step::Primitive(prep_hga),
                    Step::Primitive(downlink_gh_compressed),
                ],
                surface,
                ModeUse::GroundInTheLoop,
                false,
            )?,
        ],
    )?;
    // Exogenous uplinks: one at the start of each Earth-in-view period.
    for k in 0..options.uplinks {
        b.parent(
            100 + u16::from(k),
            "uplink",
            true,
            0,
            Some(MissionTimeUs(u64::from(k) * EARTH_PERIOD_US + HOUR_US)),
            &[decomposition(
                &[Step::Primitive(uplink)],
                PhaseMask::ANY,
                ModeUse::Always,
                false,
            )?],
        )?;
    }
    // Preamble.
    b.parent(
        1,
        "preamble",
        true,
        1,
        None,
        &[decomposition(
            &[
                Step::Primitive(find_sites),
                Step::Primitive(start_seismo),
                Step::Primitive(panorama),
                Step::Primitive(prep_hga),
                Step::Primitive(downlink_compressed),
            ],
            PhaseMask::only(PHASE_PREAMBLE),
            ModeUse::Always,
            false,
        )?],
    )?;
    // Sampling: per site an excavation (nested), per target a top-level sampling task.
    for site in 0..options.sites {
        let excavate = b.primitive(
            K::ExcavateSite,
            Some(site),
            None,
            60,
            900 + 100 * u64::from(site),
            RankedUtility::single(Rank::PostExcavation, score(4_000)),
            None,
        )?;
        let find_targets = b.primitive(
            K::FindCollectionTargets,
            Some(site),
            None,
            10,
            30,
            RankedUtility::single(Rank::PreCollection, score(3_000)),
            None,
        )?;
        for target in 0..options.targets_per_site {
            // Subway map: earlier sites and targets are worth more (estimated value order).
            let mission = 10_000 - 2_000 * u32::from(site) - 500 * u32::from(target);
            let analysis = 9_000 - 1_500 * u32::from(target) - 700 * u32::from(site);
            let collect = b.primitive(
                K::CollectSample,
                Some(site),
                Some(target),
                20,
                400,
                RankedUtility::from_scores([
                    score(mission),
                    score(analysis),
                    Score::ZERO,
                    Score::ZERO,
                    Score::ZERO,
                    Score::ZERO,
                    score(1_000),
                ]),
                None,
            )?;
            let head = [
                Step::Primitive(excavate),
                Step::Primitive(find_targets),
                Step::Primitive(prep_arm),
                Step::Primitive(collect),
                Step::Primitive(transport),
            ];
            let mut raw: heapless::Vec<Step, MAX_STEPS> =
                Vec::from_slice(&head).map_err(|_| CapacityExceeded)?;
            raw.push(Step::Parent(communicate_raw))
                .map_err(|_| CapacityExceeded)?;
            let mut compressed: heapless::Vec<Step, MAX_STEPS> =
                Vec::from_slice(&head).map_err(|_| CapacityExceeded)?;
            compressed
                .push(Step::Parent(communicate_compressed))
                .map_err(|_| CapacityExceeded)?;
            b.parent(
                10 + 10 * u16::from(site) + u16::from(target),
                "sample",
                true,
                2,
                None,
                &[
                    decomposition(&raw, surface, ModeUse::Always, true)?,
                    decomposition(&compressed, surface, ModeUse::Always, true)?,
                ],
            )?;
        }
    }
    // Panoramas (secondary science).
    for k in 0..options.panoramas {
        b.parent(
            200 + u16::from(k),
            "panorama",
            true,
            3,
            None,
            &[decomposition(
                &[
                    Step::Primitive(panorama),
                    Step::Primitive(prep_hga),
                    Step::Primitive(downlink_compressed),
                ],
                surface,
                ModeUse::Always,
                false,
            )?],
        )?;
    }
    // Backlog downlinks.
    for k in 0..drains {
        b.parent(
            300 + u16::from(k),
            "downlink backlog",
            true,
            4,
            None,
            &[decomposition(
                &[Step::Primitive(prep_hga), Step::Primitive(downlink_raw)],
                surface,
                ModeUse::Always,
                false,
            )?],
        )?;
    }
    Ok(b.model)
}

use crate::capacity::MAX_STEPS;

/// The simple placement for the reference mission: `sols` sols from time 0, the preamble phase
/// for the first sol, a hotel load of 10 W.
pub fn placement(sols: u64, battery_mj: u64) -> Option<TimelinePlacement> {
    Some(TimelinePlacement {
        horizon_start: MissionTimeUs::ZERO,
        horizon_end: MissionTimeUs(sols * SOL_US),
        phases: PhaseTimeline::new(&[(MissionTimeUs(SOL_US), PHASE_SURFACE)]).ok()?,
        battery_mj,
        hotel_load_mw: 10_000,
        earth: crate::placement::EarthView::default(),
    })
}

/// One downlink opportunity per Earth-in-view period: 4 hours from 2 hours into the period, 50
/// kbps, a 60 W radio, 3 hours of transmission before the thermal limit, 20 minutes of overhead;
/// one sol allocation per period.
pub fn opportunities(periods: u16) -> Vec<DownlinkOpportunity, { crate::capacity::MAX_DOWNLINKS }> {
    let mut out = Vec::new();
    for k in 0..periods {
        let start = u64::from(k) * EARTH_PERIOD_US + 2 * HOUR_US;
        let _ = out.push(DownlinkOpportunity {
            start: MissionTimeUs(start),
            end: MissionTimeUs(start + 4 * HOUR_US),
            overhead_us: 1_200 * SEC_US,
            sol: k,
            rate_bps: 50_000,
            radio_power_mw: 60_000,
            thermal_limit_us: 3 * HOUR_US,
        });
    }
    out
}

/// The science context of the reference model before the mission: sites and targets with the
/// estimated values the model's utilities were written from (earlier sites and targets are
/// worth more), nothing excavated, imaged or collected yet.
pub fn context(options: Rsm1Options) -> ScienceContext {
    let mut context = ScienceContext::default();
    for site in 0..options.sites {
        let mut record = SiteRecord {
            estimated: score(9_000u32.saturating_sub(2_000 * u32::from(site))),
            pre_excavation: None,
            post_excavation: None,
            targets: Vec::new(),
        };
        for target in 0..options.targets_per_site {
            let _ = record.targets.push(TargetRecord::estimated(score(
                9_000u32.saturating_sub(1_500 * u32::from(target) + 700 * u32::from(site)),
            )));
        }
        let _ = context.sites.push(record);
    }
    context
}

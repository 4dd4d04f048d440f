//! A scenario's success criteria (seed 000 V.B.1: each ELAP scenario has its own), written as
//! `[[expect]]` tables in the scenario file and checked against a run's result.
//!
//! Each expectation has a `kind` and the fields that kind takes ([`KINDS`]); an unknown kind, a
//! field the kind does not take or a missing one is an error at the field's file:line:column
//! (through [`crate::scenario::Scenario::validate`]). [`check`] gives a [`Verdict`] per
//! expectation with a readable detail, whether it passed or not.
//!
//! Kinds:
//! - `mandatory_downlinked` (`tiers`, default Critical and Mandatory): every product of those
//!   tiers created during the run reached Earth by its end.
//! - `no_stranded_samples`: every sample collected was analysed and its analysis product
//!   reached Earth (no sampling started whose data could not be downlinked).
//! - `decisional_at_next_downlink`: every Decisional product went down in the first downlink
//!   that started after it was created.
//! - `samples`, `utility`, `downlinks`, `sols`, `energy_left_wh` (`min`, `max`): the samples
//!   analysed, the value on Earth, the downlinks made, the sols simulated, the charge left.
//! - `end` (`reason`: done, abandoned, battery_exhausted, mission_end): how the run ended.
//! - `site_order` (`order`, optional `change`): the collections (after ground change `change`
//!   took effect, if given) visit the sites in this order, never going back to an earlier one;
//!   at least one collection.
//! - `max_samples_per_site` (`max`, optional `change`): every site sampled (after the change)
//!   has at most `max` samples in all.
//! - `leaves_negative_sites`: no collection at a site after a negative biosignature there (the
//!   subway map moves on).
//! - `holds_respected` (`min`, default 1): no primitive of a chain that waits for the ground's
//!   release ran while a hold was in force, and at least `min` holds were released by uplinks.
//! - `change_applied` (`change`): ground change `change` reached the lander and took effect.
use serde::{Deserialize, Serialize};

use crate::scenario::{FieldError, Mission, Scenario};
use crate::sim::{EndReason, RunResult};
use lander::htn::Tier;
use lander::rsm1::{HOUR_US, SOL_US, WH_MJ};

/// One success criterion.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Expectation {
    pub kind: String,
    /// What it checks, in words (printed with the verdict).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub note: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max: Option<f64>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub order: Vec<u8>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub change: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub tiers: Vec<String>,
}

/// Each kind with the fields it takes (`kind` and `note` always) and those it requires.
pub const KINDS: &[(&str, &[&str], &[&str])] = &[
    ("mandatory_downlinked", &["tiers"], &[]),
    ("no_stranded_samples", &[], &[]),
    ("decisional_at_next_downlink", &[], &[]),
    ("samples", &["min", "max"], &[]),
    ("utility", &["min", "max"], &[]),
    ("downlinks", &["min", "max"], &[]),
    ("sols", &["min", "max"], &[]),
    ("energy_left_wh", &["min", "max"], &[]),
    ("end", &["reason"], &["reason"]),
    ("site_order", &["order", "change"], &["order"]),
    ("max_samples_per_site", &["max", "change"], &["max"]),
    ("leaves_negative_sites", &[], &[]),
    ("holds_respected", &["min"], &[]),
    ("change_applied", &["change"], &["change"]),
];

const END_REASONS: &[&str] = &["done", "abandoned", "battery_exhausted", "mission_end"];
const TIERS: &[&str] = &["critical", "decisional", "mandatory", "residual"];

impl Expectation {
    fn given(&self) -> Vec<&'static str> {
        let mut g = Vec::new();
        if self.min.is_some() {
            g.push("min");
        }
        if self.max.is_some() {
            g.push("max");
        }
        if !self.order.is_empty() {
            g.push("order");
        }
        if self.change.is_some() {
            g.push("change");
        }
        if self.reason.is_some() {
            g.push("reason");
        }
        if !self.tiers.is_empty() {
            g.push("tiers");
        }
        g
    }
}

/// The errors of the expectations of a scenario with `mission` and `changes` ground changes.
pub fn validate(expect: &[Expectation], mission: &Mission, changes: usize) -> Vec<FieldError> {
    let mut e = Vec::new();
    for (i, x) in expect.iter().enumerate() {
        let at = format!("expect[{i}]");
        let Some(&(_, takes, requires)) = KINDS.iter().find(|k| k.0 == x.kind) else {
            e.push(FieldError {
                field: format!("{at}.kind"),
                message: format!(
                    "unknown expectation kind `{}` (known: {})",
                    x.kind,
                    KINDS.iter().map(|k| k.0).collect::<Vec<_>>().join(", ")
                ),
            });
            continue;
        };
        let given = x.given();
        for f in &given {
            if !takes.contains(f) {
                e.push(FieldError {
                    field: format!("{at}.{f}"),
                    message: format!(
                        "`{}` takes {}",
                        x.kind,
                        if takes.is_empty() {
                            "no fields but kind and note".to_string()
                        } else {
                            takes.join(", ")
                        }
                    ),
                });
            }
        }
        for f in requires {
            if !given.contains(f) {
                e.push(FieldError {
                    field: at.clone(),
                    message: format!("`{}` needs `{f}`", x.kind),
                });
            }
        }
        if let Some(r) = &x.reason {
            if !END_REASONS.contains(&r.as_str()) {
                e.push(FieldError {
                    field: format!("{at}.reason"),
                    message: format!("unknown end `{r}` (known: {})", END_REASONS.join(", ")),
                });
            }
        }
        for (k, t) in x.tiers.iter().enumerate() {
            if !TIERS.contains(&t.as_str()) {
                e.push(FieldError {
                    field: format!("{at}.tiers[{k}]"),
                    message: format!("unknown tier `{t}` (known: {})", TIERS.join(", ")),
                });
            }
        }
        for (k, &site) in x.order.iter().enumerate() {
            if site >= mission.sites {
                e.push(FieldError {
                    field: format!("{at}.order[{k}]"),
                    message: format!("no site {site}: the mission has {}", mission.sites),
                });
            }
        }
        if let Some(c) = x.change {
            if c >= changes {
                e.push(FieldError {
                    field: format!("{at}.change"),
                    message: format!("no ground change {c}: the scenario has {changes}"),
                });
            }
        }
        for (f, v) in [("min", x.min), ("max", x.max)] {
            if let Some(v) = v {
                if v.is_nan() || v < 0.0 {
                    e.push(FieldError {
                        field: format!("{at}.{f}"),
                        message: format!("{v} is not a non-negative number"),
                    });
                }
            }
        }
    }
    e
}

/// One expectation's result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Verdict {
    pub kind: String,
    pub note: String,
    pub passed: bool,
    /// What was found.
    pub detail: String,
}

fn tier_name(t: Tier) -> &'static str {
    match t {
        Tier::Critical => "critical",
        Tier::Decisional => "decisional",
        Tier::Mandatory => "mandatory",
        Tier::Residual => "residual",
    }
}

fn range(x: f64, e: &Expectation, what: &str) -> (bool, String) {
    let ok = e.min.is_none_or(|m| x >= m) && e.max.is_none_or(|m| x <= m);
    let bounds = match (e.min, e.max) {
        (Some(a), Some(b)) => format!("in {a}..={b}"),
        (Some(a), None) => format!(">= {a}"),
        (None, Some(b)) => format!("<= {b}"),
        (None, None) => "any".into(),
    };
    (ok, format!("{what} {x} (expected {bounds})"))
}

fn end_name(e: EndReason) -> &'static str {
    match e {
        EndReason::Done => "done",
        EndReason::Abandoned => "abandoned",
        EndReason::BatteryExhausted => "battery_exhausted",
        EndReason::MissionEnd => "mission_end",
    }
}

/// When ground change `c` took effect (`None`: never), or time 0 without a change.
fn since(r: &RunResult, c: Option<usize>) -> Option<u64> {
    match c {
        None => Some(0),
        Some(c) => r
            .changes
            .iter()
            .find(|a| a.index == c)
            .map(|a| a.applied_us),
    }
}

fn hours(us: u64) -> String {
    format!("{:.1} h", us as f64 / HOUR_US as f64)
}

/// Checks one expectation against a run of `s`.
pub fn check(e: &Expectation, s: &Scenario, r: &RunResult) -> Verdict {
    let (passed, detail) = match e.kind.as_str() {
        "mandatory_downlinked" => {
            let tiers: Vec<&str> = if e.tiers.is_empty() {
                vec!["critical", "mandatory"]
            } else {
                e.tiers.iter().map(String::as_str).collect()
            };
            let of: Vec<_> = r
                .products
                .iter()
                .filter(|p| tiers.contains(&tier_name(p.tier)))
                .collect();
            let missing: Vec<String> = of
                .iter()
                .filter(|p| p.received_us.is_none())
                .map(|p| format!("{} of {}", p.kind, hours(p.created_us)))
                .collect();
            (
                missing.is_empty(),
                if missing.is_empty() {
                    format!("{} {} product(s) on Earth", of.len(), tiers.join("/"))
                } else {
                    format!(
                        "{} of {} {} product(s) never reached Earth: {}",
                        missing.len(),
                        of.len(),
                        tiers.join("/"),
                        missing.join(", ")
                    )
                },
            )
        }
        "no_stranded_samples" => {
            let stranded: Vec<String> = r
                .collections
                .iter()
                .filter(|c| {
                    !r.products.iter().any(|p| {
                        p.kind == "ScienceAnalyze"
                            && p.site == Some(c.site)
                            && p.target == Some(c.target)
                            && p.received_us.is_some()
                    })
                })
                .map(|c| format!("({}, {}) at {}", c.site, c.target, hours(c.at_us)))
                .collect();
            (
                stranded.is_empty(),
                if stranded.is_empty() {
                    format!(
                        "all {} sample(s) collected have their analysis on Earth",
                        r.collections.len()
                    )
                } else {
                    format!(
                        "{} sample(s) collected without their analysis reaching Earth: {}",
                        stranded.len(),
                        stranded.join(", ")
                    )
                },
            )
        }
        "decisional_at_next_downlink" => {
            let light = s.comms.light_time_min * 60_000_000;
            let decisional: Vec<_> = r
                .products
                .iter()
                .filter(|p| p.tier == Tier::Decisional)
                .collect();
            let late: Vec<String> = decisional
                .iter()
                .filter(|p| {
                    let next = r
                        .downlinks
                        .iter()
                        .find(|d| d.start_us >= p.created_us && d.end_us > d.start_us);
                    match (next, p.received_us) {
                        (Some(d), Some(got)) => got != d.end_us + light,
                        (Some(_), None) => true,
                        // No downlink after it: nothing to be late for.
                        (None, _) => false,
                    }
                })
                .map(|p| format!("{} of {}", p.kind, hours(p.created_us)))
                .collect();
            (
                late.is_empty(),
                if late.is_empty() {
                    format!(
                        "{} decisional product(s), each in the next downlink",
                        decisional.len()
                    )
                } else {
                    format!(
                        "{} of {} decisional product(s) missed the next downlink: {}",
                        late.len(),
                        decisional.len(),
                        late.join(", ")
                    )
                },
            )
        }
        "samples" => range(f64::from(r.samples_analyzed), e, "samples analysed"),
        "utility" => range(r.utility_milli as f64 / 1_000.0, e, "utility"),
        "downlinks" => range(r.downlinks.len() as f64, e, "downlinks"),
        "sols" => range(
            ((r.end_us as f64 / SOL_US as f64) * 10.0).round() / 10.0,
            e,
            "sols",
        ),
        "energy_left_wh" => range((r.battery_end_mj / WH_MJ) as f64, e, "energy left (Wh)"),
        "end" => {
            let got = end_name(r.end);
            let want = e.reason.as_deref().unwrap_or("");
            (got == want, format!("ended {got} (expected {want})"))
        }
        "site_order" => match since(r, e.change) {
            None => (false, "the ground change never took effect".into()),
            Some(t0) => {
                let sites: Vec<u8> = r
                    .collections
                    .iter()
                    .filter(|c| c.at_us >= t0)
                    .map(|c| c.site)
                    .collect();
                let pos = |site: u8| e.order.iter().position(|&o| o == site);
                let mut last = 0usize;
                let mut ok = !sites.is_empty();
                for &site in &sites {
                    match pos(site) {
                        Some(p) if p >= last => last = p,
                        _ => ok = false,
                    }
                }
                (
                    ok,
                    format!(
                        "sites sampled{}: {:?} (expected the order {:?})",
                        if e.change.is_some() {
                            format!(" from {}", hours(t0))
                        } else {
                            String::new()
                        },
                        sites,
                        e.order
                    ),
                )
            }
        },
        "max_samples_per_site" => match since(r, e.change) {
            None => (false, "the ground change never took effect".into()),
            Some(t0) => {
                let max = e.max.unwrap_or(0.0);
                let mut touched: Vec<u8> = r
                    .collections
                    .iter()
                    .filter(|c| c.at_us >= t0)
                    .map(|c| c.site)
                    .collect();
                touched.sort_unstable();
                touched.dedup();
                let counts: Vec<(u8, usize)> = touched
                    .iter()
                    .map(|&site| {
                        (
                            site,
                            r.collections.iter().filter(|c| c.site == site).count(),
                        )
                    })
                    .collect();
                (
                    counts.iter().all(|&(_, n)| n as f64 <= max),
                    format!("samples per site sampled (site, count): {counts:?} (at most {max})"),
                )
            }
        },
        "leaves_negative_sites" => {
            let bad: Vec<String> = r
                .collections
                .iter()
                .filter(|c| {
                    r.analyses
                        .iter()
                        .any(|a| a.site == c.site && a.positive == Some(false) && a.at_us < c.at_us)
                })
                .map(|c| format!("({}, {}) at {}", c.site, c.target, hours(c.at_us)))
                .collect();
            let negatives = r
                .analyses
                .iter()
                .filter(|a| a.positive == Some(false))
                .count();
            (
                bad.is_empty(),
                if bad.is_empty() {
                    format!("{negatives} negative result(s); no site sampled after one")
                } else {
                    format!("sampled after a negative at the site: {}", bad.join(", "))
                },
            )
        }
        "holds_respected" => {
            let min = e.min.unwrap_or(1.0);
            (
                r.hold_violations == 0 && f64::from(r.holds_released) >= min,
                format!(
                    "{} hold(s) set, {} released by uplinks, {} primitive(s) run during a hold (expected none, and at least {min} released)",
                    r.holds_set, r.holds_released, r.hold_violations
                ),
            )
        }
        "change_applied" => {
            let c = e.change.unwrap_or(usize::MAX);
            match r.changes.iter().find(|a| a.index == c) {
                Some(a) => (
                    true,
                    format!(
                        "ground change {c} decided at {}, on board at {}, in effect at {}",
                        hours(a.decided_us),
                        hours(a.arrived_us),
                        hours(a.applied_us)
                    ),
                ),
                None => (false, format!("ground change {c} never took effect")),
            }
        }
        other => (false, format!("unknown expectation kind `{other}`")),
    };
    Verdict {
        kind: e.kind.clone(),
        note: e.note.clone(),
        passed,
        detail,
    }
}

/// Every expectation of `s` against `r`.
pub fn check_all(s: &Scenario, r: &RunResult) -> Vec<Verdict> {
    s.expect.iter().map(|e| check(e, s, r)).collect()
}

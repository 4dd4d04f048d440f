//! Timing and memory budgets (`budgets.toml`), measured on the emulated target in guest ticks
//! or instructions under icount (identical run to run), and checked by `hil bench`.
//!
//! Each budget names its quantity, unit, limit and where the measurement comes from:
//! - `mission:<scenario>:<metric>`: run a mission scenario (relative to the repository) on the
//!   emulated target and take one of its metrics (`max_reset_recovery_instructions`,
//!   `max_boot_to_ready_ticks_power_on`, `max_planner_ticks`, `max_step_ticks`, ...; see
//!   `mission::record::MissionRecord::metrics`);
//! - `kernel:<metric>`: the kernel benchmark (`hil bench kernel`): partition switch, syscall
//!   round trip, frame processing, footprints;
//! - `elf:<section-prefix>[+<prefix>...]`: bytes of the firmware ELF's sections whose names
//!   start with the prefixes (static memory);
//! - `plan:<domain.pddl>:<problem.pddl>`: the guest instructions the temporal planner takes on
//!   that task in the emulated target's planner partition (`hil plan --emulated`), to the
//!   search's plan; `plan-elimination:<domain.pddl>:<problem.pddl>`: those the action
//!   elimination after the search takes to improve that plan, apart;
//! - `rover:<scenario>:<metric>`: a rover mission flown by the emulated target (`hil rover run
//!   --emulated`), one of its onboard costs in guest instructions ([`crate::rover::OnboardCosts`]:
//!   `max_poll_instructions`, `max_build_instructions`, `max_network_instructions`).
//!
//! A budget is raised only by editing `budgets.toml`, so every raise shows in review. The last
//! accepted measurements live in `budgets-baseline.toml` (`hil bench --save-baseline`), so the
//! table shows the change a patch makes.
use std::collections::BTreeMap;
use std::path::Path;

use crate::diag::{Diagnostic, SourceFile};
use object::{Object, ObjectSection, ObjectSymbol};
use serde::{Deserialize, Serialize};
use toml::Spanned;

/// Unit of a budget.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Unit {
    /// Timebase ticks (16.6 MHz on g3beige).
    Ticks,
    /// Guest instructions (4 ns each under `-icount shift=2`).
    Instructions,
    Bytes,
}

impl Unit {
    pub fn name(self) -> &'static str {
        match self {
            Unit::Ticks => "ticks",
            Unit::Instructions => "instructions",
            Unit::Bytes => "bytes",
        }
    }
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BudgetSpec {
    pub quantity: String,
    pub unit: Unit,
    pub max: u64,
    pub source: String,
    /// The goal for the quantity, where it has one and it differs from the budget (a
    /// goal not reached is reported with the measured number; it is never lowered).
    #[serde(default)]
    pub goal: Option<u64>,
    #[serde(default)]
    pub description: String,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct BudgetFile {
    #[serde(rename = "budget")]
    budgets: Vec<Spanned<BudgetSpec>>,
}

/// Where a measurement comes from.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Source {
    Mission {
        scenario: String,
        metric: String,
    },
    Kernel {
        metric: String,
    },
    Elf {
        section_prefix: String,
    },

    /// The guest instructions the temporal planner takes on a PDDL task in the emulated
    /// target's planner partition (`hil plan --emulated`).
    Plan {
        domain: String,
        problem: String,
    },
    /// The guest instructions of the action elimination after the search on that task
    /// (`hil plan --emulated --json`'s `elimination_instructions`).
    PlanElimination {
        domain: String,
        problem: String,
    },
    /// A lander mission with its executor on the emulated target
    /// ([`crate::lander_emulated::lander_metrics`]).
    Lander {
        scenario: String,
        metric: String,
    },
    /// A rover mission decided by the emulated target ([`crate::rover::onboard_metric`]).
    Rover {
        scenario: String,
        metric: String,
    },
    /// Bytes of the firmware ELF's symbols whose (demangled) paths start with one of the
    /// `+`-separated prefixes.
    Symbols {
        prefix: String,
    },
}

impl Source {
    pub fn parse(text: &str) -> Result<Self, String> {
        // A symbol path has colons of its own.
        if let Some(prefix) = text.strip_prefix("sym:").filter(|p| !p.is_empty()) {
            return Ok(Source::Symbols {
                prefix: prefix.into(),
            });
        }
        let mut parts = text.splitn(3, ':');
        match (parts.next(), parts.next(), parts.next()) {
            (Some("mission"), Some(scenario), Some(metric)) if !scenario.is_empty() && !metric.is_empty() => {
                Ok(Source::Mission {
                    scenario: scenario.into(),
                    metric: metric.into(),
                })
            }
            (Some("kernel"), Some(metric), None) if !metric.is_empty() => Ok(Source::Kernel {
                metric: metric.into(),
            }),
            (Some("elf"), Some(prefix), None) if !prefix.is_empty() => Ok(Source::Elf {
                section_prefix: prefix.into(),
            }),

            (Some("plan"), Some(domain), Some(problem))
                if !domain.is_empty() && !problem.is_empty() =>
            {
                Ok(Source::Plan {
                    domain: domain.into(),
                    problem: problem.into(),
                })
            }
            (Some("plan-elimination"), Some(domain), Some(problem))
                if !domain.is_empty() && !problem.is_empty() =>
            {
                Ok(Source::PlanElimination {
                    domain: domain.into(),
                    problem: problem.into(),
                })
            }
            (Some("lander"), Some(scenario), Some(metric))
                if !scenario.is_empty() && !metric.is_empty() =>
            {
                Ok(Source::Lander {
                    scenario: scenario.into(),
                    metric: metric.into(),
                })
            }
            (Some("rover"), Some(scenario), Some(metric))
                if !scenario.is_empty() && !metric.is_empty() =>
            {
                Ok(Source::Rover {
                    scenario: scenario.into(),
                    metric: metric.into(),
                })
            }
            _ => Err(format!(
                "source {text:?}: expected mission:<scenario>:<metric>, kernel:<metric>, elf:<section-prefix>, plan:<domain.pddl>:<problem.pddl>, lander:<scenario>:<metric>, rover:<scenario>:<metric> or sym:<path-prefix>"
            )),
        }
    }
}

/// A budget file that could not be used: a [`Diagnostic`] at the offending entry.
pub type BudgetError = Diagnostic;

/// A checked budget.
#[derive(Clone, Debug)]
pub struct Budget {
    pub spec: BudgetSpec,
    pub source: Source,
}

/// Read and check `budgets.toml`.
pub fn load(path: &Path) -> Result<Vec<Budget>, BudgetError> {
    let src = SourceFile::read(path)?;
    let file: BudgetFile = toml::from_str(&src.text).map_err(|e| src.toml_error(&e, ""))?;
    let mut seen = BTreeMap::new();
    let mut out = Vec::new();
    for (i, b) in file.budgets.into_iter().enumerate() {
        let field = |f: &str| format!("budget[{i}].{f}");
        let spec = b.into_inner();
        if let Some(first) = seen.insert(spec.quantity.clone(), i) {
            return Err(src.error_at(
                &field("quantity"),
                format!(
                    "quantity {:?} has a budget already (budget[{first}])",
                    spec.quantity
                ),
            ));
        }
        let source = Source::parse(&spec.source).map_err(|m| src.error_at(&field("source"), m))?;
        if let Source::Mission { metric, .. } = &source {
            if crate::mission::metrics::lookup(metric).is_none() {
                return Err(src.error_at(
                    &field("source"),
                    format!(
                        "no mission metric named {metric:?} (metrics: {})",
                        crate::mission::metrics::names().join(", ")
                    ),
                ));
            }
        }
        out.push(Budget { spec, source });
    }
    Ok(out)
}

/// Measured values, by source.
pub type Measurements = BTreeMap<Source, u64>;

/// One row of the `hil bench` table.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub quantity: String,
    pub unit: Unit,
    pub measured: Option<u64>,
    pub budget: u64,
    /// (budget - measured) / budget, in percent; negative when over budget.
    pub headroom_percent: Option<f64>,
    pub baseline: Option<u64>,
    /// (measured - baseline) / baseline, in percent.
    pub change_percent: Option<f64>,
    pub over_budget: bool,
    /// The goal beside the budget, where it has one.
    pub goal: Option<u64>,
    pub description: String,
    /// Why it could not be measured.
    pub missing: Option<String>,
}

/// Compare measurements with budgets and the baseline.
pub fn evaluate(
    budgets: &[Budget],
    measured: &Measurements,
    missing: &BTreeMap<Source, String>,
    baseline: &BTreeMap<String, u64>,
) -> Vec<Row> {
    budgets
        .iter()
        .map(|b| {
            let value = measured.get(&b.source).copied();
            let base = baseline.get(&b.spec.quantity).copied();
            Row {
                quantity: b.spec.quantity.clone(),
                unit: b.spec.unit,
                measured: value,
                budget: b.spec.max,
                headroom_percent: value
                    .map(|v| (b.spec.max as f64 - v as f64) / (b.spec.max.max(1) as f64) * 100.0),
                baseline: base,
                change_percent: match (value, base) {
                    (Some(v), Some(b)) if b > 0 => Some((v as f64 - b as f64) / b as f64 * 100.0),
                    _ => None,
                },
                over_budget: value.is_some_and(|v| v > b.spec.max),
                goal: b.spec.goal,
                description: b.spec.description.clone(),
                missing: if value.is_none() {
                    Some(
                        missing
                            .get(&b.source)
                            .cloned()
                            .unwrap_or_else(|| "not measured".into()),
                    )
                } else {
                    None
                },
            }
        })
        .collect()
}

/// The table, for people.
pub fn table(rows: &[Row]) -> String {
    let group = |v: u64| {
        let s = v.to_string();
        let mut out = String::new();
        for (i, c) in s.chars().enumerate() {
            if i > 0 && (s.len() - i).is_multiple_of(3) {
                out.push(',');
            }
            out.push(c);
        }
        out
    };
    let mut out = format!(
        "{:<28} {:>14} {:>14} {:<13} {:>9} {:>9}\n",
        "quantity", "measured", "budget", "unit", "headroom", "change"
    );
    for r in rows {
        out.push_str(&format!(
            "{:<28} {:>14} {:>14} {:<13} {:>9} {:>9}{}\n",
            r.quantity,
            r.measured.map(group).unwrap_or_else(|| "-".into()),
            group(r.budget),
            r.unit.name(),
            r.headroom_percent
                .map(|h| format!("{h:.1}%"))
                .unwrap_or_else(|| "-".into()),
            r.change_percent
                .map(|c| format!("{c:+.1}%"))
                .unwrap_or_else(|| "-".into()),
            if r.over_budget {
                "  OVER BUDGET".to_string()
            } else if let Some(m) = &r.missing {
                format!("  NOT MEASURED: {m}")
            } else {
                String::new()
            }
        ));
    }
    // The issues' goals where a budget has one beside it: reached or not.
    for r in rows {
        if let (Some(goal), Some(v)) = (r.goal, r.measured) {
            out.push_str(&format!(
                "goal {}: {} of {} {}: {}\n",
                r.quantity,
                group(v),
                group(goal),
                r.unit.name(),
                if v <= goal { "met" } else { "NOT MET" }
            ));
        }
    }
    out
}

/// The offenders, named: over budget, or not measured at all.
pub fn offenders(rows: &[Row]) -> Vec<String> {
    rows.iter()
        .filter_map(|r| {
            if r.over_budget {
                Some(format!(
                    "{}: {} {} measured, budget {}",
                    r.quantity,
                    r.measured.unwrap_or(0),
                    r.unit.name(),
                    r.budget
                ))
            } else {
                r.missing
                    .as_ref()
                    .map(|m| format!("{}: not measured ({m})", r.quantity))
            }
        })
        .collect()
}

/// Read `budgets-baseline.toml` (`quantity = value` lines); empty when absent.
pub fn load_baseline(path: &Path) -> Result<BTreeMap<String, u64>, String> {
    match std::fs::read_to_string(path) {
        Ok(text) => toml::from_str(&text).map_err(|e| format!("{}: {e}", path.display())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(BTreeMap::new()),
        Err(e) => Err(format!("{}: {e}", path.display())),
    }
}

/// Write the measurements as the new baseline.
pub fn save_baseline(path: &Path, rows: &[Row]) -> Result<(), String> {
    let mut text = String::from(
        "# Measurements accepted as the baseline for `hil bench` (written by `hil bench --save-baseline`).\n",
    );
    for r in rows {
        if let Some(v) = r.measured {
            text.push_str(&format!("{} = {v}\n", r.quantity));
        }
    }
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

/// Static memory from the firmware ELF: bytes of the symbols whose demangled paths start with
/// one of the `+`-separated prefixes (e.g. `task_planner::lander::`). Every prefix must match a
/// symbol.
pub fn elf_symbol_bytes(elf: &Path, prefixes: &str) -> Result<u64, String> {
    let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let file = object::File::parse(&*bytes).map_err(|e| e.to_string())?;
    let mut total = 0;
    for prefix in prefixes.split('+') {
        let mut any = false;
        for s in file.symbols() {
            if s.name()
                .is_ok_and(|n| demangle_legacy(n).starts_with(prefix))
            {
                total += s.size();
                any = true;
            }
        }
        if !any {
            return Err(format!("no symbol starts with {prefix:?}"));
        }
    }
    Ok(total)
}

/// A legacy-mangled Rust symbol (`_ZN` length-prefixed segments `E`) as its path without the
/// hash (`task_planner::lander::EXECUTOR`); other names as they are.
pub fn demangle_legacy(name: &str) -> String {
    let Some(mut rest) = name.strip_prefix("_ZN") else {
        return name.to_string();
    };
    let mut parts = Vec::new();
    while let Some(len_end) = rest.find(|c: char| !c.is_ascii_digit()) {
        let Ok(len) = rest[..len_end].parse::<usize>() else {
            break;
        };
        let Some(seg) = rest.get(len_end..len_end + len) else {
            break;
        };
        parts.push(seg);
        rest = &rest[len_end + len..];
    }
    if parts
        .last()
        .is_some_and(|h| h.len() == 17 && h.starts_with('h'))
    {
        parts.pop();
    }
    parts.join("::")
}

/// Static memory from the firmware ELF: bytes of the sections whose names start with one of
/// the `+`-separated prefixes (e.g. `.kdata+.bss`). Every prefix must match a section.
pub fn elf_section_bytes(elf: &Path, prefixes: &str) -> Result<u64, String> {
    let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let file = object::File::parse(&*bytes).map_err(|e| e.to_string())?;
    let mut total = 0;
    for prefix in prefixes.split('+') {
        let mut any = false;
        for s in file.sections() {
            if s.name().is_ok_and(|n| n.starts_with(prefix)) {
                total += s.size();
                any = true;
            }
        }
        if !any {
            return Err(format!("no section named {prefix}* in {}", elf.display()));
        }
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn budgets(text: &str) -> Result<Vec<Budget>, String> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("budgets.toml");
        std::fs::write(&p, text).unwrap();
        load(&p).map_err(|e| {
            e.to_string()
                .replace(&p.display().to_string(), "budgets.toml")
        })
    }

    #[test]
    fn sources_parse_and_bad_ones_are_named() {
        assert_eq!(
            Source::parse("mission:scenarios/a.toml:max_step_ticks").unwrap(),
            Source::Mission {
                scenario: "scenarios/a.toml".into(),
                metric: "max_step_ticks".into()
            }
        );
        assert!(Source::parse("kernel:").is_err());
        assert_eq!(
            Source::parse("plan:d/domain.pddl:d/instance-2.pddl").unwrap(),
            Source::Plan {
                domain: "d/domain.pddl".into(),
                problem: "d/instance-2.pddl".into()
            }
        );
        assert!(Source::parse("plan:d/domain.pddl").is_err());
        assert_eq!(
            Source::parse("plan-elimination:d/domain.pddl:d/instance-2.pddl").unwrap(),
            Source::PlanElimination {
                domain: "d/domain.pddl".into(),
                problem: "d/instance-2.pddl".into()
            }
        );
        assert_eq!(
            Source::parse("rover:scenarios/rover/sahara-day.toml:max_build_instructions").unwrap(),
            Source::Rover {
                scenario: "scenarios/rover/sahara-day.toml".into(),
                metric: "max_build_instructions".into()
            }
        );
        assert!(Source::parse("wall:clock")
            .unwrap_err()
            .contains("expected"));
    }

    #[test]
    fn a_budget_file_with_a_mistake_names_the_line() {
        let e = budgets("[[budget]]\nquantity = \"a\"\nunit = \"ticks\"\nmax = 5\nsource = \"kernel:x\"\n\n[[budget]]\nquantity = \"a\"\nunit = \"ticks\"\nmax = 5\nsource = \"kernel:y\"\n").unwrap_err();
        assert!(
            e.starts_with(
                "budgets.toml:8:12: budget[1].quantity: quantity \"a\" has a budget already (budget[0])"
            ),
            "{e}"
        );
        let e = budgets(
            "[[budget]]\nquantity = \"a\"\nunit = \"seconds\"\nmax = 5\nsource = \"kernel:x\"\n",
        )
        .unwrap_err();
        assert!(e.starts_with("budgets.toml:3:"), "{e}");
    }

    #[test]
    fn over_budget_and_unmeasured_quantities_are_offenders_with_headroom_and_change() {
        let b = budgets("[[budget]]\nquantity = \"fast\"\nunit = \"ticks\"\nmax = 100\nsource = \"kernel:a\"\n[[budget]]\nquantity = \"slow\"\nunit = \"ticks\"\nmax = 100\nsource = \"kernel:b\"\n[[budget]]\nquantity = \"gone\"\nunit = \"bytes\"\nmax = 1\nsource = \"kernel:c\"\n").unwrap();
        let mut m = Measurements::new();
        m.insert(Source::Kernel { metric: "a".into() }, 80);
        m.insert(Source::Kernel { metric: "b".into() }, 120);
        let baseline = BTreeMap::from([("fast".to_string(), 100u64)]);
        let rows = evaluate(&b, &m, &BTreeMap::new(), &baseline);
        assert_eq!(rows[0].headroom_percent, Some(20.0));
        assert_eq!(rows[0].change_percent, Some(-20.0));
        assert!(!rows[0].over_budget);
        assert!(rows[1].over_budget);
        let off = offenders(&rows);
        assert_eq!(off.len(), 2, "{off:?}");
        assert!(off[0].starts_with("slow: 120 ticks measured, budget 100"));
        assert!(off[1].starts_with("gone: not measured"));
        assert!(table(&rows).contains("OVER BUDGET"));
    }

    #[test]
    fn goals_lander_and_symbol_sources_parse_and_a_goal_is_reported_met_or_not() {
        let b = budgets("[[budget]]\nquantity = \"plan\"\nunit = \"instructions\"\nmax = 100\ngoal = 50\nsource = \"lander:scenarios/lander/rsm-1.toml:first_plan_instructions\"\n[[budget]]\nquantity = \"ram\"\nunit = \"bytes\"\nmax = 100\ngoal = 90\nsource = \"sym:task_planner::lander::EXECUTOR+task_planner::lander::APP\"\n").unwrap();
        assert_eq!(
            b[0].source,
            Source::Lander {
                scenario: "scenarios/lander/rsm-1.toml".into(),
                metric: "first_plan_instructions".into()
            }
        );
        assert_eq!(
            b[1].source,
            Source::Symbols {
                prefix: "task_planner::lander::EXECUTOR+task_planner::lander::APP".into()
            }
        );
        let mut m = Measurements::new();
        m.insert(b[0].source.clone(), 70);
        m.insert(b[1].source.clone(), 80);
        let t = table(&evaluate(&b, &m, &BTreeMap::new(), &BTreeMap::new()));
        assert!(
            t.contains("goal plan: 70 of 50 instructions: NOT MET"),
            "{t}"
        );
        assert!(t.contains("goal ram: 80 of 90 bytes: met"), "{t}");
        assert!(Source::parse("sym:").is_err());
        assert!(Source::parse("lander:x.toml").is_err());
    }

    #[test]
    fn legacy_symbols_demangle_to_their_paths() {
        assert_eq!(
            demangle_legacy("_ZN12task_planner6lander8EXECUTOR17h0123456789abcdefE"),
            "task_planner::lander::EXECUTOR"
        );
        assert_eq!(demangle_legacy("memcpy"), "memcpy");
    }
}

/// Run whatever the budgets need and collect the measurements: each mission scenario once on
/// the emulated target, the kernel benchmark once, the ELF sections of `firmware`.
pub fn measure(
    budgets: &[Budget],
    firmware: &crate::firmware::FirmwareImage,
    progress: &mut dyn FnMut(&str),
) -> (Measurements, BTreeMap<Source, String>) {
    let mut measured = Measurements::new();
    let mut missing = BTreeMap::new();
    let mut scenarios: Vec<&str> = budgets
        .iter()
        .filter_map(|b| match &b.source {
            Source::Mission { scenario, .. } => Some(scenario.as_str()),
            _ => None,
        })
        .collect();
    scenarios.sort();
    scenarios.dedup();
    for scenario in scenarios {
        progress(&format!("measuring: {scenario} on the emulated target"));
        let sources: Vec<&Source> = budgets
            .iter()
            .map(|b| &b.source)
            .filter(|s| matches!(s, Source::Mission { scenario: sc, .. } if sc == scenario))
            .collect();
        match run_mission_metrics(scenario, firmware) {
            Ok(metrics) => {
                for s in sources {
                    let Source::Mission { metric, .. } = s else {
                        continue;
                    };
                    match metrics.get(metric) {
                        Some(v) => {
                            measured.insert(s.clone(), *v);
                        }
                        None => {
                            missing.insert(
                                s.clone(),
                                format!("{scenario} reported no metric {metric:?}"),
                            );
                        }
                    }
                }
            }
            Err(e) => {
                for s in sources {
                    missing.insert(s.clone(), format!("{scenario}: {e}"));
                }
            }
        }
    }
    let kernel: Vec<&Source> = budgets
        .iter()
        .map(|b| &b.source)
        .filter(|s| matches!(s, Source::Kernel { .. }))
        .collect();
    if !kernel.is_empty() {
        progress("measuring: kernel benchmark on the emulated target");
        match kernel_metrics(firmware) {
            Ok(metrics) => {
                for s in kernel {
                    let Source::Kernel { metric } = s else {
                        continue;
                    };
                    match metrics.get(metric) {
                        Some(v) => {
                            measured.insert(s.clone(), *v);
                        }
                        None => {
                            missing.insert(
                                s.clone(),
                                format!("the kernel benchmark has no {metric:?}"),
                            );
                        }
                    }
                }
            }
            Err(e) => {
                for s in kernel {
                    missing.insert(s.clone(), e.clone());
                }
            }
        }
    }
    let mut landers: Vec<&str> = budgets
        .iter()
        .filter_map(|b| match &b.source {
            Source::Lander { scenario, .. } => Some(scenario.as_str()),
            _ => None,
        })
        .collect();
    landers.sort();
    landers.dedup();
    for scenario in landers {
        progress(&format!(
            "measuring: lander {scenario} with its executor on the emulated target"
        ));
        let metrics = crate::lander_emulated::lander_metrics(scenario, firmware);
        for b in budgets {
            let Source::Lander {
                scenario: sc,
                metric,
            } = &b.source
            else {
                continue;
            };
            if sc != scenario {
                continue;
            }
            match metrics.as_ref().map(|m| m.get(metric)) {
                Ok(Some(v)) => {
                    measured.insert(b.source.clone(), *v);
                }
                Ok(None) => {
                    missing.insert(
                        b.source.clone(),
                        format!("{scenario} reported no lander metric {metric:?}"),
                    );
                }
                Err(e) => {
                    missing.insert(b.source.clone(), format!("{scenario}: {e}"));
                }
            }
        }
    }
    // One run a task for both its measures (to the search's plan, and the elimination's).
    let mut plans: BTreeMap<(String, String), Result<(u64, u64), String>> = BTreeMap::new();
    for b in budgets {
        let (domain, problem, elimination) = match &b.source {
            Source::Plan { domain, problem } => (domain, problem, false),
            Source::PlanElimination { domain, problem } => (domain, problem, true),
            _ => continue,
        };
        let got = plans
            .entry((domain.clone(), problem.clone()))
            .or_insert_with(|| {
                progress(&format!(
                    "measuring: hil plan --emulated {domain} {problem}"
                ));
                plan_instructions(domain, problem, firmware)
            })
            .clone();
        match got {
            Ok((search, elim)) => {
                measured.insert(b.source.clone(), if elimination { elim } else { search });
            }
            Err(e) => {
                missing.insert(b.source.clone(), e);
            }
        }
    }
    for b in budgets {
        if let Source::Rover { scenario, metric } = &b.source {
            progress(&format!("measuring: hil rover run {scenario} --emulated"));
            match crate::rover::onboard_metric(scenario, metric, firmware) {
                Ok(v) => {
                    measured.insert(b.source.clone(), v);
                }
                Err(e) => {
                    missing.insert(b.source.clone(), e);
                }
            }
        }
    }
    for b in budgets {
        if let Source::Symbols { prefix } = &b.source {
            match elf_symbol_bytes(&firmware.elf, prefix) {
                Ok(v) => {
                    measured.insert(b.source.clone(), v);
                }
                Err(e) => {
                    missing.insert(b.source.clone(), e);
                }
            }
        }
        if let Source::Elf { section_prefix } = &b.source {
            match elf_section_bytes(&firmware.elf, section_prefix) {
                Ok(v) => {
                    measured.insert(b.source.clone(), v);
                }
                Err(e) => {
                    missing.insert(b.source.clone(), e);
                }
            }
        }
    }
    (measured, missing)
}

fn run_mission_metrics(
    scenario: &str,
    firmware: &crate::firmware::FirmwareImage,
) -> Result<BTreeMap<String, u64>, String> {
    use crate::mission::runner;
    let path = crate::repo_root().join(scenario);
    let prepared = runner::prepare(&path).map_err(|e| e.to_string())?;
    let options = crate::options::RunOptions {
        firmware: Some(firmware.elf.clone()),
        ..Default::default()
    };
    let (mut target, fw) = runner::make_target(&prepared, &options, &mut |_| {})?;
    let report = runner::run(&prepared, target.as_mut(), fw.as_ref(), &mut |_, _, _| {})
        .map_err(|e| e.to_string())?;
    if !report.passed {
        return Err(format!(
            "the scenario failed, so its costs are not representative:\n{}",
            crate::mission::report::summary(&report)
        ));
    }
    Ok(report.metrics)
}

/// The guest instructions the emulated target's planner partition takes to plan `problem`
/// (paths relative to the repository) with `hil plan`'s default search, to the search's plan
/// and for the action elimination after it; an unsolved task is an error (its cost is not
/// representative).
fn plan_instructions(
    domain: &str,
    problem: &str,
    firmware: &crate::firmware::FirmwareImage,
) -> Result<(u64, u64), String> {
    let root = crate::repo_root();
    let options = crate::plan::PlanOptions::default();
    let (_, _, compiled, _) = crate::plan::compile_files(
        &root.join(domain),
        &root.join(problem),
        &pddl::ModuleRegistry::new(),
        &options,
    )
    .map_err(|e| e.render())?;
    let mut target = crate::plan_emulated::EmulatedPlanner::boot(firmware)?;
    let report = target
        .plan(&compiled, &options, 20_000)
        .map_err(|e| e.to_string())?;
    if !report.solved {
        return Err(format!("{problem}: not solved ({})", report.outcome));
    }
    report
        .emulated
        .map(|e| (e.guest_instructions, e.elimination_instructions))
        .ok_or_else(|| "no guest costs in the report".into())
}

/// The kernel benchmark's metrics by name. Provided by the kernel benchmark module when the
/// image has one.
fn kernel_metrics(
    firmware: &crate::firmware::FirmwareImage,
) -> Result<BTreeMap<String, u64>, String> {
    crate::bench::kernel_metrics(firmware)
}

/// What `hil bench` found.
#[derive(Clone, Debug, Serialize)]
pub struct BenchOutcome {
    pub rows: Vec<Row>,
    /// Each quantity over budget or not measured, named; empty when every budget holds.
    pub offenders: Vec<String>,
}

/// `hil bench`: load the budgets, measure them on the emulated target, compare with the
/// baseline.
pub fn check(
    budgets_path: &Path,
    baseline_path: &Path,
    firmware: &crate::firmware::FirmwareImage,
    progress: &mut dyn FnMut(&str),
) -> Result<BenchOutcome, String> {
    let list = load(budgets_path).map_err(|e| e.to_string())?;
    let (measured, missing) = measure(&list, firmware, progress);
    let baseline = load_baseline(baseline_path)?;
    let rows = evaluate(&list, &measured, &missing, &baseline);
    let offenders = offenders(&rows);
    Ok(BenchOutcome { rows, offenders })
}

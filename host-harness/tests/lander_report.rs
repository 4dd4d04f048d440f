//! The long-mission report (`hil lander run FILE --report DIR`, issue 12 item 5) over every
//! shipped lander mission (BSM-1, RSM-1, the ELAP scenarios), each strategy and a few seeds:
//! the trace decides nothing; the HTML and SVG are well-formed XML; the utility timeline rises
//! only at downlinks; each downlink's tiers sum to its volume; the battery timeline ends at the
//! run's charge; the Gantt chart has every dispatch; and the command writes the files with no
//! progress bar in its output when it is not on a terminal.
use std::path::{Path, PathBuf};
use std::process::Command;

use hil::study::load_scenario;
use lander_sim::report::{self, LanderReport};
use lander_sim::scenario::{Scenario, StrategyName};
use lander_sim::sim::trace::run_traced;
use lander_sim::sim::{self, EndReason, RunConfig, RunResult};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// BSM-1, RSM-1 and every ELAP scenario.
fn shipped() -> Vec<(PathBuf, Scenario)> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(repo().join("scenarios/lander/elap"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    files.push(repo().join("scenarios/lander/rsm-1.toml"));
    files.push(repo().join("scenarios/lander/bsm-1.toml"));
    let mut out: Vec<(PathBuf, Scenario)> = files
        .into_iter()
        .map(|p| {
            let s = load_scenario(&p).unwrap_or_else(|e| panic!("{}", e.render()));
            (p, s)
        })
        .collect();
    // And runs that end otherwise: RSM-1 cut short by its horizon (mid-plan, in a wait), and
    // with its battery emptied on sol 2.
    let rsm1 = out
        .iter()
        .find(|(p, _)| p.ends_with("rsm-1.toml"))
        .unwrap()
        .1
        .clone();
    let mut short = rsm1.clone();
    short.mission.sols = 4;
    out.push((PathBuf::from("rsm-1 (4 sols)"), short));
    let mut empty = rsm1;
    empty.power.drops.push(lander_sim::scenario::Drop {
        at_h: 100,
        wh: 0,
        to_soc: Some(0.001),
    });
    out.push((PathBuf::from("rsm-1 (battery emptied)"), empty));
    out
}

const STRATEGIES: [StrategyName; 4] = [
    StrategyName::Static,
    StrategyName::Ground,
    StrategyName::Fe,
    StrategyName::Replan,
];

type Runs = Vec<(String, RunResult, LanderReport)>;

/// Every (scenario, strategy, seed 1..=3) run with its report, made once for every test.
fn reports() -> &'static Runs {
    static RUNS: std::sync::OnceLock<Runs> = std::sync::OnceLock::new();
    RUNS.get_or_init(make_reports)
}

fn make_reports() -> Runs {
    let mut out = Vec::new();
    for (path, s) in shipped() {
        for strategy in STRATEGIES {
            for seed in 1..=3 {
                let config = RunConfig::new(strategy.strategy(), seed);
                let plain = sim::run(&s, &config).unwrap();
                let (traced, trace) = run_traced(&s, &config).unwrap();
                let name = format!("{} {strategy:?} seed {seed}", path.display());
                assert_eq!(plain, traced, "{name}: the trace changed the run");
                let r = LanderReport::new(&s, &format!("{strategy:?}"), traced, trace);
                out.push((name, plain, r));
            }
        }
    }
    out
}

/// Parses `text` as XML (end names checked): the number of elements with `class="{class}"`.
fn parse(text: &str, class: &str) -> Result<usize, String> {
    use quick_xml::events::Event;
    let mut reader = quick_xml::Reader::from_str(text);
    reader.config_mut().check_end_names = true;
    let mut depth = 0i64;
    let mut roots = 0;
    let mut count = 0;
    loop {
        let e = reader
            .read_event()
            .map_err(|e| format!("at {}: {e}", reader.buffer_position()))?;
        let element = match &e {
            Event::Start(x) | Event::Empty(x) => Some(x.clone()),
            _ => None,
        };
        if let Some(x) = element {
            if depth == 0 {
                roots += 1;
            }
            for a in x.attributes() {
                let a = a.map_err(|e| e.to_string())?;
                a.normalized_value(quick_xml::XmlVersion::default())
                    .map_err(|e| e.to_string())?;
                if a.key.as_ref() == b"class" && a.value.as_ref() == class.as_bytes() {
                    count += 1;
                }
            }
        }
        match e {
            Event::Start(_) => depth += 1,
            Event::End(_) => depth -= 1,
            Event::Text(t) => {
                t.decode().map_err(|e| e.to_string())?;
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if depth != 0 || roots != 1 {
        return Err(format!("{roots} root element(s), depth {depth} at the end"));
    }
    Ok(count)
}

#[test]
fn the_xml_checker_refuses_broken_documents() {
    assert_eq!(parse(r#"<svg><rect class="prim"/></svg>"#, "prim"), Ok(1));
    assert!(parse("<svg><g></svg>", "prim").is_err());
    assert!(parse("<svg>a & b</svg>", "prim").is_err());
    assert!(parse("<svg></svg><svg></svg>", "prim").is_err());
    assert!(parse("<svg><rect></svg>", "prim").is_err());
}

#[test]
fn the_report_is_well_formed_self_contained_and_covers_every_dispatch() {
    let all = reports();
    let (mut failures, mut retries, mut replans, mut halts) = (0, 0, 0, 0);
    for (name, result, r) in all {
        let html = report::html(r);
        parse(&html, "prim").unwrap_or_else(|e| panic!("{name}: report.html: {e}"));
        for needle in ["<script", " src=", " href=", "http://", "https://"] {
            let n = html.matches(needle).count();
            // The only URLs are the XML namespaces.
            let allowed = if needle == "http://" { 4 } else { 0 };
            assert!(
                n <= allowed,
                "{name}: {needle} in the report: not self-contained"
            );
        }
        let gantt = report::gantt_svg(r);
        let bars = parse(&gantt, "prim").unwrap_or_else(|e| panic!("{name}: Gantt: {e}"));
        // Every dispatch is a bar, the trace has every dispatch with its outcome.
        assert_eq!(bars, result.dispatched as usize, "{name}");
        assert_eq!(
            r.trace.primitives.len(),
            result.dispatched as usize,
            "{name}"
        );
        let completed = r
            .trace
            .primitives
            .iter()
            .filter(|p| p.result == "succeeded")
            .count();
        assert!(completed >= result.completed as usize, "{name}");
        let drawn = r
            .trace
            .primitives
            .iter()
            .filter(|p| p.failure.is_some())
            .count();
        assert_eq!(drawn as u32, result.failures.iter().sum::<u32>(), "{name}");
        for p in &r.trace.primitives {
            assert!(p.start_us <= p.end_us, "{name}: {p:?}");
        }
        // Retries, replans and ground halts: each marked.
        let marked_retries = r.trace.primitives.iter().filter(|p| p.retry).count();
        assert_eq!(marked_retries as u32, result.retries, "{name}");
        assert_eq!(parse(&gantt, "retry").unwrap(), marked_retries, "{name}");
        assert_eq!(r.trace.replans.len() as u32, result.replans, "{name}");
        assert_eq!(parse(&gantt, "replan").unwrap(), r.trace.replans.len());
        assert_eq!(
            r.trace.ground_halts.len() as u32,
            result.ground_halts,
            "{name}"
        );
        assert_eq!(parse(&gantt, "halt").unwrap(), r.trace.ground_halts.len());
        assert!(parse(&gantt, "earth").unwrap() > 0, "{name}: no Earth band");
        let timelines = report::timelines_svg(r);
        for class in ["battery", "onboard", "utility"] {
            assert_eq!(parse(&timelines, class), Ok(1), "{name}: {class}");
        }
        parse(&report::downlinks_svg(r), "tier").unwrap_or_else(|e| panic!("{name}: {e}"));
        failures += drawn;
        retries += marked_retries;
        replans += r.trace.replans.len();
        halts += r.trace.ground_halts.len();
    }
    // The runs exercise what is marked, and every way a run ends.
    assert!(failures > 0 && retries > 0 && replans > 0 && halts > 0);
    for end in [
        EndReason::Done,
        EndReason::MissionEnd,
        EndReason::BatteryExhausted,
        EndReason::Abandoned,
    ] {
        assert!(
            all.iter().any(|(_, r, _)| r.end == end),
            "no run ended {end:?}"
        );
    }
    assert!(all.len() >= 4 * 3 * 3);
}

#[test]
fn utility_rises_only_when_a_downlink_reaches_earth() {
    let mut rises = 0;
    for (name, result, r) in reports() {
        let receptions: Vec<u64> = result
            .downlinks
            .iter()
            .map(|d| d.end_us + r.trace.light_us)
            .collect();
        assert_eq!(r.utility[0].utility_milli, 0, "{name}");
        for w in r.utility.windows(2) {
            assert!(w[0].at_us < w[1].at_us, "{name}: {w:?}");
            assert!(
                w[0].utility_milli < w[1].utility_milli,
                "{name}: utility fell or stood at a point: {w:?}"
            );
            assert!(
                receptions.contains(&w[1].at_us),
                "{name}: utility rose at {} where no downlink reached Earth",
                w[1].at_us
            );
            rises += 1;
        }
        assert_eq!(
            r.utility.last().unwrap().utility_milli,
            result.utility_milli,
            "{name}"
        );
    }
    assert!(rises > 0);
}

#[test]
fn each_downlinks_tiers_sum_to_its_volume() {
    for (name, result, r) in reports() {
        assert_eq!(r.trace.downlinks.len(), result.downlinks.len(), "{name}");
        for (i, d) in r.trace.downlinks.iter().enumerate() {
            assert_eq!(d.index, i, "{name}");
            let record = &result.downlinks[i];
            assert_eq!(
                d.bytes_per_tier.iter().sum::<u64>(),
                record.bytes,
                "{name} #{i}"
            );
            assert_eq!(d.products_per_tier, record.per_tier, "{name} #{i}");
            assert_eq!(
                d.value_milli_per_tier.iter().sum::<u64>(),
                record.value_milli,
                "{name} #{i}"
            );
            assert_eq!((d.start_us, d.end_us), (record.start_us, record.end_us));
            let listed: u64 = d.products.iter().map(|p| p.bytes).sum();
            assert_eq!(listed, record.bytes, "{name} #{i}");
        }
        // And the CSV says the same.
        let csv = report::csv(r);
        let (_, downlinks) = csv.iter().find(|(n, _)| *n == "downlinks.csv").unwrap();
        for (line, record) in downlinks.lines().skip(1).zip(&result.downlinks) {
            let f: Vec<u64> = line.split(',').map(|x| x.parse().unwrap()).collect();
            let tiers: u64 = (0..4).map(|t| f[6 + 3 * t]).sum();
            assert_eq!(
                (f[4], tiers),
                (record.bytes, record.bytes),
                "{name}: {line}"
            );
        }
        assert_eq!(downlinks.lines().count(), result.downlinks.len() + 1);
    }
}

#[test]
fn the_battery_timeline_runs_from_the_start_charge_to_the_end_charge() {
    for (name, result, r) in reports() {
        let s = &r.trace.samples;
        assert_eq!(
            (s[0].at_us, s[0].battery_mj),
            (0, result.battery_start_mj),
            "{name}"
        );
        let last = s.last().unwrap();
        assert_eq!(
            (last.at_us, last.battery_mj),
            (result.end_us, result.battery_end_mj),
            "{name}"
        );
        for w in s.windows(2) {
            // (An exogenous drop is two points at its time.)
            assert!(w[0].at_us <= w[1].at_us, "{name}: {w:?}");
            // Non-rechargeable.
            assert!(w[1].battery_mj <= w[0].battery_mj, "{name}: {w:?}");
        }
    }
}

#[test]
fn hil_lander_run_writes_the_report_without_a_progress_bar_in_a_pipe() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("rep");
    let json = dir.path().join("run.json");
    let out = Command::new(env!("CARGO_BIN_EXE_hil"))
        .current_dir(repo())
        .args(["lander", "run", "scenarios/lander/rsm-1.toml", "--report"])
        .arg(&out_dir)
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stderr.trim().is_empty(), "stderr in a pipe: {stderr:?}");
    assert!(!stdout.contains("mission hours"), "{stdout}");
    assert!(stdout.contains("report: "), "{stdout}");
    for f in [
        "report.html",
        "report.json",
        "primitives.csv",
        "timeline.csv",
        "utility.csv",
        "downlinks.csv",
    ] {
        assert!(out_dir.join(f).is_file(), "{f} missing");
    }
    let html = std::fs::read_to_string(out_dir.join("report.html")).unwrap();
    parse(&html, "prim").unwrap();
    // The report's result is the run's (the same as --json's).
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("report.json")).unwrap())
            .unwrap();
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(report["result"], run["result"]);
    // And it reads back as a report: the trace has every dispatch.
    let back: LanderReport =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("report.json")).unwrap())
            .unwrap();
    assert_eq!(back.trace.primitives.len(), back.result.dispatched as usize);
    assert_eq!(back.trace.downlinks.len(), back.result.downlinks.len());
    assert_eq!(report::html(&back), html);
    let text = std::fs::read_to_string(&json).unwrap();
    assert!(!text.contains("mission hours"));
    // The help names the report.
    let help = Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(["lander", "run", "--help"])
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    assert!(
        help.contains("--report <DIR>") && help.contains("Gantt"),
        "{help}"
    );
}

#[test]
fn hil_study_shows_no_progress_bar_in_a_pipe() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("study.json");
    let out = Command::new(env!("CARGO_BIN_EXE_hil"))
        .current_dir(repo())
        .args(["study", "--runs", "1", "--json"])
        .arg(&json)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stderr.trim().is_empty(), "stderr in a pipe: {stderr:?}");
    assert!(
        !stdout.contains("runs\r") && !stdout.contains('\u{1b}'),
        "{stdout}"
    );
    let text = std::fs::read_to_string(&json).unwrap();
    assert!(!text.contains('\u{1b}'));
}

#[test]
fn an_exogenous_drop_is_a_step_at_its_time() {
    let mut s =
        load_scenario(&repo().join("scenarios/lander/elap/08-sudden-low-battery.toml")).unwrap();
    // The shipped drop (150 h) falls to a state of charge; add one of a fixed energy before.
    s.power.drops.push(lander_sim::scenario::Drop {
        at_h: 100,
        wh: 500,
        to_soc: None,
    });
    let hour = lander_sim::sim::HOUR_US;
    let to_mj = (s.mission.battery_wh as f64 * 3_600_000.0 * 0.1) as u64;
    let mut checked = 0;
    for strategy in STRATEGIES {
        let (result, trace) = run_traced(&s, &RunConfig::new(strategy.strategy(), 1)).unwrap();
        if result.end_us <= 150 * hour {
            // (Static abandons early.)
            continue;
        }
        checked += 1;
        let at = |t: u64| -> Vec<u64> {
            trace
                .samples
                .iter()
                .filter(|x| x.at_us == t)
                .map(|x| x.battery_mj)
                .collect()
        };
        // Two points at each drop's time: before and after (after a primitive's energy too
        // if one ended then).
        // 500 Wh: the step is at least the drop's.
        let first = at(100 * hour);
        assert_eq!(first.len(), 2, "{strategy:?}: {first:?}");
        assert!(
            first[0] - first[1] >= 500 * 3_600_000,
            "{strategy:?}: {first:?}"
        );
        // To 10%: from above to at most the charge it falls to.
        let second = at(150 * hour);
        assert_eq!(second.len(), 2, "{strategy:?}: {second:?}");
        assert!(
            second[0] > to_mj && second[1] <= to_mj,
            "{strategy:?}: {second:?}"
        );
    }
    assert!(checked >= 3, "only {checked} run(s) reached the drops");
}

#[test]
fn hil_lander_run_shows_its_progress_bar_on_a_terminal() {
    // util-linux `script` gives the command a terminal; skipped (and said so) without it.
    let probe = Command::new("script").arg("--version").output();
    if !probe.is_ok_and(|o| o.status.success()) {
        eprintln!("skipped: no util-linux `script` to run hil on a pseudo-terminal");
        return;
    }
    let hil = env!("CARGO_BIN_EXE_hil");
    let out = Command::new("script")
        .current_dir(repo())
        .args(["-qec"])
        .arg(format!(
            "{hil} lander run scenarios/lander/rsm-1.toml > /dev/null"
        ))
        .arg("/dev/null")
        .output()
        .unwrap();
    let terminal = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{terminal}");
    // The bar was drawn on stderr (the terminal), stdout went to /dev/null.
    assert!(terminal.contains("mission hours"), "{terminal:?}");
}

#[test]
fn a_recording_holds_only_the_run_made_while_it_is_in_force() {
    let s = load_scenario(&repo().join("scenarios/lander/rsm-1.toml")).unwrap();
    let config = RunConfig::new(StrategyName::Replan.strategy(), 2);
    let (_, a) = run_traced(&s, &config).unwrap();
    // Runs outside a recording are not recorded anywhere; the next recording starts empty.
    for seed in 3..6 {
        sim::run(&s, &RunConfig::new(StrategyName::Fe.strategy(), seed)).unwrap();
    }
    let (_, b) = run_traced(&s, &config).unwrap();
    let json = |t: &lander_sim::sim::trace::Trace| serde_json::to_string(t).unwrap();
    assert_eq!(json(&a), json(&b));
    assert!(!a.primitives.is_empty());
    // Nested: the inner run goes to the inner recording, the outer one gets nothing of it.
    let outer = lander_sim::sim::trace::Recording::start(lander_sim::sim::trace::Trace::new(&s));
    let (_, inner) = run_traced(&s, &config).unwrap();
    let outer = outer.finish();
    assert_eq!(json(&inner), json(&a));
    assert!(outer.primitives.is_empty() && outer.samples.is_empty());
}

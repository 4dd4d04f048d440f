//! Reports for long lander missions (issue 12 item 5), from a run and its
//! [`Trace`]: `hil lander run FILE --report DIR` writes
//!
//! - `report.html`: self-contained HTML with inline SVG (no script, no external resource):
//!   a Gantt chart over sols (every dispatched primitive by kind and site, its target in the
//!   tooltip and label; failures, retries, replans and ground halts marked; Earth-in-view
//!   bands), the battery's charge and the data on board over time, the utility realised (it
//!   rises only when a downlink's data reaches Earth), and each downlink's products per tier;
//! - `report.json`: the run's result, the trace and the utility timeline;
//! - `primitives.csv`, `timeline.csv`, `utility.csv`, `downlinks.csv`: the same data as tables.
//!
//! Times in the report are in sols of [`SOL_US`] (85 h) from the mission's start.
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::sim::trace::Trace;
use crate::sim::{RunResult, SOL_US, WH_MJ};

/// The value realised on Earth from a time on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct UtilityPoint {
    pub at_us: u64,
    /// Cumulative, in thousandths.
    pub utility_milli: u64,
}

/// A run's report data (`report.json`).
#[derive(Debug, Serialize, Deserialize)]
pub struct LanderReport {
    pub scenario: String,
    pub description: String,
    pub seed: u64,
    pub strategy: String,
    pub result: RunResult,
    pub trace: Trace,
    /// Starts at (0, 0); one point per time some data reached Earth.
    pub utility: Vec<UtilityPoint>,
}

impl LanderReport {
    pub fn new(
        scenario: &crate::scenario::Scenario,
        strategy: &str,
        result: RunResult,
        trace: Trace,
    ) -> Self {
        Self {
            scenario: scenario.name.clone(),
            description: scenario.description.clone(),
            seed: result.seed,
            strategy: strategy.into(),
            utility: utility_timeline(&result),
            result,
            trace,
        }
    }

    /// The time the charts span: the run, and every reception of its data on Earth.
    pub fn span_us(&self) -> u64 {
        let last_rx = self.utility.last().map_or(0, |p| p.at_us);
        self.result
            .end_us
            .max(last_rx)
            .max(self.trace.samples.last().map_or(0, |s| s.at_us))
            .max(1)
    }
}

/// The utility realised over time: the products' values summed at the times they reached
/// Earth (a downlink's transmission end plus the light time).
pub fn utility_timeline(result: &RunResult) -> Vec<UtilityPoint> {
    let mut received: Vec<(u64, u64)> = result
        .products
        .iter()
        .filter_map(|p| p.received_us.map(|t| (t, p.value_milli)))
        .collect();
    received.sort_unstable();
    let mut out = vec![UtilityPoint {
        at_us: 0,
        utility_milli: 0,
    }];
    let mut total = 0u64;
    for (t, v) in received {
        total += v;
        match out.last_mut() {
            Some(last) if last.at_us == t => last.utility_milli = total,
            _ => out.push(UtilityPoint {
                at_us: t,
                utility_milli: total,
            }),
        }
    }
    out
}

pub const TIERS: [&str; 4] = ["Critical", "Decisional", "Mandatory", "Residual"];
const TIER_COLORS: [&str; 4] = ["#c0392b", "#e67e22", "#2e86c1", "#95a5a6"];

/// Text and attribute values.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// `sol 3 + 04:12` (sols of 85 h).
pub fn fmt_sol(us: u64) -> String {
    let sol = us / SOL_US;
    let rest = us % SOL_US;
    let min = rest / 60_000_000;
    format!("sol {sol} + {:02}:{:02}", min / 60, min % 60)
}

fn wh(mj: u64) -> f64 {
    mj as f64 / WH_MJ as f64
}

const LABEL_W: f64 = 210.0;
const PLOT_W: f64 = 1000.0;
const ROW_H: f64 = 20.0;

/// The x position of mission time `t` on a chart spanning `span` µs.
fn xpos(t: u64, span: u64) -> f64 {
    LABEL_W + (t.min(span) as f64 / span as f64) * PLOT_W
}

/// Sol ticks and labels from `top` to `bottom`.
fn sol_axis(svg: &mut String, span: u64, top: f64, bottom: f64) {
    let sols = span.div_ceil(SOL_US);
    let every = sols.div_ceil(20).max(1);
    let mut s = 0;
    while s * SOL_US <= span {
        let x = xpos(s * SOL_US, span);
        let _ = write!(
            svg,
            r##"<line x1="{x:.1}" y1="{top:.1}" x2="{x:.1}" y2="{bottom:.1}" stroke="#ccc"/><text x="{x:.1}" y="{:.1}" text-anchor="middle" fill="#555">{s}</text>"##,
            bottom + 14.0
        );
        s += every;
    }
    let _ = write!(
        svg,
        r##"<text x="{:.1}" y="{:.1}" text-anchor="middle" fill="#555">sol</text>"##,
        LABEL_W + PLOT_W / 2.0,
        bottom + 28.0
    );
}

/// Earth-in-view bands from `top` to `bottom`.
fn earth_bands(svg: &mut String, r: &LanderReport, span: u64, top: f64, bottom: f64) {
    for v in &r.trace.earth_in_view {
        if v.start_us >= span {
            break;
        }
        let (a, b) = (xpos(v.start_us, span), xpos(v.end_us, span));
        let _ = write!(
            svg,
            r##"<rect class="earth" x="{a:.1}" y="{top:.1}" width="{:.1}" height="{:.1}" fill="#d6eaf8" fill-opacity="0.6"><title>Earth in view {} - {}</title></rect>"##,
            (b - a).max(0.5),
            bottom - top,
            fmt_sol(v.start_us),
            fmt_sol(v.end_us)
        );
    }
}

/// A primitive's lane: its kind, and its site where it has one.
fn lane_of(kind: &str, site: Option<u8>) -> String {
    match site {
        Some(s) => format!("{kind} site {s}"),
        None => kind.to_string(),
    }
}

/// The Gantt chart over sols (SVG): a lane per primitive kind and site, every dispatch as a
/// bar (`class="prim"`), failed ones red, faulted ones dark red, retries outlined orange with
/// an `R`; a planner lane with the replans, a ground lane with the halts and the ground
/// changes taking effect; Earth-in-view bands behind.
pub fn gantt_svg(r: &LanderReport) -> String {
    let span = r.span_us();
    let mut lanes: Vec<String> = Vec::new();
    for p in &r.trace.primitives {
        let l = lane_of(&p.kind, p.site);
        if !lanes.contains(&l) {
            lanes.push(l);
        }
    }
    let top = 30.0;
    let planner_y = top + ROW_H * lanes.len() as f64;
    let ground_y = planner_y + ROW_H;
    let bottom = ground_y + ROW_H;
    let height = bottom + 40.0;
    let width = LABEL_W + PLOT_W + 20.0;
    let mut svg = String::new();
    let _ = write!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif" font-size="11">"#
    );
    let _ = write!(
        svg,
        "<title>{}: executed primitives over sols</title>",
        escape(&r.scenario)
    );
    svg.push_str(r#"<rect width="100%" height="100%" fill="white"/>"#);
    earth_bands(&mut svg, r, span, top, bottom);
    let _ = write!(
        svg,
        r##"<text x="{LABEL_W}" y="18" fill="#2874a6">blue bands: Earth in view</text>"##
    );
    sol_axis(&mut svg, span, top, bottom);
    let label = |svg: &mut String, y: f64, text: &str| {
        let _ = write!(
            svg,
            r##"<text x="4" y="{:.1}">{}</text><line x1="{LABEL_W}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="#eee"/>"##,
            y + 14.0,
            escape(text),
            y + ROW_H,
            LABEL_W + PLOT_W,
            y + ROW_H
        );
    };
    for (i, l) in lanes.iter().enumerate() {
        label(&mut svg, top + ROW_H * i as f64, l);
    }
    label(&mut svg, planner_y, "Planner: replans");
    label(&mut svg, ground_y, "Ground: halts, changes");
    for (i, p) in r.trace.primitives.iter().enumerate() {
        let lane = lanes
            .iter()
            .position(|l| *l == lane_of(&p.kind, p.site))
            .unwrap_or(0);
        let y = top + ROW_H * lane as f64 + 3.0;
        let (a, b) = (xpos(p.start_us, span), xpos(p.end_us, span));
        let w = (b - a).max(1.5);
        let fill = match p.result.as_str() {
            "succeeded" if p.kind.starts_with("Downlink") => "#27ae60",
            "succeeded" => "#5d6d7e",
            "failed" => "#e74c3c",
            _ => "#7b241c",
        };
        let stroke = if p.retry {
            r##" stroke="#f39c12" stroke-width="2""##
        } else {
            ""
        };
        let target = p.target.map_or(String::new(), |t| format!(" target {t}"));
        let failure = p
            .failure
            .map_or(String::new(), |f| format!(", failure class {f:?}"));
        let _ = write!(
            svg,
            r##"<rect class="prim" data-i="{i}" x="{a:.1}" y="{y:.1}" width="{w:.1}" height="{:.1}" fill="{fill}"{stroke}><title>{}{}: {} - {}, {}{}{}, {:.1} Wh</title></rect>"##,
            ROW_H - 6.0,
            escape(&lane_of(&p.kind, p.site)),
            target,
            fmt_sol(p.start_us),
            fmt_sol(p.end_us),
            p.result,
            failure,
            if p.retry { ", a retry" } else { "" },
            wh(p.energy_mj)
        );
        if let Some(t) = p.target {
            if w > 14.0 {
                let _ = write!(
                    svg,
                    r##"<text x="{:.1}" y="{:.1}" fill="white" font-size="9">t{t}</text>"##,
                    a + 2.0,
                    y + 10.0
                );
            }
        }
        if p.retry {
            let _ = write!(
                svg,
                r##"<text class="retry" x="{:.1}" y="{:.1}" fill="#d35400" font-size="10" font-weight="bold">R</text>"##,
                a - 8.0,
                y + 11.0
            );
        }
        if p.result != "succeeded" {
            let _ = write!(
                svg,
                r##"<text class="failure" x="{:.1}" y="{:.1}" fill="#922b21" font-size="12" font-weight="bold">x</text>"##,
                b + 1.0,
                y + 11.0
            );
        }
    }
    for &t in &r.trace.replans {
        let x = xpos(t, span);
        let y = planner_y + ROW_H / 2.0;
        let _ = write!(
            svg,
            r##"<path class="replan" d="M{:.1} {y:.1} L{x:.1} {:.1} L{:.1} {y:.1} L{x:.1} {:.1} Z" fill="#8e44ad"><title>replan at {}</title></path><line x1="{x:.1}" y1="{top:.1}" x2="{x:.1}" y2="{:.1}" stroke="#8e44ad" stroke-dasharray="3,3"/>"##,
            x - 5.0,
            y - 6.0,
            x + 5.0,
            y + 6.0,
            fmt_sol(t),
            planner_y
        );
    }
    for h in &r.trace.ground_halts {
        let (a, b) = (xpos(h.start_us, span), xpos(h.end_us, span));
        let _ = write!(
            svg,
            r##"<rect class="halt" x="{a:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="#f1c40f" stroke="#b7950b"><title>halted for the ground {} - {}</title></rect><rect x="{a:.1}" y="{top:.1}" width="{:.1}" height="{:.1}" fill="#f1c40f" fill-opacity="0.15"/>"##,
            ground_y + 3.0,
            (b - a).max(1.5),
            ROW_H - 6.0,
            fmt_sol(h.start_us),
            fmt_sol(h.end_us),
            (b - a).max(1.5),
            ground_y - top
        );
    }
    for c in &r.result.changes {
        let x = xpos(c.applied_us, span);
        let _ = write!(
            svg,
            r##"<text class="change" x="{:.1}" y="{:.1}" fill="#1e8449" font-weight="bold">G<title>ground change {} in effect at {}</title></text>"##,
            x - 4.0,
            ground_y + 14.0,
            c.index,
            fmt_sol(c.applied_us)
        );
    }
    svg.push_str("</svg>");
    svg
}

/// One line chart panel: `points` (time, value) as steps (`step`) or straight segments.
#[allow(clippy::too_many_arguments)]
fn panel(
    svg: &mut String,
    r: &LanderReport,
    span: u64,
    top: f64,
    h: f64,
    title: &str,
    class: &str,
    color: &str,
    points: &[(u64, f64)],
    step: bool,
    unit: &str,
) {
    let max = points.iter().map(|p| p.1).fold(0.0f64, f64::max).max(1e-9) * 1.05;
    let y = |v: f64| top + h * (1.0 - v / max);
    earth_bands(svg, r, span, top, top + h);
    let _ = write!(
        svg,
        r##"<rect x="{LABEL_W}" y="{top:.1}" width="{PLOT_W}" height="{h:.1}" fill="none" stroke="#999"/><text x="4" y="{:.1}" font-weight="bold">{}</text><text x="{:.1}" y="{:.1}" text-anchor="end" fill="#555">{:.1} {}</text><text x="{:.1}" y="{:.1}" text-anchor="end" fill="#555">0</text>"##,
        top + 14.0,
        escape(title),
        LABEL_W - 4.0,
        top + 10.0,
        max,
        escape(unit),
        LABEL_W - 4.0,
        top + h
    );
    let mut d = String::new();
    for (i, &(t, v)) in points.iter().enumerate() {
        let (x, yy) = (xpos(t, span), y(v));
        if i == 0 {
            let _ = write!(d, "M{x:.1} {yy:.1}");
        } else {
            if step {
                let prev = y(points[i - 1].1);
                let _ = write!(d, " L{x:.1} {prev:.1}");
            }
            let _ = write!(d, " L{x:.1} {yy:.1}");
        }
    }
    if step {
        if let Some(&(_, v)) = points.last() {
            let _ = write!(d, " L{:.1} {:.1}", xpos(span, span), y(v));
        }
    }
    let _ = write!(
        svg,
        r##"<path class="{class}" d="{d}" fill="none" stroke="{color}" stroke-width="1.8"/>"##
    );
}

/// The timelines (SVG): battery charge (Wh), data on board (kB), utility realised.
pub fn timelines_svg(r: &LanderReport) -> String {
    let span = r.span_us();
    let (h, gap, top) = (130.0, 30.0, 20.0);
    let height = top + 3.0 * (h + gap) + 30.0;
    let width = LABEL_W + PLOT_W + 20.0;
    let mut svg = String::new();
    let _ = write!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif" font-size="11">"#
    );
    let _ = write!(
        svg,
        "<title>{}: battery, data on board and utility over sols</title>",
        escape(&r.scenario)
    );
    svg.push_str(r#"<rect width="100%" height="100%" fill="white"/>"#);
    let battery: Vec<(u64, f64)> = r
        .trace
        .samples
        .iter()
        .map(|s| (s.at_us, wh(s.battery_mj)))
        .collect();
    let data: Vec<(u64, f64)> = r
        .trace
        .samples
        .iter()
        .map(|s| (s.at_us, s.onboard_bytes as f64 / 1_000.0))
        .collect();
    let utility: Vec<(u64, f64)> = r
        .utility
        .iter()
        .map(|p| (p.at_us, p.utility_milli as f64 / 1_000.0))
        .collect();
    panel(
        &mut svg,
        r,
        span,
        top,
        h,
        "Battery charge",
        "battery",
        "#c0392b",
        &battery,
        false,
        "Wh",
    );
    panel(
        &mut svg,
        r,
        span,
        top + h + gap,
        h,
        "Data on board",
        "onboard",
        "#2e86c1",
        &data,
        false,
        "kB",
    );
    panel(
        &mut svg,
        r,
        span,
        top + 2.0 * (h + gap),
        h,
        "Utility realised",
        "utility",
        "#27ae60",
        &utility,
        true,
        "",
    );
    for d in &r.trace.downlinks {
        let x = xpos(d.received_us, span);
        let t = top + 2.0 * (h + gap);
        let _ = write!(
            svg,
            r##"<line class="rx" x1="{x:.1}" y1="{t:.1}" x2="{x:.1}" y2="{:.1}" stroke="#27ae60" stroke-dasharray="2,3"><title>downlink {} received {}</title></line>"##,
            t + h,
            d.index + 1,
            fmt_sol(d.received_us)
        );
    }
    sol_axis(
        &mut svg,
        span,
        top + 2.0 * (h + gap) + h,
        top + 2.0 * (h + gap) + h,
    );
    svg.push_str("</svg>");
    svg
}

/// Each downlink's volume per tier as stacked bars (SVG), in kB.
pub fn downlinks_svg(r: &LanderReport) -> String {
    let n = r.trace.downlinks.len().max(1);
    let (left, top, h, bw) = (60.0, 20.0, 180.0, (PLOT_W / n as f64).min(60.0));
    let width = left + bw * n as f64 + 180.0;
    let height = top + h + 40.0;
    let max = r
        .trace
        .downlinks
        .iter()
        .map(|d| d.bytes_per_tier.iter().sum::<u64>())
        .max()
        .unwrap_or(0)
        .max(1) as f64
        / 1_000.0;
    let mut svg = String::new();
    let _ = write!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif" font-size="11">"#
    );
    svg.push_str("<title>volume per tier of each downlink</title>");
    svg.push_str(r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = write!(
        svg,
        r##"<line x1="{left}" y1="{top}" x2="{left}" y2="{:.1}" stroke="#999"/><text x="{:.1}" y="{:.1}" text-anchor="end">{max:.1} kB</text><text x="{:.1}" y="{:.1}" text-anchor="end">0</text>"##,
        top + h,
        left - 4.0,
        top + 10.0,
        left - 4.0,
        top + h
    );
    for (i, d) in r.trace.downlinks.iter().enumerate() {
        let x = left + bw * i as f64 + 2.0;
        let mut y = top + h;
        for (t, &bytes) in d.bytes_per_tier.iter().enumerate() {
            let bh = bytes as f64 / 1_000.0 / max * h;
            if bytes == 0 {
                continue;
            }
            y -= bh;
            let _ = write!(
                svg,
                r##"<rect class="tier" x="{x:.1}" y="{y:.1}" width="{:.1}" height="{bh:.1}" fill="{}"><title>downlink {}: {} {} product(s), {} bytes</title></rect>"##,
                bw - 4.0,
                TIER_COLORS[t],
                d.index + 1,
                d.products_per_tier[t],
                TIERS[t],
                bytes
            );
        }
        let _ = write!(
            svg,
            r##"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
            x + (bw - 4.0) / 2.0,
            top + h + 14.0,
            d.index + 1
        );
    }
    for (t, name) in TIERS.iter().enumerate() {
        let x = left + bw * n as f64 + 20.0;
        let y = top + 20.0 * t as f64;
        let _ = write!(
            svg,
            r##"<rect x="{x:.1}" y="{y:.1}" width="12" height="12" fill="{}"/><text x="{:.1}" y="{:.1}">{name}</text>"##,
            TIER_COLORS[t],
            x + 16.0,
            y + 10.0
        );
    }
    let _ = write!(
        svg,
        r##"<text x="{:.1}" y="{:.1}" text-anchor="middle" fill="#555">downlink</text>"##,
        left + bw * n as f64 / 2.0,
        top + h + 30.0
    );
    svg.push_str("</svg>");
    svg
}

/// The whole report page: self-contained HTML (well-formed XML) with the charts inline.
pub fn html(r: &LanderReport) -> String {
    let res = &r.result;
    let mut rows = String::new();
    for d in &r.trace.downlinks {
        let record = res.downlinks.get(d.index);
        let _ = write!(
            rows,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td>",
            d.index + 1,
            fmt_sol(d.start_us),
            fmt_sol(d.end_us),
            fmt_sol(d.received_us)
        );
        for t in 0..4 {
            let _ = write!(
                rows,
                "<td>{} / {}</td>",
                d.products_per_tier[t], d.bytes_per_tier[t]
            );
        }
        let _ = write!(
            rows,
            "<td>{}</td><td>{:.1}</td></tr>",
            record.map_or(0, |x| x.bytes),
            d.value_milli_per_tier.iter().sum::<u64>() as f64 / 1_000.0
        );
    }
    let failed = r
        .trace
        .primitives
        .iter()
        .filter(|p| p.result != "succeeded")
        .count();
    let retries = r.trace.primitives.iter().filter(|p| p.retry).count();
    format!(
        r##"<!DOCTYPE html>
<html xmlns="http://www.w3.org/1999/xhtml"><head><meta charset="utf-8"/><title>{name}: lander mission report</title>
<style>body{{font-family:sans-serif;margin:1.5em}} table{{border-collapse:collapse}} td,th{{border:1px solid #ccc;padding:2px 6px;text-align:right}} .legend span{{display:inline-block;width:14px;height:10px;margin:0 4px 0 12px}}</style></head>
<body><h2>{name}: lander mission report</h2><p>{desc}</p>
<p>Strategy {strategy}, seed {seed}; ended {end:?} at {end_at}; utility {utility:.1}; {dispatched} dispatches ({failed} failed, {retries} retries), {replans} replans, {halts} ground halts; battery {b0:.0} to {b1:.0} Wh; {n_dl} downlinks, {unsent} product(s) left on board.</p>
<h3>Executed primitives over sols</h3>
<p class="legend"><span style="background:#5d6d7e"></span>succeeded <span style="background:#27ae60"></span>downlink <span style="background:#e74c3c"></span>failed (x) <span style="background:#7b241c"></span>faulted (x) <span style="background:#fff;border:2px solid #f39c12"></span>retry (R) <span style="background:#8e44ad"></span>replan <span style="background:#f1c40f"></span>halted for the ground (G: a ground change in effect) <span style="background:#d6eaf8"></span>Earth in view</p>
{gantt}
<h3>Battery, data on board and utility realised</h3>
<p>Sampled after every executor step and dispatch (straight lines between). Utility counts when data reaches Earth: it rises only at downlinks' receptions (dashed lines).</p>
{timelines}
<h3>Downlinks: products per tier</h3>
{downlinks}
<table><tr><th>#</th><th>start</th><th>end</th><th>on Earth</th><th>Critical n / bytes</th><th>Decisional n / bytes</th><th>Mandatory n / bytes</th><th>Residual n / bytes</th><th>bytes</th><th>value</th></tr>
{rows}</table>
<p>Data: report.json, primitives.csv, timeline.csv, utility.csv, downlinks.csv.</p>
</body></html>
"##,
        name = escape(&r.scenario),
        desc = escape(&r.description),
        strategy = escape(&r.strategy),
        seed = r.seed,
        end = res.end,
        end_at = fmt_sol(res.end_us),
        utility = res.utility_milli as f64 / 1_000.0,
        dispatched = res.dispatched,
        replans = r.trace.replans.len(),
        halts = r.trace.ground_halts.len(),
        b0 = wh(res.battery_start_mj),
        b1 = wh(res.battery_end_mj),
        n_dl = r.trace.downlinks.len(),
        unsent = res.unsent,
        gantt = gantt_svg(r),
        timelines = timelines_svg(r),
        downlinks = downlinks_svg(r),
    )
}

fn opt<T: std::fmt::Display>(x: Option<T>) -> String {
    x.map_or(String::new(), |x| x.to_string())
}

/// The CSV tables: (file name, text).
pub fn csv(r: &LanderReport) -> Vec<(&'static str, String)> {
    let mut prims = String::from(
        "start_us,end_us,kind,site,target,chain,primitive,result,failure,retry,energy_mj\n",
    );
    for p in &r.trace.primitives {
        let _ = writeln!(
            prims,
            "{},{},{},{},{},{},{},{},{},{},{}",
            p.start_us,
            p.end_us,
            p.kind,
            opt(p.site),
            opt(p.target),
            p.chain,
            p.primitive,
            p.result,
            p.failure.map_or(String::new(), |f| format!("{f:?}")),
            p.retry,
            p.energy_mj
        );
    }
    let mut timeline = String::from("at_us,battery_mj,onboard_bytes\n");
    for s in &r.trace.samples {
        let _ = writeln!(timeline, "{},{},{}", s.at_us, s.battery_mj, s.onboard_bytes);
    }
    let mut utility = String::from("at_us,utility_milli\n");
    for p in &r.utility {
        let _ = writeln!(utility, "{},{}", p.at_us, p.utility_milli);
    }
    let mut downlinks = String::from("downlink,start_us,end_us,received_us,bytes");
    for t in TIERS {
        let t = t.to_lowercase();
        let _ = write!(downlinks, ",{t}_products,{t}_bytes,{t}_value_milli");
    }
    downlinks.push('\n');
    for d in &r.trace.downlinks {
        let _ = write!(
            downlinks,
            "{},{},{},{},{}",
            d.index + 1,
            d.start_us,
            d.end_us,
            d.received_us,
            r.result.downlinks.get(d.index).map_or(0, |x| x.bytes)
        );
        for t in 0..4 {
            let _ = write!(
                downlinks,
                ",{},{},{}",
                d.products_per_tier[t], d.bytes_per_tier[t], d.value_milli_per_tier[t]
            );
        }
        downlinks.push('\n');
    }
    vec![
        ("primitives.csv", prims),
        ("timeline.csv", timeline),
        ("utility.csv", utility),
        ("downlinks.csv", downlinks),
    ]
}

/// Writes the report into `dir` (created if needed): report.html, report.json and the CSV
/// tables. Returns the files written.
pub fn write_dir(r: &LanderReport, dir: &Path) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let json = serde_json::to_string_pretty(r).map_err(|e| e.to_string())? + "\n";
    let mut files = vec![("report.html", html(r)), ("report.json", json)];
    files.extend(csv(r));
    let mut written = Vec::new();
    for (name, text) in files {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|e| format!("cannot write {}: {e}", p.display()))?;
        written.push(p);
    }
    Ok(written)
}

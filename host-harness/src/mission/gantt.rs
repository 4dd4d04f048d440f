//! A Gantt chart of planned versus as-executed tasks, with resets marked, in the manner of
//! seed 003's Figs 6-8: HTML with inline SVG, no script, no external resources.
use std::fmt::Write;

use super::report::MissionReport;
use super::CompiledNetwork;
use crate::time::fmt_time;
use autonomy::TaskRole;
use fsw_bridge::MissionTimeUs;

const ROW_H: f64 = 26.0;
const LABEL_W: f64 = 230.0;
const PLOT_W: f64 = 900.0;
const TOP: f64 = 40.0;

/// One chart row: its label, the planned span, and the executed span with its outcome.
type Row = (
    String,
    Option<(u64, u64)>,
    Option<(u64, u64, String, String)>,
);

/// Text and attribute values in the chart's HTML.
fn esc(s: &str) -> String {
    quick_xml::escape::escape(s).into_owned()
}

/// Render the chart. Planned bars come from the task network (requested tasks at their
/// earliest start); as-executed bars from the run.
pub fn render(
    report: &MissionReport,
    net: &CompiledNetwork,
    start: MissionTimeUs,
    end: MissionTimeUs,
) -> String {
    let span = (end.0 - start.0).max(1) as f64;
    let x = |t: u64| LABEL_W + (t.saturating_sub(start.0) as f64 / span * PLOT_W).min(PLOT_W);
    // Rows: planned requested tasks first, then every executed instance.
    let mut rows: Vec<Row> = Vec::new();
    for t in net
        .network
        .tasks()
        .iter()
        .filter(|t| t.role == TaskRole::Requested)
    {
        rows.push((
            format!("{} (plan)", t.name.as_str()),
            Some((t.earliest_start.0, t.earliest_start.0 + t.duration_us)),
            None,
        ));
    }
    for i in &report.record.instances {
        if let Some(s) = i.started_at {
            let e = i.ended_at.unwrap_or(end.0);
            rows.push((
                format!("{} ({})", i.name, i.origin),
                None,
                Some((s, e, i.outcome_name().to_string(), i.origin.clone())),
            ));
        }
    }
    let height = TOP + ROW_H * rows.len() as f64 + 50.0;
    let width = LABEL_W + PLOT_W + 20.0;
    let mut svg = String::new();
    let _ = write!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" font-family="sans-serif" font-size="12">"#
    );
    // Time axis: a tick every 10 minutes (or every hour for long spans).
    let step: u64 = if span > 6.0 * 3.6e9 {
        3_600_000_000
    } else {
        600_000_000
    };
    let mut t = start.0.div_ceil(step) * step;
    while t <= end.0 {
        let px = x(t);
        let _ = write!(
            svg,
            r##"<line x1="{px:.1}" y1="{:.1}" x2="{px:.1}" y2="{:.1}" stroke="#ddd"/>"##,
            TOP - 5.0,
            height - 40.0
        );
        let _ = write!(
            svg,
            r##"<text x="{px:.1}" y="{:.1}" text-anchor="middle" fill="#555">{}</text>"##,
            TOP - 10.0,
            &fmt_time(MissionTimeUs(t))[..5]
        );
        t += step;
    }
    for (row, (label, planned, executed)) in rows.iter().enumerate() {
        let y = TOP + ROW_H * row as f64;
        let _ = write!(
            svg,
            r##"<text x="4" y="{:.1}">{}</text>"##,
            y + 17.0,
            esc(label)
        );
        if let Some((s, e)) = planned {
            let _ = write!(
                svg,
                r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="18" fill="#7aa6da" stroke="#3b6ea8"><title>{} planned {} - {}</title></rect>"##,
                x(*s),
                y + 4.0,
                (x(*e) - x(*s)).max(1.0),
                esc(label),
                fmt_time(MissionTimeUs(*s)),
                fmt_time(MissionTimeUs(*e))
            );
        }
        if let Some((s, e, outcome, _)) = executed {
            let color = match outcome.as_str() {
                "completed" => "#f0a050",
                "aborted" | "failed" => "#d9534f",
                _ => "#bbbbbb",
            };
            let _ = write!(
                svg,
                r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="18" fill="{color}" stroke="#7a4a10"><title>{}: {} - {}, {}</title></rect>"##,
                x(*s),
                y + 4.0,
                (x(*e) - x(*s)).max(1.0),
                esc(label),
                fmt_time(MissionTimeUs(*s)),
                fmt_time(MissionTimeUs(*e)),
                outcome
            );
        }
    }
    for r in &report.record.resets {
        let (a, b) = (x(r.at), x(r.restart_at));
        let _ = write!(
            svg,
            r##"<rect x="{a:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="#d9534f" fill-opacity="0.15"/>"##,
            TOP - 5.0,
            (b - a).max(1.0),
            height - 35.0 - TOP
        );
        let _ = write!(
            svg,
            r##"<line x1="{a:.1}" y1="{:.1}" x2="{a:.1}" y2="{:.1}" stroke="#d9534f" stroke-width="2"/>"##,
            TOP - 5.0,
            height - 40.0
        );
        let _ = write!(
            svg,
            r##"<text x="{:.1}" y="{:.1}" fill="#d9534f">{} {}</text>"##,
            a + 3.0,
            height - 25.0,
            esc(&r.kind),
            &fmt_time(MissionTimeUs(r.at))[..5]
        );
    }
    svg.push_str("</svg>");
    let verdicts: String = report
        .expectations
        .iter()
        .map(|v| {
            format!(
                "<li class=\"{}\">{}: {}</li>",
                if v.passed { "ok" } else { "fail" },
                esc(&v.what),
                esc(&v.detail)
            )
        })
        .collect();
    format!(
        r##"<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{name}</title>
<style>body{{font-family:sans-serif;margin:1.5em}} .ok{{color:#2a7a2a}} .fail{{color:#b00;font-weight:bold}}
.legend span{{display:inline-block;width:14px;height:10px;margin:0 4px 0 12px}}</style></head>
<body><h2>{name}: {verdict}</h2><p>{desc}</p>
<p class="legend"><span style="background:#7aa6da"></span>planned <span style="background:#f0a050"></span>as executed
<span style="background:#d9534f"></span>aborted / failed, resets</p>
{svg}
<h3>Expectations</h3><ul>{verdicts}</ul>
<p>Target: {target}. Transcript SHA-256 {sha}.</p></body></html>
"##,
        name = esc(&report.scenario),
        verdict = if report.passed { "PASS" } else { "FAIL" },
        desc = esc(&report.description),
        target = esc(&report.target),
        sha = report.transcript_sha256,
    )
}

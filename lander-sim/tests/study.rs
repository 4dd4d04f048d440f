//! A reduced study (3 runs per cell): the statistics and the ordering are computed, the JSON
//! and SVG parse, the same seed gives the same report, and shards merge into the unsharded
//! report.
use lander_sim::scenario::Scenario;
use lander_sim::study::{self, mean_ci, merge, run_study, StudyConfig, StudyReport};

fn reduced(seed: u64) -> StudyConfig {
    let mut c = StudyConfig::new(Scenario::bsm1(), 3, seed);
    c.prescient_runs = 3;
    c
}

fn study(seed: u64, shard: Option<(u32, u32)>) -> StudyReport {
    run_study(&reduced(seed), shard, &mut |_| {}).unwrap()
}

/// A minimal well-formedness check: every tag closes in order, attributes are quoted, no stray
/// `<` or `&` in text.
fn well_formed_xml(text: &str) -> Result<(), String> {
    let mut stack: Vec<String> = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find('<') {
        let between = &rest[..i];
        if between.contains('>') {
            return Err(format!("stray '>' in {between:?}"));
        }
        for (j, _) in between.match_indices('&') {
            let ent = &between[j..];
            if !["&amp;", "&lt;", "&gt;", "&quot;"]
                .iter()
                .any(|e| ent.starts_with(e))
            {
                return Err(format!("bad entity at {ent:?}"));
            }
        }
        let end = rest[i..].find('>').ok_or("unclosed tag")? + i;
        let tag = &rest[i + 1..end];
        if !tag.matches('"').count().is_multiple_of(2) {
            return Err(format!("unbalanced quotes in <{tag}>"));
        }
        if let Some(name) = tag.strip_prefix('/') {
            let open = stack.pop().ok_or(format!("</{name}> closes nothing"))?;
            if open != name.trim() {
                return Err(format!("</{name}> closes <{open}>"));
            }
        } else if !tag.ends_with('/') && !tag.starts_with('?') && !tag.starts_with('!') {
            let name = tag.split_whitespace().next().ok_or("empty tag")?;
            stack.push(name.to_string());
        }
        rest = &rest[end + 1..];
    }
    if !stack.is_empty() {
        return Err(format!("unclosed: {stack:?}"));
    }
    if !rest.trim().is_empty() {
        return Err("text after the root".into());
    }
    Ok(())
}

#[test]
fn the_reduced_study_computes_cells_model_and_ordering() {
    let r = study(1, None);
    assert!(r.complete);
    assert_eq!(r.runs.len(), 3 * 4 * 3);
    assert_eq!(r.cells.len(), 12);
    assert_eq!(r.orderings.len(), 3);
    for (o, v) in r.orderings.iter().zip(&r.config.variants) {
        assert_eq!(o.variant, v.name);
        // All four strategies, once each.
        for s in ["Static", "Ground", "FE", "Replan"] {
            assert_eq!(o.measured.matches(s).count(), 1, "{}", o.measured);
        }
        // The statistic agrees with the means it is computed from.
        let means: Vec<f64> = r
            .cells
            .iter()
            .filter(|c| c.variant == v.name)
            .map(|c| c.mean)
            .collect();
        let increasing = means.windows(2).all(|w| w[0] < w[1]);
        assert_eq!(o.matches_paper, increasing, "{o:?} {means:?}");
        assert_eq!(o.differences.is_empty(), increasing);
    }
    for c in &r.cells {
        assert_eq!(c.runs, 3);
        assert!(c.ci95[0] <= c.mean && c.mean <= c.ci95[1], "{c:?}");
    }
    // The model: Static below the no-failure utility; the predictions use the inputs.
    for m in &r.models {
        assert!(m.u_avg > 0.0 && m.b_wh > 0.0 && m.n_tasks > 0.0, "{m:?}");
        let expect_ground = m.u_avg * (m.b_wh - m.p_fail * m.n_tasks * m.c_g_wh);
        assert!((m.predicted[1] - expect_ground).abs() < 1e-9);
        assert!(m.predicted[0] <= m.u_avg * m.b_wh + 1e-9);
    }
    let text = study::table(&r);
    assert!(text.contains("| unbiased | Replan | 3 |"), "{text}");
    assert!(
        text.contains("paper Static < Ground < FE < Replan"),
        "{text}"
    );
}

#[test]
fn the_json_round_trips_and_the_svg_is_well_formed() {
    let r = study(1, None);
    let json = serde_json::to_string_pretty(&r).unwrap();
    let back: StudyReport = serde_json::from_str(&json).unwrap();
    assert_eq!(back, r);
    let svg = study::svg(&r);
    assert!(svg.starts_with("<svg"));
    well_formed_xml(&svg).unwrap();
    // One bar per cell, one model diamond per cell.
    assert_eq!(svg.matches("<rect x=").count(), r.cells.len());
    assert_eq!(svg.matches("<path d=").count(), r.cells.len());
    // The checker itself rejects broken XML.
    assert!(well_formed_xml("<svg><g></svg>").is_err());
    assert!(well_formed_xml("<svg><text>a < b</text></svg>").is_err());
}

#[test]
fn the_same_seed_gives_the_same_report() {
    let a = serde_json::to_string(&study(5, None)).unwrap();
    let b = serde_json::to_string(&study(5, None)).unwrap();
    assert_eq!(a, b);
    let c = serde_json::to_string(&study(6, None)).unwrap();
    assert_ne!(a, c);
}

#[test]
fn shards_merge_into_the_unsharded_report() {
    let whole = study(1, None);
    for n in [2u32, 3, 5] {
        let shards: Vec<StudyReport> = (1..=n).map(|k| study(1, Some((k, n)))).collect();
        for s in &shards {
            assert!(!s.complete);
            assert!(s.runs.len() < whole.runs.len());
        }
        // In any order.
        let merged = merge(shards.into_iter().rev().collect()).unwrap();
        assert_eq!(merged, whole, "{n} shards");
    }
    // Overlaps and different studies are refused.
    let e = merge(vec![study(1, Some((1, 2))), study(1, Some((1, 2)))]).unwrap_err();
    assert!(e.contains("overlapping"), "{e}");
    let e = merge(vec![study(1, Some((1, 2))), study(2, Some((2, 2)))]).unwrap_err();
    assert!(e.contains("different study"), "{e}");
    // A partial merge stays partial.
    let part = merge(vec![study(1, Some((1, 3))), study(1, Some((2, 3)))]).unwrap();
    assert!(!part.complete);
    assert_eq!(part.shards, vec!["1/3".to_string(), "2/3".to_string()]);
}

#[test]
fn mean_and_interval() {
    let (m, sd, ci) = mean_ci(&[1.0, 2.0, 3.0, 4.0]);
    assert!((m - 2.5).abs() < 1e-12);
    assert!((sd - 1.290_994_448_7).abs() < 1e-9);
    // t(0.975, 3) = 3.182: half-width 3.182 * sd / 2.
    assert!((ci[1] - m - 3.182 * sd / 2.0).abs() < 1e-9);
    assert!((m - ci[0] - 3.182 * sd / 2.0).abs() < 1e-9);
}

//! The sweep page, `OUT/report.html` of `python -m loomlab.sweep`: the ranking table and a
//! hit-rate-vs-false-alarm-rate scatter of every parameter point, each point linking to its own
//! run page `points/<label>/report.html` (written here too, by [`crate::page`], from the point's
//! `report.json` and `episodes.csv`).
//!
//! It reads what the sweep's merge step writes (`summary.json`, `points/<label>/{report.json,
//! episodes.csv}`), so it can also be rebuilt for a finished sweep folder.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use loomlab_scenarios::episodes_csv::read_episodes_csv;
use loomlab_scenarios::report::Report;
use serde_json::Value;

use crate::html::{cell, escape, num, page, pct, table, text_cell, url_segment};
use crate::page::RunPage;
use crate::plot::palette;
use crate::run_plots::run_figures;
use crate::{REPORT_HTML, ReportError};

/// Scatter size in pixels.
const SCATTER: (f64, f64) = (640.0, 520.0);

/// One ranked point of `summary.json`.
#[derive(Debug, Clone)]
struct Point {
    rank: u64,
    label: String,
    detector: String,
    values: Vec<(String, String)>,
    score: Option<f64>,
    /// The objective per difficulty tier (`tier_scores`; empty for an untiered suite).
    tier_scores: Vec<(String, Option<f64>)>,
    within_budget: bool,
    hit_rate: Option<f64>,
    false_alarm_rate: Option<f64>,
    collision_rate: Option<f64>,
    auc: Option<f64>,
}

fn bad(path: &Path, reason: impl Into<String>) -> ReportError {
    ReportError::Sweep {
        path: path.display().to_string(),
        reason: reason.into(),
    }
}

fn read_points(path: &Path, summary: &Value) -> Result<Vec<Point>, ReportError> {
    let ranking = summary
        .get("ranking")
        .and_then(Value::as_array)
        .ok_or_else(|| bad(path, "no `ranking` list: is this the summary.json of a finished sweep?"))?;
    let mut out = Vec::with_capacity(ranking.len());
    for (i, p) in ranking.iter().enumerate() {
        let label = p
            .get("label")
            .and_then(Value::as_str)
            .ok_or_else(|| bad(path, format!("ranking[{i}].label: missing or not a string")))?;
        if label.is_empty() || label.contains(['/', '\\']) || label == "." || label == ".." {
            return Err(bad(path, format!("ranking[{i}].label: `{label}` is not a folder name")));
        }
        let f = |k: &str| p.get("summary").and_then(|s| s.get(k)).and_then(Value::as_f64);
        let values = p
            .get("values")
            .and_then(Value::as_object)
            .map(|m| {
                m.iter()
                    .map(|(k, v)| (k.clone(), v.as_str().map_or_else(|| v.to_string(), String::from)))
                    .collect()
            })
            .unwrap_or_default();
        out.push(Point {
            rank: p.get("rank").and_then(Value::as_u64).unwrap_or(i as u64 + 1),
            label: label.to_string(),
            detector: p
                .get("detector")
                .and_then(|d| d.get("id"))
                .and_then(Value::as_str)
                .unwrap_or("")
                .to_string(),
            values,
            score: p.get("score").and_then(Value::as_f64),
            tier_scores: p
                .get("tier_scores")
                .and_then(Value::as_object)
                .map(|m| m.iter().map(|(t, v)| (t.clone(), v.as_f64())).collect())
                .unwrap_or_default(),
            within_budget: p.get("within_budget").and_then(Value::as_bool).unwrap_or(false),
            hit_rate: f("hit_rate"),
            false_alarm_rate: f("false_alarm_rate"),
            collision_rate: f("collision_rate"),
            auc: f("auc"),
        });
    }
    Ok(out)
}

/// Writes `root/report.html` and every point's `root/points/<label>/report.html`; returns the
/// sweep page's path.
pub fn write_sweep_pages(root: &Path) -> Result<PathBuf, ReportError> {
    let summary_path = root.join("summary.json");
    let text = std::fs::read_to_string(&summary_path).map_err(|e| ReportError::io(&summary_path, e))?;
    let summary: Value = serde_json::from_str(&text).map_err(|e| bad(&summary_path, e.to_string()))?;
    let points = read_points(&summary_path, &summary)?;
    let s = |k: &str| {
        summary.get(k).map_or(String::new(), |v| {
            v.as_str().map_or_else(|| v.to_string(), String::from)
        })
    };
    let name = s("name");

    for p in &points {
        let dir = root.join("points").join(&p.label);
        let report = Report::read_json(&dir.join("report.json")).map_err(|e| bad(&dir, e.to_string()))?;
        let csv = dir.join("episodes.csv");
        let outcomes = read_episodes_csv(&csv).map_err(|e| bad(&csv, e.to_string()))?;
        let values: Vec<String> = p.values.iter().map(|(k, v)| format!("{k} = {v}")).collect();
        let rerun = format!(
            "loomlab run {} --detectors-file points/{}/detectors.toml --seed {}",
            s("suite"),
            p.label,
            s("seed")
        );
        let page = RunPage {
            report: &report,
            title: format!("sweep {name}: point {} (rank {})", p.label, p.rank),
            facts: vec![
                ("sweep page".into(), "../../report.html".into()),
                ("values".into(), values.join(", ")),
                ("rerun as a run (with exemplary episodes)".into(), rerun),
            ],
            figures: run_figures(&report, &outcomes, None),
            exemplars: Vec::new(),
            baseline: None,
            notes: vec![
                "A sweep keeps no per-frame traces, so a point's page has no exemplary episodes: rerun the \
                 point with the command above to get them."
                    .into(),
            ],
        };
        let html = page
            .render()?
            .replacen("<nav>", "<nav><a href=\"../../report.html\">← the sweep</a>", 1);
        let path = dir.join(REPORT_HTML);
        std::fs::write(&path, html).map_err(|e| ReportError::io(&path, e))?;
    }

    let mut b = String::new();
    let _ = writeln!(b, "<h1>Sweep {}</h1>", escape(&name));
    let objective = summary.get("objective").map_or(String::new(), Value::to_string);
    let _ = writeln!(
        b,
        "<p class=\"meta\">sweep file <code>{}</code> · suite <code>{}</code> · seed {} · {} episodes · {} points · \
         objective <code>{}</code></p>",
        escape(&s("sweep")),
        escape(&s("suite")),
        escape(&s("seed")),
        escape(&s("episodes")),
        points.len(),
        escape(&objective)
    );
    b.push_str("<h2 id=\"scatter\">Hit rate against false-alarm rate</h2>\n");
    b.push_str(&scatter(&points));
    b.push_str(
        "<p class=\"meta\">One dot per parameter point (colour: detector; ringed: the best-ranked point); \
         click a dot for the point's own report.</p>\n",
    );
    b.push_str("<h2 id=\"ranking\">Ranking</h2>\n");
    let keys: Vec<String> = {
        let mut k: Vec<String> = points
            .iter()
            .flat_map(|p| p.values.iter().map(|(k, _)| k.clone()))
            .collect();
        k.sort();
        k.dedup();
        k
    };
    let tiers: Vec<String> = {
        let mut t: Vec<String> = points
            .iter()
            .flat_map(|p| p.tier_scores.iter().map(|(t, _)| t.clone()))
            .collect();
        t.sort();
        t.dedup();
        t
    };
    let mut headers: Vec<String> = vec!["rank".into(), "point".into(), "detector".into()];
    headers.extend(keys.iter().map(|k| escape(k)));
    headers.extend(
        [
            "score",
            "within budget",
            "hit rate",
            "false-alarm rate",
            "collision rate",
            "AUC",
        ]
        .map(String::from),
    );
    headers.extend(tiers.iter().map(|t| format!("score, tier {}", escape(t))));
    let rows: Vec<(String, Vec<String>)> = points
        .iter()
        .map(|p| {
            let mut cells = vec![
                cell(&p.rank.to_string(), Some(p.rank as f64)),
                format!(
                    "<td><a href=\"points/{}/{REPORT_HTML}\">{}</a></td>",
                    url_segment(&p.label),
                    escape(&p.label)
                ),
                text_cell(&p.detector),
            ];
            for k in &keys {
                let v = p.values.iter().find(|(pk, _)| pk == k).map_or("", |(_, v)| v.as_str());
                cells.push(cell(&escape(v), v.parse::<f64>().ok()));
            }
            cells.extend([
                cell(&num(p.score, 4), p.score),
                text_cell(if p.within_budget { "yes" } else { "no" }),
                cell(&pct(p.hit_rate), p.hit_rate),
                cell(&pct(p.false_alarm_rate), p.false_alarm_rate),
                cell(&pct(p.collision_rate), p.collision_rate),
                cell(&num(p.auc, 3), p.auc),
            ]);
            for t in &tiers {
                let v = p.tier_scores.iter().find(|(pt, _)| pt == t).and_then(|(_, v)| *v);
                cells.push(cell(&num(v, 4), v));
            }
            (String::new(), cells)
        })
        .collect();
    let header_refs: Vec<&str> = headers.iter().map(String::as_str).collect();
    b.push_str(&table("ranking", &header_refs, &rows));
    let path = root.join(REPORT_HTML);
    std::fs::write(&path, page(&format!("sweep {name}"), &b)).map_err(|e| ReportError::io(&path, e))?;
    Ok(path)
}

/// The scatter: x false-alarm rate, y hit rate, both in [0, 1]; each dot a link.
fn scatter(points: &[Point]) -> String {
    let (w, h) = SCATTER;
    let (l, r, t, bm) = (60.0, 170.0, 20.0, 50.0);
    let pw = w - l - r;
    let ph = h - t - bm;
    let x = |v: f64| l + v.clamp(0.0, 1.0) * pw;
    let y = |v: f64| t + (1.0 - v.clamp(0.0, 1.0)) * ph;
    let mut s = format!(
        "<svg id=\"sweep-scatter\" xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" \
         font-family=\"sans-serif\" font-size=\"12\">\n<rect x=\"{l}\" y=\"{t}\" width=\"{pw}\" height=\"{ph}\" fill=\"white\" stroke=\"#888\"/>\n"
    );
    for i in 0..=10 {
        let v = f64::from(i) / 10.0;
        let _ = writeln!(
            s,
            "<line x1=\"{0}\" y1=\"{t}\" x2=\"{0}\" y2=\"{1}\" stroke=\"#eee\"/><line x1=\"{l}\" y1=\"{2}\" x2=\"{3}\" y2=\"{2}\" stroke=\"#eee\"/>\
             <text x=\"{0}\" y=\"{4}\" text-anchor=\"middle\">{v:.1}</text><text x=\"{5}\" y=\"{6}\" text-anchor=\"end\">{v:.1}</text>",
            x(v),
            t + ph,
            y(v),
            l + pw,
            t + ph + 16.0,
            l - 6.0,
            y(v) + 4.0
        );
    }
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">false-alarm rate</text>\
         <text transform=\"translate(16 {}) rotate(-90)\" text-anchor=\"middle\">hit rate</text>",
        l + pw / 2.0,
        h - 10.0,
        t + ph / 2.0
    );
    let mut detectors: Vec<&str> = points.iter().map(|p| p.detector.as_str()).collect();
    detectors.dedup();
    let mut seen = Vec::new();
    for d in detectors {
        if !seen.contains(&d) {
            seen.push(d);
        }
    }
    let colour = |d: &str| {
        let c = palette(seen.iter().position(|s| *s == d).unwrap_or(0));
        format!("rgb({},{},{})", c.0, c.1, c.2)
    };
    for (i, d) in seen.iter().enumerate() {
        let ly = t + 10.0 + 18.0 * i as f64;
        let _ = writeln!(
            s,
            "<circle cx=\"{}\" cy=\"{ly}\" r=\"5\" fill=\"{}\"/><text x=\"{}\" y=\"{}\">{}</text>",
            l + pw + 16.0,
            colour(d),
            l + pw + 26.0,
            ly + 4.0,
            escape(d)
        );
    }
    // best rank last, so it is drawn on top
    for p in points.iter().rev() {
        let (Some(hr), Some(fa)) = (p.hit_rate, p.false_alarm_rate) else {
            continue;
        };
        let ring = if p.rank == 1 {
            " stroke=\"black\" stroke-width=\"2\""
        } else {
            ""
        };
        let _ = writeln!(
            s,
            "<a class=\"point\" href=\"points/{}/{REPORT_HTML}\"><circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"6\" fill=\"{}\" fill-opacity=\"0.8\"{ring}>\
             <title>{} (rank {}): hit rate {}, false-alarm rate {}</title></circle></a>",
            url_segment(&p.label),
            x(fa),
            y(hr),
            colour(&p.detector),
            escape(&p.label),
            p.rank,
            pct(Some(hr)),
            pct(Some(fa))
        );
    }
    s.push_str("</svg>\n");
    s
}

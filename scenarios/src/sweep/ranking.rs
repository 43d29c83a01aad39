//! Merged point results, their ranking by the objective and the ranking as a text table.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use super::file::SweepPoint;
use super::objective::Metric;
use super::plan::SweepPlan;
use crate::metrics::EpisodeOutcome;
use crate::report::Report;

/// One point's merged result.
#[derive(Debug, Clone)]
pub struct PointResult {
    /// The point.
    pub point: SweepPoint,
    /// Its report (as `loomlab run` with its detectors file would write).
    pub report: Report,
    /// Its episodes, in suite order.
    pub outcomes: Vec<EpisodeOutcome>,
    /// The objective's value.
    pub score: Option<f64>,
    /// The objective's value over each difficulty tier's episodes (key `"0"` … `"3"`; empty when
    /// the suite states no tiers). The ranking uses [`PointResult::score`]; these show where a
    /// point wins or loses.
    pub tier_scores: BTreeMap<String, Option<f64>>,
    /// Whether it keeps the false-alarm budget (always true for the threshold-free metrics).
    pub feasible: bool,
}

/// Indices of `results` best first: points within the budget before the others, then by score
/// (undefined scores last), ties in point order.
pub fn rank(results: &[PointResult], metric: Metric) -> Vec<usize> {
    let mut order: Vec<usize> = (0..results.len()).collect();
    order.sort_by(|&a, &b| {
        let (ra, rb) = (&results[a], &results[b]);
        rb.feasible
            .cmp(&ra.feasible)
            .then_with(|| match (ra.score, rb.score) {
                (Some(x), Some(y)) if metric.maximise() => y.total_cmp(&x),
                (Some(x), Some(y)) => x.total_cmp(&y),
                (Some(_), None) => std::cmp::Ordering::Less,
                (None, Some(_)) => std::cmp::Ordering::Greater,
                (None, None) => std::cmp::Ordering::Equal,
            })
            .then(a.cmp(&b))
    });
    order
}

/// The ranking as a text table (the first `top` rows).
pub fn format_ranking(plan: &SweepPlan, results: &[PointResult], order: &[usize], top: usize) -> String {
    let metric = plan.file.objective.metric;
    let metric_name = serde_json::to_value(metric)
        .ok()
        .and_then(|v| v.as_str().map(String::from))
        .unwrap_or_default();
    let mut out = format!(
        "{:<4} {:<16} {:>12} {:>6} {:>6} {:>6} {:>6}  values\n",
        "rank", "point", metric_name, "hit", "FA", "coll", "AUC"
    );
    let f = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
    for (rank, &i) in order.iter().take(top).enumerate() {
        let r = &results[i];
        let s = r.report.detectors.get(&r.point.label);
        let vals = r
            .point
            .values
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(" ");
        let tiers = if r.tier_scores.is_empty() {
            String::new()
        } else {
            let per: Vec<String> = r.tier_scores.iter().map(|(t, v)| format!("{t}:{}", f(*v))).collect();
            format!("  [{metric_name} per tier {}]", per.join(" "))
        };
        let _ = writeln!(
            out,
            "{:<4} {:<16} {:>12} {:>6} {:>6} {:>6} {:>6}  {vals}{tiers}{}",
            rank + 1,
            r.point.label,
            f(r.score),
            f(s.and_then(|s| s.hit_rate)),
            f(s.and_then(|s| s.false_alarm_rate)),
            f(s.and_then(|s| s.collision_rate)),
            f(s.and_then(|s| s.auc)),
            if r.feasible { "" } else { "  (over the FA budget)" }
        );
    }
    if order.len() > top {
        let _ = writeln!(out, "… {} more in ranking.csv", order.len() - top);
    }
    out
}

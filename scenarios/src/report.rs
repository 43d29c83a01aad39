//! The suite report (`report.json`, design §7) and its terminal table.
//!
//! `report.json` layout (keys always present; unknown/absent values are `null`, never NaN):
//! ```json
//! { "loomlab_version": "0.1.0", "suite": "suites/smoke", "seed": 1, "episodes": 40,
//!   "wall_time_s": 12.5, "lead_min_s": 0.1,
//!   "detectors": { "<id>": { "episodes": 40, "hits": 18, "misses": 2, "false_alarms": 1,
//!                            "correct_rejections": 19, "hit_rate": 0.9, "false_alarm_rate": 0.05,
//!                            "collisions": 2, "collision_rate": 0.05,
//!                            "hit_rate_ci": {"lower": …, "upper": …}, …, "mean_lead_s": 0.4,
//!                            "mean_angular_size_at_alarm_deg": 11.2, "auc": 0.97, "roc": [ … ] } },
//!   "scenarios": { "<name>": { "episodes": 20, "detectors": { "<id>": { …same… } } } } }
//! ```
//! `detectors.<id>` pools every episode of the suite; `scenarios.<name>.detectors.<id>` only that
//! scenario's. See [`crate::metrics`] for the definitions.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::metrics::{DetectorEpisode, DetectorSummary, EpisodeOutcome, ScoringError, summarize_by_detector};
use crate::stats::Interval;

/// The loomlab version written into reports.
pub const LOOMLAB_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Run metadata the runner provides for a report.
#[derive(Debug, Clone, PartialEq)]
pub struct ReportMeta {
    /// The suite as given on the command line (folder or file list).
    pub suite: String,
    /// The suite's base seed.
    pub seed: u64,
    /// Wall-clock time of the run in seconds.
    pub wall_time_s: f64,
    /// The `lead_min_s` the episodes were scored with.
    pub lead_min_s: f64,
}

/// Scores of one scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScenarioSummary {
    /// Number of episodes of this scenario.
    pub episodes: u64,
    /// Per-detector summaries over this scenario's episodes.
    pub detectors: BTreeMap<String, DetectorSummary>,
}

/// The whole suite's report, serialised as `report.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// Version of loomlab that wrote the report.
    pub loomlab_version: String,
    /// The suite that was run.
    pub suite: String,
    /// The suite's base seed.
    pub seed: u64,
    /// Number of episodes (each may have run several detectors).
    pub episodes: u64,
    /// Wall-clock time of the run in seconds.
    pub wall_time_s: f64,
    /// Minimal warning time the episodes were scored with.
    pub lead_min_s: f64,
    /// Per-detector summaries over all episodes.
    pub detectors: BTreeMap<String, DetectorSummary>,
    /// Per-scenario, per-detector summaries.
    pub scenarios: BTreeMap<String, ScenarioSummary>,
}

fn finite_or_zero(x: f64) -> f64 {
    if x.is_finite() { x } else { 0.0 }
}

impl Report {
    /// Aggregate scored episodes into a report (non-finite metadata times are written as 0).
    pub fn from_episodes(meta: &ReportMeta, episodes: &[EpisodeOutcome]) -> Self {
        let mut by_scenario: BTreeMap<&str, Vec<EpisodeOutcome>> = BTreeMap::new();
        for e in episodes {
            by_scenario.entry(&e.scenario).or_default().push(e.clone());
        }
        let scenarios = by_scenario
            .into_iter()
            .map(|(name, eps)| {
                let summary = ScenarioSummary {
                    episodes: eps.len() as u64,
                    detectors: summarize_by_detector(&eps),
                };
                (name.to_string(), summary)
            })
            .collect();
        Self {
            loomlab_version: LOOMLAB_VERSION.to_string(),
            suite: meta.suite.clone(),
            seed: meta.seed,
            episodes: episodes.len() as u64,
            wall_time_s: finite_or_zero(meta.wall_time_s),
            lead_min_s: finite_or_zero(meta.lead_min_s),
            detectors: summarize_by_detector(episodes),
            scenarios,
        }
    }

    /// Pretty JSON text of the report.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a Report always serialises (string keys, no maps of floats)")
    }

    /// Parse report JSON text; `origin` names the source in errors.
    pub fn from_json(text: &str, origin: &Path) -> Result<Self, ScoringError> {
        serde_json::from_str(text).map_err(|e| ScoringError::Json {
            path: origin.to_path_buf(),
            reason: e.to_string(),
        })
    }

    /// Write `report.json` (pretty, trailing newline).
    pub fn write_json(&self, path: &Path) -> Result<(), ScoringError> {
        std::fs::write(path, self.to_json() + "\n").map_err(|source| ScoringError::Io {
            path: path.into(),
            source,
        })
    }

    /// Read a `report.json` (e.g. a regression baseline).
    pub fn read_json(path: &Path) -> Result<Self, ScoringError> {
        let text = std::fs::read_to_string(path).map_err(|source| ScoringError::Io {
            path: path.into(),
            source,
        })?;
        Self::from_json(&text, path)
    }

    /// The terminal summary: the pooled table, then (if `per_scenario`) one table per scenario.
    pub fn format_table(&self, per_scenario: bool) -> String {
        let mut out = format!(
            "suite {} — {} episodes, {:.1} s\n",
            self.suite, self.episodes, self.wall_time_s
        );
        out += &format_summary_table(&self.detectors);
        if per_scenario {
            for (name, s) in &self.scenarios {
                let _ = write!(out, "\nscenario {name} ({} episodes)\n", s.episodes);
                out += &format_summary_table(&s.detectors);
            }
        }
        out
    }
}

/// All detector episodes of `episodes` for detector `id` (helper for plots).
pub fn detector_episodes<'a>(episodes: &'a [EpisodeOutcome], id: &'a str) -> impl Iterator<Item = &'a DetectorEpisode> {
    episodes
        .iter()
        .flat_map(|e| e.detectors.iter())
        .filter(move |d| d.detector == id)
}

fn fmt_rate(rate: Option<f64>, ci: Option<Interval>) -> String {
    match (rate, ci) {
        (Some(r), Some(ci)) => format!("{r:.2} [{:.2}, {:.2}]", ci.lower, ci.upper),
        (Some(r), None) => format!("{r:.2}"),
        _ => "n/a".into(),
    }
}

fn fmt_opt(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "n/a".into(), |v| format!("{v:.digits$}"))
}

/// Aligned table: detector, episodes, hit rate [95 % CI], FA rate [95 % CI], collision rate, AUC.
pub fn format_summary_table(detectors: &BTreeMap<String, DetectorSummary>) -> String {
    let header = [
        "detector",
        "episodes",
        "hit rate [95% CI]",
        "FA rate [95% CI]",
        "collision rate",
        "AUC",
    ];
    let rows: Vec<[String; 6]> = detectors
        .iter()
        .map(|(id, s)| {
            [
                id.clone(),
                s.episodes.to_string(),
                fmt_rate(s.hit_rate, s.hit_rate_ci),
                fmt_rate(s.false_alarm_rate, s.false_alarm_rate_ci),
                fmt_opt(s.collision_rate, 2),
                fmt_opt(s.auc, 3),
            ]
        })
        .collect();
    let mut widths = header.map(|h| h.chars().count());
    for row in &rows {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let mut out = String::new();
    let mut line = |cells: &[String]| {
        let parts: Vec<String> = cells
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let pad = widths[i] - c.chars().count();
                // Text left-aligned in the first column, numbers right-aligned elsewhere.
                if i == 0 {
                    format!("{c}{}", " ".repeat(pad))
                } else {
                    format!("{}{c}", " ".repeat(pad))
                }
            })
            .collect();
        out += parts.join("  ").trim_end();
        out.push('\n');
    };
    line(&header.map(String::from));
    line(&widths.map(|w| "-".repeat(w)));
    for row in &rows {
        line(row);
    }
    out
}

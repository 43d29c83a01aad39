//! The suite report (`report.json`, design §7) and its terminal table.
//!
//! `report.json` layout (keys always present; unknown/absent values are `null`, never NaN):
//! ```json
//! { "loomlab_version": "0.1.0", "suite": "suites/smoke", "seed": 1, "episodes": 40,
//!   "wall_time_s": 12.5, "lead_margin_s": 0.0, "references": ["null", "oracle", "ideal_theta", "ideal_tau", "ideal_course"],
//!   "detectors": { "<id>": { "episodes": 40, "hits": 18, "misses": 2, "false_alarms": 1,
//!                            "correct_rejections": 19, "hit_rate": 0.9, "false_alarm_rate": 0.05,
//!                            "collisions": 2, "collision_rate": 0.05,
//!                            "hit_rate_ci": {"lower": …, "upper": …}, …, "mean_lead_s": 0.4,
//!                            "mean_angular_size_at_alarm_deg": 11.2, "auc": 0.97, "roc": [ … ] } },
//!   "scenarios": { "<name>": { "episodes": 20, "detectors": { "<id>": { …same… } },
//!                              "theta_required_deg": { "count": 9, "min": …, "p10": …, "p25": …,
//!                                                      "median": …, "p75": …, "p90": …, "max": … } } } }
//! ```
//! `tiers` pools the episodes of each difficulty tier ([`crate::tier`]; `{}` when no scenario
//! states one): `"tiers": { "0": { "episodes": 90, "threats": 40, "non_threats": 50,
//! "evadable_threats": 38, "detectors": { "<id>": { …same keys as detectors.<id>… } } }, … }`.
//! `detectors.<id>` pools every episode of the suite; `scenarios.<name>.detectors.<id>` only that
//! scenario's. The reference rows (`null`, `oracle`, `ideal_theta`, `ideal_tau`, `ideal_course`, see [`crate::reference`]) sit
//! beside the detectors and are listed in `references`. Every summary also carries the escape
//! fields (`evadable_threats`, `unavoidable_threats`, `evaded`, `evasion_rate`, `late_misses`,
//! `silent_misses`, `hit_collisions`, `retriggered_hit_collisions`, `false_alarm_collisions`,
//! `collisions_caused`, `collisions_caused_rate`, `collisions_caused_rate_ci`,
//! `collision_reduction`), `lv_fit` and `theta_accuracy`. See [`crate::metrics`] for the
//! definitions.

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
    /// The `lead_margin_s` the episodes were scored with.
    pub lead_margin_s: f64,
}

/// Scores of one scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScenarioSummary {
    /// Number of episodes of this scenario.
    pub episodes: u64,
    /// Per-detector summaries over this scenario's episodes.
    pub detectors: BTreeMap<String, DetectorSummary>,
    /// Distribution of `theta_required_deg` (the true angular size of each evadable threat at its
    /// escape deadline) over this scenario's episodes (`None`: no evadable threat).
    #[serde(default)]
    pub theta_required_deg: Option<Distribution>,
}

/// Scores of one difficulty tier (every episode of the scenarios with that `tier`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TierSummary {
    /// Number of episodes of this tier.
    pub episodes: u64,
    /// Threats among them (evadable and unavoidable).
    pub threats: u64,
    /// Non-threats among them.
    pub non_threats: u64,
    /// Threats that some trigger time evades.
    pub evadable_threats: u64,
    /// Per-detector (and reference-row) summaries over this tier's episodes.
    pub detectors: BTreeMap<String, DetectorSummary>,
}

impl TierSummary {
    /// Pools `episodes` (all of one tier).
    pub fn of(episodes: &[EpisodeOutcome]) -> Self {
        let detectors = summarize_by_detector(episodes);
        let (threats, non_threats, evadable_threats) = detectors.values().next().map_or((0, 0, 0), |s| {
            (
                s.hits + s.misses + s.unavoidable_threats,
                s.false_alarms + s.correct_rejections,
                s.evadable_threats,
            )
        });
        Self {
            episodes: episodes.len() as u64,
            threats,
            non_threats,
            evadable_threats,
            detectors,
        }
    }
}

/// Quantiles of a sample (linear interpolation between order statistics).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Distribution {
    /// Sample size.
    pub count: u64,
    /// Smallest value.
    pub min: f64,
    /// 10th percentile.
    pub p10: f64,
    /// 25th percentile.
    pub p25: f64,
    /// Median.
    pub median: f64,
    /// 75th percentile.
    pub p75: f64,
    /// 90th percentile.
    pub p90: f64,
    /// Largest value.
    pub max: f64,
}

impl Distribution {
    /// The quantiles of the finite values of `values` (`None` when there are none).
    pub fn of(values: impl IntoIterator<Item = f64>) -> Option<Self> {
        let mut v: Vec<f64> = values.into_iter().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let q = |p: f64| {
            let x = p * (v.len() - 1) as f64;
            let (lo, hi) = (x.floor() as usize, x.ceil() as usize);
            v[lo] + (v[hi] - v[lo]) * (x - lo as f64)
        };
        Some(Self {
            count: v.len() as u64,
            min: v[0],
            p10: q(0.1),
            p25: q(0.25),
            median: q(0.5),
            p75: q(0.75),
            p90: q(0.9),
            max: v[v.len() - 1],
        })
    }
}

/// The `theta_required_deg` of each episode that has one (read from its first row).
pub fn theta_required(episodes: &[EpisodeOutcome]) -> impl Iterator<Item = f64> + '_ {
    episodes
        .iter()
        .filter_map(|e| e.detectors.iter().find_map(|d| d.theta_required_deg))
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
    /// Margin before the escape deadline the episodes were scored with (s).
    pub lead_margin_s: f64,
    /// Labels of the reference rows among `detectors` (computed from ground truth).
    #[serde(default)]
    pub references: Vec<String>,
    /// Per-detector summaries over all episodes.
    pub detectors: BTreeMap<String, DetectorSummary>,
    /// Per-scenario, per-detector summaries.
    pub scenarios: BTreeMap<String, ScenarioSummary>,
    /// Per-tier summaries, keyed by the tier (`"0"` … `"3"`); empty when no scenario states one.
    #[serde(default)]
    pub tiers: BTreeMap<String, TierSummary>,
    /// The sensor profile the worlds ran under (`loomlab run --sensor`, a suite's `sensor` key);
    /// absent: each scenario file's own sensor (the ideal camera unless it sets one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor_profile: Option<String>,
}

/// The reference labels that occur in `episodes`, in table order.
fn present_references(episodes: &[EpisodeOutcome]) -> Vec<String> {
    crate::reference::REFERENCE_LABELS
        .iter()
        .filter(|r| episodes.iter().any(|e| e.detectors.iter().any(|d| d.detector == **r)))
        .map(|r| r.to_string())
        .collect()
}

fn finite_or_zero(x: f64) -> f64 {
    if x.is_finite() { x } else { 0.0 }
}

impl Report {
    /// Aggregate scored episodes into a report (non-finite metadata times are written as 0),
    /// without tiers (`tiers` is empty; see [`Report::from_tiered_episodes`]).
    pub fn from_episodes(meta: &ReportMeta, episodes: &[EpisodeOutcome]) -> Self {
        Self::from_tiered_episodes(meta, episodes, &BTreeMap::new())
    }

    /// Aggregate scored episodes into a report with per-tier summaries: `tiers` maps a scenario
    /// name to its difficulty tier (e.g. [`crate::Suite::tiers`]); episodes of scenarios not in it
    /// count in the pooled and per-scenario summaries only.
    pub fn from_tiered_episodes(meta: &ReportMeta, episodes: &[EpisodeOutcome], tiers: &BTreeMap<String, u8>) -> Self {
        let mut by_tier: BTreeMap<u8, Vec<EpisodeOutcome>> = BTreeMap::new();
        for e in episodes {
            if let Some(t) = tiers.get(&e.scenario) {
                by_tier.entry(*t).or_default().push(e.clone());
            }
        }
        let tiers = by_tier
            .into_iter()
            .map(|(t, eps)| (t.to_string(), TierSummary::of(&eps)))
            .collect();
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
                    theta_required_deg: Distribution::of(theta_required(&eps)),
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
            lead_margin_s: finite_or_zero(meta.lead_margin_s),
            references: present_references(episodes),
            detectors: summarize_by_detector(episodes),
            sensor_profile: None,
            scenarios,
            tiers,
        }
    }

    /// The tiers of the report as numbers with their summaries, in tier order.
    pub fn tier_summaries(&self) -> impl Iterator<Item = (u8, &TierSummary)> {
        self.tiers.iter().filter_map(|(k, v)| Some((k.parse().ok()?, v)))
    }

    /// Pretty JSON text of the report.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a Report always serialises (string keys, no maps of floats)")
    }

    /// Parse report JSON text; `origin` names the source in errors. The collisions caused by each
    /// row's manoeuvres are derived again from the counts every report carries
    /// ([`DetectorSummary::derive_collisions_caused`]), so that reports written before those keys
    /// existed (committed baselines) read with the right numbers rather than zeros.
    pub fn from_json(text: &str, origin: &Path) -> Result<Self, ScoringError> {
        let mut report: Self = serde_json::from_str(text).map_err(|e| ScoringError::Json {
            path: origin.to_path_buf(),
            reason: e.to_string(),
        })?;
        let summaries = report
            .detectors
            .values_mut()
            .chain(report.scenarios.values_mut().flat_map(|s| s.detectors.values_mut()))
            .chain(report.tiers.values_mut().flat_map(|t| t.detectors.values_mut()));
        for s in summaries {
            s.derive_collisions_caused();
        }
        Ok(report)
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
        for (t, s) in self.tier_summaries() {
            let _ = write!(
                out,
                "\ntier {t} ({}; {} episodes): {}\n",
                crate::tier::tier_name(t),
                s.episodes,
                crate::tier::TIER_DESCRIPTIONS
                    .get(t as usize)
                    .copied()
                    .unwrap_or_default()
            );
            out += &format_summary_table(&s.detectors);
        }
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

/// Aligned table: the detectors, then the reference rows (marked `*`): episodes, hit rate
/// [95 % CI], false-alarm rate [95 % CI], evasion rate [95 % CI], collision rate, collision
/// reduction against `null`, hits that collided, the collisions the row's own manoeuvres caused
/// (false alarms + hits that collided), AUC; a first line counts the threats.
pub fn format_summary_table(detectors: &BTreeMap<String, DetectorSummary>) -> String {
    let header = [
        "detector",
        "episodes",
        "hit rate [95% CI]",
        "FA rate [95% CI]",
        "evasion rate [95% CI]",
        "collision rate",
        "coll. reduction",
        "hit+coll (retrig.)",
        "caused coll. (FA+hit)",
        "AUC",
    ];
    let is_ref = |id: &str| crate::reference::is_reference(id);
    let ordered = detectors.iter().filter(|(id, _)| !is_ref(id)).chain(
        crate::reference::REFERENCE_LABELS
            .iter()
            .filter_map(|r| detectors.get_key_value(*r)),
    );
    let rows: Vec<[String; 10]> = ordered
        .map(|(id, s)| {
            [
                if is_ref(id) { format!("{id} *") } else { id.clone() },
                s.episodes.to_string(),
                fmt_rate(s.hit_rate, s.hit_rate_ci),
                fmt_rate(s.false_alarm_rate, s.false_alarm_rate_ci),
                fmt_rate(s.evasion_rate, s.evasion_rate_ci),
                fmt_opt(s.collision_rate, 2),
                fmt_opt(s.collision_reduction, 2),
                format!("{} ({})", s.hit_collisions, s.retriggered_hit_collisions),
                format!(
                    "{} ({}+{})",
                    s.collisions_caused, s.false_alarm_collisions, s.hit_collisions
                ),
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
    if let Some(s) = detectors.values().next() {
        let threats = s.hits + s.misses + s.unavoidable_threats;
        out += &format!(
            "{threats} threats ({} evadable, {} unavoidable), {} non-threats\n",
            s.evadable_threats,
            s.unavoidable_threats,
            s.false_alarms + s.correct_rejections
        );
    }
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
    if detectors.keys().any(|id| is_ref(id)) {
        out += "* reference row from ground truth (null: never alarms; oracle: alarms at each escape deadline; \
                ideal_theta: true angular size of a moving object >= the hopfield threshold; ideal_tau: \
                time to contact from each object's true angular size; ideal_course: ideal_tau behind the \
                collision-course gate on the true image)\n";
    }
    out
}

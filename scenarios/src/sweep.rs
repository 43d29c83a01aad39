//! Detector-parameter sweeps: a suite × a grid (or seeded random search) of detector settings,
//! cut into shards that can run anywhere, and merged into one report per parameter point.
//!
//! A sweep file (documented in `scenarios/README.md`, example in `sweeps/`):
//!
//! ```toml
//! name = "hopfield_alpha"                 # default: the file name; output folder out/sweep/<name>
//! suite = "../scenarios/suites/default"   # relative to this file
//! seed = 0                                # suite seed, as `loomlab run --seed`
//! size = 64                               # frame size, as `loomlab run --size` (optional)
//! limit = 40                              # the first N episodes only, as `--limit` (optional)
//! episodes_per_shard = 8                  # default 16
//! points_per_shard = 0                    # parameter points per shard, 0 = all (default)
//! search_seed = 0                         # seeds the [random] draws
//!
//! [objective]
//! metric = "roc_hit_rate"                 # see [`Metric`]
//! false_alarm_budget = 0.1
//!
//! [[detectors]]                           # a scenario [[detectors]] entry ...
//! id = "hopfield"
//! threshold = 10.0
//! [detectors.sweep]                       # ... with the scenario [sweep] / [random] syntax
//! threshold = [6.0, 10.0, 14.0]
//! "params.alpha" = [0.8, 0.9]
//! ```
//!
//! Every parameter point becomes a labelled detector (`hopfield-003`), and all points of a shard
//! watch the same rendered frames of an episode. A point's report is built from exactly the rows
//! `loomlab run SUITE --seed S --size N --limit L --detectors-file points/<label>/detectors.toml`
//! writes, in the same order, so the two reports are identical but for `wall_time_s`.
//!
//! The output folder holds `manifest.json` (what the sweep is: its fingerprint must match to
//! resume), `shards/NNNNN.csv` (episodes.csv rows of finished shards, written atomically: a file
//! that exists is complete), and after merging `points/<label>/{report.json, episodes.csv,
//! detectors.toml}`, `ranking.csv` and `summary.json`.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use toml::{Table, Value};

use crate::episodes_csv::{format_rows, header_line, parse_episodes_csv, quote};
use crate::error::{RunError, ScenarioError};
use crate::expand::{KeyPath, KeySegment, Variation, mix_seed};
use crate::fingerprint::Fingerprint;
use crate::metrics::{DetectorEpisode, DetectorSummary, EpisodeOutcome, ScoringError};
use crate::reference::is_reference;
use crate::report::{LOOMLAB_VERSION, Report, ReportMeta};
use crate::runner::Runner;
use crate::schema::{DetectorDesc, EpisodeSpec, LoadOptions, default_camera, resolve_detector, typed};
use crate::suite::load_suite;

/// Most parameter points one sweep may expand to.
pub const MAX_POINTS: usize = 10_000;

/// An error of a sweep: its file, its output folder or one of its shards.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The sweep file or the suite it names is invalid (names the file and key).
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// Reading or writing the output folder failed.
    #[error("{path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The output folder holds another sweep (or a damaged one).
    #[error("{path}: {reason}")]
    OutDir {
        /// The output folder or the file in it.
        path: PathBuf,
        /// What is wrong and how to fix it.
        reason: String,
    },
    /// A shard index out of range, or a shard's rows that do not match the plan.
    #[error("shard {shard}: {reason}")]
    Shard {
        /// Shard index.
        shard: usize,
        /// What is wrong.
        reason: String,
    },
    /// An episode failed to run.
    #[error(transparent)]
    Run(#[from] RunError),
    /// A shard file could not be parsed, or a report not written.
    #[error(transparent)]
    Scoring(#[from] ScoringError),
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> SweepError + '_ {
    move |source| SweepError::Io {
        path: path.into(),
        source,
    }
}

/// What the sweep optimises (`[objective] metric`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Metric {
    /// Best hit rate over all thresholds with a false-alarm rate ≤ `false_alarm_budget`, read off
    /// the ROC curve (threshold-free: ranks the detector's parameters, not its threshold).
    RocHitRate,
    /// Area under the ROC curve (threshold-free).
    Auc,
    /// Hit rate at the point's threshold (with `false_alarm_budget`: points above it rank last).
    HitRate,
    /// Hit rate − false-alarm rate at the point's threshold (Youden's J).
    Youden,
    /// Closed-loop escape rate: evaded / evadable threats at the point's threshold.
    EvasionRate,
    /// Closed-loop collision rate (lower is better).
    CollisionRate,
    /// False-alarm rate (lower is better).
    FalseAlarmRate,
}

impl Metric {
    /// Whether larger values are better.
    pub fn maximise(self) -> bool {
        !matches!(self, Self::CollisionRate | Self::FalseAlarmRate)
    }

    /// The metric's value for a summary (`None` where it is undefined, e.g. no threats).
    pub fn value(self, s: &DetectorSummary, budget: Option<f64>) -> Option<f64> {
        match self {
            Self::RocHitRate => {
                let budget = budget.unwrap_or(1.0);
                s.roc
                    .iter()
                    .filter(|p| p.fpr <= budget + 1e-12)
                    .map(|p| p.tpr)
                    .max_by(f64::total_cmp)
            }
            Self::Auc => s.auc,
            Self::HitRate => s.hit_rate,
            Self::Youden => Some(s.hit_rate? - s.false_alarm_rate?),
            Self::EvasionRate => s.evasion_rate,
            Self::CollisionRate => s.collision_rate,
            Self::FalseAlarmRate => s.false_alarm_rate,
        }
    }
}

/// `[objective]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Objective {
    /// The metric (default `roc_hit_rate`).
    #[serde(default = "d_metric")]
    pub metric: Metric,
    /// False-alarm budget in [0, 1] (default 0.1): the ROC operating point of `roc_hit_rate`, a
    /// constraint for the other metrics (points above it rank after every point within it).
    #[serde(default = "d_budget")]
    pub false_alarm_budget: Option<f64>,
}

fn d_metric() -> Metric {
    Metric::RocHitRate
}
fn d_budget() -> Option<f64> {
    Some(0.1)
}

impl Default for Objective {
    fn default() -> Self {
        Self {
            metric: d_metric(),
            false_alarm_budget: d_budget(),
        }
    }
}

fn d_eps_per_shard() -> usize {
    16
}

/// The typed top level of a sweep file (`detectors` is expanded separately).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SweepDoc {
    #[serde(default)]
    name: Option<String>,
    suite: PathBuf,
    #[serde(default)]
    seed: u64,
    #[serde(default)]
    size: Option<u32>,
    #[serde(default)]
    limit: Option<usize>,
    #[serde(default = "d_eps_per_shard")]
    episodes_per_shard: usize,
    #[serde(default)]
    points_per_shard: usize,
    #[serde(default)]
    search_seed: u64,
    #[serde(default)]
    objective: Objective,
    #[serde(default)]
    detectors: Vec<Value>,
}

/// One parameter point: a labelled `[[detectors]]` entry.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepPoint {
    /// Label in reports and folder names (`<id or entry label>-<index within the entry>`).
    pub label: String,
    /// The detector entry, `label` set.
    pub detector: DetectorDesc,
    /// The swept / drawn values of this point (`key path → TOML value text`).
    pub values: BTreeMap<String, String>,
}

/// A parsed sweep file.
#[derive(Debug, Clone)]
pub struct SweepFile {
    /// Sweep name (output folder name).
    pub name: String,
    /// The sweep file.
    pub path: PathBuf,
    /// The suite (resolved against the sweep file's folder).
    pub suite: PathBuf,
    /// Suite seed.
    pub seed: u64,
    /// Frame size override.
    pub size: Option<u32>,
    /// Run only the first `limit` episodes.
    pub limit: Option<usize>,
    /// Episodes per shard.
    pub episodes_per_shard: usize,
    /// Points per shard (0: all).
    pub points_per_shard: usize,
    /// The ranking objective.
    pub objective: Objective,
    /// Every parameter point, entry by entry.
    pub points: Vec<SweepPoint>,
}

fn key_err(path: &Path, key: impl Into<String>, reason: impl Into<String>) -> SweepError {
    SweepError::Scenario(ScenarioError::key(path, key, reason))
}

/// Creates the tables on the way to every varied key of an entry, so that `params.alpha` can be
/// swept without writing `params = {}` first.
fn create_varied_tables(entry: &mut Table) {
    let mut keys: Vec<String> = Vec::new();
    for section in ["sweep", "random"] {
        if let Some(Value::Table(t)) = entry.get(section) {
            keys.extend(
                t.keys()
                    .filter(|k| k.as_str() != "samples")
                    .flat_map(|k| k.split(',').map(|s| s.trim().to_string())),
            );
        }
    }
    for key in keys {
        let Ok(path) = KeyPath::parse(&key) else { continue };
        let mut cur = &mut *entry;
        for seg in &path.0[..path.0.len().saturating_sub(1)] {
            let KeySegment::Key(k) = seg else { break };
            let next = cur.entry(k.clone()).or_insert_with(|| Value::Table(Table::new()));
            let Value::Table(t) = next else { break };
            cur = t;
        }
    }
}

impl SweepFile {
    /// Parses sweep text; `path` names the file in errors and anchors the suite path.
    pub fn parse(text: &str, path: &Path) -> Result<Self, SweepError> {
        let tree: Table = toml::from_str(text).map_err(|e| ScenarioError::Syntax {
            path: path.into(),
            message: e.to_string().trim_end().to_string(),
        })?;
        let doc: SweepDoc = typed(Value::Table(tree), "").map_err(|(k, r)| key_err(path, k, r))?;
        if doc.episodes_per_shard == 0 {
            return Err(key_err(path, "episodes_per_shard", "must be at least 1"));
        }
        if doc.limit == Some(0) {
            return Err(key_err(
                path,
                "limit",
                "must be at least 1 (or left out for every episode)",
            ));
        }
        if let Some(b) = doc.objective.false_alarm_budget
            && !(0.0..=1.0).contains(&b)
        {
            return Err(key_err(
                path,
                "objective.false_alarm_budget",
                format!("{b} must be a rate in [0, 1]"),
            ));
        }
        if doc.detectors.is_empty() {
            return Err(key_err(
                path,
                "detectors",
                "no [[detectors]] entries; give at least one (id, and a [detectors.sweep] or [detectors.random] table)",
            ));
        }
        let mut points: Vec<SweepPoint> = Vec::new();
        for (i, entry) in doc.detectors.into_iter().enumerate() {
            let here = |k: &str| format!("detectors[{i}].{k}");
            let Value::Table(mut entry) = entry else {
                return Err(key_err(path, format!("detectors[{i}]"), "must be a table"));
            };
            create_varied_tables(&mut entry);
            let variation = Variation::take_from(&mut entry).map_err(|(k, r)| key_err(path, here(&k), r))?;
            if variation.points() > MAX_POINTS {
                return Err(key_err(
                    path,
                    format!("detectors[{i}]"),
                    format!("expands to more than {MAX_POINTS} points; sweep fewer values"),
                ));
            }
            let prefix = match entry.get("label") {
                Some(Value::String(s)) => {
                    crate::schema::check_file_name(s)
                        .map_err(|r| key_err(path, format!("detectors[{i}].label"), format!("{s:?}: {r}")))?;
                    s.clone()
                }
                _ => entry
                    .get("id")
                    .and_then(Value::as_str)
                    .unwrap_or("detector")
                    .to_string(),
            };
            for (k, (table, values)) in variation
                .expand(&entry, mix_seed(doc.search_seed, i as u64))
                .enumerate()
            {
                let mut desc: DetectorDesc =
                    typed(Value::Table(table), &format!("detectors[{i}]")).map_err(|(k, r)| key_err(path, k, r))?;
                let label = format!("{prefix}-{k:03}");
                desc.label = Some(label.clone());
                // Check the point (values out of range name the point and its values).
                resolve_detector(&desc, default_camera(doc.size.unwrap_or(64) as usize)).map_err(|(key, r)| {
                    let vals = values
                        .iter()
                        .map(|(k, v)| format!("{k} = {v}"))
                        .collect::<Vec<_>>()
                        .join(", ");
                    key_err(path, here(&key), format!("point {label} ({vals}): {r}"))
                })?;
                if points.iter().any(|p| p.label == label) {
                    return Err(key_err(
                        path,
                        here("label"),
                        format!("points labelled `{label}` come from two entries; give the entries different `label`s"),
                    ));
                }
                points.push(SweepPoint {
                    label,
                    detector: desc,
                    values,
                });
            }
        }
        if points.len() > MAX_POINTS {
            return Err(key_err(
                path,
                "detectors",
                format!("more than {MAX_POINTS} points in all"),
            ));
        }
        let name = match doc.name {
            Some(n) => {
                crate::schema::check_file_name(&n).map_err(|r| key_err(path, "name", format!("{n:?}: {r}")))?;
                n
            }
            None => path
                .file_stem()
                .map_or_else(|| "sweep".into(), |s| s.to_string_lossy().into_owned()),
        };
        let suite = if doc.suite.is_absolute() {
            doc.suite
        } else {
            path.parent().unwrap_or(Path::new("")).join(doc.suite)
        };
        Ok(Self {
            name,
            path: path.into(),
            suite,
            seed: doc.seed,
            size: doc.size,
            limit: doc.limit,
            episodes_per_shard: doc.episodes_per_shard,
            points_per_shard: doc.points_per_shard,
            objective: doc.objective,
            points,
        })
    }

    /// Reads and parses a sweep file.
    pub fn load(path: &Path) -> Result<Self, SweepError> {
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
            path: path.into(),
            source,
        })?;
        Self::parse(&text, path)
    }
}

/// One shard: a block of episodes × a block of parameter points.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Shard {
    /// Episodes (indices into the plan's episode list).
    pub episodes: Range<usize>,
    /// Points (indices into the sweep's points).
    pub points: Range<usize>,
}

/// A sweep ready to run: the file, its expanded episodes (every point as a detector) and shards.
#[derive(Debug, Clone)]
pub struct SweepPlan {
    /// The sweep file.
    pub file: SweepFile,
    /// The episodes in suite order (after `limit`), each with every point as a detector.
    pub episodes: Vec<EpisodeSpec>,
    /// The shards, episode block outer, point block inner.
    pub shards: Vec<Shard>,
    /// Hex fingerprint of everything that determines the results (loomlab version, points,
    /// episodes, shards): a resumed sweep must have the same.
    pub fingerprint: String,
    /// The difficulty tier of each scenario of the suite that states one (by scenario name): each
    /// point's report pools them (`tiers`) and its objective is also scored per tier.
    pub tiers: BTreeMap<String, u8>,
}

impl SweepPlan {
    /// Loads the suite of a parsed sweep file and cuts it into shards.
    pub fn new(file: SweepFile) -> Result<Self, SweepError> {
        let opts = LoadOptions {
            seed: file.seed,
            size: file.size,
            detectors: None,
            detector_entries: Some(file.points.iter().map(|p| p.detector.clone()).collect()),
            ..Default::default()
        };
        let suite = load_suite(&file.suite, &opts)?;
        let episodes: Vec<EpisodeSpec> = suite
            .episodes()
            .take(file.limit.unwrap_or(usize::MAX))
            .collect::<Result<_, _>>()?;
        let per_points = if file.points_per_shard == 0 {
            file.points.len()
        } else {
            file.points_per_shard
        };
        let mut shards = Vec::new();
        for e in (0..episodes.len()).step_by(file.episodes_per_shard) {
            for p in (0..file.points.len()).step_by(per_points) {
                shards.push(Shard {
                    episodes: e..(e + file.episodes_per_shard).min(episodes.len()),
                    points: p..(p + per_points).min(file.points.len()),
                });
            }
        }
        // What determines the rows: the version, the points, every episode as built, the shards.
        let mut fingerprint = Fingerprint::new();
        fingerprint.add(format!("{LOOMLAB_VERSION}\n").as_bytes());
        fingerprint.add(serde_json::to_string(&file.points).unwrap_or_default().as_bytes());
        for ep in &episodes {
            fingerprint.add_episode(ep);
        }
        fingerprint.add(serde_json::to_string(&shards).unwrap_or_default().as_bytes());
        let fingerprint = fingerprint.hex();
        let tiers = suite.tiers();
        Ok(Self {
            file,
            episodes,
            shards,
            fingerprint,
            tiers,
        })
    }

    /// Parses the sweep file at `path` and plans it; `limit` overrides the file's.
    pub fn load(path: &Path, limit: Option<usize>) -> Result<Self, SweepError> {
        let mut file = SweepFile::load(path)?;
        if limit.is_some() {
            file.limit = limit;
        }
        Self::new(file)
    }

    fn shard(&self, i: usize) -> Result<&Shard, SweepError> {
        self.shards.get(i).ok_or_else(|| SweepError::Shard {
            shard: i,
            reason: format!("no such shard; the sweep has {}", self.shards.len()),
        })
    }

    /// Runs shard `i`: its episodes, each with its points as detectors. Returns the outcomes in
    /// episode order.
    pub fn run_shard(&self, runner: &Runner, i: usize) -> Result<Vec<EpisodeOutcome>, SweepError> {
        let shard = self.shard(i)?;
        let specs: Vec<EpisodeSpec> = self.episodes[shard.episodes.clone()]
            .iter()
            .map(|ep| EpisodeSpec {
                detectors: ep.detectors[shard.points.clone()].to_vec(),
                ..ep.clone()
            })
            .collect();
        let refs: Vec<&EpisodeSpec> = specs.iter().collect();
        let runs = runner.run(&refs, |_, _| Ok(()))?;
        Ok(runs.into_iter().map(|r| r.outcome).collect())
    }

    /// The shard file text of shard outcomes (the `episodes.csv` format).
    pub fn shard_csv(outcomes: &[EpisodeOutcome]) -> String {
        let mut text = header_line();
        for o in outcomes {
            text += &format_rows(o);
        }
        text
    }

    /// Parses a shard file's text and checks that it holds exactly shard `i`'s rows.
    pub fn parse_shard(&self, i: usize, text: &str, origin: &Path) -> Result<Vec<EpisodeOutcome>, SweepError> {
        let shard = self.shard(i)?;
        let outcomes = parse_episodes_csv(text, origin)?;
        let bad = |reason: String| SweepError::Shard {
            shard: i,
            reason: format!("{}: {reason}; delete the file to run the shard again", origin.display()),
        };
        if outcomes.len() != shard.episodes.len() {
            return Err(bad(format!(
                "{} episodes, the shard has {}",
                outcomes.len(),
                shard.episodes.len()
            )));
        }
        let want: Vec<&str> = self.file.points[shard.points.clone()]
            .iter()
            .map(|p| p.label.as_str())
            .collect();
        for (o, ep) in outcomes.iter().zip(&self.episodes[shard.episodes.clone()]) {
            let labels: Vec<&str> = o
                .detectors
                .iter()
                .map(|d| d.detector.as_str())
                .filter(|l| !is_reference(l))
                .collect();
            if o.scenario != ep.scenario || o.episode != ep.index || o.seed != ep.seed || labels != want {
                return Err(bad(format!(
                    "rows of {} episode {} ({labels:?}) where {} episode {} ({want:?}) belongs",
                    o.scenario, o.episode, ep.scenario, ep.index
                )));
            }
        }
        Ok(outcomes)
    }

    /// Merges every shard's outcomes (indexed by shard) into one result per point.
    pub fn merge(&self, shards: &[Vec<EpisodeOutcome>], wall_time_s: f64) -> Result<Vec<PointResult>, SweepError> {
        if shards.len() != self.shards.len() {
            return Err(SweepError::Shard {
                shard: shards.len(),
                reason: format!("{} shard results for {} shards", shards.len(), self.shards.len()),
            });
        }
        let mut per_point: Vec<Vec<EpisodeOutcome>> =
            vec![Vec::with_capacity(self.episodes.len()); self.file.points.len()];
        // Shards are episode block outer, so walking them in order keeps suite order per point.
        for (shard, outcomes) in self.shards.iter().zip(shards) {
            for o in outcomes {
                // every point's report carries the episode's reference rows, as `loomlab run` does
                let (references, rows): (Vec<&DetectorEpisode>, Vec<&DetectorEpisode>) =
                    o.detectors.iter().partition(|d| is_reference(&d.detector));
                for (p, d) in shard.points.clone().zip(rows) {
                    per_point[p].push(EpisodeOutcome {
                        detectors: std::iter::once(d).chain(references.iter().copied()).cloned().collect(),
                        ..o.clone()
                    });
                }
            }
        }
        let meta = ReportMeta {
            suite: self.file.suite.display().to_string(),
            seed: self.file.seed,
            wall_time_s,
            lead_margin_s: self.episodes.first().map_or(0.0, |e| e.scoring.lead_margin_s),
        };
        let Objective {
            metric,
            false_alarm_budget,
        } = self.file.objective;
        Ok(self
            .file
            .points
            .iter()
            .zip(per_point)
            .map(|(point, outcomes)| {
                let report = Report::from_tiered_episodes(&meta, &outcomes, &self.tiers);
                let summary = report.detectors.get(&point.label);
                let score = summary.and_then(|s| metric.value(s, false_alarm_budget));
                let tier_scores = report
                    .tiers
                    .iter()
                    .map(|(t, ts)| {
                        let v = ts
                            .detectors
                            .get(&point.label)
                            .and_then(|s| metric.value(s, false_alarm_budget));
                        (t.clone(), v)
                    })
                    .collect();
                let feasible = match (metric, false_alarm_budget, summary) {
                    (Metric::RocHitRate, _, _) | (_, None, _) => true,
                    (_, Some(b), Some(s)) => s.false_alarm_rate.is_none_or(|f| f <= b + 1e-12),
                    (_, Some(_), None) => false,
                };
                PointResult {
                    point: point.clone(),
                    report,
                    outcomes,
                    score,
                    tier_scores,
                    feasible,
                }
            })
            .collect())
    }
}

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

/// The output folder of a sweep (see the module docs for its layout).
#[derive(Debug, Clone)]
pub struct SweepDir {
    /// The folder.
    pub root: PathBuf,
}

#[derive(Debug, Serialize, Deserialize)]
struct Manifest {
    loomlab_version: String,
    sweep: String,
    fingerprint: String,
    shards: usize,
    episodes: usize,
    points: Vec<String>,
}

fn write_atomic(path: &Path, text: &str) -> Result<(), SweepError> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, text).map_err(io_err(&tmp))?;
    std::fs::rename(&tmp, path).map_err(io_err(path))
}

impl SweepDir {
    /// Opens (creating it if needed) the output folder of `plan`. A folder holding another sweep
    /// is an error unless `restart`, which deletes its shards and results first.
    pub fn open(root: &Path, plan: &SweepPlan, restart: bool) -> Result<Self, SweepError> {
        let dir = Self { root: root.into() };
        let manifest_path = root.join("manifest.json");
        if restart {
            for sub in ["shards", "points"] {
                let p = root.join(sub);
                if p.exists() {
                    std::fs::remove_dir_all(&p).map_err(io_err(&p))?;
                }
            }
        } else if manifest_path.exists() {
            let text = std::fs::read_to_string(&manifest_path).map_err(io_err(&manifest_path))?;
            let old: Manifest = serde_json::from_str(&text).map_err(|e| SweepError::OutDir {
                path: manifest_path.clone(),
                reason: format!("unreadable manifest ({e}); use --restart to start over"),
            })?;
            if old.fingerprint != plan.fingerprint {
                return Err(SweepError::OutDir {
                    path: root.into(),
                    reason: format!(
                        "holds the shards of another sweep ({}, fingerprint {}; this one is {}): the sweep \
                         file, its suite, --limit or the loomlab version changed. Use --restart to discard \
                         them, or --out for another folder",
                        old.sweep, old.fingerprint, plan.fingerprint
                    ),
                });
            }
        }
        let shards = root.join("shards");
        std::fs::create_dir_all(&shards).map_err(io_err(&shards))?;
        let manifest = Manifest {
            loomlab_version: LOOMLAB_VERSION.into(),
            sweep: plan.file.path.display().to_string(),
            fingerprint: plan.fingerprint.clone(),
            shards: plan.shards.len(),
            episodes: plan.episodes.len(),
            points: plan.file.points.iter().map(|p| p.label.clone()).collect(),
        };
        let text = serde_json::to_string_pretty(&manifest).expect("a manifest serialises");
        write_atomic(&manifest_path, &text)?;
        Ok(dir)
    }

    /// The file of shard `i`.
    pub fn shard_path(&self, i: usize) -> PathBuf {
        self.root.join("shards").join(format!("{i:05}.csv"))
    }

    /// Which shards are finished (their file exists).
    pub fn done(&self, plan: &SweepPlan) -> Vec<bool> {
        (0..plan.shards.len()).map(|i| self.shard_path(i).is_file()).collect()
    }

    /// Checks shard `i`'s rows and writes its file atomically.
    pub fn write_shard(&self, plan: &SweepPlan, i: usize, csv: &str) -> Result<(), SweepError> {
        let path = self.shard_path(i);
        plan.parse_shard(i, csv, &path)?;
        write_atomic(&path, csv)
    }

    /// Reads every shard file (all must be finished).
    pub fn read_shards(&self, plan: &SweepPlan) -> Result<Vec<Vec<EpisodeOutcome>>, SweepError> {
        (0..plan.shards.len())
            .map(|i| {
                let path = self.shard_path(i);
                let text = std::fs::read_to_string(&path).map_err(io_err(&path))?;
                plan.parse_shard(i, &text, &path)
            })
            .collect()
    }

    /// Writes every point's `report.json`, `episodes.csv` and `detectors.toml`, `ranking.csv` and
    /// `summary.json`. Returns the ranking (indices into `results`, best first).
    pub fn write_results(&self, plan: &SweepPlan, results: &[PointResult]) -> Result<Vec<usize>, SweepError> {
        let metric = plan.file.objective.metric;
        for r in results {
            let dir = self.root.join("points").join(&r.point.label);
            std::fs::create_dir_all(&dir).map_err(io_err(&dir))?;
            r.report.write_json(&dir.join("report.json"))?;
            let csv = SweepPlan::shard_csv(&r.outcomes);
            std::fs::write(dir.join("episodes.csv"), csv).map_err(io_err(&dir))?;
            let entries = toml::to_string(&DetectorsFile {
                detectors: vec![r.point.detector.clone()],
            })
            .expect("a detector entry serialises");
            std::fs::write(dir.join("detectors.toml"), entries).map_err(io_err(&dir))?;
        }
        let order = rank(results, metric);
        let keys: Vec<String> = {
            let mut k: Vec<String> = results.iter().flat_map(|r| r.point.values.keys().cloned()).collect();
            k.sort();
            k.dedup();
            k
        };
        let cell = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
        let mut csv = format!(
            "rank,label,detector,{},score,within_budget,hit_rate,false_alarm_rate,collision_rate,auc,mean_lead_s\n",
            keys.iter().map(|k| quote(k)).collect::<Vec<_>>().join(",")
        );
        let mut ranking = Vec::new();
        for (rank, &i) in order.iter().enumerate() {
            let r = &results[i];
            let s = r.report.detectors.get(&r.point.label);
            let vals: Vec<String> = keys
                .iter()
                .map(|k| quote(r.point.values.get(k).map_or("", String::as_str)))
                .collect();
            let _ = writeln!(
                csv,
                "{},{},{},{},{},{},{},{},{},{},{}",
                rank + 1,
                r.point.label,
                r.point.detector.id,
                vals.join(","),
                cell(r.score),
                r.feasible,
                cell(s.and_then(|s| s.hit_rate)),
                cell(s.and_then(|s| s.false_alarm_rate)),
                cell(s.and_then(|s| s.collision_rate)),
                cell(s.and_then(|s| s.auc)),
                cell(s.and_then(|s| s.mean_lead_s)),
            );
            ranking.push(serde_json::json!({
                "rank": rank + 1,
                "label": r.point.label,
                "detector": r.point.detector,
                "values": r.point.values,
                "score": r.score,
                "tier_scores": r.tier_scores,
                "within_budget": r.feasible,
                "summary": s,
            }));
        }
        std::fs::write(self.root.join("ranking.csv"), csv).map_err(io_err(&self.root))?;
        let summary = serde_json::json!({
            "loomlab_version": LOOMLAB_VERSION,
            "name": plan.file.name,
            "sweep": plan.file.path.display().to_string(),
            "suite": plan.file.suite.display().to_string(),
            "seed": plan.file.seed,
            "episodes": plan.episodes.len(),
            "points": results.len(),
            "shards": plan.shards.len(),
            "objective": plan.file.objective,
            "fingerprint": plan.fingerprint,
            "ranking": ranking,
        });
        let text = serde_json::to_string_pretty(&summary).expect("a summary serialises");
        std::fs::write(self.root.join("summary.json"), text).map_err(io_err(&self.root))?;
        Ok(order)
    }
}

#[derive(Serialize)]
struct DetectorsFile {
    detectors: Vec<DetectorDesc>,
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

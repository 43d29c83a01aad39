//! The sweep file: parsing it and expanding its `[[detectors]]` entries into parameter points.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use toml::{Table, Value};

use super::error::SweepError;
use super::objective::Objective;
use crate::error::ScenarioError;
use crate::expand::{KeyPath, KeySegment, Variation, mix_seed};
use crate::schema::{DetectorDesc, default_camera, resolve_detector, typed};

/// Most parameter points one sweep may expand to.
pub const MAX_POINTS: usize = 10_000;

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

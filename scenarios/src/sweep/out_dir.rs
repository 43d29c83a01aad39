//! The sweep's output folder: its manifest, resumption, shard files and result files.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::error::{SweepError, io_err};
use super::plan::SweepPlan;
use super::ranking::{PointResult, rank};
use crate::episodes_csv::quote;
use crate::metrics::EpisodeOutcome;
use crate::report::LOOMLAB_VERSION;
use crate::schema::DetectorDesc;

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

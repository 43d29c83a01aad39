//! The sweep plan: the suite's episodes cut into shards, running, checking and merging them.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::Path;

use serde::Serialize;

use super::error::SweepError;
use super::file::SweepFile;
use super::objective::{Metric, Objective};
use super::ranking::PointResult;
use crate::episodes_csv::{format_rows, header_line, parse_episodes_csv};
use crate::fingerprint::Fingerprint;
use crate::metrics::{DetectorEpisode, EpisodeOutcome};
use crate::reference::is_reference;
use crate::report::{LOOMLAB_VERSION, Report, ReportMeta};
use crate::runner::Runner;
use crate::schema::{EpisodeSpec, LoadOptions};
use crate::suite::load_suite;

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

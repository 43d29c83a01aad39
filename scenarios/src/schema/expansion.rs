//! A loaded [`Scenario`] and the on-demand expansion of its sweeps and random draws into episodes.

use std::path::PathBuf;
use std::sync::Arc;

use toml::{Table, Value};

use super::SuiteDefaults;
use super::document::ScenarioDoc;
use super::episode::{EpisodeSpec, params_text, robot_facts};
use super::load::{LoadOptions, typed};
use super::resolve::resolve;
use crate::error::ScenarioError;
use crate::expand::{KeyPath, Variation, mix_seed};
use crate::metrics::ScoringConfig;

/// A loaded scenario. Its episodes are expanded on demand ([`Scenario::episode`],
/// [`Scenario::episodes`]), so loading costs the same for one episode or millions.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Name (unique within a suite).
    pub name: String,
    /// Description.
    pub description: String,
    /// The file it came from.
    pub file: PathBuf,
    /// Its difficulty tier (top-level `tier`, 0 ..= [`crate::tier::MAX_TIER`]; `None`: not stated).
    pub tier: Option<u8>,
    pub(super) expansion: Arc<Expansion>,
}

/// Where a scenario's keys were written: the scenario file, or the suite's `[defaults]`.
#[derive(Debug)]
pub(super) struct KeyOrigin {
    pub(super) file: PathBuf,
    /// The scenario file's own tree (before the merge) and the defaults merged under it.
    pub(super) defaults: Option<(Table, SuiteDefaults)>,
}

impl KeyOrigin {
    /// The suite's defaults, if `key` was not written in the scenario file but in them.
    fn defaults_of(&self, key: &str) -> Option<&SuiteDefaults> {
        let (own, defaults) = self.defaults.as_ref()?;
        let path = KeyPath::parse(key).ok()?;
        (path.get(own).is_none() && path.get(&defaults.table).is_some()).then_some(defaults)
    }

    /// A key error, naming the file the key was written in.
    pub(super) fn key_error(&self, key: String, reason: String) -> ScenarioError {
        match self.defaults_of(&key) {
            Some(d) => ScenarioError::key(
                &d.file,
                format!("defaults.{key}"),
                format!("{reason} (in [defaults], merged under {})", self.file.display()),
            ),
            None => ScenarioError::key(&self.file, key, reason),
        }
    }
}

/// A scenario's tree and variation: expands any one of its episodes on demand.
#[derive(Debug)]
pub(super) struct Expansion {
    pub(super) file: PathBuf,
    pub(super) origin: KeyOrigin,
    pub(super) name: String,
    /// The file's tree (with the suite's defaults merged, without `[sweep]` and `[random]`).
    pub(super) tree: Table,
    pub(super) variation: Variation,
    /// Canonical key paths of the varied keys.
    pub(super) varied: Vec<String>,
    pub(super) base_seed: u64,
    pub(super) repeats: usize,
    pub(super) count: usize,
    pub(super) opts: LoadOptions,
}

impl Expansion {
    /// The episodes of parameter point `point` (all its repeats) and the scenario description.
    pub(super) fn point(&self, point: usize) -> Result<(Vec<EpisodeSpec>, String), ScenarioError> {
        let path = self.file.as_path();
        let (t, params) = self.variation.point(&self.tree, self.base_seed, point);
        let first_index = point * self.repeats;
        // In a scenario with varied keys an error can be specific to this point (also at a key
        // that is not varied itself, e.g. an arrival time the swept speed cannot reach): the
        // message names the episode and its parameters.
        let err = |(k, r): (String, String)| {
            if self.varied.is_empty() || self.origin.defaults_of(&k).is_some() {
                self.origin.key_error(k, r)
            } else {
                ScenarioError::Episode {
                    path: path.into(),
                    episode: first_index,
                    params: params_text(&params),
                    reason: format!("`{k}`: {r}"),
                }
            }
        };
        let doc: ScenarioDoc = typed(Value::Table(t), "").map_err(&err)?;
        let (world, detectors) = resolve(&doc, &self.opts).map_err(&err)?;
        let facts = robot_facts(&world);
        let scoring = ScoringConfig {
            lead_margin_s: doc.scoring.lead_margin_s,
            ..ScoringConfig::default()
        };
        let episodes = (0..self.repeats)
            .map(|r| {
                let index = first_index + r;
                let mut params = params.clone();
                if self.repeats > 1 {
                    params.insert("repeat".into(), r.to_string());
                }
                EpisodeSpec {
                    scenario: self.name.clone(),
                    file: path.into(),
                    index,
                    seed: mix_seed(self.base_seed, index as u64),
                    params,
                    world: world.clone(),
                    cruise: doc.robot.clone(),
                    duration_s: doc.episode.duration_s,
                    detectors: detectors.clone(),
                    controller: doc.controller.clone(),
                    facts,
                    scoring: scoring.clone(),
                }
            })
            .collect();
        Ok((episodes, doc.description))
    }
}

impl Scenario {
    /// Number of episodes (Π len(sweep lists) × samples × repeats).
    pub fn len(&self) -> usize {
        self.expansion.count
    }

    /// Whether the scenario has no episodes (never: every scenario has at least one).
    pub fn is_empty(&self) -> bool {
        self.expansion.count == 0
    }

    /// Episode `index` (0 ≤ index < [`Self::len`]), expanded now; an error names the file, the
    /// episode and its parameters.
    pub fn episode(&self, index: usize) -> Result<EpisodeSpec, ScenarioError> {
        if index >= self.len() {
            return Err(ScenarioError::key(
                &self.file,
                "episode",
                format!("episode {index} does not exist (the scenario has {})", self.len()),
            ));
        }
        let repeats = self.expansion.repeats;
        let (mut episodes, _) = self.expansion.point(index / repeats)?;
        Ok(episodes.swap_remove(index % repeats))
    }

    /// Every episode in order, expanded one parameter point at a time.
    pub fn episodes(&self) -> impl Iterator<Item = Result<EpisodeSpec, ScenarioError>> + '_ {
        let points = self.len() / self.expansion.repeats;
        (0..points).flat_map(move |p| match self.expansion.point(p) {
            Ok((episodes, _)) => episodes.into_iter().map(Ok).collect::<Vec<_>>(),
            Err(e) => vec![Err(e)],
        })
    }

    /// Every episode, expanded (for small scenarios: tests, the Gymnasium env).
    pub fn expand_all(&self) -> Result<Vec<EpisodeSpec>, ScenarioError> {
        self.episodes().collect()
    }
}

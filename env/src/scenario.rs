//! The scenario of an environment: a scenario file (the schema of [`loomlab_scenarios::schema`]) or
//! a suite (a folder, a list file or several scenario files, loaded as `loomlab run` loads them:
//! [`loomlab_scenarios::suite`]) expanded into its episodes, from which every reset draws one.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use loomlab_detector::{DetectorError, Registry};

use super::{EnvError, EnvOptions};
use loomlab_scenarios::ScenarioError;
use loomlab_scenarios::schema::{EpisodeSpec, LoadOptions, parse_scenario};
use loomlab_scenarios::suite::{Suite, load_suite};

/// A scenario for environments: TOML text in the scenario schema ([`loomlab_scenarios::schema`]) and the file
/// name that error messages and the default scenario name use, or a suite.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvScenario {
    /// The scenario file's text (empty for a suite).
    pub text: String,
    /// Where it came from (a path, or a pseudo-path such as `<scenario_toml>`; a suite's first path).
    pub path: PathBuf,
    /// A suite's sources (`None`: the scenario text above): each a suite folder, a list file or a
    /// scenario file ([`loomlab_scenarios::suite::load_suite`]); their scenarios are pooled in order.
    pub suite: Option<Vec<PathBuf>>,
}

impl EnvScenario {
    /// Scenario TOML text; `path` names it in error messages (and gives the default name).
    pub fn from_toml(text: impl Into<String>, path: impl Into<PathBuf>) -> Self {
        Self {
            text: text.into(),
            path: path.into(),
            suite: None,
        }
    }

    /// A suite: one folder or list file, or several scenario files (or suites), pooled in order,
    /// each loaded as `loomlab run` loads a suite (`[defaults]`, `require_tier`, the suite's
    /// sensor). Every reset draws among all their episodes, re-expanded with a fresh seed (their
    /// `[random]` ranges drawn afresh, as `loomlab run --seed` does).
    pub fn from_suite(paths: Vec<PathBuf>) -> Result<Self, EnvError> {
        let Some(first) = paths.first().cloned() else {
            return Err(EnvError::option(
                "scenario",
                "[]",
                "give at least one scenario file or suite folder",
            ));
        };
        for p in &paths {
            if !p.exists() {
                return Err(EnvError::option(
                    "scenario",
                    p.display(),
                    "no such file or folder; give a suite folder (e.g. scenarios/suites/default), a list file or \
                     scenario files",
                ));
            }
        }
        Ok(Self {
            text: String::new(),
            path: first,
            suite: Some(paths),
        })
    }

    /// A path as `loomlab run` takes it: a folder or a list file (a TOML file with a `scenarios`
    /// key) is a suite ([`Self::from_suite`]), any other file one scenario ([`Self::from_file`]).
    pub fn open(path: &Path) -> Result<Self, EnvError> {
        let list_file = || {
            std::fs::read_to_string(path)
                .ok()
                .and_then(|t| toml::from_str::<toml::Table>(&t).ok())
                .is_some_and(|t| t.contains_key("scenarios"))
        };
        if path.is_dir() || list_file() {
            Self::from_suite(vec![path.to_path_buf()])
        } else {
            Self::from_file(path)
        }
    }

    /// Whether this is a suite (see [`Self::from_suite`]).
    pub fn is_suite(&self) -> bool {
        self.suite.is_some()
    }

    /// Reads a scenario file.
    pub fn from_file(path: &Path) -> Result<Self, EnvError> {
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
            path: path.into(),
            source,
        })?;
        Ok(Self::from_toml(text, path))
    }

    /// Whether the file has a `[random]` table (then every reset draws fresh random values); a
    /// suite always counts as having one (its files are re-expanded at every reset).
    pub fn has_random_ranges(&self) -> bool {
        self.is_suite() || toml::from_str::<toml::Table>(&self.text).is_ok_and(|t| t.contains_key("random"))
    }

    /// Expands the scenario with the environment's frame size and detector choice; `seed` (0: the
    /// file's) is mixed into the file's seed, which draws the random ranges.
    pub fn load(&self, options: &EnvOptions, seed: u64) -> Result<ScenarioEpisodes, EnvError> {
        if let Some(ids) = &options.detectors {
            for id in ids {
                if Registry::builtin().find(id).is_none() {
                    return Err(DetectorError::UnknownDetector(id.clone()).into());
                }
            }
        }
        let opts = load_options(options, seed)?;
        if let Some(paths) = &self.suite {
            let suite = self.load_suite(paths, &opts, options.tiers.as_deref())?;
            let episodes = suite.episodes().collect::<Result<Vec<_>, _>>()?;
            let sc = ScenarioEpisodes {
                episodes,
                name: suite_name(&suite.path),
            };
            sc.check(&self.path)?;
            return Ok(sc);
        }
        if let Some(tiers) = &options.tiers {
            return Err(EnvError::option(
                "tiers",
                format!("{tiers:?}"),
                format!(
                    "the tier filter applies to suites; {} is one scenario file: give a suite folder (e.g. \
                     scenarios/suites/default) or a list of files, or leave tiers out",
                    self.path.display()
                ),
            ));
        }
        let parsed = parse_scenario(&self.text, &self.path, None, &opts)?;
        let sc = ScenarioEpisodes {
            episodes: parsed.expand_all()?,
            name: parsed.name,
        };
        sc.check(&self.path)?;
        Ok(sc)
    }
}

impl EnvScenario {
    /// One episode of the suite expanded with `seed`: episode `pick % count` of the suite's
    /// episodes in suite order (only that episode is expanded). The detectors and the frame size
    /// do not depend on the seed: the environment's first expansion checked them for every episode.
    pub(crate) fn draw_episode(&self, options: &EnvOptions, seed: u64, pick: u64) -> Result<EpisodeSpec, EnvError> {
        let paths = self.suite.as_deref().unwrap_or_default();
        let opts = load_options(options, seed)?;
        let suite = self.load_suite(paths, &opts, options.tiers.as_deref())?;
        let count = suite.episode_count().max(1) as u64;
        let mut index = (pick % count) as usize;
        for sc in &suite.scenarios {
            if index < sc.len() {
                return Ok(sc.episode(index)?);
            }
            index -= sc.len();
        }
        Err(EnvError::Scenario(format!(
            "{}: the suite expands to no episode",
            self.path.display()
        )))
    }

    /// Loads the suite's sources with `opts`, pooled, keeping the scenarios of `tiers` (all
    /// without).
    fn load_suite(&self, paths: &[PathBuf], opts: &LoadOptions, tiers: Option<&[u8]>) -> Result<Suite, EnvError> {
        let mut suite = load_suite(&paths[0], opts)?;
        for p in &paths[1..] {
            suite.scenarios.extend(load_suite(p, opts)?.scenarios);
        }
        if let Some(tiers) = tiers {
            let set: BTreeSet<u8> = tiers.iter().copied().collect();
            suite.retain_tiers(&set).map_err(|e| {
                EnvError::option(
                    "tiers",
                    format!("{tiers:?}"),
                    format!("{e} (keep tiers the suite's scenarios state, 0 to 3)"),
                )
            })?;
        }
        Ok(suite)
    }
}

/// The scenario crate's load options of an environment's options, expansion seed `seed`.
fn load_options(options: &EnvOptions, seed: u64) -> Result<LoadOptions, EnvError> {
    let sensor = match &options.sensor {
        Some(name) => {
            Some(loomlab_sim::SensorProfile::named(name).map_err(|reason| EnvError::option("sensor", name, reason))?)
        }
        None => None,
    };
    Ok(LoadOptions {
        seed,
        size: options.frame_size,
        sensor,
        detectors: options.detectors.clone(),
        detector_entries: None,
        ..Default::default()
    })
}

/// A suite's name: its folder's or list file's stem (`default` for `scenarios/suites/default`).
fn suite_name(path: &Path) -> String {
    path.file_stem()
        .map_or_else(|| path.display().to_string(), |s| s.to_string_lossy().into_owned())
}

/// A scenario's name and its expanded episodes (an environment draws from all of them).
#[derive(Debug, Clone)]
pub struct ScenarioEpisodes {
    /// The scenario's name.
    pub name: String,
    /// Its episodes, expanded.
    pub episodes: Vec<EpisodeSpec>,
}

impl ScenarioEpisodes {
    /// Checks that an environment can run these episodes: at least one, and every episode runs the
    /// same detectors at the same frame size (an environment observes a fixed set). `path` names
    /// their source in errors.
    pub fn check(&self, path: &Path) -> Result<(), EnvError> {
        let sc = self;
        if sc.episodes.is_empty() {
            return Err(EnvError::Scenario(format!(
                "{}: the scenario expands to no episode",
                path.display()
            )));
        }
        let labels = |e: &EpisodeSpec| e.detectors.iter().map(|d| d.label.clone()).collect::<Vec<_>>();
        let first = labels(&sc.episodes[0]);
        if let Some(e) = sc.episodes.iter().find(|e| labels(e) != first) {
            return Err(EnvError::Scenario(format!(
                "{}: episode {} runs detectors {:?} but episode 0 runs {:?}; an environment observes a fixed set \
                 of detectors, so do not sweep the detector list",
                path.display(),
                e.index,
                labels(e),
                first
            )));
        }
        if let Some(e) = sc
            .episodes
            .iter()
            .find(|e| e.world.camera.n != sc.episodes[0].world.camera.n)
        {
            return Err(EnvError::Scenario(format!(
                "{}: episode {} has frame size {} but episode 0 has {}; sweep the frame size with separate \
                 environments (or set the frame size option)",
                path.display(),
                e.index,
                e.world.camera.n,
                sc.episodes[0].world.camera.n
            )));
        }
        let events = |e: &EpisodeSpec| !e.world.camera.kind.is_frames();
        if let Some(e) = sc.episodes.iter().find(|e| events(e) != events(&sc.episodes[0])) {
            let kind = |e: &EpisodeSpec| if events(e) { "events" } else { "frames" };
            return Err(EnvError::Scenario(format!(
                "{}: episode {} has camera kind `{}` but episode 0 has `{}`; an environment observes one kind of \
                 camera, so do not sweep `world.camera.kind` (or set the sensor option)",
                path.display(),
                e.index,
                kind(e),
                kind(&sc.episodes[0])
            )));
        }
        Ok(())
    }
}

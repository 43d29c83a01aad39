//! The scenario of an environment: a scenario file (the schema of [`loomlab_scenarios::schema`]) expanded into
//! its episodes, from which every reset draws one.

use std::path::{Path, PathBuf};

use loomlab_detector::{DetectorError, Registry};

use super::{EnvError, EnvOptions};
use loomlab_scenarios::ScenarioError;
use loomlab_scenarios::schema::{EpisodeSpec, LoadOptions, parse_scenario};

/// A scenario for environments: TOML text in the scenario schema ([`loomlab_scenarios::schema`]) and the file
/// name that error messages and the default scenario name use.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvScenario {
    /// The scenario file's text.
    pub text: String,
    /// Where it came from (a path, or a pseudo-path such as `<scenario_toml>`).
    pub path: PathBuf,
}

impl EnvScenario {
    /// Scenario TOML text; `path` names it in error messages (and gives the default name).
    pub fn from_toml(text: impl Into<String>, path: impl Into<PathBuf>) -> Self {
        Self {
            text: text.into(),
            path: path.into(),
        }
    }

    /// Reads a scenario file.
    pub fn from_file(path: &Path) -> Result<Self, EnvError> {
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
            path: path.into(),
            source,
        })?;
        Ok(Self::from_toml(text, path))
    }

    /// Whether the file has a `[random]` table (then every reset draws fresh random values).
    pub fn has_random_ranges(&self) -> bool {
        toml::from_str::<toml::Table>(&self.text).is_ok_and(|t| t.contains_key("random"))
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
        let sensor = match &options.sensor {
            Some(name) => Some(
                loomlab_sim::SensorProfile::named(name).map_err(|reason| EnvError::option("sensor", name, reason))?,
            ),
            None => None,
        };
        let opts = LoadOptions {
            seed,
            size: options.frame_size,
            sensor,
            detectors: options.detectors.clone(),
            detector_entries: None,
            ..Default::default()
        };
        let parsed = parse_scenario(&self.text, &self.path, None, &opts)?;
        let sc = ScenarioEpisodes {
            episodes: parsed.expand_all()?,
            name: parsed.name,
        };
        sc.check(&self.path)?;
        Ok(sc)
    }
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
        Ok(())
    }
}

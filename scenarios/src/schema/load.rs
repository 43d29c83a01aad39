//! Reading and parsing scenario files: load options, suite defaults and file-name checks.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use loomlab_detector::Registry;
use toml::{Table, Value};

use super::document::{DetectorDesc, EpisodeDesc};
use super::expansion::{Expansion, KeyOrigin, Scenario};
use crate::error::ScenarioError;
use crate::expand::{KeyPath, MAX_EPISODES_PER_SUITE, Variation, merge_defaults, mix_seed};

/// Options applied while loading (command-line overrides).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LoadOptions {
    /// Suite seed mixed into every scenario's `episode.seed` (0: the files' seeds unchanged).
    pub seed: u64,
    /// Frame size n overriding every `world.camera.n`.
    pub size: Option<u32>,
    /// A sensor profile set on every world (`--sensor`, a suite's `sensor` key): it replaces the
    /// scenario files' `[world.camera.sensor]` and latencies ([`loomlab_sim::SensorProfile`]).
    pub sensor: Option<loomlab_sim::SensorProfile>,
    /// Run exactly these detector ids (the scenario's settings for them when it lists them,
    /// defaults otherwise); `None`: the scenario's list (default every registered detector). With
    /// `detector_entries` it only filters those entries by id.
    pub detectors: Option<Vec<String>>,
    /// Use these `[[detectors]]` entries instead of every scenario's own list (a detectors file,
    /// or the parameter points of a sweep); `detectors` then filters them by id.
    pub detector_entries: Option<Vec<DetectorDesc>>,
    /// Entries run in addition to the rows chosen above, in every scenario (Python detectors);
    /// their ids must be in `registry`.
    pub added_detectors: Vec<DetectorDesc>,
    /// The detectors that ids resolve to (default: [`Registry::builtin`]; a run adds its own, e.g.
    /// Python detectors, with [`Registry::with`]).
    pub registry: Registry,
}

/// A suite's `[defaults]` table and the file it is written in (errors at keys that come from it
/// name that file and `defaults.<key>`).
#[derive(Debug, Clone, PartialEq)]
pub struct SuiteDefaults {
    /// The `[defaults]` table.
    pub table: Table,
    /// The suite file holding it (`suite.toml` or the list file).
    pub file: PathBuf,
}

/// Reads and expands one scenario file (`defaults`: a suite's `[defaults]`, merged under it).
pub fn load_scenario(
    path: &Path,
    defaults: Option<&SuiteDefaults>,
    opts: &LoadOptions,
) -> Result<Scenario, ScenarioError> {
    let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
        path: path.into(),
        source,
    })?;
    parse_scenario(&text, path, defaults, opts)
}

/// Deserialises `value`, reporting errors as `(key path under prefix, first line of the reason)`.
pub(crate) fn typed<T: serde::de::DeserializeOwned>(value: Value, prefix: &str) -> Result<T, (String, String)> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let key = e.path().to_string();
        // the first line: toml appends an "in `table`" context line that repeats the path
        let reason = e.inner().to_string().lines().next().unwrap_or_default().to_string();
        let key = match (prefix.is_empty(), key.as_str()) {
            (true, ".") => "<root>".to_string(),
            (true, _) => key,
            (false, ".") => prefix.to_string(),
            (false, _) => format!("{prefix}.{key}"),
        };
        (key, reason)
    })
}

/// Longest name that becomes a file name (a scenario's, a sweep's, a sweep point's label).
pub const MAX_FILE_NAME: usize = 100;

/// Checks a name that becomes (part of) a file name: a scenario's name names its trace CSVs and
/// exemplar GIFs (`traces/<name>_0003.csv`), a sweep's and a sweep point's name their folders. The
/// safe set: 1 to [`MAX_FILE_NAME`] ASCII letters, digits, `_`, `-`, `.` and `+`, starting with a
/// letter, digit or `_` (so never `..`, a hidden file, an option-like `-x`, a path separator or a
/// character that HTML, a shell or a CSV file would treat specially). Returns the reason otherwise.
pub fn check_file_name(name: &str) -> Result<(), String> {
    let allowed = |c: char| c.is_ascii_alphanumeric() || "_-.+".contains(c);
    if name.is_empty() {
        return Err("a name must not be empty".into());
    }
    if name.len() > MAX_FILE_NAME {
        return Err(format!(
            "a name has at most {MAX_FILE_NAME} characters, this one {}",
            name.chars().count()
        ));
    }
    if let Some(bad) = name.chars().find(|&c| !allowed(c)) {
        return Err(format!(
            "{bad:?} is not allowed in a name (it names files): use ASCII letters, digits, `_`, `-`, `.` and `+`"
        ));
    }
    if !name.starts_with(|c: char| c.is_ascii_alphanumeric() || c == '_') {
        return Err("a name starts with an ASCII letter, a digit or `_` (it names files)".into());
    }
    Ok(())
}

/// Parses and expands scenario text; `path` names the file in errors and gives the default name.
pub fn parse_scenario(
    text: &str,
    path: &Path,
    defaults: Option<&SuiteDefaults>,
    opts: &LoadOptions,
) -> Result<Scenario, ScenarioError> {
    let mut tree: Table = toml::from_str(text).map_err(|e| ScenarioError::Syntax {
        path: path.into(),
        message: e.to_string().trim_end().to_string(),
    })?;
    let origin = KeyOrigin {
        file: path.into(),
        defaults: defaults.map(|d| (tree.clone(), d.clone())),
    };
    if let Some(d) = defaults {
        merge_defaults(&mut tree, &d.table);
    }
    let kerr = |(k, r): (String, String)| origin.key_error(k, r);
    if let Some(Value::Table(c)) = tree.get("controller") {
        for k in [
            "threshold",
            "trigger",
            "tau_threshold_s",
            "min_angular_size_deg",
            "course",
            "persistence_frames",
            "persistence_window_frames",
        ] {
            if c.contains_key(k) {
                return Err(ScenarioError::key(
                    path,
                    format!("controller.{k}"),
                    format!("set the alarm {k} per detector, in [[detectors]] {k} = …"),
                ));
            }
        }
    }
    let name = match tree.get("name") {
        None => {
            let stem = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "scenario".into());
            check_file_name(&stem).map_err(|reason| {
                ScenarioError::key(
                    path,
                    "name",
                    format!(
                        "the file name `{stem}` is the scenario's name by default, but {reason}; set `name = \"…\"` in the file"
                    ),
                )
            })?;
            stem
        }
        Some(Value::String(s)) => {
            check_file_name(s).map_err(|reason| ScenarioError::key(path, "name", format!("{s:?}: {reason}")))?;
            s.clone()
        }
        Some(other) => {
            return Err(ScenarioError::key(
                path,
                "name",
                format!("must be a non-empty string, not {other}"),
            ));
        }
    };
    if defaults.is_some_and(|d| d.table.contains_key("tier")) {
        let file = &defaults.expect("checked").file;
        return Err(ScenarioError::key(
            file,
            "defaults.tier",
            "a difficulty tier belongs to each scenario file, not to the suite's [defaults]: remove it here and \
             write `tier = N` at the top of every scenario file",
        ));
    }
    let tier = match tree.remove("tier") {
        None => None,
        Some(v) => Some(crate::tier::parse_tier_value(&v).map_err(|reason| ScenarioError::key(path, "tier", reason))?),
    };
    let variation = Variation::take_from(&mut tree).map_err(kerr)?;
    for (table, key, path_key) in variation
        .sweep
        .iter()
        .flat_map(|(k, ps, _)| ps.iter().map(move |p| ("sweep", k, p)))
        .chain(variation.random.iter().map(|(k, p, _)| ("random", k, p)))
    {
        let reason = match path_key.canonical().as_str() {
            "tier" => {
                "the tier is one per scenario file and cannot be swept or sampled: split the file into one file per tier"
            }
            "name" => {
                "the name is one per scenario file (it names the scenario's rows and files) and cannot be swept or \
                 sampled: the sweep's parameters already tell its episodes apart, so remove this key"
            }
            _ => continue,
        };
        return Err(ScenarioError::key(path, format!("{table}.\"{key}\""), reason));
    }
    let episode: EpisodeDesc = typed(
        tree.get("episode").cloned().unwrap_or(Value::Table(Table::new())),
        "episode",
    )
    .map_err(kerr)?;
    if !(episode.duration_s.is_finite() && episode.duration_s > 0.0) {
        return Err(ScenarioError::key(
            path,
            "episode.duration_s",
            format!("{} must be a finite number of seconds > 0", episode.duration_s),
        ));
    }
    if episode.repeats == 0 {
        return Err(ScenarioError::key(path, "episode.repeats", "must be >= 1"));
    }
    let count = variation.points().saturating_mul(episode.repeats as usize);
    if count > MAX_EPISODES_PER_SUITE {
        return Err(ScenarioError::key(
            path,
            if variation.points() > 1 {
                "sweep"
            } else {
                "episode.repeats"
            },
            format!(
                "expands to {count} episodes (more than {MAX_EPISODES_PER_SUITE}); use fewer values, samples or repeats"
            ),
        ));
    }
    let base_seed = if opts.seed == 0 {
        episode.seed
    } else {
        mix_seed(episode.seed, opts.seed)
    };
    let expansion = Expansion {
        file: path.into(),
        origin,
        name,
        varied: variation
            .sweep
            .iter()
            .flat_map(|(_, ps, _)| ps.iter().map(KeyPath::canonical))
            .chain(variation.random.iter().map(|(_, p, _)| p.canonical()))
            .collect(),
        tree,
        variation,
        base_seed,
        repeats: episode.repeats as usize,
        count,
        opts: opts.clone(),
    };
    // the first point is checked (and gives the description) now; the others as they are expanded
    let (first, description) = expansion.point(0)?;
    drop(first);
    Ok(Scenario {
        name: expansion.name.clone(),
        description,
        file: path.into(),
        tier,
        expansion: Arc::new(expansion),
    })
}

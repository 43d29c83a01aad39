//! Suites: sets of scenario files run and scored together.
//!
//! A suite is one of
//! - a **folder**: every `*.toml` file in it (not in sub-folders) except `suite.toml`, in file-name
//!   order. An optional `suite.toml` in the folder may hold a `description`, a `[defaults]` table
//!   and a `scenarios` list (then only those files, in that order);
//! - a **list file** (any TOML file with a `scenarios` key):
//!   ```toml
//!   description = "quick checks"
//!   scenarios = ["default/head_on_ball.toml", "default/overpass.toml"]  # relative to this file
//!   [defaults]            # merged under every scenario (the scenario's own values win)
//!   world.camera.n = 64
//!   ```
//! - a single **scenario file** (a TOML file without a `scenarios` key).
//!
//! `require_tier = true` in `suite.toml` or a list file makes the top-level `tier` key (the
//! difficulty tier, 0 to 3: [`crate::tier`]) required in every scenario of the suite; elsewhere it
//! is optional.
//!
//! `[defaults]` is deep-merged under each scenario file before its sweeps are expanded (tables
//! merge key by key, arrays and other values are replaced by the scenario's). Scenario names must
//! be unique within a suite (reports are keyed by them).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::{Table, Value};

use crate::error::ScenarioError;
use crate::expand::MAX_EPISODES_PER_SUITE;
use crate::schema::{EpisodeSpec, LoadOptions, Scenario, SuiteDefaults, load_scenario};

/// The default suite, relative to the repository root.
pub const DEFAULT_SUITE: &str = "scenarios/suites/default";

/// Name of the optional suite file inside a suite folder.
pub const SUITE_FILE: &str = "suite.toml";

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct SuiteDoc {
    #[serde(default)]
    description: String,
    #[serde(default)]
    scenarios: Option<Vec<String>>,
    #[serde(default)]
    defaults: Option<Table>,
    #[serde(default)]
    require_tier: bool,
    /// The sensor profile every scenario runs under (`loomlab run --sensor` overrides it).
    #[serde(default)]
    sensor: Option<String>,
}

/// A loaded suite.
#[derive(Debug, Clone)]
pub struct Suite {
    /// The folder or file it was loaded from.
    pub path: PathBuf,
    /// Its description (from `suite.toml` or the list file; empty if none).
    pub description: String,
    /// The scenarios, in run order.
    pub scenarios: Vec<Scenario>,
    /// The sensor profile its worlds were given (the load options', else the suite's `sensor`
    /// key); `None`: each scenario file's own sensor (ideal unless it sets one).
    pub sensor: Option<&'static str>,
}

/// Every scenario's tier, by scenario name (scenarios without one are left out).
pub fn scenario_tiers(scenarios: &[Scenario]) -> BTreeMap<String, u8> {
    scenarios
        .iter()
        .filter_map(|s| Some((s.name.clone(), s.tier?)))
        .collect()
}

impl Suite {
    /// Every episode, scenario by scenario, expanded as the iterator advances (memory does not
    /// grow with the suite; `take(n)` expands n episodes).
    pub fn episodes(&self) -> impl Iterator<Item = Result<EpisodeSpec, ScenarioError>> + '_ {
        self.scenarios.iter().flat_map(Scenario::episodes)
    }

    /// Every scenario's difficulty tier, by scenario name (scenarios without one are left out).
    pub fn tiers(&self) -> BTreeMap<String, u8> {
        scenario_tiers(&self.scenarios)
    }

    /// Keeps only the scenarios of these tiers (`loomlab run --tier`); an error when none is left.
    pub fn retain_tiers(&mut self, tiers: &BTreeSet<u8>) -> Result<(), ScenarioError> {
        let have: BTreeSet<u8> = self.scenarios.iter().filter_map(|s| s.tier).collect();
        self.scenarios.retain(|s| s.tier.is_some_and(|t| tiers.contains(&t)));
        if self.scenarios.is_empty() {
            let list = |set: &BTreeSet<u8>| set.iter().map(u8::to_string).collect::<Vec<_>>().join(",");
            return Err(ScenarioError::Suite {
                path: self.path.clone(),
                reason: format!(
                    "--tier {}: no scenario of the suite has that tier (its scenarios' tiers: {}); pick one of those",
                    list(tiers),
                    if have.is_empty() {
                        "none: no file sets `tier`".to_string()
                    } else {
                        list(&have)
                    }
                ),
            });
        }
        Ok(())
    }

    /// Number of episodes.
    pub fn episode_count(&self) -> usize {
        self.scenarios.iter().map(Scenario::len).sum()
    }

    /// Expands the first `limit` episodes (all with `None`) without keeping them: the first
    /// invalid one's error, so that a run can refuse bad input before it starts.
    pub fn check(&self, limit: Option<usize>) -> Result<(), ScenarioError> {
        self.episodes()
            .take(limit.unwrap_or(usize::MAX))
            .try_for_each(|e| e.map(drop))
    }
}

fn read(path: &Path) -> Result<String, ScenarioError> {
    std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
        path: path.into(),
        source,
    })
}

fn parse_suite_doc(path: &Path, table: Table) -> Result<SuiteDoc, ScenarioError> {
    serde_path_to_error::deserialize(Value::Table(table)).map_err(|e| {
        let reason = e.inner().to_string().lines().next().unwrap_or_default().to_string();
        let key = e.path().to_string();
        let key = if key == "." { "<root>".to_string() } else { key };
        ScenarioError::key(path, key, reason)
    })
}

fn toml_files(dir: &Path) -> Result<Vec<PathBuf>, ScenarioError> {
    let io = |source| ScenarioError::Io {
        path: dir.into(),
        source,
    };
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let p = entry.map_err(io)?.path();
        if p.extension().is_some_and(|e| e == "toml") && p.file_name().is_some_and(|n| n != SUITE_FILE) {
            if p.is_file() {
                files.push(p);
            } else if !p.is_dir() {
                // a dangling symlink (or an unreadable entry) would shrink the suite silently
                let reason = match (std::fs::read_link(&p), std::fs::metadata(&p)) {
                    (Ok(target), Err(e)) if e.kind() != std::io::ErrorKind::NotFound => format!(
                        "{} is a symbolic link to {} that cannot be followed ({e}: a loop of links?) (a suite never \
                         skips a scenario file; fix or remove the link)",
                        p.display(),
                        target.display()
                    ),
                    (Ok(target), _) => format!(
                        "{} is a symbolic link to {}, which does not exist (a suite never skips a scenario file; fix or remove the link)",
                        p.display(),
                        target.display()
                    ),
                    (Err(_), _) => format!("{} is not a readable file", p.display()),
                };
                return Err(ScenarioError::Suite {
                    path: dir.into(),
                    reason,
                });
            }
        }
    }
    files.sort();
    Ok(files)
}

/// Loads a suite folder, list file or single scenario file (see the module docs).
pub fn load_suite(path: &Path, opts: &LoadOptions) -> Result<Suite, ScenarioError> {
    let meta = std::fs::metadata(path).map_err(|source| ScenarioError::Io {
        path: path.into(),
        source,
    })?;
    let (doc, files) = if meta.is_dir() {
        let suite_file = path.join(SUITE_FILE);
        let doc = if suite_file.is_file() {
            let table: Table = toml::from_str(&read(&suite_file)?).map_err(|e| ScenarioError::Syntax {
                path: suite_file.clone(),
                message: e.to_string().trim_end().into(),
            })?;
            parse_suite_doc(&suite_file, table)?
        } else {
            SuiteDoc::default()
        };
        let files = match &doc.scenarios {
            Some(list) => list.iter().map(|f| path.join(f)).collect(),
            None => toml_files(path)?,
        };
        (doc, files)
    } else {
        let text = read(path)?;
        let table: Table = toml::from_str(&text).map_err(|e| ScenarioError::Syntax {
            path: path.into(),
            message: e.to_string().trim_end().into(),
        })?;
        if table.contains_key("scenarios") {
            let doc = parse_suite_doc(path, table)?;
            let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
            let mut files = Vec::new();
            for f in doc.scenarios.as_deref().unwrap_or_default() {
                let p = dir.join(f);
                if p.is_dir() {
                    files.extend(toml_files(&p)?);
                } else {
                    if let Ok(text) = std::fs::read_to_string(&p)
                        && let Ok(t) = toml::from_str::<Table>(&text)
                        && t.contains_key("scenarios")
                    {
                        return Err(ScenarioError::key(
                            path,
                            "scenarios",
                            format!(
                                "{f:?} is itself a list file ({} has `scenarios = [...]`); list files do not nest: \
                                 list its scenario files (or their folder) here instead",
                                p.display()
                            ),
                        ));
                    }
                    files.push(p);
                }
            }
            (doc, files)
        } else {
            let scenario = load_scenario(path, None, opts)?;
            let mut suite = finish(path, String::new(), vec![scenario])?;
            suite.sensor = opts.sensor.map(|p| p.name);
            return Ok(suite);
        }
    };
    let suite_file: PathBuf = if meta.is_dir() {
        path.join(SUITE_FILE)
    } else {
        path.into()
    };
    let defaults = doc.defaults.map(|table| SuiteDefaults {
        table,
        file: suite_file.clone(),
    });
    // the suite's sensor profile, unless the options set one
    let with_profile;
    let opts = match (&opts.sensor, &doc.sensor) {
        (None, Some(name)) => {
            let profile = loomlab_sim::SensorProfile::named(name)
                .map_err(|reason| ScenarioError::key(&suite_file, "sensor", reason))?;
            with_profile = LoadOptions {
                sensor: Some(profile),
                ..opts.clone()
            };
            &with_profile
        }
        _ => opts,
    };
    let mut scenarios = Vec::with_capacity(files.len());
    for f in &files {
        let scenario = load_scenario(f, defaults.as_ref(), opts)?;
        if doc.require_tier && scenario.tier.is_none() {
            return Err(ScenarioError::key(
                f,
                "tier",
                format!(
                    "missing: {} sets `require_tier = true`, so every scenario file states its difficulty tier; \
                     add `tier = N` at the top of the file, N {}",
                    suite_file.display(),
                    crate::tier::TIER_HELP.trim_start_matches("an integer ")
                ),
            ));
        }
        scenarios.push(scenario);
    }
    let mut suite = finish(path, doc.description, scenarios)?;
    suite.sensor = opts.sensor.map(|p| p.name);
    Ok(suite)
}

fn finish(path: &Path, description: String, scenarios: Vec<Scenario>) -> Result<Suite, ScenarioError> {
    if scenarios.is_empty() {
        return Err(ScenarioError::Suite {
            path: path.into(),
            reason: "no scenario files (*.toml) found".into(),
        });
    }
    for (i, s) in scenarios.iter().enumerate() {
        if let Some(other) = scenarios[..i].iter().find(|o| o.name == s.name) {
            return Err(ScenarioError::Suite {
                path: path.into(),
                reason: format!(
                    "scenario name `{}` is used by both {} and {}; names must be unique (set `name = …`)",
                    s.name,
                    other.file.display(),
                    s.file.display()
                ),
            });
        }
    }
    let total = scenarios.iter().fold(0usize, |n, s| n.saturating_add(s.len()));
    if total > MAX_EPISODES_PER_SUITE {
        return Err(ScenarioError::Suite {
            path: path.into(),
            reason: format!(
                "the suite expands to {total} episodes (more than {MAX_EPISODES_PER_SUITE}); split it or use fewer sweep values"
            ),
        });
    }
    Ok(Suite {
        path: path.into(),
        description,
        scenarios,
        sensor: None,
    })
}

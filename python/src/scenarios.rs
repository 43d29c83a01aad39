//! Scenarios shipped inside the extension (so that an installed package needs no data files) and
//! scenario lookup by name or path.

use std::path::Path;

use loomlab_env::{EnvError, EnvScenario};

/// The name of the default scenario of `loomlab/Escape-v0`.
pub const DEFAULT: &str = "escape_default";

/// `(name, TOML text)` of every shipped scenario.
pub const BUILTIN: &[(&str, &str)] = &[(DEFAULT, include_str!("../python/loomlab/scenarios/escape_default.toml"))];

/// The TOML text of shipped scenario `name`.
pub fn builtin(name: &str) -> Result<&'static str, EnvError> {
    BUILTIN
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, t)| *t)
        .ok_or_else(|| {
            EnvError::Scenario(format!(
                "no shipped scenario named `{name}`; shipped: {:?} (or pass a path to a scenario TOML file)",
                BUILTIN.iter().map(|(n, _)| *n).collect::<Vec<_>>()
            ))
        })
}

/// The `scenario` argument of the environments: a shipped name or a path (a scenario file, a suite
/// folder or list file), or a list of paths (scenario files or suites, pooled as one suite).
#[derive(Debug, Clone, pyo3::FromPyObject)]
pub enum ScenarioArg {
    /// One name or path.
    One(String),
    /// Several paths, one suite.
    Many(Vec<String>),
}

/// Loads the scenario or suite of an environment's `scenario` / `scenario_toml` arguments (see
/// [`load`]; a list of paths is a suite, `EnvScenario::from_suite`).
pub fn load_arg(scenario: Option<&ScenarioArg>, toml: Option<&str>) -> Result<EnvScenario, EnvError> {
    match scenario {
        Some(ScenarioArg::Many(paths)) => {
            if toml.is_some() {
                return Err(EnvError::Scenario(
                    "give either a scenario (name, path or list of paths) or scenario_toml text, not both".into(),
                ));
            }
            EnvScenario::from_suite(paths.iter().map(std::path::PathBuf::from).collect())
        }
        Some(ScenarioArg::One(s)) => load(Some(s), toml),
        None => load(None, toml),
    }
}

/// Loads a scenario: `scenario` is a shipped name, a TOML file path or a suite (a folder or list
/// file, `EnvScenario::open`), `toml` is TOML text; at most one of them; neither gives the default
/// scenario.
pub fn load(scenario: Option<&str>, toml: Option<&str>) -> Result<EnvScenario, EnvError> {
    match (scenario, toml) {
        (Some(_), Some(_)) => Err(EnvError::Scenario(
            "give either a scenario (name or path) or scenario_toml text, not both".into(),
        )),
        (None, Some(text)) => Ok(EnvScenario::from_toml(text, "<scenario_toml>")),
        (None, None) => Ok(EnvScenario::from_toml(builtin(DEFAULT)?, format!("{DEFAULT}.toml"))),
        (Some(s), None) => {
            if let Ok(text) = builtin(s) {
                return Ok(EnvScenario::from_toml(text, format!("{s}.toml")));
            }
            let path = Path::new(s);
            if path.exists() {
                return EnvScenario::open(path);
            }
            Err(EnvError::Scenario(format!(
                "scenario `{s}` is neither a shipped scenario ({:?}) nor an existing file or suite folder",
                BUILTIN.iter().map(|(n, _)| *n).collect::<Vec<_>>(),
            )))
        }
    }
}

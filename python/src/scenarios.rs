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

/// Loads a scenario: `scenario` is a shipped name or a TOML file path, `toml` is TOML text; at most
/// one of them; neither gives the default scenario.
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
            if path.is_file() {
                return EnvScenario::from_file(path);
            }
            Err(EnvError::Scenario(format!(
                "scenario `{s}` is neither a shipped scenario ({:?}) nor an existing file{}",
                BUILTIN.iter().map(|(n, _)| *n).collect::<Vec<_>>(),
                if path.exists() { " (it is a directory)" } else { "" }
            )))
        }
    }
}

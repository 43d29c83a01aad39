//! Errors of scenario loading ([`ScenarioError`]: bad input, exit code 2 in the CLI) and of running
//! episodes ([`RunError`]).

use std::path::PathBuf;

use loomlab_agents::AgentError;
use loomlab_detector::DetectorError;
use loomlab_sim::SimError;

use crate::metrics::ScoringError;

/// A scenario or suite file could not be read, parsed, expanded or validated.
///
/// Every message starts with the file, names the key path (e.g. `world.projectiles[0].speed_mps`)
/// where there is one, and says what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The file is not valid TOML.
    #[error("{path}: invalid TOML: {message}")]
    Syntax {
        /// The file.
        path: PathBuf,
        /// The TOML parser's message (with line and column).
        message: String,
    },
    /// A key has a wrong value, a wrong type, is unknown, or is missing.
    #[error("{path}: `{key}`: {reason}")]
    Key {
        /// The file.
        path: PathBuf,
        /// Key path, e.g. `world.projectiles[0].speed_mps` (`<root>` for the whole file).
        key: String,
        /// What is wrong and how to fix it.
        reason: String,
    },
    /// One expanded episode of a scenario is invalid (e.g. a swept value out of range).
    #[error("{path}: episode {episode} ({params}): {reason}")]
    Episode {
        /// The file.
        path: PathBuf,
        /// Episode index within the scenario.
        episode: usize,
        /// The episode's swept/sampled values, `key = value, …`.
        params: String,
        /// What is wrong (names the key).
        reason: String,
    },
    /// A suite is malformed (no scenarios, duplicate names, …).
    #[error("{path}: {reason}")]
    Suite {
        /// The suite folder or list file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

impl ScenarioError {
    /// A [`ScenarioError::Key`] error.
    pub fn key(path: impl Into<PathBuf>, key: impl Into<String>, reason: impl Into<String>) -> Self {
        Self::Key {
            path: path.into(),
            key: key.into(),
            reason: reason.into(),
        }
    }
}

/// Something failed while running episodes (the input was valid).
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The episode gave up because the run was interrupted ([`crate::Runner::with_cancel`]).
    #[error("interrupted")]
    Interrupted,
    /// The simulator failed (no GPU adapter, rendering error, …).
    #[error("scenario `{scenario}` episode {episode}: simulator: {source}")]
    Sim {
        /// Scenario name.
        scenario: String,
        /// Episode index.
        episode: usize,
        /// The simulator's error.
        source: SimError,
    },
    /// A detector failed.
    #[error("scenario `{scenario}` episode {episode}: detector: {source}")]
    Detector {
        /// Scenario name.
        scenario: String,
        /// Episode index.
        episode: usize,
        /// The detector's error.
        source: DetectorError,
    },
    /// The escape controller rejected its configuration.
    #[error("scenario `{scenario}` episode {episode}: controller: {source}")]
    Controller {
        /// Scenario name.
        scenario: String,
        /// Episode index.
        episode: usize,
        /// The controller's error.
        source: AgentError,
    },
    /// Scoring failed (inconsistent ground truth: a bug, reported rather than hidden).
    #[error("scenario `{scenario}` episode {episode}: scoring: {source}")]
    Scoring {
        /// Scenario name.
        scenario: String,
        /// Episode index.
        episode: usize,
        /// The scoring error.
        source: ScoringError,
    },
    /// The GPU context could not be created (names the fix).
    #[error("cannot create the GPU context: {0}")]
    Gpu(SimError),
    /// The worker thread pool could not be created.
    #[error("cannot start {jobs} worker threads: {reason}")]
    Threads {
        /// Requested number of workers.
        jobs: usize,
        /// Why.
        reason: String,
    },
    /// The per-episode callback (e.g. writing episodes.csv) failed; the run was stopped.
    #[error("{0}")]
    Callback(String),
}

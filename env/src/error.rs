//! The error type of the step-by-step environment, with the coarse [`ErrorKind`] that the Python
//! bindings map to their exception tree (`loomlab.ScenarioError`, `RenderError`, `DetectorError`,
//! `ActionError`, all subclasses of `loomlab.LoomlabError`).

use loomlab_agents::AgentError;
use loomlab_detector::DetectorError;
use loomlab_sim::SimError;

use loomlab_scenarios::ScenarioError;
use loomlab_scenarios::metrics::ScoringError;

/// Everything that can go wrong while building or stepping an environment.
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    /// The scenario file could not be read, parsed or expanded.
    #[error(transparent)]
    Load(#[from] ScenarioError),
    /// The scenario cannot drive an environment (e.g. it sweeps the detector list).
    #[error("{0}")]
    Scenario(String),
    /// An environment option is out of range.
    #[error("invalid environment option `{key}` = {value}: {reason}")]
    InvalidOption {
        /// The option's name (e.g. `frame_size`, `reward.effort_per_s`).
        key: String,
        /// The offending value, formatted.
        value: String,
        /// What is wrong and how to fix it.
        reason: String,
    },
    /// The simulator failed (invalid world, no GPU adapter, rendering error).
    #[error(transparent)]
    Sim(#[from] SimError),
    /// A detector could not be built or stepped.
    #[error(transparent)]
    Detector(#[from] DetectorError),
    /// An action was malformed (NaN, out of range, unknown discrete index) or an action batch had
    /// the wrong size.
    #[error(transparent)]
    Action(#[from] AgentError),
    /// A batch of actions does not match the number of environments.
    #[error("got {got} actions for {expected} environments; pass one action per environment")]
    ActionCount {
        /// Number of environments.
        expected: usize,
        /// Number of actions given.
        got: usize,
    },
    /// A manoeuvre action index out of range ([`crate::MANOEUVRE_ACTIONS`]).
    #[error(
        "manoeuvre action index {index} is invalid: valid indices are 0..6 (cruise, sidestep_left, sidestep_right, \
         stop, reverse, plan)"
    )]
    InvalidManoeuvre {
        /// The offending index.
        index: i64,
    },
    /// An action of the wrong kind (continuous vs discrete) for this environment.
    #[error("this environment takes {expected} actions, got a {got} action")]
    ActionKind {
        /// The configured action kind.
        expected: &'static str,
        /// The kind given.
        got: &'static str,
    },
    /// The episode's outcome could not be scored.
    #[error(transparent)]
    Scoring(#[from] ScoringError),
    /// `step` was called before `reset` or after the episode ended.
    #[error("{0}")]
    State(&'static str),
    /// An error of one environment of an [`EscapeVectorEnv`](crate::EscapeVectorEnv), with its index.
    #[error("environment {index} of the vector environment: {source}")]
    InEnv {
        /// The environment's index in the vector environment (0-based).
        index: usize,
        /// What went wrong there.
        source: Box<EnvError>,
    },
    /// A seed outside the range of seeds (`u64`), e.g. a vector environment's `seed + i`.
    #[error("seed {seed} is out of range: {reason}")]
    Seed {
        /// The seed as given.
        seed: String,
        /// Why it is out of range and how to fix it.
        reason: String,
    },
}

/// Coarse classes of [`EnvError`], one per Python exception class.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// Bad scenario file, name, world description or environment option.
    Scenario,
    /// No GPU adapter, device or rendering failure.
    Render,
    /// Detector construction or stepping failed.
    Detector,
    /// A malformed action.
    Action,
    /// A seed out of range (Python `ValueError`).
    Seed,
    /// Anything else (scoring, calling `step` in the wrong state).
    Other,
}

impl EnvError {
    /// The class of this error.
    pub fn kind(&self) -> ErrorKind {
        match self {
            EnvError::Load(_) | EnvError::Scenario(_) | EnvError::InvalidOption { .. } => ErrorKind::Scenario,
            EnvError::Sim(SimError::InvalidDesc { .. }) => ErrorKind::Scenario,
            EnvError::Sim(_) => ErrorKind::Render,
            EnvError::Detector(_) => ErrorKind::Detector,
            EnvError::Action(_)
            | EnvError::ActionCount { .. }
            | EnvError::ActionKind { .. }
            | EnvError::InvalidManoeuvre { .. } => ErrorKind::Action,
            EnvError::Seed { .. } => ErrorKind::Seed,
            EnvError::InEnv { source, .. } => source.kind(),
            EnvError::Scoring(_) | EnvError::State(_) => ErrorKind::Other,
        }
    }

    /// This error as one of environment `index` of a vector environment (the message names it).
    pub fn in_env(self, index: usize) -> Self {
        EnvError::InEnv {
            index,
            source: Box::new(self),
        }
    }

    /// The index of the vector environment's sub-environment this error comes from, if any.
    pub fn env_index(&self) -> Option<usize> {
        match self {
            EnvError::InEnv { index, .. } => Some(*index),
            _ => None,
        }
    }

    pub(crate) fn option(key: impl Into<String>, value: impl ToString, reason: impl Into<String>) -> Self {
        EnvError::InvalidOption {
            key: key.into(),
            value: value.to_string(),
            reason: reason.into(),
        }
    }
}

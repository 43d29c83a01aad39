//! The errors of a sweep.

use std::path::{Path, PathBuf};

use crate::error::{RunError, ScenarioError};
use crate::metrics::ScoringError;

/// An error of a sweep: its file, its output folder or one of its shards.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The sweep file or the suite it names is invalid (names the file and key).
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// Reading or writing the output folder failed.
    #[error("{path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The output folder holds another sweep (or a damaged one).
    #[error("{path}: {reason}")]
    OutDir {
        /// The output folder or the file in it.
        path: PathBuf,
        /// What is wrong and how to fix it.
        reason: String,
    },
    /// A shard index out of range, or a shard's rows that do not match the plan.
    #[error("shard {shard}: {reason}")]
    Shard {
        /// Shard index.
        shard: usize,
        /// What is wrong.
        reason: String,
    },
    /// An episode failed to run.
    #[error(transparent)]
    Run(#[from] RunError),
    /// A shard file could not be parsed, or a report not written.
    #[error(transparent)]
    Scoring(#[from] ScoringError),
}

pub(super) fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> SweepError + '_ {
    move |source| SweepError::Io {
        path: path.into(),
        source,
    }
}

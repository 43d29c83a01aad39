//! Error type of the detector crate.

use std::path::PathBuf;

/// Everything that can go wrong in the detector crate.
#[derive(Debug, thiserror::Error)]
pub enum DetectorError {
    /// A configuration value is out of its valid range.
    #[error("invalid detector parameter `{name}` = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name as written in config files.
        name: &'static str,
        /// The offending value, formatted.
        value: String,
        /// What is wrong and how to fix it.
        reason: String,
    },
    /// A frame does not have the size the detector was built for.
    #[error(
        "frame is {got}×{got} pixels but the detector was built for {expected}×{expected}; rebuild the detector with n = {got} or resize the frames"
    )]
    FrameSize {
        /// Expected side length.
        expected: usize,
        /// Actual side length.
        got: usize,
    },
    /// Image data is malformed (wrong buffer length, zero size...).
    #[error("invalid image: {0}")]
    InvalidImage(String),
    /// A file could not be read or decoded.
    #[error("{path}: {reason}")]
    Io {
        /// The file involved.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// A stimulus description is malformed.
    #[error("{path}: {reason}")]
    Stimulus {
        /// The stimulus file (or `<inline>`).
        path: PathBuf,
        /// What is wrong, naming the key and the fix.
        reason: String,
    },
    /// A detector implemented outside Rust (a Python detector) failed: its exception, or an
    /// answer of the wrong form.
    #[error("detector `{detector}`: {reason}")]
    Failed {
        /// The detector's id.
        detector: String,
        /// What went wrong (the exception and where it was raised, or what was expected).
        reason: String,
    },
    /// An unknown detector id was requested.
    #[error("unknown detector `{0}`; known ids: {known} (or `all`)", known = crate::registry::detector_ids().join(", "))]
    UnknownDetector(String),
}

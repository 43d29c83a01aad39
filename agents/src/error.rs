//! Error type of the agents crate.

/// Everything that can go wrong in the agents crate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AgentError {
    /// A configuration value is out of its valid range.
    #[error("invalid controller parameter `{key}` = {value}: {reason}")]
    InvalidConfig {
        /// Key as written in config files (e.g. `escape.duration_s`).
        key: &'static str,
        /// The offending value, formatted.
        value: String,
        /// What is wrong and how to fix it.
        reason: String,
    },
    /// A continuous action component is NaN or infinite.
    #[error(
        "continuous action component {index} ({name}) is {value}: actions must be finite numbers in [-1, 1]; check the policy output for NaN"
    )]
    NonFiniteAction {
        /// Component index (0 forward, 1 yaw rate, 2 lateral).
        index: usize,
        /// Component name.
        name: &'static str,
        /// The offending value.
        value: f32,
    },
    /// A continuous action component lies outside [-1, 1].
    #[error(
        "continuous action component {index} ({name}) = {value} is outside [-1, 1]; rescale the policy output or use the clamping mapping"
    )]
    ActionOutOfRange {
        /// Component index (0 forward, 1 yaw rate, 2 lateral).
        index: usize,
        /// Component name.
        name: &'static str,
        /// The offending value.
        value: f32,
    },
    /// A discrete action index does not name an action.
    #[error(
        "discrete action index {index} is invalid: valid indices are 0..{count} (none, dodge_left, dodge_right, stop)"
    )]
    InvalidDiscreteAction {
        /// The offending index.
        index: i64,
        /// Number of discrete actions.
        count: usize,
    },
}

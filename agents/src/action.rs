//! Action spaces for external (RL) agents and their mapping to [`VelocityCommand`]s.
//!
//! - [`DiscreteAction`] (Gymnasium `Discrete(4)`): keep cruising, dodge left, dodge right, stop.
//!   Dodges add a lateral speed to the cruise command; stop zeroes everything.
//! - [`ContinuousAction`] (Gymnasium `Box(-1, 1, (3,), float32)`): normalised **absolute** commands
//!   `[forward, yaw_rate, lateral]`, each in [-1, 1], scaled by [`ActionConfig`]'s maxima. The cruise
//!   command is not used: the agent drives. NaN/∞ are always errors; values outside [-1, 1] are
//!   errors in [`ContinuousAction::to_command`] and clamped in [`ContinuousAction::to_command_clamped`].

use serde::{Deserialize, Serialize};

use crate::{AgentError, VelocityCommand};

/// Scales of the RL action mappings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ActionConfig {
    /// Lateral speed of the discrete dodge actions in m/s (> 0).
    pub dodge_speed_mps: f64,
    /// Forward speed for continuous action component 0 = ±1, in m/s (> 0).
    pub max_forward_mps: f64,
    /// Yaw rate for continuous action component 1 = ±1, in rad/s (> 0).
    pub max_yaw_rate_rps: f64,
    /// Lateral speed for continuous action component 2 = ±1, in m/s (> 0).
    pub max_lateral_mps: f64,
}

impl Default for ActionConfig {
    fn default() -> Self {
        Self {
            dodge_speed_mps: 1.5,
            max_forward_mps: 3.0,
            max_yaw_rate_rps: 1.5,
            max_lateral_mps: 1.5,
        }
    }
}

impl ActionConfig {
    /// Check every value; the error names the key, the value and the valid range.
    pub fn validate(&self) -> Result<(), AgentError> {
        for (key, v) in [
            ("action.dodge_speed_mps", self.dodge_speed_mps),
            ("action.max_forward_mps", self.max_forward_mps),
            ("action.max_yaw_rate_rps", self.max_yaw_rate_rps),
            ("action.max_lateral_mps", self.max_lateral_mps),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(AgentError::InvalidConfig {
                    key,
                    value: v.to_string(),
                    reason: "must be a finite number > 0".into(),
                });
            }
        }
        Ok(())
    }
}

/// The discrete action space (Gymnasium `Discrete(4)`, indices in declaration order).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DiscreteAction {
    /// 0: follow the cruise command.
    None,
    /// 1: cruise plus `dodge_speed_mps` to the left.
    DodgeLeft,
    /// 2: cruise plus `dodge_speed_mps` to the right.
    DodgeRight,
    /// 3: stand still.
    Stop,
}

impl DiscreteAction {
    /// Number of discrete actions.
    pub const COUNT: usize = 4;
    /// All actions, in index order.
    pub const ALL: [Self; 4] = [Self::None, Self::DodgeLeft, Self::DodgeRight, Self::Stop];

    /// The action with Gymnasium index `index`.
    pub fn from_index(index: i64) -> Result<Self, AgentError> {
        usize::try_from(index)
            .ok()
            .and_then(|i| Self::ALL.get(i).copied())
            .ok_or(AgentError::InvalidDiscreteAction {
                index,
                count: Self::COUNT,
            })
    }

    /// The Gymnasium index of this action.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The command for this action given the cruise command.
    pub fn to_command(self, cruise: VelocityCommand, config: &ActionConfig) -> VelocityCommand {
        match self {
            Self::None => cruise,
            Self::DodgeLeft => VelocityCommand {
                lateral_mps: cruise.lateral_mps + config.dodge_speed_mps,
                ..cruise
            },
            Self::DodgeRight => VelocityCommand {
                lateral_mps: cruise.lateral_mps - config.dodge_speed_mps,
                ..cruise
            },
            Self::Stop => VelocityCommand::STOP,
        }
    }

    /// The discrete action closest in meaning to `command` given the cruise command: `None` when
    /// it is the cruise command, a dodge by the sign of the extra lateral speed, else `Stop` (the
    /// escape controller's manoeuvres as discrete actions).
    pub fn from_command(command: VelocityCommand, cruise: VelocityCommand) -> Self {
        if command == cruise {
            Self::None
        } else if command.lateral_mps > cruise.lateral_mps + 1e-9 {
            Self::DodgeLeft
        } else if command.lateral_mps < cruise.lateral_mps - 1e-9 {
            Self::DodgeRight
        } else {
            Self::Stop
        }
    }
}

/// A continuous action `[forward, yaw_rate, lateral]`, each normalised to [-1, 1].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ContinuousAction(pub [f32; 3]);

impl ContinuousAction {
    /// Component names, in index order.
    pub const NAMES: [&'static str; 3] = ["forward", "yaw_rate", "lateral"];

    /// Check that every component is finite and in [-1, 1].
    pub fn validate(&self) -> Result<(), AgentError> {
        self.check_finite()?;
        for (index, &value) in self.0.iter().enumerate() {
            if !(-1.0..=1.0).contains(&value) {
                return Err(AgentError::ActionOutOfRange {
                    index,
                    name: Self::NAMES[index],
                    value,
                });
            }
        }
        Ok(())
    }

    /// The action with every component clamped into [-1, 1]; NaN/∞ are still errors
    /// (an infinite component usually means a broken policy, not a large request).
    pub fn clamped(&self) -> Result<Self, AgentError> {
        self.check_finite()?;
        Ok(Self(self.0.map(|v| v.clamp(-1.0, 1.0))))
    }

    /// Map to a command; errors on NaN/∞ or a component outside [-1, 1].
    pub fn to_command(&self, config: &ActionConfig) -> Result<VelocityCommand, AgentError> {
        self.validate()?;
        Ok(self.scale(config))
    }

    /// Map to a command after clamping into [-1, 1]; errors only on NaN/∞.
    pub fn to_command_clamped(&self, config: &ActionConfig) -> Result<VelocityCommand, AgentError> {
        Ok(self.clamped()?.scale(config))
    }

    /// The normalised action of a command (each component divided by its maximum, clamped into
    /// [-1, 1]): the inverse of [`to_command`](Self::to_command) for commands within the limits.
    pub fn from_command(command: VelocityCommand, config: &ActionConfig) -> Self {
        Self(
            [
                command.forward_mps / config.max_forward_mps,
                command.yaw_rate_rps / config.max_yaw_rate_rps,
                command.lateral_mps / config.max_lateral_mps,
            ]
            .map(|v| v.clamp(-1.0, 1.0) as f32),
        )
    }

    fn check_finite(&self) -> Result<(), AgentError> {
        match self.0.iter().position(|v| !v.is_finite()) {
            Some(index) => Err(AgentError::NonFiniteAction {
                index,
                name: Self::NAMES[index],
                value: self.0[index],
            }),
            None => Ok(()),
        }
    }

    fn scale(&self, config: &ActionConfig) -> VelocityCommand {
        let [f, y, l] = self.0;
        VelocityCommand {
            forward_mps: f64::from(f) * config.max_forward_mps,
            yaw_rate_rps: f64::from(y) * config.max_yaw_rate_rps,
            lateral_mps: f64::from(l) * config.max_lateral_mps,
        }
    }
}

//! The velocity command every controller produces.

use serde::{Deserialize, Serialize};

/// A body-frame velocity command (REP 103: x forward, y left, z up).
///
/// `lateral_mps` is only honoured by holonomic bases; the simulator ignores it (or converts it)
/// for differential-drive robots.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VelocityCommand {
    /// Forward speed in m/s (negative: backwards).
    pub forward_mps: f64,
    /// Yaw rate in rad/s (positive: turn left, counter-clockwise seen from above).
    pub yaw_rate_rps: f64,
    /// Lateral speed in m/s (positive: to the robot's left).
    pub lateral_mps: f64,
}

impl VelocityCommand {
    /// This command as the efference copy a detector gets for the camera period it was applied in.
    pub fn efference_copy(&self) -> loomlab_detector::EfferenceCopy {
        loomlab_detector::EfferenceCopy {
            forward_mps: self.forward_mps,
            yaw_rate_rps: self.yaw_rate_rps,
            lateral_mps: self.lateral_mps,
            ..loomlab_detector::EfferenceCopy::default()
        }
    }

    /// All components zero: stand still.
    pub const STOP: Self = Self {
        forward_mps: 0.0,
        yaw_rate_rps: 0.0,
        lateral_mps: 0.0,
    };

    /// Straight-ahead cruise at `forward_mps`.
    pub fn forward(forward_mps: f64) -> Self {
        Self {
            forward_mps,
            ..Self::STOP
        }
    }

    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        self.forward_mps.is_finite() && self.yaw_rate_rps.is_finite() && self.lateral_mps.is_finite()
    }

    /// The simulator's command (single precision).
    pub fn to_sim(self) -> loomlab_sim::Command {
        loomlab_sim::Command {
            forward_mps: self.forward_mps as f32,
            yaw_rate_rps: self.yaw_rate_rps as f32,
            lateral_mps: self.lateral_mps as f32,
        }
    }
}

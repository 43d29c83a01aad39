//! Observation modes: the raw detector outputs ([`ObsMode::Raw`]) or bounded, scaled features a
//! policy network can take as they are ([`ObsMode::Normalized`]). This module is the one source of
//! truth for the normalized features: their names, scales and declared bounds (exported to Python
//! as `loomlab._native.FEATURE_SCALES` and by each environment's `feature_names` / `feature_low` /
//! `feature_high`).
//!
//! # The normalized feature vector
//! In order (`D` detectors, in [`EscapeEnv::detector_labels`](crate::EscapeEnv::detector_labels) order):
//!
//! | feature | definition | bounds |
//! |---|---|---|
//! | `{label}.log_output` (× D) | `sign(y)·ln(1+|y|) / ln(1+SIGNAL_LIMIT)` of the detector's output `y` | [−1, 1] |
//! | `{label}.log_output_rate` (× D) | `tanh(Δ log_output / Δt / LOG_RATE_SCALE_PER_S)` | [−1, 1] |
//! | `theta_hat_rad` | θ̂ of the first detector giving one, radians | [0, π] |
//! | `theta_hat_rate_rps` | dθ̂/dt (rad/s), clamped into ±[`THETA_RATE_LIMIT_RPS`] | [−10, 10] |
//! | `{label}.alarm` (× D) | 1 when the detector's trigger signal is at or above its threshold | {0, 1} |
//! | `looming_side` | image x of the looming object (the x centroid of the temporal contrast, [`loomlab_agents::LoomingSideEstimator`]: −1 left edge, +1 right edge), 0 when unknown | [−1, 1] |
//! | `robot.x` | distance along the start heading / [`POSITION_SCALE_M`], clamped | [−1, 1] |
//! | `robot.y` | lateral offset (left +) / [`POSITION_SCALE_M`], clamped | [−1, 1] |
//! | `robot.yaw` | heading relative to the start heading / π | [−1, 1] |
//! | `robot.forward`, `robot.yaw_rate`, `robot.lateral` | last command over the action scales (`ActionConfig`'s maxima), clamped | [−1, 1] |
//! | `robot.time` | episode time / the episode's duration | [0, 1] |
//!
//! Rates are differences between consecutive observations over the camera period; the reset
//! observation has zero signals (the detectors see their first frame in the first step), so the
//! first step's rates are measured from zero.

use serde::{Deserialize, Serialize};

use super::{Observation, SIGNAL_LIMIT};
use loomlab_agents::{ActionConfig, ContinuousAction, VelocityCommand};

/// What an observation holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObsMode {
    /// The raw signals: per detector `[output, aux…]` in ±[`SIGNAL_LIMIT`], θ̂ in degrees, alarm
    /// flags and the robot state in SI units.
    #[default]
    Raw,
    /// One vector of bounded, scaled features (see the module docs).
    Normalized,
}

impl ObsMode {
    /// `"raw"` or `"normalized"`.
    pub fn as_str(self) -> &'static str {
        match self {
            ObsMode::Raw => "raw",
            ObsMode::Normalized => "normalized",
        }
    }
}

/// Rate of the log-compressed output (per second) that maps to tanh(1) ≈ 0.76.
pub const LOG_RATE_SCALE_PER_S: f64 = 2.0;
/// dθ̂/dt is clamped into ±this (rad/s).
pub const THETA_RATE_LIMIT_RPS: f64 = 10.0;
/// Robot positions are divided by this and clamped into [−1, 1] (m).
pub const POSITION_SCALE_M: f64 = 5.0;

/// The scales of the normalized features, by name (exported to Python as `FEATURE_SCALES`).
pub const FEATURE_SCALES: [(&str, f64); 4] = [
    ("signal_limit", SIGNAL_LIMIT as f64),
    ("log_rate_scale_per_s", LOG_RATE_SCALE_PER_S),
    ("theta_rate_limit_rps", THETA_RATE_LIMIT_RPS),
    ("position_scale_m", POSITION_SCALE_M),
];

/// Number of features that do not depend on the number of detectors (θ̂, its rate, the looming
/// side and the 7 robot features).
pub const FIXED_FEATURES: usize = 10;

/// Name and declared bounds of one feature.
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureSpec {
    /// Feature name (`hopfield.log_output`, `robot.y`, …).
    pub name: String,
    /// Lower bound.
    pub low: f32,
    /// Upper bound.
    pub high: f32,
}

fn spec(name: impl Into<String>, low: f64, high: f64) -> FeatureSpec {
    FeatureSpec {
        name: name.into(),
        low: low as f32,
        high: high as f32,
    }
}

/// The features of an environment observing `labels` (in order), with their bounds.
pub fn feature_specs(labels: &[&str]) -> Vec<FeatureSpec> {
    let mut v = Vec::with_capacity(3 * labels.len() + FIXED_FEATURES);
    v.extend(labels.iter().map(|l| spec(format!("{l}.log_output"), -1.0, 1.0)));
    v.extend(labels.iter().map(|l| spec(format!("{l}.log_output_rate"), -1.0, 1.0)));
    v.push(spec("theta_hat_rad", 0.0, std::f64::consts::PI));
    v.push(spec("theta_hat_rate_rps", -THETA_RATE_LIMIT_RPS, THETA_RATE_LIMIT_RPS));
    v.extend(labels.iter().map(|l| spec(format!("{l}.alarm"), 0.0, 1.0)));
    v.push(spec("looming_side", -1.0, 1.0));
    for name in ["x", "y", "yaw", "forward", "yaw_rate", "lateral"] {
        v.push(spec(format!("robot.{name}"), -1.0, 1.0));
    }
    v.push(spec("robot.time", 0.0, 1.0));
    v
}

/// `sign(y)·ln(1+|y|) / ln(1+SIGNAL_LIMIT)`: in [−1, 1] for |y| ≤ [`SIGNAL_LIMIT`] (the raw
/// observation's clamp), monotone, ≈ linear near 0.
pub fn log_compress(y: f32) -> f64 {
    let y = f64::from(y).clamp(-f64::from(SIGNAL_LIMIT), f64::from(SIGNAL_LIMIT));
    y.signum() * y.abs().ln_1p() / f64::from(SIGNAL_LIMIT).ln_1p()
}

/// Computes normalized features from successive raw observations (one per environment; reset at
/// every episode start).
#[derive(Debug, Clone, Default)]
pub struct Normalizer {
    last_log: Vec<f64>,
    last_theta_rad: f64,
}

impl Normalizer {
    /// Forgets the previous observation (the reset observation's signals are zero).
    pub fn reset(&mut self, detectors: usize) {
        self.last_log = vec![0.0; detectors];
        self.last_theta_rad = 0.0;
    }

    /// The features of `obs` (see the module docs), `dt` after the previous one; `looming_side` is
    /// the looming object's image x on this frame, `duration_s` the episode's duration, `action` the
    /// action scales, `last_command` the robot's last command.
    #[allow(clippy::too_many_arguments)]
    pub fn features(
        &mut self,
        obs: &Observation,
        looming_side: Option<f32>,
        dt: f64,
        duration_s: f64,
        action: &ActionConfig,
        last_command: VelocityCommand,
    ) -> Vec<f32> {
        let nd = obs.signals.len();
        if self.last_log.len() != nd {
            self.reset(nd);
        }
        let mut f = Vec::with_capacity(3 * nd + FIXED_FEATURES);
        let logs: Vec<f64> = obs.signals.iter().map(|s| log_compress(s[0])).collect();
        f.extend(logs.iter().map(|&v| v as f32));
        let dt = if dt > 0.0 { dt } else { 1.0 };
        f.extend(
            logs.iter()
                .zip(&self.last_log)
                .map(|(v, last)| ((v - last) / dt / LOG_RATE_SCALE_PER_S).tanh() as f32),
        );
        let theta = f64::from(obs.theta_hat_deg)
            .to_radians()
            .clamp(0.0, std::f64::consts::PI);
        f.push(theta as f32);
        let rate = ((theta - self.last_theta_rad) / dt).clamp(-THETA_RATE_LIMIT_RPS, THETA_RATE_LIMIT_RPS);
        f.push(rate as f32);
        f.extend(obs.alarm.iter().map(|&a| f32::from(u8::from(a))));
        f.push(
            looming_side
                .filter(|v| v.is_finite())
                .map_or(0.0, |v| v.clamp(-1.0, 1.0)),
        );
        let unit = |v: f64| v.clamp(-1.0, 1.0) as f32;
        let r = &obs.robot;
        f.push(unit(f64::from(r[0]) / POSITION_SCALE_M));
        f.push(unit(f64::from(r[1]) / POSITION_SCALE_M));
        f.push(unit(f64::from(r[2]) / std::f64::consts::PI));
        f.extend(
            ContinuousAction::from_command(last_command, action)
                .0
                .map(|v| v.clamp(-1.0, 1.0)),
        );
        let t = if duration_s > 0.0 {
            f64::from(r[6]) / duration_s
        } else {
            0.0
        };
        f.push(t.clamp(0.0, 1.0) as f32);
        self.last_log = logs;
        self.last_theta_rad = theta;
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_compress_is_bounded_monotone_and_odd() {
        assert_eq!(log_compress(0.0), 0.0);
        assert!((log_compress(SIGNAL_LIMIT) - 1.0).abs() < 1e-12);
        assert!((log_compress(-SIGNAL_LIMIT) + 1.0).abs() < 1e-12);
        assert!(log_compress(1e9) <= 1.0, "beyond the clamp stays in bounds");
        let xs = [0.0, 0.5, 3.0, 1e2, 1e4, 1e6];
        for w in xs.windows(2) {
            assert!(log_compress(w[1]) > log_compress(w[0]));
        }
        assert_eq!(log_compress(-3.0), -log_compress(3.0));
    }

    #[test]
    fn feature_names_are_unique_and_bounds_ordered() {
        let specs = feature_specs(&["hopfield", "soc"]);
        assert_eq!(specs.len(), 3 * 2 + FIXED_FEATURES);
        let mut names: Vec<_> = specs.iter().map(|s| s.name.as_str()).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), specs.len());
        assert!(specs.iter().all(|s| s.low < s.high));
    }
}

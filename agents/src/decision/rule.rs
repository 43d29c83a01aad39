//! The decision's configuration: [`DecisionRule`] (what is decided on and how) and the robot's
//! facts the course gate needs ([`BodyExtent`]).

use serde::{Deserialize, Serialize};

#[allow(unused_imports)] // for doc links
use loomlab_detector::Signals;

/// The most frames of [`DecisionRule::persistence_frames`] (10 000: over a minute at 120 Hz).
pub const MAX_PERSISTENCE_FRAMES: usize = 10_000;

/// Which detector signal the decision reads and compares with its threshold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TriggerSignal {
    /// The angular-size estimate θ̂ in degrees ([`Signals::angular_size_deg`], Hopfield detector).
    /// Also spelled `angular_size`.
    #[default]
    #[serde(alias = "angular_size")]
    AngularSizeDeg,
    /// The detector's primary output ([`Signals::output`]) in its own units (baselines).
    Output,
    /// Time to contact estimated from θ̂ ([`crate::decision`]): the value is the urgency 1/τ̂
    /// (s⁻¹), alarm when τ̂ ≤ [`DecisionRule::tau_threshold_s`] and θ̂ ≥
    /// [`DecisionRule::min_angular_size_deg`]. Needs a detector that gives θ̂.
    Tau,
}

impl TriggerSignal {
    /// The scalar this trigger reads from a detector's signals (`None` when the detector gives none):
    /// θ̂ for the angular-size and τ triggers (τ is estimated from θ̂ by the decider), the output
    /// otherwise.
    pub fn value(self, signals: &Signals) -> Option<f64> {
        match self {
            Self::AngularSizeDeg | Self::Tau => signals.angular_size_deg,
            Self::Output => Some(signals.output),
        }
    }

    /// Whether this trigger reads θ̂ (degrees) rather than a detector output.
    pub fn reads_angular_size(self) -> bool {
        matches!(self, Self::AngularSizeDeg | Self::Tau)
    }
}

/// The collision-course gate (see the [module docs](crate::decision)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Course {
    /// No gate: every alarm goes through.
    #[default]
    Off,
    /// The gate from the object's image position and angular size and the robot's body.
    Image,
}

/// How a row decides (see the [module docs](crate::decision)): the trigger and its threshold, the
/// τ estimator's window, the optional collision-course gate and K-of-M persistence. The escape
/// controller's `[controller]` keys of the same names configure it
/// ([`EscapeConfig::decision_rule`](crate::EscapeConfig::decision_rule)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DecisionRule {
    /// Which detector signal is decided on (default: θ̂, [`TriggerSignal::AngularSizeDeg`]).
    pub trigger: TriggerSignal,
    /// Alarm threshold of the angular-size (degrees; default 10) and output (detector units)
    /// triggers; not used by [`TriggerSignal::Tau`].
    pub threshold: f64,
    /// [`TriggerSignal::Tau`]: alarm when τ̂ ≤ this (s, > 0; default 1).
    pub tau_threshold_s: f64,
    /// Smallest θ̂ (degrees, ≥ 0; default 1) for a τ alarm, and for a frame to enter the τ̂ fit.
    pub min_angular_size_deg: f64,
    /// Length of the τ̂ estimation window (s, > 0; default 0.1).
    pub tau_window_s: f64,
    /// The collision-course gate (default off).
    pub course: Course,
    /// Closing speed the gate assumes to turn τ̂ into a distance (m/s, > 0; default 10).
    pub course_closing_speed_mps: f64,
    /// Length of the window over which the gate estimates bearing and expansion rates (s, > 0;
    /// default 0.25).
    pub course_window_s: f64,
    /// Persistence K (frames, 1–[`MAX_PERSISTENCE_FRAMES`]; default 1: none): the value is the K-th
    /// largest of the last M frames' values.
    pub persistence_frames: usize,
    /// The persistence window M (frames, ≥ K; default `None`: M = K, consecutive frames).
    pub persistence_window_frames: Option<usize>,
}

impl Default for DecisionRule {
    fn default() -> Self {
        Self {
            trigger: TriggerSignal::AngularSizeDeg,
            threshold: 10.0,
            tau_threshold_s: 1.0,
            min_angular_size_deg: 1.0,
            tau_window_s: 0.1,
            course: Course::Off,
            course_closing_speed_mps: 10.0,
            course_window_s: 0.25,
            persistence_frames: 1,
            persistence_window_frames: None,
        }
    }
}

impl DecisionRule {
    /// The persistence window M (frames, at least K).
    pub fn persistence_window(&self) -> usize {
        self.persistence_window_frames
            .unwrap_or(self.persistence_frames)
            .max(self.persistence_frames)
    }

    /// Whether the decision keeps state (τ trigger, course gate or persistence): only then does
    /// the decision value differ from the raw trigger signal.
    pub fn is_stateful(&self) -> bool {
        self.trigger == TriggerSignal::Tau || self.course != Course::Off || self.persistence_window() > 1
    }

    /// The threshold the decision value is compared with: `threshold`, or the urgency
    /// `1 / tau_threshold_s` (s⁻¹) for [`TriggerSignal::Tau`].
    pub fn alarm_threshold(&self) -> f64 {
        match self.trigger {
            TriggerSignal::Tau => 1.0 / self.tau_threshold_s,
            _ => self.threshold,
        }
    }
}

/// Where the robot's body extends about its camera (what the course gate tests an object's
/// predicted arrival against).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyExtent {
    /// Half-width of the body (m, ≥ 0; default 0.2).
    pub half_width_m: f64,
    /// How far the body reaches above the camera (m; default 0.05).
    pub above_camera_m: f64,
    /// How far the body reaches below the camera (m; default 0.25).
    pub below_camera_m: f64,
}

impl Default for BodyExtent {
    fn default() -> Self {
        Self {
            half_width_m: 0.2,
            above_camera_m: 0.05,
            below_camera_m: 0.25,
        }
    }
}

//! The decision's configuration: [`DecisionRule`] (what is decided on and how) and the robot's
//! facts the course gate needs ([`BodyExtent`]).

use serde::{Deserialize, Serialize};

use crate::AgentError;
use crate::escape::{invalid, non_negative};

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
/// τ estimator's window, K-of-M persistence and the optional collision-course gate. The escape
/// controller embeds it ([`EscapeConfig::decision`](crate::EscapeConfig::decision): its keys are
/// keys of the scenario's `[controller]` table), and a scenario's `[[detectors]]` row sets its
/// trigger, threshold, course and persistence. (Serialized flat, in this order, inside
/// [`crate::EscapeConfig`].)
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DecisionRule {
    /// Which detector signal is decided on (default: θ̂, [`TriggerSignal::AngularSizeDeg`]).
    pub trigger: TriggerSignal,
    /// Trigger threshold: degrees for [`TriggerSignal::AngularSizeDeg`] (default 10°, the locust's
    /// escape angle; tuned by the scenario suite), detector output units for
    /// [`TriggerSignal::Output`]. Not used by [`TriggerSignal::Tau`] (see `tau_threshold_s`).
    pub threshold: f64,
    /// [`TriggerSignal::Tau`]: alarm when the estimated time to contact τ̂ ≤ this (s, > 0; default
    /// 1).
    pub tau_threshold_s: f64,
    /// [`TriggerSignal::Tau`]: the smallest θ̂ (degrees, ≥ 0; default 1) for an alarm, and for a
    /// frame to enter the τ̂ fit.
    pub min_angular_size_deg: f64,
    /// Length of the window over which τ̂ is estimated (s, > 0; default 0.1).
    pub tau_window_s: f64,
    /// The collision-course gate (default off); needs θ̂.
    pub course: Course,
    /// Persistence K (frames, 1–[`MAX_PERSISTENCE_FRAMES`]; default 1: none): the decision value is
    /// the smallest of the last K frames' values, so an alarm needs the value at or above the
    /// threshold on K consecutive frames — for any threshold, so a calibration of the threshold
    /// sees the same rule.
    pub persistence_frames: usize,
    /// The persistence window M (frames, K–[`MAX_PERSISTENCE_FRAMES`]; default `None`: M = K,
    /// consecutive frames): with a longer window the decision value is the K-th largest of the
    /// last M frames' values, so an alarm needs the value at or above the threshold on any K of the
    /// last M frames — a K-of-M confirmation that a single frame's dropout does not reset.
    pub persistence_window_frames: Option<usize>,
    /// Closing speed the course gate assumes to turn τ̂ into a distance (m/s, > 0; default 10: a
    /// thrown ball). An object closing faster looks nearer the robot's axis than it is (a fast near
    /// pass may get through), a slower one farther (a slow graze of the body's edge may be gated
    /// out); objects standing in the world close at the robot's own speed, which the gate uses.
    pub course_closing_speed_mps: f64,
    /// Window over which the course gate estimates the bearing and expansion rates (s, > 0;
    /// default 0.25).
    pub course_window_s: f64,
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
            persistence_frames: 1,
            persistence_window_frames: None,
            course_closing_speed_mps: 10.0,
            course_window_s: 0.25,
        }
    }
}

impl DecisionRule {
    /// Check every value; the error names the key (as a key of the escape controller's table,
    /// `escape.<key>`), the value and the valid range.
    pub fn validate(&self) -> Result<(), AgentError> {
        if !self.threshold.is_finite() {
            return Err(invalid("escape.threshold", self.threshold, "must be a finite number"));
        }
        for (key, v) in [
            ("escape.tau_threshold_s", self.tau_threshold_s),
            ("escape.tau_window_s", self.tau_window_s),
            ("escape.course_closing_speed_mps", self.course_closing_speed_mps),
            ("escape.course_window_s", self.course_window_s),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(invalid(key, v, "must be a finite number > 0"));
            }
        }
        non_negative("escape.min_angular_size_deg", self.min_angular_size_deg)?;
        if !(1..=MAX_PERSISTENCE_FRAMES).contains(&self.persistence_frames) {
            return Err(invalid(
                "escape.persistence_frames",
                self.persistence_frames,
                &format!("must be a whole number of frames from 1 (no persistence) to {MAX_PERSISTENCE_FRAMES}"),
            ));
        }
        if let Some(m) = self.persistence_window_frames
            && !(self.persistence_frames..=MAX_PERSISTENCE_FRAMES).contains(&m)
        {
            return Err(invalid(
                "escape.persistence_window_frames",
                m,
                &format!(
                    "must be a whole number of frames from escape.persistence_frames ({}) to {MAX_PERSISTENCE_FRAMES}",
                    self.persistence_frames
                ),
            ));
        }
        if self.course != Course::Off && self.trigger == TriggerSignal::Output {
            return Err(invalid(
                "escape.course",
                "image",
                "the collision-course gate needs θ̂: use trigger = \"tau\" or \"angular_size\" on a detector that gives θ̂",
            ));
        }
        Ok(())
    }

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
    /// How far the body reaches ahead of the camera (m, ≥ 0; default 0: a camera at the front).
    pub ahead_of_camera_m: f64,
    /// How far the body reaches behind the camera (m, ≥ 0; default 0.5).
    pub behind_camera_m: f64,
}

impl Default for BodyExtent {
    fn default() -> Self {
        Self {
            half_width_m: 0.2,
            above_camera_m: 0.05,
            below_camera_m: 0.25,
            ahead_of_camera_m: 0.0,
            behind_camera_m: 0.5,
        }
    }
}

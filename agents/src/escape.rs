//! The escape controller: cruise until the detector's signal crosses a threshold, then run one
//! escape manoeuvre for a fixed time, then a cooldown during which it cannot trigger again.
//!
//! # Trigger semantics
//! The controller compares one scalar per frame against [`EscapeConfig::threshold`]:
//! - [`TriggerSignal::AngularSizeDeg`]: the Hopfield detector's angular-size estimate θ̂ in degrees
//!   ([`Signals::angular_size_deg`]); the threshold is an angle (locusts escape at about 10°, the
//!   paper's discussion; the default, to be tuned by the scenario suite).
//! - [`TriggerSignal::Output`]: the detector's primary output ([`Signals::output`]) in that
//!   detector's own units (the baselines' LGMD potentials); the threshold must be chosen per detector.
//!
//! The trigger is **level-based**: an armed controller triggers on the first step whose signal is
//! `>= threshold`. So if the signal is still above the threshold when the cooldown ends, the
//! controller triggers again at once (the object is still looming). NaN or missing signals never
//! trigger. This is the same rule the scoring uses for the alarm time, so "first alarm" and "first
//! trigger" coincide.
//!
//! # Timeline
//! A trigger at `t0` runs the manoeuvre over `[t0, t0 + duration_s)`, then the cruise command is
//! passed through again during the cooldown `[t0 + duration_s, t0 + duration_s + cooldown_s)`, in
//! which no new trigger is accepted; from `t0 + duration_s + cooldown_s` on the controller is armed.
//! `t_s` must be non-decreasing within an episode; call [`EscapeController::reset`] between episodes.
//!
//! # Dodge side
//! A lateral dodge moves away from the side of the image where the looming object is. The runner
//! passes that side as `looming_side`, the image x of the object in [-1, 1] (−1 left edge, +1 right
//! edge); the scenario runner estimates it from the frame, e.g. as the x centroid of the temporal
//! contrast |frame(t) − frame(t−1)|. An object on the right (x > `side_deadband`) makes the robot
//! dodge left, one on the left (x < −`side_deadband`) right. When the side is unknown (`None`, NaN)
//! or too central (|x| ≤ `side_deadband`) the controller dodges to `default_side`. The side is
//! latched at the trigger and kept for the whole manoeuvre.

use serde::{Deserialize, Serialize};

use loomlab_sim::RobotBase;

use crate::{AgentError, VelocityCommand};

#[allow(unused_imports)] // for doc links
use loomlab_detector::Signals;

/// Which detector signal the controller compares against its threshold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TriggerSignal {
    /// The angular-size estimate θ̂ in degrees ([`Signals::angular_size_deg`], Hopfield detector).
    #[default]
    AngularSizeDeg,
    /// The detector's primary output ([`Signals::output`]) in its own units (baselines).
    Output,
}

impl TriggerSignal {
    /// The scalar this trigger reads from a detector's signals (`None` when the detector gives none).
    pub fn value(self, signals: &Signals) -> Option<f64> {
        match self {
            Self::AngularSizeDeg => signals.angular_size_deg,
            Self::Output => Some(signals.output),
        }
    }
}

/// The escape manoeuvre run after a trigger.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Manoeuvre {
    /// Get out of the looming object's way, towards the side away from it. On a holonomic base:
    /// sidestep at `dodge_speed_mps` (forward speed scaled by `dodge_forward_scale`, optional yaw
    /// away at `dodge_yaw_rate_rps`). On a differential drive, which cannot sidestep: turn away at
    /// `turn_rate_rps` while driving forward at `dodge_speed_mps` (or the cruise speed if faster), so
    /// the robot arcs out of the object's path.
    #[default]
    DodgeLateral,
    /// Stand still.
    Stop,
    /// Drive backwards at `reverse_speed_mps`.
    Reverse,
}

/// A side of the robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DodgeSide {
    /// The robot's left (+y).
    #[default]
    Left,
    /// The robot's right (−y).
    Right,
}

impl DodgeSide {
    /// +1 for left, −1 for right (the sign of a lateral speed or yaw rate towards that side).
    pub fn sign(self) -> f64 {
        match self {
            Self::Left => 1.0,
            Self::Right => -1.0,
        }
    }

    /// The side to dodge to, away from an object at image x `looming_side` (see the module docs).
    pub fn away_from(looming_side: Option<f32>, deadband: f32, default: DodgeSide) -> DodgeSide {
        match looming_side {
            Some(x) if x.is_finite() && x > deadband => Self::Left,
            Some(x) if x.is_finite() && x < -deadband => Self::Right,
            _ => default,
        }
    }
}

/// Configuration of the [`EscapeController`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EscapeConfig {
    /// Which detector signal is compared with `threshold`.
    pub trigger: TriggerSignal,
    /// Trigger threshold: degrees for [`TriggerSignal::AngularSizeDeg`] (default 10°, the locust's
    /// escape angle; tuned by the scenario suite), detector output units for [`TriggerSignal::Output`].
    pub threshold: f64,
    /// The manoeuvre run after a trigger.
    pub manoeuvre: Manoeuvre,
    /// Lateral speed of a dodge in m/s (≥ 0).
    pub dodge_speed_mps: f64,
    /// Factor on the cruise forward speed during a dodge (1 keeps going, 0 sidesteps on the spot).
    pub dodge_forward_scale: f64,
    /// Yaw rate towards the dodge side in rad/s during a dodge (≥ 0; 0 keeps the heading).
    pub dodge_yaw_rate_rps: f64,
    /// Yaw rate of a dodge on a differential drive in rad/s (≥ 0; see [`Manoeuvre::DodgeLateral`]).
    pub turn_rate_rps: f64,
    /// Backwards speed of [`Manoeuvre::Reverse`] in m/s (≥ 0).
    pub reverse_speed_mps: f64,
    /// How long the manoeuvre lasts, in seconds (> 0).
    pub duration_s: f64,
    /// Time after the manoeuvre during which no new trigger is accepted, in seconds (≥ 0).
    pub cooldown_s: f64,
    /// Side to dodge to when the looming side is unknown or central.
    pub default_side: DodgeSide,
    /// |image x| of the looming side at or below which it counts as central, in [0, 1).
    pub side_deadband: f32,
    /// The robot's drive, which decides what a dodge is. Not a key of the `[controller]` table: the
    /// scenario loader sets it from `world.robot.base`.
    #[serde(skip)]
    pub base: RobotBase,
}

impl Default for EscapeConfig {
    fn default() -> Self {
        Self {
            trigger: TriggerSignal::AngularSizeDeg,
            threshold: 10.0,
            manoeuvre: Manoeuvre::DodgeLateral,
            dodge_speed_mps: 1.5,
            dodge_forward_scale: 1.0,
            dodge_yaw_rate_rps: 0.0,
            turn_rate_rps: 2.0,
            reverse_speed_mps: 1.0,
            duration_s: 0.6,
            cooldown_s: 0.5,
            default_side: DodgeSide::Left,
            side_deadband: 0.05,
            base: RobotBase::Holonomic,
        }
    }
}

fn invalid(key: &'static str, value: impl ToString, reason: &str) -> AgentError {
    AgentError::InvalidConfig {
        key,
        value: value.to_string(),
        reason: reason.to_string(),
    }
}

fn non_negative(key: &'static str, v: f64) -> Result<(), AgentError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(invalid(key, v, "must be a finite number >= 0"))
    }
}

impl EscapeConfig {
    /// Check every value; the error names the key, the value and the valid range.
    pub fn validate(&self) -> Result<(), AgentError> {
        if !self.threshold.is_finite() {
            return Err(invalid("escape.threshold", self.threshold, "must be a finite number"));
        }
        non_negative("escape.dodge_speed_mps", self.dodge_speed_mps)?;
        non_negative("escape.dodge_forward_scale", self.dodge_forward_scale)?;
        non_negative("escape.dodge_yaw_rate_rps", self.dodge_yaw_rate_rps)?;
        non_negative("escape.turn_rate_rps", self.turn_rate_rps)?;
        non_negative("escape.reverse_speed_mps", self.reverse_speed_mps)?;
        if !(self.duration_s.is_finite() && self.duration_s > 0.0) {
            return Err(invalid(
                "escape.duration_s",
                self.duration_s,
                "must be a finite number of seconds > 0",
            ));
        }
        non_negative("escape.cooldown_s", self.cooldown_s)?;
        if !(self.side_deadband.is_finite() && (0.0..1.0).contains(&self.side_deadband)) {
            return Err(invalid(
                "escape.side_deadband",
                self.side_deadband,
                "must lie in [0, 1)",
            ));
        }
        Ok(())
    }

    /// Whether `signal` is an alarm: `signal >= threshold` (NaN and `None` never are).
    pub fn is_alarm(&self, signal: Option<f64>) -> bool {
        signal.is_some_and(|s| s >= self.threshold)
    }

    /// The command of the manoeuvre towards `side` given the cruise command.
    pub fn manoeuvre_command(&self, side: DodgeSide, cruise: VelocityCommand) -> VelocityCommand {
        match self.manoeuvre {
            Manoeuvre::DodgeLateral if !self.base.can_sidestep() => VelocityCommand {
                forward_mps: cruise.forward_mps.max(self.dodge_speed_mps),
                yaw_rate_rps: side.sign() * self.turn_rate_rps,
                lateral_mps: 0.0,
            },
            Manoeuvre::DodgeLateral => VelocityCommand {
                forward_mps: cruise.forward_mps * self.dodge_forward_scale,
                yaw_rate_rps: side.sign() * self.dodge_yaw_rate_rps,
                lateral_mps: side.sign() * self.dodge_speed_mps,
            },
            Manoeuvre::Stop => VelocityCommand::STOP,
            Manoeuvre::Reverse => VelocityCommand::forward(-self.reverse_speed_mps),
        }
    }
}

/// What the controller did in one step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ControllerEvent {
    /// Armed, no trigger: the cruise command passed through.
    Cruise,
    /// The signal crossed the threshold in this step and the manoeuvre started.
    /// `side` is the dodge side for [`Manoeuvre::DodgeLateral`], `None` for the others.
    Triggered {
        /// Dodge side (lateral dodges only).
        side: Option<DodgeSide>,
    },
    /// A manoeuvre started in an earlier step is running.
    Manoeuvring {
        /// Dodge side (lateral dodges only).
        side: Option<DodgeSide>,
    },
    /// Cooldown after a manoeuvre: cruise command passed through, triggers ignored.
    Cooldown,
}

impl ControllerEvent {
    /// Whether this step started a manoeuvre (the controller's alarm).
    pub fn is_trigger(&self) -> bool {
        matches!(self, Self::Triggered { .. })
    }

    /// Whether the manoeuvre's command (not the cruise command) was issued this step.
    pub fn is_escaping(&self) -> bool {
        matches!(self, Self::Triggered { .. } | Self::Manoeuvring { .. })
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Armed,
    Manoeuvre { start_s: f64, side: DodgeSide },
    Cooldown { until_s: f64 },
}

/// Threshold-triggered escape controller (see the module docs for the exact semantics).
#[derive(Debug, Clone)]
pub struct EscapeController {
    config: EscapeConfig,
    phase: Phase,
    triggers: usize,
    first_trigger_s: Option<f64>,
}

impl EscapeController {
    /// Build a controller; fails if the configuration is invalid.
    pub fn new(config: EscapeConfig) -> Result<Self, AgentError> {
        config.validate()?;
        Ok(Self {
            config,
            phase: Phase::Armed,
            triggers: 0,
            first_trigger_s: None,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &EscapeConfig {
        &self.config
    }

    /// Return to the armed state before the first step (start a new episode).
    pub fn reset(&mut self) {
        self.phase = Phase::Armed;
        self.triggers = 0;
        self.first_trigger_s = None;
    }

    /// Number of triggers since the last reset.
    pub fn triggers(&self) -> usize {
        self.triggers
    }

    /// Time of the first trigger since the last reset.
    pub fn first_trigger_s(&self) -> Option<f64> {
        self.first_trigger_s
    }

    /// Read this controller's trigger signal from a detector's signals and step.
    pub fn step_signals(
        &mut self,
        t_s: f64,
        signals: &Signals,
        looming_side: Option<f32>,
        cruise: VelocityCommand,
    ) -> (VelocityCommand, ControllerEvent) {
        let value = self.config.trigger.value(signals).unwrap_or(f64::NAN);
        self.step(t_s, value, looming_side, cruise)
    }

    /// Advance to time `t_s` with this frame's trigger-signal value (see [`TriggerSignal`]), the
    /// looming object's image x (`None` if unknown) and the command the robot would follow without
    /// a threat. Returns the command to apply and what happened.
    ///
    /// A non-finite `t_s` changes nothing (no phase change, no trigger); a NaN signal never triggers.
    pub fn step(
        &mut self,
        t_s: f64,
        signal_value: f64,
        looming_side: Option<f32>,
        cruise: VelocityCommand,
    ) -> (VelocityCommand, ControllerEvent) {
        let cfg = &self.config;
        if t_s.is_finite() {
            if let Phase::Manoeuvre { start_s, .. } = self.phase
                && t_s >= start_s + cfg.duration_s
            {
                self.phase = Phase::Cooldown {
                    until_s: start_s + cfg.duration_s + cfg.cooldown_s,
                };
            }
            if let Phase::Cooldown { until_s } = self.phase
                && t_s >= until_s
            {
                self.phase = Phase::Armed;
            }
            if self.phase == Phase::Armed && cfg.is_alarm(Some(signal_value)) {
                let side = DodgeSide::away_from(looming_side, cfg.side_deadband, cfg.default_side);
                self.phase = Phase::Manoeuvre { start_s: t_s, side };
                self.triggers += 1;
                self.first_trigger_s.get_or_insert(t_s);
                let command = cfg.manoeuvre_command(side, cruise);
                return (
                    command,
                    ControllerEvent::Triggered {
                        side: self.reported_side(side),
                    },
                );
            }
        }
        match self.phase {
            Phase::Armed => (cruise, ControllerEvent::Cruise),
            Phase::Cooldown { .. } => (cruise, ControllerEvent::Cooldown),
            Phase::Manoeuvre { side, .. } => (
                cfg.manoeuvre_command(side, cruise),
                ControllerEvent::Manoeuvring {
                    side: self.reported_side(side),
                },
            ),
        }
    }

    fn reported_side(&self, side: DodgeSide) -> Option<DodgeSide> {
        (self.config.manoeuvre == Manoeuvre::DodgeLateral).then_some(side)
    }
}

//! The escape controller: cruise until the detector's signal crosses a threshold, then run one
//! escape manoeuvre for a fixed time, then a cooldown during which it cannot trigger again.
//!
//! # Trigger semantics
//! Each frame the controller's decider ([`crate::decision`]) turns the percept into one
//! decision value, compared against [`EscapeConfig::alarm_threshold`]:
//! - [`TriggerSignal::AngularSizeDeg`] (`"angular_size_deg"` or `"angular_size"`): the Hopfield
//!   detector's angular-size estimate θ̂ in degrees ([`Signals::angular_size_deg`]) against
//!   `threshold` (locusts escape at about 10°, the paper's discussion; the default);
//! - [`TriggerSignal::Output`]: the detector's primary output ([`Signals::output`]) in that
//!   detector's own units (the baselines' LGMD potentials); the threshold must be chosen per detector;
//! - [`TriggerSignal::Tau`]: the urgency 1/τ̂ (s⁻¹), τ̂ the time to contact estimated causally from
//!   θ̂, against `1 / tau_threshold_s` (and θ̂ ≥ `min_angular_size_deg`).
//!
//! With `course = "image"` the collision-course gate holds the value at 0 while the object's image
//! says it will pass beside the robot's body.
//!
//! The trigger is **level-based**: an armed controller triggers on the first step whose value is
//! `>= alarm_threshold()`. So if the value is still above the threshold when the cooldown ends, the
//! controller triggers again at once (the object is still looming). NaN or missing signals never
//! trigger. This is the same rule the scoring uses for the alarm time, so "first alarm" and "first
//! trigger" coincide.
//!
//! # Timeline
//! A trigger at `t0` runs the manoeuvre over `[t0, t0 + duration_s)`, then the cruise command is
//! passed through again during the cooldown `[t0 + duration_s, t0 + duration_s + cooldown_s)`, in
//! which no new trigger is accepted; from `t0 + duration_s + cooldown_s` on the controller is armed.
//! With `manoeuvre = "plan"`, a stop or a reversal is followed by standing while the planner predicts
//! that cruising on would run into a perceived object standing in the world (for as long as it is
//! in the way), or meet a moving one that waiting lets pass (at most
//! [`crate::planner::MAX_WAIT_S`]); the cooldown starts when the wait ends.
//! `t_s` must be non-decreasing within an episode; call [`EscapeController::reset`] between episodes.
//!
//! # Dodge side
//! A lateral dodge moves away from the side of the image where the looming object is. The runner
//! passes that side as `looming_side`, the image x of the object in [-1, 1] (−1 left edge, +1 right
//! edge); the scenario runner estimates it from the frame, e.g. as the x centroid of the temporal
//! contrast |frame(t) − frame(t−1)|. An object on the right (x > `side_deadband`) makes the robot
//! dodge left, one on the left (x < −`side_deadband`) right. When the side is unknown (`None`, NaN)
//! or too central (|x| ≤ `side_deadband`) the controller dodges to `default_side`. The side is
//! latched at the trigger and kept for the whole manoeuvre. A re-trigger within `side_memory_s` of
//! the last frame that was an alarm (the same object still looms; the alarm never cleared for
//! longer) or of the controller re-arming after its last manoeuvre and cooldown (the danger it
//! dodged is still near) keeps the previous side, unless the caller names the objects and they
//! differ: after a dodge the object's image can sit on the other side of centre or be swamped by
//! background motion or camera shake, and a fresh estimate would dodge back into it.
//!
//! # Several objects
//! When the caller names the object each value comes from (the ideal reference rows), an alarm
//! about another object than the one being dodged is not a re-trigger: it ends the manoeuvre or
//! cooldown at once and is dodged afresh, away from that object (a manoeuvre's cooldown would
//! otherwise hold the robot on a course into a second ball; without names, every alarm is taken
//! to be about the same object). (In the
//! default suite, two τ rows under 3° camera shake re-triggered 0.1 s after re-arming on a noisy
//! side and dodged back into the ball.)

use serde::{Deserialize, Serialize};

use loomlab_sim::RobotBase;

#[allow(unused_imports)] // for doc links
use crate::decision::{Course, MAX_PERSISTENCE_FRAMES, TriggerSignal};
use crate::decision::{Decider, Decision, DecisionRule, Percept, SelfMotion};
use crate::planner::{Candidate, OdometryTrail, PlanContext, Planner};
use crate::{AgentError, DodgeOffset, RobotFacts, VelocityCommand};
use loomlab_detector::{PerceivedObject, Signals};

/// The escape manoeuvre run after a trigger.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Manoeuvre {
    /// Choose among the others at the alarm and while it lasts: the one with the largest
    /// predicted clearance from every perceived object ([`crate::planner`]); without any object's
    /// forecast, a lateral dodge away from the alarming object.
    #[default]
    Plan,
    /// Get out of the looming object's way, towards the side away from it. On a holonomic base:
    /// sidestep at `dodge_speed_mps` (forward speed scaled by `dodge_forward_scale`, optional yaw
    /// away at `dodge_yaw_rate_rps`). On a differential drive, which cannot sidestep: turn away at
    /// `turn_rate_rps` while driving forward at `dodge_speed_mps` (or the cruise speed if faster), so
    /// the robot arcs out of the object's path.
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

/// Configuration of the [`EscapeController`] (the scenario's `[controller]` table: the keys of its
/// [`DecisionRule`] and of the manoeuvre, flat in one table; every key optional).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EscapeConfig {
    /// How the controller decides ([`crate::decision`]); its fields are keys of this table.
    #[serde(flatten)]
    pub decision: DecisionRule,
    /// A re-trigger less than this long (s, ≥ 0) after the last frame that was an alarm, or after
    /// the controller re-armed following its last manoeuvre, keeps the previous dodge side: the
    /// same object is still looming, and dodging back would run into it.
    pub side_memory_s: f64,
    /// How far (m, > 0) lateral dodges may take the robot's body sideways from its cruising path,
    /// all dodges together (`None`, the default: no limit). A dodge's sidestep is held once the
    /// body, braking from then on, would come to rest at the limit, and the robot keeps its
    /// lateral position for the rest of the manoeuvre. A robot that knows the width of the lane or
    /// corridor it drives in (its map) sets it, so that repeated dodges to one side never drive it
    /// into the side. The body's offset is modelled from the controller's own lateral commands
    /// beyond the cruise command through the drive's acceleration limit ([`DodgeOffset`];
    /// holonomic bases; a differential drive's turning dodge is not limited).
    pub max_dodge_offset_m: Option<f64>,
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
    /// With `manoeuvre = "plan"`: the predicted clearance (m, ≥ 0) from every object at or above
    /// which a manoeuvre counts as safe; among safe ones the preferred is taken (the running one,
    /// then the dodge away from the alarming object; [`crate::planner`]). Default 0.3.
    pub clearance_margin_m: f64,
    /// Time after the manoeuvre during which no new trigger is accepted, in seconds (≥ 0).
    pub cooldown_s: f64,
    /// Side to dodge to when the looming side is unknown or central.
    pub default_side: DodgeSide,
    /// |image x| of the looming side at or below which it counts as central, in [0, 1).
    pub side_deadband: f32,
}

impl Default for EscapeConfig {
    fn default() -> Self {
        Self {
            decision: DecisionRule::default(),
            side_memory_s: 0.5,
            max_dodge_offset_m: None,
            manoeuvre: Manoeuvre::Plan,
            dodge_speed_mps: 1.5,
            dodge_forward_scale: 1.0,
            dodge_yaw_rate_rps: 0.0,
            turn_rate_rps: 2.0,
            reverse_speed_mps: 1.0,
            duration_s: 0.6,
            clearance_margin_m: 0.3,
            cooldown_s: 0.5,
            default_side: DodgeSide::Left,
            side_deadband: 0.05,
        }
    }
}

/// The keys of the escape controller's table, in order: the decision rule's, then the manoeuvre's
/// (the keys [`EscapeConfig`] reads and writes).
const KEYS: &[&str] = &[
    "trigger",
    "threshold",
    "tau_threshold_s",
    "min_angular_size_deg",
    "tau_window_s",
    "course",
    "persistence_frames",
    "persistence_window_frames",
    "course_closing_speed_mps",
    "course_window_s",
    "side_memory_s",
    "max_dodge_offset_m",
    "manoeuvre",
    "dodge_speed_mps",
    "dodge_forward_scale",
    "dodge_yaw_rate_rps",
    "turn_rate_rps",
    "reverse_speed_mps",
    "duration_s",
    "clearance_margin_m",
    "cooldown_s",
    "default_side",
    "side_deadband",
];

/// Reads the flat `[controller]` table into an [`EscapeConfig`] (its [`DecisionRule`] included):
/// every key optional (the default otherwise), an unknown key an error that lists the known ones.
struct EscapeConfigVisitor;

impl<'de> serde::de::Visitor<'de> for EscapeConfigVisitor {
    type Value = EscapeConfig;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("struct EscapeConfig")
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<EscapeConfig, A::Error> {
        let mut c = EscapeConfig::default();
        let mut seen = Vec::new();
        while let Some(key) = map.next_key::<String>()? {
            if seen.contains(&key) {
                return Err(serde::de::Error::custom(format_args!("duplicate field `{key}`")));
            }
            let d = &mut c.decision;
            match key.as_str() {
                "trigger" => d.trigger = map.next_value()?,
                "threshold" => d.threshold = map.next_value()?,
                "tau_threshold_s" => d.tau_threshold_s = map.next_value()?,
                "min_angular_size_deg" => d.min_angular_size_deg = map.next_value()?,
                "tau_window_s" => d.tau_window_s = map.next_value()?,
                "course" => d.course = map.next_value()?,
                "persistence_frames" => d.persistence_frames = map.next_value()?,
                "persistence_window_frames" => d.persistence_window_frames = map.next_value()?,
                "course_closing_speed_mps" => d.course_closing_speed_mps = map.next_value()?,
                "course_window_s" => d.course_window_s = map.next_value()?,
                "side_memory_s" => c.side_memory_s = map.next_value()?,
                "max_dodge_offset_m" => c.max_dodge_offset_m = map.next_value()?,
                "manoeuvre" => c.manoeuvre = map.next_value()?,
                "dodge_speed_mps" => c.dodge_speed_mps = map.next_value()?,
                "dodge_forward_scale" => c.dodge_forward_scale = map.next_value()?,
                "dodge_yaw_rate_rps" => c.dodge_yaw_rate_rps = map.next_value()?,
                "turn_rate_rps" => c.turn_rate_rps = map.next_value()?,
                "reverse_speed_mps" => c.reverse_speed_mps = map.next_value()?,
                "duration_s" => c.duration_s = map.next_value()?,
                "clearance_margin_m" => c.clearance_margin_m = map.next_value()?,
                "cooldown_s" => c.cooldown_s = map.next_value()?,
                "default_side" => c.default_side = map.next_value()?,
                "side_deadband" => c.side_deadband = map.next_value()?,
                other => return Err(serde::de::Error::unknown_field(other, KEYS)),
            }
            seen.push(key);
        }
        Ok(c)
    }
}

impl<'de> Deserialize<'de> for EscapeConfig {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_struct("EscapeConfig", KEYS, EscapeConfigVisitor)
    }
}

pub(crate) fn invalid(key: &'static str, value: impl ToString, reason: &str) -> AgentError {
    AgentError::InvalidConfig {
        key,
        value: value.to_string(),
        reason: reason.to_string(),
    }
}

pub(crate) fn non_negative(key: &'static str, v: f64) -> Result<(), AgentError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(invalid(key, v, "must be a finite number >= 0"))
    }
}

impl EscapeConfig {
    /// Check every value; the error names the key, the value and the valid range.
    pub fn validate(&self) -> Result<(), AgentError> {
        self.decision.validate()?;
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
        non_negative("escape.clearance_margin_m", self.clearance_margin_m)?;
        non_negative("escape.side_memory_s", self.side_memory_s)?;
        if let Some(v) = self.max_dodge_offset_m
            && !(v.is_finite() && v > 0.0)
        {
            return Err(invalid(
                "escape.max_dodge_offset_m",
                v,
                "must be a finite distance in metres > 0 (leave it out for no limit)",
            ));
        }
        if !(self.side_deadband.is_finite() && (0.0..1.0).contains(&self.side_deadband)) {
            return Err(invalid(
                "escape.side_deadband",
                self.side_deadband,
                "must lie in [0, 1)",
            ));
        }
        Ok(())
    }

    /// The threshold the decision value is compared with: `threshold`, or the urgency
    /// `1 / tau_threshold_s` (s⁻¹) for [`TriggerSignal::Tau`].
    pub fn alarm_threshold(&self) -> f64 {
        self.decision.alarm_threshold()
    }

    /// Whether `signal` (a decision value) is an alarm: `signal >= alarm_threshold()` (NaN and
    /// `None` never are).
    pub fn is_alarm(&self, signal: Option<f64>) -> bool {
        signal.is_some_and(|s| s >= self.alarm_threshold())
    }

    /// A fresh decider of this configuration's rule for the robot of `facts` ([`crate::decision`]).
    pub fn decider(&self, facts: &RobotFacts) -> Decider {
        Decider::new(self.decision, facts)
    }

    /// The command of the manoeuvre towards `side` given the cruise command, on a robot with the
    /// drive `base` (`plan`: the lateral dodge, its fallback).
    pub fn manoeuvre_command(&self, side: DodgeSide, cruise: VelocityCommand, base: RobotBase) -> VelocityCommand {
        self.command(self.fixed_candidate(side), cruise, base)
    }

    /// The candidate this configuration's manoeuvre runs towards `side` (`plan`: the lateral dodge,
    /// its fallback without forecasts).
    pub fn fixed_candidate(&self, side: DodgeSide) -> Candidate {
        Candidate {
            manoeuvre: match self.manoeuvre {
                Manoeuvre::Plan => Manoeuvre::DodgeLateral,
                m => m,
            },
            side,
        }
    }

    /// [`Self::command`], its sidestep held within [`Self::max_dodge_offset_m`] of the cruising
    /// path: once the robot's body, `dodge` off that path (what the robot knows of itself), would
    /// come to rest at the limit or beyond it braking at `facts.accel_mps2`
    /// ([`DodgeOffset::holds`]), the command keeps the cruise's lateral speed.
    pub fn command_within_offset(
        &self,
        candidate: Candidate,
        cruise: VelocityCommand,
        facts: &RobotFacts,
        dodge: &DodgeOffset,
    ) -> VelocityCommand {
        let mut command = self.command(candidate, cruise, facts.base);
        if let Some(limit) = self.max_dodge_offset_m
            && dodge.holds(command.lateral_mps - cruise.lateral_mps, limit, facts.accel_mps2)
        {
            command.lateral_mps = cruise.lateral_mps;
        }
        command
    }

    /// The command of `candidate` given the cruise command, on a robot with the drive `base`.
    pub fn command(&self, candidate: Candidate, cruise: VelocityCommand, base: RobotBase) -> VelocityCommand {
        let side = candidate.side;
        match candidate.manoeuvre {
            Manoeuvre::DodgeLateral | Manoeuvre::Plan if !base.can_sidestep() => VelocityCommand {
                forward_mps: cruise.forward_mps.max(self.dodge_speed_mps),
                yaw_rate_rps: side.sign() * self.turn_rate_rps,
                lateral_mps: 0.0,
            },
            Manoeuvre::DodgeLateral | Manoeuvre::Plan => VelocityCommand {
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
    Manoeuvre {
        start_s: f64,
        chosen: Candidate,
    },
    /// Standing after a stop or a reversal until cruising on is clear (the planner's
    /// [`Planner::keeps_waiting`]; at most [`crate::planner::MAX_WAIT_S`] for moving objects).
    Waiting {
        since_s: f64,
    },
    Cooldown {
        until_s: f64,
    },
}

/// Threshold-triggered escape controller (see the module docs for the exact semantics).
#[derive(Debug, Clone)]
pub struct EscapeController {
    config: EscapeConfig,
    facts: RobotFacts,
    phase: Phase,
    triggers: usize,
    first_trigger_s: Option<f64>,
    decider: Decider,
    last_command: Option<VelocityCommand>,
    last_side: Option<DodgeSide>,
    last_alarm_s: Option<f64>,
    /// When the controller last re-armed after a manoeuvre and its cooldown.
    rearmed_s: Option<f64>,
    /// The object the current and the last trigger's values come from, when the caller knows it.
    object: Option<usize>,
    last_object: Option<usize>,
    /// Time of the last step and the lateral speed its command added to the cruise command.
    last_step: Option<(f64, f64)>,
    /// How far the dodges have moved the robot sideways from its cruising path (m, + = left).
    dodge: DodgeOffset,
    /// Every perceived object's forecast (`manoeuvre = "plan"`).
    planner: Planner,
    /// One decider per object a detector lists besides its driving percept, by the detector's id.
    object_deciders: Vec<(usize, Decider)>,
    /// The robot's recent poses from its own commands (the latest: its pose now), and since when
    /// its motion has been steady.
    trail: OdometryTrail,
}

impl EscapeController {
    /// Build a controller of `config` for the robot of `facts`; fails if either is invalid.
    pub fn new(config: EscapeConfig, facts: RobotFacts) -> Result<Self, AgentError> {
        config.validate()?;
        facts.validate()?;
        Ok(Self {
            decider: config.decider(&facts),
            config,
            facts,
            phase: Phase::Armed,
            triggers: 0,
            first_trigger_s: None,
            last_command: None,
            last_side: None,
            last_alarm_s: None,
            rearmed_s: None,
            object: None,
            last_object: None,
            last_step: None,
            dodge: DodgeOffset::default(),
            planner: Planner::new(facts),
            object_deciders: Vec::new(),
            trail: OdometryTrail::default(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &EscapeConfig {
        &self.config
    }

    /// The robot's and its camera's facts the controller was built with.
    pub fn facts(&self) -> &RobotFacts {
        &self.facts
    }

    /// Return to the armed state before the first step (start a new episode).
    pub fn reset(&mut self) {
        self.phase = Phase::Armed;
        self.triggers = 0;
        self.first_trigger_s = None;
        self.decider.reset();
        self.last_command = None;
        self.last_side = None;
        self.last_alarm_s = None;
        self.rearmed_s = None;
        self.object = None;
        self.last_object = None;
        self.last_step = None;
        self.dodge = DodgeOffset::default();
        self.planner.reset();
        self.object_deciders.clear();
        self.trail.clear();
    }

    /// Bring the odometry to `t_s` under the last command (`cruise` before the first).
    fn advance_odometry(&mut self, t_s: f64, cruise: VelocityCommand) {
        if !t_s.is_finite() {
            return;
        }
        let command = self.last_command.unwrap_or(cruise);
        let mut odometry = self.trail.now();
        match self.trail.latest_s() {
            None => {
                // the episode starts cruising at the cruise speed
                odometry.velocity = [command.forward_mps, command.lateral_mps, command.yaw_rate_rps];
            }
            Some(t0) if t_s > t0 => odometry.advance(&command, t_s - t0, &self.facts),
            Some(_) => return,
        }
        self.trail.push(t_s, odometry);
    }

    /// Tell the planner what the decider of object `id` decided at `t_s` (`manoeuvre = "plan"`;
    /// call before [`Self::step`] at the same time, for every perceived object).
    pub fn observe(&mut self, t_s: f64, id: usize, decision: &crate::Decision, cruise: VelocityCommand) {
        if self.config.manoeuvre != Manoeuvre::Plan {
            return;
        }
        self.advance_odometry(t_s, cruise);
        if let Some(f) = &decision.forecast {
            self.planner.observe(id, f, t_s, &self.trail);
        }
    }

    /// The planner's choice at `t_s`: the candidate with the largest capped clearance, preferring
    /// `running`, then the dodge to `side`, the other dodge, stopping, reversing.
    fn plan(
        &self,
        t_s: f64,
        side: DodgeSide,
        cruise: VelocityCommand,
        running: Option<Candidate>,
    ) -> Option<Candidate> {
        if self.config.manoeuvre != Manoeuvre::Plan || !self.planner.has_objects() {
            return None;
        }
        let other = match side {
            DodgeSide::Left => DodgeSide::Right,
            DodgeSide::Right => DodgeSide::Left,
        };
        let preference = [
            Candidate::dodge(side),
            Candidate::dodge(other),
            Candidate::ALL[2],
            Candidate::ALL[3],
        ];
        self.planner
            .choose(&self.plan_context(t_s, cruise), &preference, running)
    }

    /// What the planner knows of the robot at `t_s`, cruising at `cruise`.
    fn plan_context(&self, t_s: f64, cruise: VelocityCommand) -> PlanContext<'_> {
        PlanContext {
            t_s,
            odometry: self.trail.now(),
            cruise,
            dodge: self.dodge,
            config: &self.config,
        }
    }

    /// Whether the robot, standing after a stop or a reversal, keeps standing at `t_s`
    /// (`manoeuvre = "plan"` with forecasts only; [`Planner::keeps_waiting`]): while cruising on
    /// would run into an object standing in the world, or meet a moving one that waiting `wait_s`
    /// more at most lets pass.
    fn keeps_waiting(&self, t_s: f64, cruise: VelocityCommand, wait_s: f64) -> bool {
        self.config.manoeuvre == Manoeuvre::Plan && self.planner.keeps_waiting(&self.plan_context(t_s, cruise), wait_s)
    }

    /// The manoeuvre the planner would choose now at `t_s` (`manoeuvre = "plan"`), preferring the
    /// dodge to `side`, then the other dodge, stopping, reversing, from the forecasts of the objects
    /// it was told about ([`Self::observe`]); without any forecast (or with another manoeuvre),
    /// the configuration's fixed candidate towards `side`. Read-only: what an external agent's
    /// "plan" action runs (the Gymnasium env's manoeuvre actions); the controller's own phase,
    /// odometry and planner are not changed.
    pub fn planned_candidate(&self, t_s: f64, side: DodgeSide, cruise: VelocityCommand) -> Candidate {
        self.plan(t_s, side, cruise, None)
            .unwrap_or_else(|| self.config.fixed_candidate(side))
    }

    /// Which object the next [`Self::step`]'s value comes from (`None`: unknown, e.g. a detector's
    /// whole-image θ̂). A re-trigger keeps the previous side only for the same object (or when
    /// either is unknown) — a different object is dodged afresh.
    pub fn set_object(&mut self, object: Option<usize>) {
        self.object = object;
    }

    /// Feed this frame's percept to the decider ([`crate::decision`]) and return its decision;
    /// `decision.value` is what [`Self::step`] then compares with the alarm threshold. The robot's
    /// own motion is the command this controller returned in its last step (`cruise` before the
    /// first) and its camera's rotation relative to its mount, `shake_rad` (`[yaw, pitch, roll]`,
    /// rad, as [`crate::SensedCamera::shake_rad`]; zeros for a rigid mount).
    pub fn perceive(&mut self, t_s: f64, percept: Percept, cruise: VelocityCommand, shake_rad: [f64; 3]) -> Decision {
        let motion = SelfMotion::of(self.last_command.unwrap_or(cruise), shake_rad);
        self.decider.decide(t_s, percept, motion)
    }

    /// The robot's own motion as the decider sees it: the command this controller returned in its
    /// last step (`cruise` before the first) and the camera's sensed shake.
    pub fn self_motion(&self, cruise: VelocityCommand, shake_rad: [f64; 3]) -> SelfMotion {
        SelfMotion::of(self.last_command.unwrap_or(cruise), shake_rad)
    }

    /// [`Self::perceive`] on a real detector's `signals`: its trigger signal, and its image region
    /// when it gives one, else the looming side ([`Percept::of_detector`]).
    pub fn perceive_signals(
        &mut self,
        t_s: f64,
        signals: &Signals,
        looming_side: Option<f32>,
        cruise: VelocityCommand,
        shake_rad: [f64; 3],
    ) -> Decision {
        let value = self.config.decision.trigger.value(signals).unwrap_or(f64::NAN);
        let motion = SelfMotion::of(self.last_command.unwrap_or(cruise), shake_rad);
        self.decider
            .decide_on_detector(t_s, value, looming_side, signals.region.as_ref(), motion)
    }

    /// Run one decider per object in `objects` other than `primary` (the driving percept's: a
    /// detector's [`Signals::objects`](loomlab_detector::Signals::objects)), tell the planner each
    /// decision, and return the largest decision value (NaN when there is none): an alarm is
    /// raised by any object. Deciders of objects no longer listed are dropped.
    pub fn perceive_objects(
        &mut self,
        t_s: f64,
        objects: &[PerceivedObject],
        primary: Option<usize>,
        cruise: VelocityCommand,
        shake_rad: [f64; 3],
    ) -> f64 {
        if objects.is_empty() && self.object_deciders.is_empty() {
            return f64::NAN;
        }
        self.object_deciders
            .retain(|(id, _)| objects.iter().any(|o| o.id == *id));
        let motion = self.self_motion(cruise, shake_rad);
        let mut largest = f64::NAN;
        for o in objects.iter().filter(|o| Some(o.id) != primary) {
            let index = match self.object_deciders.iter().position(|(id, _)| *id == o.id) {
                Some(i) => i,
                None => {
                    self.object_deciders
                        .push((o.id, self.config.decider(&self.facts).for_one_object()));
                    self.object_deciders.len() - 1
                }
            };
            let percept = Percept::of_detector(o.angular_size_deg, None, Some(&o.region), &self.facts.pinhole);
            let decision = self.object_deciders[index].1.decide(t_s, percept, motion);
            self.observe(t_s, o.id, &decision, cruise);
            if largest.is_nan() || decision.value > largest {
                largest = decision.value;
            }
        }
        largest
    }

    /// Number of triggers since the last reset.
    pub fn triggers(&self) -> usize {
        self.triggers
    }

    /// The command this controller returned in its last step (`None` before the first step).
    pub fn last_command(&self) -> Option<VelocityCommand> {
        self.last_command
    }

    /// Time of the first trigger since the last reset.
    pub fn first_trigger_s(&self) -> Option<f64> {
        self.first_trigger_s
    }

    /// Read this controller's trigger signal from a detector's signals, run the decider on it
    /// (with the looming side as the object's image position; a rigid camera) and step.
    pub fn step_signals(
        &mut self,
        t_s: f64,
        signals: &Signals,
        looming_side: Option<f32>,
        cruise: VelocityCommand,
    ) -> (VelocityCommand, ControllerEvent) {
        let value = self
            .perceive_signals(t_s, signals, looming_side, cruise, [0.0; 3])
            .value;
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
        self.advance_odometry(t_s, cruise);
        if t_s.is_finite() {
            self.planner.forget_old(t_s, &self.trail.now());
        }
        let cfg = &self.config;
        if t_s.is_finite() {
            if let Some((t0, lateral_mps)) = self.last_step
                && t_s > t0
            {
                self.dodge.advance(lateral_mps, t_s - t0, self.facts.accel_mps2);
            }
            if let Phase::Manoeuvre { start_s, chosen } = self.phase
                && t_s >= start_s + cfg.duration_s
            {
                self.phase = if chosen.holds() && self.keeps_waiting(t_s, cruise, crate::planner::MAX_WAIT_S) {
                    Phase::Waiting { since_s: t_s }
                } else {
                    Phase::Cooldown {
                        until_s: start_s + cfg.duration_s + cfg.cooldown_s,
                    }
                };
            }
            if let Phase::Waiting { since_s } = self.phase
                && !self.keeps_waiting(t_s, cruise, crate::planner::MAX_WAIT_S - (t_s - since_s))
            {
                self.phase = Phase::Cooldown {
                    until_s: t_s + cfg.cooldown_s,
                };
            }
            if let Phase::Cooldown { until_s } = self.phase
                && t_s >= until_s
            {
                self.phase = Phase::Armed;
                self.rearmed_s = Some(until_s);
            }
            let alarm = cfg.is_alarm(Some(signal_value));
            // An alarm about another object (both named by the caller) is not a re-trigger for
            // the one being dodged: it ends the manoeuvre or cooldown and is dodged at once.
            let other_object = matches!((self.object, self.last_object), (Some(a), Some(b)) if a != b);
            if alarm && other_object && self.phase != Phase::Armed {
                self.phase = Phase::Armed;
            }
            let previous_alarm_s = self.last_alarm_s;
            if alarm {
                self.last_alarm_s = Some(t_s);
            }
            if self.phase == Phase::Armed && alarm {
                // The same object still looms (an alarm within side_memory_s of the last one, or
                // of re-arming after the last manoeuvre): keep the side, never dodge back into it.
                let same_object = match (self.object, self.last_object) {
                    (Some(a), Some(b)) => a == b,
                    _ => true,
                };
                let recent = |s: Option<f64>| s.is_some_and(|s| t_s - s <= cfg.side_memory_s);
                let side = match self.last_side {
                    Some(side) if same_object && (recent(previous_alarm_s) || recent(self.rearmed_s)) => side,
                    _ => DodgeSide::away_from(looming_side, cfg.side_deadband, cfg.default_side),
                };
                self.last_object = self.object;
                let chosen = self
                    .plan(t_s, side, cruise, None)
                    .unwrap_or_else(|| self.config.fixed_candidate(side));
                self.phase = Phase::Manoeuvre { start_s: t_s, chosen };
                self.triggers += 1;
                self.first_trigger_s.get_or_insert(t_s);
                self.last_side = Some(chosen.side)
                    .filter(|_| chosen.manoeuvre == Manoeuvre::DodgeLateral)
                    .or(Some(side));
                let command = self.dodge_command(chosen, cruise);
                self.record(t_s, command, cruise);
                return (
                    command,
                    ControllerEvent::Triggered {
                        side: reported_side(chosen),
                    },
                );
            }
            // while the alarm lasts, the planner may replace the running manoeuvre
            if alarm
                && let Phase::Manoeuvre { chosen, .. } = self.phase
                && let Some(better) = self.plan(t_s, chosen.side, cruise, Some(chosen))
                && !better.same_as(&chosen)
            {
                self.phase = Phase::Manoeuvre {
                    start_s: t_s,
                    chosen: better,
                };
                if better.manoeuvre == Manoeuvre::DodgeLateral {
                    self.last_side = Some(better.side);
                }
            }
        }
        let (command, event) = match self.phase {
            Phase::Armed => (cruise, ControllerEvent::Cruise),
            Phase::Cooldown { .. } => (cruise, ControllerEvent::Cooldown),
            Phase::Waiting { .. } => (VelocityCommand::STOP, ControllerEvent::Manoeuvring { side: None }),
            Phase::Manoeuvre { chosen, .. } => (
                self.dodge_command(chosen, cruise),
                ControllerEvent::Manoeuvring {
                    side: reported_side(chosen),
                },
            ),
        };
        self.record(t_s, command, cruise);
        (command, event)
    }

    /// The manoeuvre's command towards `side`, its sidestep held once the body would come to rest
    /// `max_dodge_offset_m` to that side ([`EscapeConfig::command_within_offset`]).
    fn dodge_command(&self, chosen: Candidate, cruise: VelocityCommand) -> VelocityCommand {
        self.config
            .command_within_offset(chosen, cruise, &self.facts, &self.dodge)
    }

    /// Remember this step's command, and the lateral speed it adds to the cruise command (what
    /// moves the robot off its cruising path until the next step).
    fn record(&mut self, t_s: f64, command: VelocityCommand, cruise: VelocityCommand) {
        self.last_command = Some(command);
        if t_s.is_finite() {
            self.last_step = Some((t_s, command.lateral_mps - cruise.lateral_mps));
        }
    }
}

/// The side a [`ControllerEvent`] reports for `chosen` (lateral dodges only).
fn reported_side(chosen: Candidate) -> Option<DodgeSide> {
    (chosen.manoeuvre == Manoeuvre::DodgeLateral).then_some(chosen.side)
}

//! Reference rows: what a report's detectors are measured against, computed from ground truth and
//! scored by the same code as the detectors.
//!
//! - `null` never alarms: its collision rate is the threat rate, the floor every detector must
//!   beat ([`DetectorSummary::collision_reduction`](crate::metrics::DetectorSummary) is measured
//!   against it);
//! - `oracle` alarms exactly at each evadable threat's escape deadline frame and never otherwise:
//!   the ceiling (it evades every evadable threat with no false alarm);
//! - `ideal_theta` alarms when the true angular size of any approaching object (angular size
//!   growing) **that moves relative to the world** (a projectile or a vehicle; static scenery —
//!   walls, poles, the overpass — looms as the robot drives and would alarm at once in a corridor)
//!   reaches the Hopfield trigger threshold: what a perfect θ̂ of the moving objects would do with
//!   the same threshold. It separates "the estimate is wrong" from "thresholding θ is too late".
//!   Its perception is perfect throughout: it dodges away from the true image side (bearing) of the
//!   object it triggers on, and its closed loop after the first alarm is simulated physics-only
//!   with ground truth as its input (re-triggers included).
//! - `ideal_tau` runs the escape controller's τ decider ([`loomlab_agents::decision`], the same
//!   code a detector row runs on θ̂) on **each** object's true angular size, every object its own
//!   estimator; the row's value is the largest urgency 1/τ̂ over the objects and it dodges away from
//!   that object's true bearing. Alarm when τ̂ ≤ the controller's `tau_threshold_s` and θ ≥ its
//!   `min_angular_size_deg`.
//! - `ideal_course` is `ideal_tau` with the collision-course gate, fed each object's true azimuth
//!   and elevation, and dodging away from the side on which the gate predicts the object to
//!   arrive. The gate's vertical test applies to objects on a straight course only: the vertical
//!   course of a lobbed ball is curved by gravity, and the gate judges it laterally (see
//!   [`loomlab_agents::decision`]). Each object's decider is bound to it
//!   ([`Decider::for_one_object`](loomlab_agents::Decider::for_one_object)): an object seen standing
//!   before it moves (a ball before it is thrown) gets its closing speed measured from its size then,
//!   not assumed.
//!
//! Perfect perception has no noise to average, so `ideal_tau` and `ideal_course` estimate τ over
//! the shortest window the estimator accepts (three frames, [`IDEAL_TAU_WINDOW_FRAMES`]) instead of
//! the controller's `tau_window_s`, which only adds lag: with it, a ball launched 0.6 s before
//! contact alarmed five frames after its launch, a frame after its escape deadline. (The course
//! gate keeps its `course_window_s`: a bearing rate is a small difference.)
//!
//! Each ideal row names to the escape controller the object its value comes from: a re-trigger
//! keeps the dodge side only for the same object, and an alarm about another object ends a
//! manoeuvre or its cooldown at once ([`loomlab_agents::escape`], "Several objects"). In a threat
//! episode an ideal row is scored on its alarms about the threat object alone: an alarm about a
//! passing car before the threat looms is not a hit, though the row's closed loop starts with it
//! (the runner's `about_threat` signal). A detector that numbers its tracks (`tracker`) is scored
//! the same way: its alarms count only in frames whose tracked region overlaps the threat's true
//! image extent (the scoring reads the truth; the detector and its agent never do).
//!
//! `ideal_tau` and `ideal_course` perceive an object only while its reference point is in view and
//! its angular size fits in the field of view (`θ ≤ fov`): the image cannot show a larger angular
//! size (a wall alongside the robot subtends almost 180°, most of it outside the view), and the
//! τ estimate assumes a compact object.
//!
//! The ideal rows see only what perfect perception of the image gives: per-object angular sizes,
//! bearings (and, for `ideal_theta`, whether θ grows and whether the object moves in the world);
//! never distances, velocities or contact predictions. Their closed loops run physics-only.
//!
//! The oracle and null signals are indicators (1 at an alarm frame, 0 elsewhere, threshold
//! [`INDICATOR_THRESHOLD`]); ideal_theta's signal is in degrees, ideal_tau's and ideal_course's the
//! urgency 1/τ̂ (s⁻¹, threshold `1 / tau_threshold_s`). Reference rows are excluded from
//! regressions and from threshold calibration.

use loomlab_agents::{
    Course, Decider, Decision, DecisionRule, EscapeConfig, ImageExtent, Percept, RobotFacts, SelfMotion, TriggerSignal,
};
use loomlab_sim::{ObjectKind, ObjectTruth};

/// Label of the never-alarming reference row.
pub const NULL: &str = "null";
/// Label of the reference row that alarms at each threat's escape deadline.
pub const ORACLE: &str = "oracle";
/// Label of the reference row that thresholds the true angular size.
pub const IDEAL_THETA: &str = "ideal_theta";
/// Label of the reference row that runs the τ decider on each object's true angular size.
pub const IDEAL_TAU: &str = "ideal_tau";
/// Label of the reference row that runs the τ decider and the course gate on true θ and bearings.
pub const IDEAL_COURSE: &str = "ideal_course";
/// Every reference label, in table order.
pub const REFERENCE_LABELS: [&str; 5] = [NULL, ORACLE, IDEAL_THETA, IDEAL_TAU, IDEAL_COURSE];
/// The τ window of the ideal rows in camera frame periods: the least-squares fit over the last
/// three frames ([`loomlab_agents::decision::MIN_SAMPLES`]; 2.5 periods hold exactly three).
pub const IDEAL_TAU_WINDOW_FRAMES: f64 = 2.5;
/// The course gate's window of the ideal rows in camera frame periods: the shortest that holds
/// the four frames a parabola through the elevations needs (a straight course told from a lob).
pub const IDEAL_COURSE_WINDOW_FRAMES: f64 = 4.5;
/// Alarm threshold of the indicator signals of `null` and `oracle`.
pub const INDICATOR_THRESHOLD: f64 = 1.0;

/// Whether `label` names a reference row (reserved: detectors may not use these labels).
pub fn is_reference(label: &str) -> bool {
    REFERENCE_LABELS.contains(&label)
}

/// The ideal θ̂: the largest true angular size (degrees) of the moving objects whose angular size
/// is growing; 0 when none is.
pub fn ideal_theta_deg(truth: &[ObjectTruth]) -> f64 {
    ideal_percept(truth).0
}

/// The ideal θ̂, the image side (bearing, −1 left … +1 right) of the object it comes from and that
/// object's id (`None`s when no moving object is looming).
pub fn ideal_percept(truth: &[ObjectTruth]) -> (f64, Option<f32>, Option<usize>) {
    truth
        .iter()
        .filter(|o| o.angular_rate_deg_s > 0.0 && o.kind != ObjectKind::Scenery)
        .max_by(|a, b| a.angular_size_deg.total_cmp(&b.angular_size_deg))
        .map_or((0.0, None, None), |o| {
            (f64::from(o.angular_size_deg), Some(o.bearing), Some(o.id))
        })
}

/// Which ideal observer a reference row runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IdealKind {
    /// `ideal_theta`.
    Theta,
    /// `ideal_tau`.
    Tau,
    /// `ideal_course`.
    Course,
}

/// An ideal observer: perfect perception of every object's angular size and bearing, one decider
/// per object (see the module docs).
#[derive(Debug, Clone)]
pub struct IdealObserver {
    kind: IdealKind,
    config: EscapeConfig,
    facts: RobotFacts,
    per_object: Vec<Decider>,
    /// This frame's decision about each visible object, by id (what the planner reads).
    decisions: Vec<(usize, Decision)>,
}

impl IdealObserver {
    /// An observer of `kind` with the controller `base` (its τ threshold and minimum angle;
    /// `threshold` is the angle of `ideal_theta`) for the robot of `facts` (its body and camera)
    /// on a camera with frame period `frame_period_s`. The τ window is the shortest the estimator
    /// accepts ([`IDEAL_TAU_WINDOW_FRAMES`] frame periods): see the module docs.
    pub fn new(
        kind: IdealKind,
        base: &EscapeConfig,
        facts: RobotFacts,
        theta_threshold_deg: f64,
        frame_period_s: f64,
    ) -> Self {
        let shortest_window_s = IDEAL_TAU_WINDOW_FRAMES * frame_period_s;
        let config = EscapeConfig {
            decision: DecisionRule {
                tau_window_s: shortest_window_s,
                // ideal_tau has no gate: its window only serves the side it dodges to (where the
                // object will arrive), which must be known as soon as τ̂ is
                course_window_s: IDEAL_COURSE_WINDOW_FRAMES * frame_period_s,
                trigger: match kind {
                    IdealKind::Theta => TriggerSignal::AngularSizeDeg,
                    IdealKind::Tau | IdealKind::Course => TriggerSignal::Tau,
                },
                threshold: theta_threshold_deg,
                course: if kind == IdealKind::Course {
                    Course::Image
                } else {
                    Course::Off
                },
                ..base.decision
            },
            ..base.clone()
        };
        Self {
            kind,
            config,
            facts,
            per_object: Vec::new(),
            decisions: Vec::new(),
        }
    }

    /// The decisions of the last [`Self::update`] about every object in view, by object id (empty
    /// for `ideal_theta`, which has no decider).
    pub fn decisions(&self) -> &[(usize, Decision)] {
        &self.decisions
    }

    /// The controller configuration of this row (its `alarm_threshold()` is the row's threshold).
    pub fn config(&self) -> &EscapeConfig {
        &self.config
    }

    /// The robot's and its camera's facts this observer decides for.
    pub fn facts(&self) -> &RobotFacts {
        &self.facts
    }

    /// This frame's decision value, the image side (−1 … 1) of the object it comes from and that
    /// object's id, with `motion` the robot's own motion during the last camera period.
    pub fn update(&mut self, t_s: f64, truth: &[ObjectTruth], motion: SelfMotion) -> (f64, Option<f32>, Option<usize>) {
        self.decisions.clear();
        if self.kind == IdealKind::Theta {
            return ideal_percept(truth);
        }
        let mut best: (f64, Option<f32>, Option<usize>) = (0.0, None, None);
        let fov = self.facts.pinhole.fov_deg();
        for o in truth {
            // the image shows an object's angular size only while it fits in the view
            let visible = o.in_view && f64::from(o.angular_size_deg) <= fov;
            if self.per_object.len() <= o.id {
                self.per_object
                    .resize_with(o.id + 1, || self.config.decider(&self.facts).for_one_object());
            }
            let percept = Percept {
                value: if visible {
                    f64::from(o.angular_size_deg)
                } else {
                    f64::NAN
                },
                azimuth_deg: Some(f64::from(o.bearing_deg)).filter(|_| visible),
                elevation_deg: Some(f64::from(o.elevation_deg)).filter(|_| visible),
                extent: visible.then(|| ImageExtent {
                    azimuth_deg: o.azimuth_extent_deg.map(f64::from),
                    elevation_deg: o.elevation_extent_deg.map(f64::from),
                }),
            };
            let decision = self.per_object[o.id].decide(t_s, percept, motion);
            if visible {
                self.decisions.push((o.id, decision));
            }
            if decision.value > best.0 {
                // the τ rows escape from where the object will arrive, when the image says (their
                // percept has the object's image extent)
                best = (decision.value, decision.escape_side(Some(o.bearing), true), Some(o.id));
            }
        }
        best
    }
}

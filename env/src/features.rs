//! Observation modes: the raw detector outputs ([`ObsMode::Raw`]), bounded, scaled features a
//! policy network can take as they are ([`ObsMode::Normalized`]), or the privileged percept of the
//! ideal reference rows ([`ObsMode::Privileged`], ground truth: a learnability check, never a
//! detector observation). This module is the one source of
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
//!
//! # The privileged feature vector
//! [`ObsMode::Privileged`] replaces the detector features by the true percept of the most
//! threatening object, the one the ideal reference rows (`ideal_tau`, `ideal_course`) decide on:
//! their τ trigger and collision-course gate read the true angular size, bearing and image extent.
//! The most threatening object is the looming one (θ̇ > 0) with the shortest optical τ = θ/θ̇ that
//! is in view; when none looms, the largest in view (all features 0 when nothing is in view). It
//! is chosen from what the camera could see, never from the future (no time to contact, no
//! collision flag). In order:
//!
//! | feature | definition | bounds |
//! |---|---|---|
//! | `threat.theta_rad` | true angular size θ (rad) | [0, π] |
//! | `threat.theta_rate_rps` | θ̇ (rad/s), clamped into ±[`THETA_RATE_LIMIT_RPS`] | [−10, 10] |
//! | `threat.inv_tau_ps` | urgency 1/τ = θ̇/θ (s⁻¹), 0 when not looming, clamped into [0, [`INV_TAU_LIMIT_PS`]] | [0, 20] |
//! | `threat.bearing` | image x of its reference point (−1 left edge, +1 right edge) | [−1, 1] |
//! | `threat.bearing_rate` | d bearing/dt (per s) / [`BEARING_RATE_SCALE_PS`], clamped | [−1, 1] |
//! | `threat.miss_radii` | \|μ\| / [`MISS_RADII_LIMIT`], clamped, μ = 2β̇/θ̇ the miss at contact in object radii predicted from the percept (β the azimuth; the sphere model of the course gate, `loomlab_agents::decision`); 1 when not looming | [0, 1] |
//! | `threat.left_deg`, `threat.right_deg` | azimuths of its image edges / 90° (positive right), clamped | [−1, 1] |
//! | `threat.bottom_deg`, `threat.top_deg` | elevations of its image edges / 90° (positive up), clamped | [−1, 1] |
//! | `robot.*` | the normalized mode's 7 robot features | as above |
//!
//! # The decision feature vector
//! [`ObsMode::Decision`] holds, per row (`R` rows, in
//! [`EscapeEnv::detector_labels`](crate::EscapeEnv::detector_labels) order), the quantities its
//! decision step uses, taken from the row's decider ([`loomlab_agents::Decider`],
//! `agents/src/decision/`: the same [`loomlab_agents::Decision`] the escape controller and the runner
//! read, never recomputed here), then the driving track's box and the most urgent other tracks of
//! the first row whose detector localises objects (`tracker`), the looming side and the robot. A
//! stateless row (θ̂ or output against a threshold, no gate, no persistence) estimates nothing:
//! its τ̂, course and arrival features stay at their "unknown" values. Nothing comes from ground
//! truth. In order:
//!
//! | feature | definition | bounds |
//! |---|---|---|
//! | `{label}.value` (× R) | the decision value over the row's alarm threshold (θ̂ / threshold, output / threshold or urgency 1/τ̂ × `tau_threshold_s`), clamped; NaN → 0 | [−2, 2] |
//! | `{label}.alarm` (× R) | 1 when the decision value is at or above the threshold | {0, 1} |
//! | `{label}.theta_hat_rad` (× R) | the row's detector's θ̂ (rad), 0 when it gives none | [0, π] |
//! | `{label}.inv_tau_ps` (× R) | 1/τ̂ of the decider's τ estimator (s⁻¹), 0 when not estimated or τ̂ ≤ 0, clamped into [0, [`INV_TAU_LIMIT_PS`]] | [0, 20] |
//! | `{label}.gate_open` (× R) | the collision-course gate's state (1 with `course = "off"`) | {0, 1} |
//! | `{label}.miss_radii` (× R) | the gate's predicted lateral miss μ (object radii, + right) / [`MISS_RADII_LIMIT`], clamped; 0 when not estimated | [−1, 1] |
//! | `{label}.pass_side` (× R) | the predicted arrival side (−1 left, +1 right), 0 when none | [−1, 1] |
//! | `{label}.arrival_s` (× R) | time until the predicted arrival / [`ARRIVAL_SCALE_S`], clamped: the course forecast's τ at its time less the time since, else τ̂; 1 when unknown | [0, 1] |
//! | `{label}.arrival_lateral` (× R) | the middle of the predicted arrival extent (m, + right) / [`ARRIVAL_LATERAL_SCALE_M`], clamped; 0 when unknown | [−1, 1] |
//! | `{label}.confirmations` (× R) | the K-of-M count: values at or above the threshold among the last M, over K, clamped (`Decider::confirmations`); without a window, the alarm | [0, 1] |
//! | `track.seen` | 1 when a row's detector gives the driving track's image box | {0, 1} |
//! | `track.left`, `track.right`, `track.bottom`, `track.top` | that box's edges (image x and y, −1 … 1), 0 when none | [−1, 1] |
//! | `objects.{i}.theta_rad` (i < [`DECISION_OBJECTS`]) | θ̂ of the detector's i-th most urgent other track (`Signals::objects`, the driving track left out; by the detector's τ̂ when it gives one, else the largest θ̂ first), 0 when fewer | [0, π] |
//! | `objects.{i}.inv_tau_ps` | its 1/τ̂ when the detector gives one (s⁻¹, clamped), else 0 | [0, 20] |
//! | `objects.{i}.left`, `.right`, `.bottom`, `.top` | its image box | [−1, 1] |
//! | `looming_side` | as in the normalized mode | [−1, 1] |
//! | `robot.*` | the normalized mode's 7 robot features | as above |
//!
//! A row's decider steps on the row's detector's θ̂ (or output) with the self-motion of the
//! shadow escape controller's last command, as in the normalized mode's alarms.

use serde::{Deserialize, Serialize};

use super::{Observation, SIGNAL_LIMIT};
use loomlab_agents::{ActionConfig, ContinuousAction, Decision, VelocityCommand};
use loomlab_detector::{ImageRegion, PerceivedObject};
use loomlab_sim::ObjectTruth;

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
    /// One vector of the true percept of the most threatening object and the robot's state (see
    /// the module docs): ground truth, the reference a policy on detector features is measured
    /// against, like the ideal rows.
    Privileged,
    /// One vector of every row's decision quantities (τ̂, the gate, the predicted arrival, the
    /// K-of-M count, the alarm), the driving track's box and the most urgent other tracks (see the
    /// module docs): what the rows decide on, from the one decision pipeline.
    Decision,
}

impl ObsMode {
    /// `"raw"`, `"normalized"` or `"privileged"`.
    pub fn as_str(self) -> &'static str {
        match self {
            ObsMode::Raw => "raw",
            ObsMode::Normalized => "normalized",
            ObsMode::Privileged => "privileged",
            ObsMode::Decision => "decision",
        }
    }

    /// Whether the observation is one feature vector (normalized, privileged or decision).
    pub fn is_vector(self) -> bool {
        matches!(self, ObsMode::Normalized | ObsMode::Privileged | ObsMode::Decision)
    }
}

/// Rate of the log-compressed output (per second) that maps to tanh(1) ≈ 0.76.
pub const LOG_RATE_SCALE_PER_S: f64 = 2.0;
/// dθ̂/dt is clamped into ±this (rad/s).
pub const THETA_RATE_LIMIT_RPS: f64 = 10.0;
/// Robot positions are divided by this and clamped into [−1, 1] (m).
pub const POSITION_SCALE_M: f64 = 5.0;

/// The privileged urgency 1/τ is clamped into [0, this] (s⁻¹; τ below 50 ms is "now").
pub const INV_TAU_LIMIT_PS: f64 = 20.0;
/// The privileged bearing rate (image widths per second / 2) that maps to 1.
pub const BEARING_RATE_SCALE_PS: f64 = 4.0;
/// Image-edge angles of the privileged features are divided by this (degrees).
pub const EDGE_SCALE_DEG: f64 = 90.0;

/// The decision mode's time until the predicted arrival that maps to 1 (s).
pub const ARRIVAL_SCALE_S: f64 = 4.0;
/// The decision mode's predicted arrival offset that maps to ±1 (m).
pub const ARRIVAL_LATERAL_SCALE_M: f64 = 2.0;
/// How many other tracks the decision mode lists (`objects.{i}.*`).
pub const DECISION_OBJECTS: usize = 3;
/// The decision mode's value over threshold is clamped into ±this.
pub const VALUE_RATIO_LIMIT: f64 = 2.0;

/// The scales of the normalized features, by name (exported to Python as `FEATURE_SCALES`).
pub const FEATURE_SCALES: [(&str, f64); 10] = [
    ("signal_limit", SIGNAL_LIMIT as f64),
    ("log_rate_scale_per_s", LOG_RATE_SCALE_PER_S),
    ("theta_rate_limit_rps", THETA_RATE_LIMIT_RPS),
    ("position_scale_m", POSITION_SCALE_M),
    ("inv_tau_limit_ps", INV_TAU_LIMIT_PS),
    ("bearing_rate_scale_ps", BEARING_RATE_SCALE_PS),
    ("edge_scale_deg", EDGE_SCALE_DEG),
    ("arrival_scale_s", ARRIVAL_SCALE_S),
    ("arrival_lateral_scale_m", ARRIVAL_LATERAL_SCALE_M),
    ("value_ratio_limit", VALUE_RATIO_LIMIT),
];

/// Number of privileged features ([`ObsMode::Privileged`]): 10 of the threat, 7 of the robot.
pub const PRIVILEGED_FEATURES: usize = 17;
/// The privileged predicted miss |μ| (object radii) is divided by this and clamped into [0, 1].
pub const MISS_RADII_LIMIT: f64 = 10.0;

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
    push_robot_specs(&mut v);
    v
}

fn push_robot_specs(v: &mut Vec<FeatureSpec>) {
    for name in ["x", "y", "yaw", "forward", "yaw_rate", "lateral"] {
        v.push(spec(format!("robot.{name}"), -1.0, 1.0));
    }
    v.push(spec("robot.time", 0.0, 1.0));
}

/// The features of `mode` for an environment observing `labels` (the raw mode has none: the
/// normalized mode's names describe its signals).
pub fn mode_feature_specs(mode: ObsMode, labels: &[&str]) -> Vec<FeatureSpec> {
    match mode {
        ObsMode::Raw | ObsMode::Normalized => feature_specs(labels),
        ObsMode::Privileged => privileged_specs(),
        ObsMode::Decision => decision_specs(labels),
    }
}

/// The per-row features of the decision mode, in order, with their bounds.
const ROW_DECISION_FEATURES: [(&str, f64, f64); 10] = [
    ("value", -VALUE_RATIO_LIMIT, VALUE_RATIO_LIMIT),
    ("alarm", 0.0, 1.0),
    ("theta_hat_rad", 0.0, std::f64::consts::PI),
    ("inv_tau_ps", 0.0, INV_TAU_LIMIT_PS),
    ("gate_open", 0.0, 1.0),
    ("miss_radii", -1.0, 1.0),
    ("pass_side", -1.0, 1.0),
    ("arrival_s", 0.0, 1.0),
    ("arrival_lateral", -1.0, 1.0),
    ("confirmations", 0.0, 1.0),
];

/// Features of one track's box: left, right, bottom, top.
const BOX_EDGES: [&str; 4] = ["left", "right", "bottom", "top"];

/// The decision features (see the module docs) of an environment observing `labels`, with their
/// bounds.
pub fn decision_specs(labels: &[&str]) -> Vec<FeatureSpec> {
    let mut v = Vec::new();
    for l in labels {
        v.extend(
            ROW_DECISION_FEATURES
                .iter()
                .map(|(name, lo, hi)| spec(format!("{l}.{name}"), *lo, *hi)),
        );
    }
    v.push(spec("track.seen", 0.0, 1.0));
    v.extend(BOX_EDGES.iter().map(|e| spec(format!("track.{e}"), -1.0, 1.0)));
    for i in 0..DECISION_OBJECTS {
        v.push(spec(format!("objects.{i}.theta_rad"), 0.0, std::f64::consts::PI));
        v.push(spec(format!("objects.{i}.inv_tau_ps"), 0.0, INV_TAU_LIMIT_PS));
        v.extend(BOX_EDGES.iter().map(|e| spec(format!("objects.{i}.{e}"), -1.0, 1.0)));
    }
    v.push(spec("looming_side", -1.0, 1.0));
    push_robot_specs(&mut v);
    v
}

/// What one row decided on one frame (the decision mode's per-row input).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowDecision {
    /// The decision value compared with the alarm threshold.
    pub value: f64,
    /// The row's alarm threshold (θ̂ in degrees, the output, or the urgency 1/τ in s⁻¹).
    pub threshold: f64,
    /// The row's detector's θ̂ (degrees), when it gives one.
    pub theta_hat_deg: Option<f64>,
    /// The decider's decision (`None`: a stateless row, whose value is the percept).
    pub decision: Option<Decision>,
    /// The decider's K-of-M count and K ([`loomlab_agents::Decider::confirmations`]).
    pub confirmations: Option<(usize, usize)>,
}

impl RowDecision {
    /// A row before its detector's first frame: nothing decided.
    pub fn idle(threshold: f64) -> Self {
        Self {
            value: 0.0,
            threshold,
            theta_hat_deg: None,
            decision: None,
            confirmations: None,
        }
    }
}

/// What the decision mode reads on one frame besides the rows.
#[derive(Debug, Clone, Copy)]
pub struct DecisionFrame<'a> {
    /// The frame's time (s).
    pub t_s: f64,
    /// The driving track's box: the image region of the first row's detector that gives one.
    pub track: Option<&'a ImageRegion>,
    /// That detector's listed tracks ([`loomlab_detector::Signals::objects`]).
    pub objects: &'a [PerceivedObject],
    /// The looming object's image x, when known.
    pub looming_side: Option<f32>,
}

/// The decision features (see the module docs) of one frame; `duration_s` the episode's
/// duration, `action` the action scales, `last_command` the robot's last command.
pub fn decision_features(
    rows: &[RowDecision],
    frame: &DecisionFrame<'_>,
    obs: &Observation,
    duration_s: f64,
    action: &ActionConfig,
    last_command: VelocityCommand,
) -> Vec<f32> {
    let unit = |v: f64| if v.is_finite() { v.clamp(-1.0, 1.0) as f32 } else { 0.0 };
    let inv_tau = |tau: Option<f64>| match tau {
        Some(t) if t > 0.0 => (1.0 / t).min(INV_TAU_LIMIT_PS) as f32,
        _ => 0.0,
    };
    let mut f = Vec::with_capacity(ROW_DECISION_FEATURES.len() * rows.len() + 30);
    for r in rows {
        let alarm = r.value >= r.threshold;
        let ratio = if r.threshold != 0.0 {
            r.value / r.threshold.abs()
        } else {
            r.value
        };
        f.push(if ratio.is_finite() {
            ratio.clamp(-VALUE_RATIO_LIMIT, VALUE_RATIO_LIMIT) as f32
        } else {
            0.0
        });
        f.push(f32::from(u8::from(alarm)));
        let theta = r.theta_hat_deg.filter(|v| v.is_finite()).unwrap_or(0.0).to_radians();
        f.push(theta.clamp(0.0, std::f64::consts::PI) as f32);
        let d = r.decision;
        f.push(inv_tau(d.and_then(|d| d.tau_s)));
        f.push(f32::from(u8::from(d.is_none_or(|d| d.gate_open))));
        f.push(unit(d.and_then(|d| d.miss_radii).unwrap_or(0.0) / MISS_RADII_LIMIT));
        f.push(d.and_then(|d| d.pass_side).map_or(0.0, |s| s.clamp(-1.0, 1.0)));
        let arrival = d.and_then(|d| match d.forecast {
            Some(fc) => Some(fc.tau_s - (frame.t_s - fc.t_s)),
            None => d.tau_s,
        });
        f.push(arrival.map_or(1.0, |a| (a.max(0.0) / ARRIVAL_SCALE_S).min(1.0) as f32));
        let lateral = d
            .and_then(|d| d.arrival_extent_m)
            .map_or(0.0, |e| (e[0] + e[1]) / 2.0 / ARRIVAL_LATERAL_SCALE_M);
        f.push(unit(lateral));
        f.push(match r.confirmations {
            Some((count, k)) => (count as f64 / k.max(1) as f64).min(1.0) as f32,
            None => f32::from(u8::from(alarm)),
        });
    }
    let edges = |b: &ImageRegion| [b.x[0], b.x[1], b.y[0], b.y[1]].map(unit);
    f.push(f32::from(u8::from(frame.track.is_some())));
    f.extend(frame.track.map_or([0.0; 4], edges));
    for o in most_urgent(frame.objects, frame.track.and_then(|t| t.track)) {
        match o {
            Some(o) => {
                f.push(o.angular_size_deg.to_radians().clamp(0.0, std::f64::consts::PI) as f32);
                f.push(inv_tau(o.tau_s));
                f.extend(edges(&o.region));
            }
            None => f.extend([0.0; 6]),
        }
    }
    f.push(
        frame
            .looming_side
            .filter(|v| v.is_finite())
            .map_or(0.0, |v| v.clamp(-1.0, 1.0)),
    );
    robot_features(&mut f, obs, duration_s, action, last_command);
    f
}

/// The [`DECISION_OBJECTS`] most urgent tracks other than `driving` (see the module docs), `None`
/// for the missing ones.
fn most_urgent(objects: &[PerceivedObject], driving: Option<usize>) -> [Option<&PerceivedObject>; DECISION_OBJECTS] {
    let mut others: Vec<&PerceivedObject> = objects.iter().filter(|o| Some(o.id) != driving).collect();
    let tau = |o: &PerceivedObject| o.tau_s.filter(|t| t.is_finite() && *t > 0.0).unwrap_or(f64::INFINITY);
    others.sort_by(|a, b| {
        tau(a)
            .total_cmp(&tau(b))
            .then(b.angular_size_deg.total_cmp(&a.angular_size_deg))
            .then(a.id.cmp(&b.id))
    });
    std::array::from_fn(|i| others.get(i).copied())
}

/// The privileged features (see the module docs), with their bounds.
pub fn privileged_specs() -> Vec<FeatureSpec> {
    let mut v = vec![
        spec("threat.theta_rad", 0.0, std::f64::consts::PI),
        spec("threat.theta_rate_rps", -THETA_RATE_LIMIT_RPS, THETA_RATE_LIMIT_RPS),
        spec("threat.inv_tau_ps", 0.0, INV_TAU_LIMIT_PS),
        spec("threat.bearing", -1.0, 1.0),
        spec("threat.bearing_rate", -1.0, 1.0),
        spec("threat.miss_radii", 0.0, 1.0),
    ];
    for name in ["left_deg", "right_deg", "bottom_deg", "top_deg"] {
        v.push(spec(format!("threat.{name}"), -1.0, 1.0));
    }
    push_robot_specs(&mut v);
    v
}

/// The robot features of the normalized and privileged modes (see the module docs).
fn robot_features(
    f: &mut Vec<f32>,
    obs: &Observation,
    duration_s: f64,
    action: &ActionConfig,
    last_command: VelocityCommand,
) {
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
}

/// The most threatening object of a frame's ground truth (see the module docs): the looming
/// object in view with the shortest optical τ, else the largest in view.
pub fn most_threatening(truth: &[ObjectTruth]) -> Option<&ObjectTruth> {
    let in_view = || {
        truth
            .iter()
            .filter(|t| t.in_view && t.angular_size_deg.is_finite() && t.angular_size_deg > 0.0)
    };
    let inv_tau = |t: &ObjectTruth| f64::from(t.angular_rate_deg_s) / f64::from(t.angular_size_deg);
    in_view()
        .filter(|t| t.angular_rate_deg_s > 0.0)
        .max_by(|a, b| inv_tau(a).total_cmp(&inv_tau(b)).then(b.id.cmp(&a.id)))
        .or_else(|| in_view().max_by(|a, b| a.angular_size_deg.total_cmp(&b.angular_size_deg).then(b.id.cmp(&a.id))))
}

/// Computes privileged features from successive frames' ground truth (one per environment; reset
/// at every episode start).
#[derive(Debug, Clone, Default)]
pub struct PrivilegedPercept {
    /// The last frame's object: id, bearing (image x) and azimuth (rad).
    last: Option<(usize, f64, f64)>,
}

impl PrivilegedPercept {
    /// Forgets the previous frame.
    pub fn reset(&mut self) {
        self.last = None;
    }

    /// The privileged features of a frame (see the module docs), `dt` after the previous one.
    pub fn features(
        &mut self,
        truth: &[ObjectTruth],
        obs: &Observation,
        dt: f64,
        duration_s: f64,
        action: &ActionConfig,
        last_command: VelocityCommand,
    ) -> Vec<f32> {
        let mut f = Vec::with_capacity(PRIVILEGED_FEATURES);
        let dt = if dt > 0.0 { dt } else { 1.0 };
        match most_threatening(truth) {
            Some(t) => {
                let theta = f64::from(t.angular_size_deg)
                    .to_radians()
                    .clamp(0.0, std::f64::consts::PI);
                let rate = f64::from(t.angular_rate_deg_s).to_radians();
                let inv_tau = if rate > 0.0 && theta > 0.0 {
                    (rate / theta).min(INV_TAU_LIMIT_PS)
                } else {
                    0.0
                };
                let bearing = f64::from(t.bearing).clamp(-1.0, 1.0);
                let azimuth = f64::from(t.bearing_deg).to_radians();
                let (bearing_rate, azimuth_rate) = match self.last {
                    Some((id, b, a)) if id == t.id => ((bearing - b) / dt / BEARING_RATE_SCALE_PS, (azimuth - a) / dt),
                    _ => (0.0, 0.0),
                };
                let miss = if rate > 0.0 {
                    (2.0 * azimuth_rate / rate).abs() / MISS_RADII_LIMIT
                } else {
                    1.0
                };
                let edge = |d: f32| (f64::from(d) / EDGE_SCALE_DEG).clamp(-1.0, 1.0) as f32;
                f.push(theta as f32);
                f.push(rate.clamp(-THETA_RATE_LIMIT_RPS, THETA_RATE_LIMIT_RPS) as f32);
                f.push(inv_tau as f32);
                f.push(bearing as f32);
                f.push(bearing_rate.clamp(-1.0, 1.0) as f32);
                f.push(miss.clamp(0.0, 1.0) as f32);
                f.extend(t.azimuth_extent_deg.map(edge));
                f.extend(t.elevation_extent_deg.map(edge));
                self.last = Some((t.id, bearing, azimuth));
            }
            None => {
                f.extend([0.0; 10]);
                self.last = None;
            }
        }
        robot_features(&mut f, obs, duration_s, action, last_command);
        f
    }
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
        robot_features(&mut f, obs, duration_s, action, last_command);
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
        let p = privileged_specs();
        assert_eq!(p.len(), PRIVILEGED_FEATURES);
        assert!(p.iter().all(|s| s.low < s.high));
        assert_eq!(mode_feature_specs(ObsMode::Privileged, &["soc"]), p);
    }
}

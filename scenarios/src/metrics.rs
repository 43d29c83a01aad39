//! Per-episode scoring and per-detector aggregation.
//!
//! # Definitions
//! For one detector in one episode, with ground truth from the runner (an object is a **threat**
//! if it would touch the robot's body with no escape; `t_c` is its contact time; `t_dl` is its
//! **escape deadline**, the latest trigger time from which the episode's own escape manoeuvre
//! still avoids every contact, see [`crate::deadline`]) and the detector's trigger-signal trace,
//! the **alarm** is the first frame whose signal is `>= threshold` (the escape controller's rule;
//! NaN never alarms), at time `t_a`:
//! - evadable threat (it has a deadline): [`Outcome::Hit`] if `t_a ≤ t_dl − lead_margin`
//!   (equality counts; a tolerance of [`TIME_EPS_S`] absorbs frame-time rounding), else
//!   [`Outcome::Miss`]: *late* if it alarmed after that, *silent* if it never alarmed;
//! - threat that no trigger time evades: [`Outcome::Unavoidable`], reported apart (neither hit nor
//!   miss, whatever the detector did);
//! - no threat: [`Outcome::FalseAlarm`] if there is any alarm, else [`Outcome::CorrectRejection`];
//! - closed loop: `collision` (the robot was touched) or evaded;
//! - at the alarm: the true TTC and true angular size of the threat, as the runner recorded them.
//!
//! So a hit is an alarm in time to evade, and a hit that still collides is a contradiction of the
//! closed loop (a re-trigger of the level-triggered controller that dodges back into the object,
//! a dodge into another object, or a non-monotone deadline): reports count it as `hit_collisions`.
//!
//! **Collisions caused by a row's own manoeuvres** ([`DetectorEpisode::collision_caused`]): a
//! false alarm that collides (the open loop touched nothing, so only the escape manoeuvre can have
//! driven the robot into an object) and a hit that collides (the alarm came in time for the
//! manoeuvre to evade, yet the closed loop collided). Late and silent misses and unavoidable
//! threats collide with or without the manoeuvre and are not counted. Reports give
//! `collisions_caused = false_alarm_collisions + hit_collisions` and `collisions_caused_rate =
//! collisions_caused / episodes` (the row's episodes, threats and non-threats alike).
//!
//! The ROC **score** of an episode ([`DetectorEpisode::max_signal`]) is the maximum signal over the
//! window in which an alarm counts: frames with `t ≤ t_dl − lead_margin` for evadable threats, all
//! frames for non-threats (unavoidable threats are not ROC positives); see [`crate::stats`] for why
//! this gives the exact threshold sweep.
//!
//! # Rates
//! `hit_rate = hits / (hits + misses)` (evadable threats), `false_alarm_rate = false_alarms /
//! (false_alarms + correct_rejections)`, `collision_rate = collisions / episodes`, `evasion_rate =
//! evaded / evadable_threats`, each with a 95 % Wilson interval.
//! A rate whose denominator is zero (e.g. the hit rate of a suite without threats) is `None`,
//! written `null` in JSON and empty in CSV — not 0, which would read as "every threat missed";
//! the same holds for its interval, the mean lead time (no hits) and the AUC (no threats or no
//! non-threats). No NaN or infinity ever reaches a report.

use std::collections::BTreeMap;
use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::lv::LvFit;
use crate::stats::{self, Interval, RocPoint};

/// Tolerance on time comparisons (seconds), so that `t_a = t_dl − lead_margin` computed from frame
/// counts still counts as a hit despite floating-point rounding.
pub const TIME_EPS_S: f64 = 1e-9;

/// Everything that can go wrong while scoring, reporting or comparing reports.
#[derive(Debug, thiserror::Error)]
pub enum ScoringError {
    /// A scoring parameter is out of range.
    #[error("invalid scoring parameter `{key}` = {value}: {reason}")]
    InvalidConfig {
        /// Key as written in config files.
        key: &'static str,
        /// The offending value, formatted.
        value: String,
        /// What is wrong and how to fix it.
        reason: String,
    },
    /// Inconsistent ground truth handed over by the runner.
    #[error("invalid ground truth for detector `{detector}`: {reason}")]
    GroundTruth {
        /// Detector id of the episode being scored.
        detector: String,
        /// What is inconsistent.
        reason: String,
    },
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file involved.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A report file is not valid report JSON.
    #[error("{path}: not a valid loomlab report: {reason}")]
    Json {
        /// The file involved.
        path: PathBuf,
        /// What serde_json said.
        reason: String,
    },
    /// An episodes CSV file is malformed.
    #[error("{path}:{line}: {reason}")]
    Csv {
        /// The file involved.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        reason: String,
    },
}

/// The scoring outcome of one detector in one episode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// Evadable threat, alarm no later than its escape deadline (minus `lead_margin_s`).
    Hit,
    /// Evadable threat, alarm after the deadline (late) or none (silent).
    Miss,
    /// Threat that no trigger time evades.
    Unavoidable,
    /// No threat, but an alarm.
    FalseAlarm,
    /// No threat, no alarm.
    CorrectRejection,
}

impl Outcome {
    /// The snake_case name used in CSV and JSON.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Hit => "hit",
            Self::Miss => "miss",
            Self::Unavoidable => "unavoidable",
            Self::FalseAlarm => "false_alarm",
            Self::CorrectRejection => "correct_rejection",
        }
    }
}

impl fmt::Display for Outcome {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Outcome {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "hit" => Ok(Self::Hit),
            "miss" => Ok(Self::Miss),
            "unavoidable" => Ok(Self::Unavoidable),
            "false_alarm" => Ok(Self::FalseAlarm),
            "correct_rejection" => Ok(Self::CorrectRejection),
            _ => Err(format!(
                "unknown outcome `{s}` (expected hit, miss, unavoidable, false_alarm or correct_rejection)"
            )),
        }
    }
}

/// Scoring parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScoringConfig {
    /// Extra margin in seconds: a threat's alarm must come at least this long before its escape
    /// deadline to count as a hit (default 0: the deadline itself).
    pub lead_margin_s: f64,
    /// Removed: the fixed lead before contact is replaced by the escape deadline. Accepted by the
    /// parser only to reject it with a message naming the replacement.
    #[serde(default, skip_serializing)]
    pub lead_min_s: Option<f64>,
    /// Keep the full signal trace in each [`DetectorEpisode`] (memory grows with episode length).
    pub keep_traces: bool,
}

impl Default for ScoringConfig {
    fn default() -> Self {
        Self {
            lead_margin_s: 0.0,
            lead_min_s: None,
            keep_traces: false,
        }
    }
}

impl ScoringConfig {
    /// Check every value.
    pub fn validate(&self) -> Result<(), ScoringError> {
        if let Some(v) = self.lead_min_s {
            return Err(ScoringError::InvalidConfig {
                key: "scoring.lead_min_s",
                value: v.to_string(),
                reason: "was removed: a hit is now an alarm no later than the threat's escape deadline (found \
                         by physics-only replays of the escape manoeuvre); delete the key, or use \
                         `scoring.lead_margin_s` for an extra margin before the deadline"
                    .into(),
            });
        }
        if !(self.lead_margin_s.is_finite() && self.lead_margin_s >= 0.0) {
            return Err(ScoringError::InvalidConfig {
                key: "scoring.lead_margin_s",
                value: self.lead_margin_s.to_string(),
                reason: "must be a finite number of seconds >= 0".into(),
            });
        }
        Ok(())
    }
}

/// Ground truth of one episode run for one detector.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GroundTruth {
    /// Whether an object would touch the robot's body with no escape.
    pub threat: bool,
    /// Contact time `t_c` in seconds (required for threats, `None` otherwise).
    pub t_contact_s: Option<f64>,
    /// Escape deadline `t_dl` in seconds of a threat (`None`: unavoidable, or no threat).
    pub t_deadline_s: Option<f64>,
    /// Whether the robot was actually touched in this (closed-loop) run.
    pub collision: bool,
}

/// One frame of a detector's trace, as recorded by the runner.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TraceSample {
    /// Episode time in seconds.
    pub t_s: f64,
    /// The trigger signal (θ̂ in degrees for Hopfield, the output for baselines); NaN = no value.
    pub signal: f64,
    /// True time-to-contact of the threat (or nearest) object at this frame, if known.
    pub ttc_s: Option<f64>,
    /// True angular size of that object in degrees at this frame, if known.
    pub angular_size_deg: Option<f64>,
}

/// The score of one detector in one episode.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DetectorEpisode {
    /// Detector id (`hopfield`, `soc`, …).
    pub detector: String,
    /// Ground truth: threat or not.
    pub threat: bool,
    /// Contact time `t_c` of the threat.
    pub t_contact_s: Option<f64>,
    /// Escape deadline `t_dl` of an evadable threat.
    #[serde(default)]
    pub t_deadline_s: Option<f64>,
    /// First alarm time `t_a`.
    pub t_alarm_s: Option<f64>,
    /// Hit / miss / false alarm / correct rejection.
    pub outcome: Outcome,
    /// Whether the robot was touched (closed loop; harmless contacts do not count).
    pub collision: bool,
    /// Relative speed of the robot and the object at the closed loop's collision (m/s).
    #[serde(default)]
    pub impact_speed_mps: Option<f64>,
    /// Contact impulse of the closed loop's collision (N·s; dynamic physics).
    #[serde(default)]
    pub impulse_ns: Option<f64>,
    /// True angular size of an evadable threat at its escape deadline (degrees): the θ a
    /// threshold on the true angular size needs to reach to be in time (`None`: no evadable threat).
    #[serde(default)]
    pub theta_required_deg: Option<f64>,
    /// First time the threat's reference point is in the camera's view (s; ground truth, threats
    /// only; `None`: not before contact). An evadable threat first in view after its escape
    /// deadline is one no camera-based controller sees in time ([`Self::seen_in_time`]).
    #[serde(default)]
    pub t_in_view_s: Option<f64>,
    /// Escape manoeuvres started in the closed loop (the level-triggered controller re-triggers
    /// after its cooldown while the signal stays above the threshold).
    #[serde(default)]
    pub triggers: u64,
    /// True TTC at the alarm.
    pub ttc_at_alarm_s: Option<f64>,
    /// True angular size at the alarm, degrees.
    pub angular_size_at_alarm_deg: Option<f64>,
    /// ROC score: maximum finite signal in the scoring window (`None`: no finite value there).
    pub max_signal: Option<f64>,
    /// Half-size over closing speed `l/|v|` (s) of a threat approaching head-on at constant speed
    /// (the l/|v| analysis; `None` for other episodes).
    #[serde(default)]
    pub l_over_v_s: Option<f64>,
    /// At the alarm, the time until the threat's centre would reach the camera at its current
    /// closing speed (s): the time to collision of the l/|v| analysis.
    #[serde(default)]
    pub eye_ttc_at_alarm_s: Option<f64>,
    /// θ̂ accuracy on a threat, for detectors triggered by θ̂: median of |θ̂ − θ|/θ over the frames
    /// whose true θ (reference object) is in [5°, 60°] ([`ThetaAccuracy`]).
    #[serde(default)]
    pub theta_rel_err_median: Option<f64>,
    /// The 90th percentile of the same.
    #[serde(default)]
    pub theta_rel_err_p90: Option<f64>,
    /// True angular size (degrees) at the first frame with θ̂ ≥ 5°.
    #[serde(default)]
    pub theta_at_first_estimate_deg: Option<f64>,
    /// The full trace, if [`ScoringConfig::keep_traces`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trace: Option<Vec<TraceSample>>,
}

impl DetectorEpisode {
    /// Warning time `t_c − t_a` of a hit (`None` for other outcomes).
    pub fn lead_s(&self) -> Option<f64> {
        match (self.outcome, self.t_contact_s, self.t_alarm_s) {
            (Outcome::Hit, Some(tc), Some(ta)) => Some(tc - ta),
            _ => None,
        }
    }

    /// Whether the episode is a threat that some trigger time evades.
    pub fn evadable(&self) -> bool {
        self.threat && self.t_deadline_s.is_some()
    }

    /// Whether an evadable threat was in the camera's view at or before its escape deadline: one
    /// that a controller seeing the frames could have evaded (the others come into view too late,
    /// thrown from outside the field of view, whatever the detector).
    pub fn seen_in_time(&self) -> bool {
        self.evadable() && matches!((self.t_in_view_s, self.t_deadline_s), (Some(v), Some(d)) if v <= d)
    }

    /// How long before contact the deadline is, `t_c − t_dl` (s; evadable threats).
    pub fn deadline_lead_s(&self) -> Option<f64> {
        Some(self.t_contact_s? - self.t_deadline_s?)
    }

    /// Whether the row's own escape manoeuvre caused this episode's collision: a false alarm or a
    /// hit whose closed loop collided (see the module docs).
    pub fn collision_caused(&self) -> bool {
        self.collision && matches!(self.outcome, Outcome::FalseAlarm | Outcome::Hit)
    }

    /// A miss with an alarm after the deadline.
    pub fn is_late_miss(&self) -> bool {
        self.outcome == Outcome::Miss && self.t_alarm_s.is_some()
    }

    /// A miss without any alarm.
    pub fn is_silent_miss(&self) -> bool {
        self.outcome == Outcome::Miss && self.t_alarm_s.is_none()
    }

    /// The score used for ROC curves (−∞ when there is none: never alarms).
    pub fn roc_score(&self) -> f64 {
        self.max_signal.unwrap_or(f64::NEG_INFINITY)
    }
}

/// One episode: where it came from and the score of every detector run on it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EpisodeOutcome {
    /// Scenario name.
    pub scenario: String,
    /// Episode index within the scenario.
    pub episode: usize,
    /// The episode's seed.
    pub seed: u64,
    /// Swept / sampled parameter values (key → value as written).
    pub params: BTreeMap<String, String>,
    /// One entry per detector.
    pub detectors: Vec<DetectorEpisode>,
}

fn check_time(detector: &str, what: &str, t: f64) -> Result<(), ScoringError> {
    if t.is_finite() {
        Ok(())
    } else {
        Err(ScoringError::GroundTruth {
            detector: detector.into(),
            reason: format!("{what} is {t}, not a finite time"),
        })
    }
}

/// Classify one episode from the ground truth and the first alarm time (see the module docs).
///
/// Errors if a threat has no (finite) contact time, a non-threat has one or a deadline.
pub fn classify(truth: &GroundTruth, t_alarm_s: Option<f64>, lead_margin_s: f64) -> Result<Outcome, ScoringError> {
    if let Some(ta) = t_alarm_s {
        check_time("<unnamed>", "t_alarm_s", ta)?;
    }
    match (truth.threat, truth.t_contact_s) {
        (true, Some(tc)) => {
            check_time("<unnamed>", "t_contact_s", tc)?;
            let Some(td) = truth.t_deadline_s else {
                return Ok(Outcome::Unavoidable);
            };
            check_time("<unnamed>", "t_deadline_s", td)?;
            Ok(match t_alarm_s {
                Some(ta) if ta <= td - lead_margin_s + TIME_EPS_S => Outcome::Hit,
                _ => Outcome::Miss,
            })
        }
        (true, None) => Err(ScoringError::GroundTruth {
            detector: "<unnamed>".into(),
            reason: "a threat needs a contact time t_contact_s".into(),
        }),
        (false, Some(tc)) => Err(ScoringError::GroundTruth {
            detector: "<unnamed>".into(),
            reason: format!("a non-threat has contact time t_contact_s = {tc}; mark it as a threat or drop the time"),
        }),
        (false, None) if truth.t_deadline_s.is_some() => Err(ScoringError::GroundTruth {
            detector: "<unnamed>".into(),
            reason: "a non-threat has an escape deadline".into(),
        }),
        (false, None) => Ok(if t_alarm_s.is_some() {
            Outcome::FalseAlarm
        } else {
            Outcome::CorrectRejection
        }),
    }
}

/// Score one detector's run of one episode from its trace (samples need not be sorted).
///
/// `threshold` is the alarm threshold on [`TraceSample::signal`] (the escape controller's).
pub fn score_detector_episode(
    detector: &str,
    threshold: f64,
    samples: &[TraceSample],
    truth: &GroundTruth,
    config: &ScoringConfig,
) -> Result<DetectorEpisode, ScoringError> {
    config.validate()?;
    let name_err = |e: ScoringError| match e {
        ScoringError::GroundTruth { reason, .. } => ScoringError::GroundTruth {
            detector: detector.into(),
            reason,
        },
        other => other,
    };
    if !threshold.is_finite() {
        return Err(ScoringError::InvalidConfig {
            key: "threshold",
            value: threshold.to_string(),
            reason: format!("the alarm threshold of detector `{detector}` must be finite"),
        });
    }
    for s in samples {
        check_time(detector, "a trace sample's t_s", s.t_s)?;
    }
    let alarm = samples
        .iter()
        .filter(|s| s.signal >= threshold)
        .min_by(|a, b| a.t_s.total_cmp(&b.t_s));
    let t_alarm_s = alarm.map(|s| s.t_s);
    let outcome = classify(truth, t_alarm_s, config.lead_margin_s).map_err(name_err)?;
    let window_end = match (truth.threat, truth.t_deadline_s, truth.t_contact_s) {
        (true, Some(td), _) => td - config.lead_margin_s + TIME_EPS_S,
        (true, None, Some(tc)) => tc,
        _ => f64::INFINITY,
    };
    let max_signal = samples
        .iter()
        .filter(|s| s.t_s <= window_end && s.signal.is_finite())
        .map(|s| s.signal)
        .max_by(f64::total_cmp);
    Ok(DetectorEpisode {
        detector: detector.into(),
        threat: truth.threat,
        t_contact_s: truth.t_contact_s,
        t_deadline_s: truth.t_deadline_s.filter(|_| truth.threat),
        t_alarm_s,
        outcome,
        collision: truth.collision,
        impact_speed_mps: None,
        impulse_ns: None,
        theta_required_deg: None,
        t_in_view_s: None,
        triggers: u64::from(t_alarm_s.is_some()),
        ttc_at_alarm_s: alarm.and_then(|s| s.ttc_s).filter(|v| v.is_finite()),
        angular_size_at_alarm_deg: alarm.and_then(|s| s.angular_size_deg).filter(|v| v.is_finite()),
        max_signal,
        l_over_v_s: None,
        eye_ttc_at_alarm_s: None,
        theta_rel_err_median: None,
        theta_rel_err_p90: None,
        theta_at_first_estimate_deg: None,
        trace: config.keep_traces.then(|| samples.to_vec()),
    })
}

/// Aggregated scores of one detector over a set of episodes (see the module docs for the rates).
///
/// The first nine fields are the report contract (`docs/design.md`) and always present; `None` is
/// `null`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DetectorSummary {
    /// Number of episodes.
    pub episodes: u64,
    /// Threat episodes that were hits.
    pub hits: u64,
    /// Threat episodes that were misses.
    pub misses: u64,
    /// Non-threat episodes with an alarm.
    pub false_alarms: u64,
    /// Non-threat episodes without an alarm.
    pub correct_rejections: u64,
    /// hits / (hits + misses); `None` without threats.
    pub hit_rate: Option<f64>,
    /// false_alarms / (false_alarms + correct_rejections); `None` without non-threats.
    pub false_alarm_rate: Option<f64>,
    /// Episodes in which the robot was touched.
    pub collisions: u64,
    /// collisions / episodes.
    pub collision_rate: Option<f64>,
    /// 95 % Wilson interval of `hit_rate`.
    #[serde(default)]
    pub hit_rate_ci: Option<Interval>,
    /// 95 % Wilson interval of `false_alarm_rate`.
    #[serde(default)]
    pub false_alarm_rate_ci: Option<Interval>,
    /// 95 % Wilson interval of `collision_rate`.
    #[serde(default)]
    pub collision_rate_ci: Option<Interval>,
    /// Mean warning time `t_c − t_a` over hits, seconds.
    #[serde(default)]
    pub mean_lead_s: Option<f64>,
    /// Mean true angular size at the alarm over hits, degrees.
    #[serde(default)]
    pub mean_angular_size_at_alarm_deg: Option<f64>,
    /// Area under the ROC curve; `None` without threats or without non-threats.
    #[serde(default)]
    pub auc: Option<f64>,
    /// Threats some trigger time evades (the denominator of `hit_rate` and `evasion_rate`).
    #[serde(default)]
    pub evadable_threats: u64,
    /// Threats no trigger time evades (neither hits nor misses).
    #[serde(default)]
    pub unavoidable_threats: u64,
    /// Evadable threats the closed loop evaded.
    #[serde(default)]
    pub evaded: u64,
    /// evaded / evadable_threats.
    #[serde(default)]
    pub evasion_rate: Option<f64>,
    /// 95 % Wilson interval of `evasion_rate`.
    #[serde(default)]
    pub evasion_rate_ci: Option<Interval>,
    /// Evadable threats in the camera's view by their escape deadline
    /// ([`DetectorEpisode::seen_in_time`]): the threats a controller seeing the frames can evade.
    #[serde(default)]
    pub evadable_in_view: u64,
    /// Of those, the ones the closed loop evaded.
    #[serde(default)]
    pub evaded_in_view: u64,
    /// evaded_in_view / evadable_in_view.
    #[serde(default)]
    pub evasion_rate_in_view: Option<f64>,
    /// Misses with an alarm after the deadline.
    #[serde(default)]
    pub late_misses: u64,
    /// Misses without any alarm.
    #[serde(default)]
    pub silent_misses: u64,
    /// Hits that still collided (a contradiction of the closed loop; see the module docs).
    #[serde(default)]
    pub hit_collisions: u64,
    /// Of those, the ones whose closed loop re-triggered (a second manoeuvre that the deadline,
    /// computed for one manoeuvre, does not cover).
    #[serde(default)]
    pub retriggered_hit_collisions: u64,
    /// Non-threat episodes that collided after a false-alarm escape.
    #[serde(default)]
    pub false_alarm_collisions: u64,
    /// Collisions the row's own manoeuvres caused: `false_alarm_collisions + hit_collisions`
    /// ([`DetectorEpisode::collision_caused`]). Reports written before the key existed get it
    /// derived on reading ([`DetectorSummary::derive_collisions_caused`]).
    #[serde(default)]
    pub collisions_caused: u64,
    /// collisions_caused / episodes (`None` without episodes).
    #[serde(default)]
    pub collisions_caused_rate: Option<f64>,
    /// 95 % Wilson interval of `collisions_caused_rate`.
    #[serde(default)]
    pub collisions_caused_rate_ci: Option<Interval>,
    /// 1 − collisions / collisions of the `null` reference row (filled in by the report; `None`
    /// without a null row or when null never collides).
    #[serde(default)]
    pub collision_reduction: Option<f64>,
    /// The l/|v| fit over constant-speed head-on threats ([`crate::lv`]).
    #[serde(default)]
    pub lv_fit: Option<LvFit>,
    /// θ̂ accuracy over the threats (detectors triggered by θ̂ only).
    #[serde(default)]
    pub theta_accuracy: Option<ThetaAccuracy>,
    /// The ROC curve (see [`crate::stats`]).
    #[serde(default)]
    pub roc: Vec<RocPoint>,
}

fn mean(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, n) = values
        .filter(|v| v.is_finite())
        .fold((0.0, 0u64), |(s, n), v| (s + v, n + 1));
    (n > 0).then(|| sum / n as f64)
}

impl DetectorSummary {
    /// Aggregate episodes (normally all of one detector).
    pub fn from_episodes<'a>(episodes: impl IntoIterator<Item = &'a DetectorEpisode>) -> Self {
        let eps: Vec<&DetectorEpisode> = episodes.into_iter().collect();
        let count = |o: Outcome| eps.iter().filter(|e| e.outcome == o).count() as u64;
        let (hits, misses) = (count(Outcome::Hit), count(Outcome::Miss));
        let (false_alarms, correct_rejections) = (count(Outcome::FalseAlarm), count(Outcome::CorrectRejection));
        let episodes = eps.len() as u64;
        let collisions = eps.iter().filter(|e| e.collision).count() as u64;
        let evadable_threats = eps.iter().filter(|e| e.evadable()).count() as u64;
        let evaded = eps.iter().filter(|e| e.evadable() && !e.collision).count() as u64;
        let evadable_in_view = eps.iter().filter(|e| e.seen_in_time()).count() as u64;
        let evaded_in_view = eps.iter().filter(|e| e.seen_in_time() && !e.collision).count() as u64;
        let positives: Vec<f64> = eps.iter().filter(|e| e.evadable()).map(|e| e.roc_score()).collect();
        let negatives: Vec<f64> = eps.iter().filter(|e| !e.threat).map(|e| e.roc_score()).collect();
        let roc = stats::roc_curve(&positives, &negatives);
        let auc = (!roc.is_empty()).then(|| stats::auc_trapezoid(&roc));
        let hits_iter = || eps.iter().filter(|e| e.outcome == Outcome::Hit);
        let mut summary = Self {
            episodes,
            hits,
            misses,
            false_alarms,
            correct_rejections,
            hit_rate: stats::rate(hits, hits + misses),
            false_alarm_rate: stats::rate(false_alarms, false_alarms + correct_rejections),
            collisions,
            collision_rate: stats::rate(collisions, episodes),
            hit_rate_ci: stats::wilson_95(hits, hits + misses),
            false_alarm_rate_ci: stats::wilson_95(false_alarms, false_alarms + correct_rejections),
            collision_rate_ci: stats::wilson_95(collisions, episodes),
            mean_lead_s: mean(hits_iter().filter_map(|e| e.lead_s())),
            mean_angular_size_at_alarm_deg: mean(hits_iter().filter_map(|e| e.angular_size_at_alarm_deg)),
            auc,
            evadable_threats,
            unavoidable_threats: count(Outcome::Unavoidable),
            evaded,
            evasion_rate: stats::rate(evaded, evadable_threats),
            evasion_rate_ci: stats::wilson_95(evaded, evadable_threats),
            evadable_in_view,
            evaded_in_view,
            evasion_rate_in_view: stats::rate(evaded_in_view, evadable_in_view),
            late_misses: eps.iter().filter(|e| e.is_late_miss()).count() as u64,
            silent_misses: eps.iter().filter(|e| e.is_silent_miss()).count() as u64,
            hit_collisions: eps.iter().filter(|e| e.outcome == Outcome::Hit && e.collision).count() as u64,
            retriggered_hit_collisions: eps
                .iter()
                .filter(|e| e.outcome == Outcome::Hit && e.collision && e.triggers > 1)
                .count() as u64,
            false_alarm_collisions: eps
                .iter()
                .filter(|e| e.outcome == Outcome::FalseAlarm && e.collision)
                .count() as u64,
            collisions_caused: 0,
            collisions_caused_rate: None,
            collisions_caused_rate_ci: None,
            collision_reduction: None,
            lv_fit: LvFit::from_episodes(&eps),
            theta_accuracy: ThetaAccuracy::from_episodes(&eps),
            roc,
        };
        summary.derive_collisions_caused();
        summary
    }

    /// Fills `collisions_caused` and its rate and interval from `false_alarm_collisions`,
    /// `hit_collisions` and `episodes`, which every report carries (also those written before the
    /// keys existed: [`crate::report::Report::from_json`] calls this on every summary it reads).
    pub fn derive_collisions_caused(&mut self) {
        self.collisions_caused = self.false_alarm_collisions + self.hit_collisions;
        self.collisions_caused_rate = stats::rate(self.collisions_caused, self.episodes);
        self.collisions_caused_rate_ci = stats::wilson_95(self.collisions_caused, self.episodes);
    }
}

/// True angular sizes over which θ̂ accuracy is measured (degrees).
pub const THETA_ACCURACY_RANGE_DEG: (f64, f64) = (5.0, 60.0);
/// θ̂ at or above which a detector counts as having an estimate (degrees).
pub const THETA_ESTIMATE_ONSET_DEG: f64 = 5.0;

/// How well a detector's angular-size estimate θ̂ tracks the true angular size θ of the threat.
///
/// Per threat episode, the relative error |θ̂ − θ|/θ over the frames whose true θ lies in
/// [`THETA_ACCURACY_RANGE_DEG`] gives a median and a 90th percentile; the summary is the median
/// over episodes of each (so every episode weighs the same, and a report rebuilt from
/// `episodes.csv` gives the same numbers).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ThetaAccuracy {
    /// Median over episodes of the per-episode median relative error.
    pub median_rel_err: f64,
    /// Median over episodes of the per-episode 90th-percentile relative error.
    pub p90_rel_err: f64,
    /// Median over episodes of the true θ (degrees) when θ̂ first reaches 5° (`None`: never).
    pub theta_at_first_estimate_deg: Option<f64>,
    /// Threat episodes measured.
    pub episodes: u64,
}

/// The `q`-quantile (0..=1) of `values` by linear interpolation (`None` when empty).
pub fn quantile(values: &[f64], q: f64) -> Option<f64> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let pos = q.clamp(0.0, 1.0) * (v.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    Some(v[lo] + (v[hi] - v[lo]) * (pos - lo as f64))
}

impl ThetaAccuracy {
    /// The per-episode numbers from per-frame `(θ̂, θ)` pairs in degrees: (median relative
    /// error, 90th percentile, true θ at the first θ̂ ≥ 5°).
    pub fn episode(pairs: &[(f64, f64)]) -> (Option<f64>, Option<f64>, Option<f64>) {
        let (lo, hi) = THETA_ACCURACY_RANGE_DEG;
        let errors: Vec<f64> = pairs
            .iter()
            .filter(|(est, theta)| est.is_finite() && (lo..=hi).contains(theta))
            .map(|(est, theta)| (est - theta).abs() / theta)
            .collect();
        let onset = pairs
            .iter()
            .find(|(est, _)| *est >= THETA_ESTIMATE_ONSET_DEG)
            .map(|(_, theta)| *theta)
            .filter(|t| t.is_finite());
        (quantile(&errors, 0.5), quantile(&errors, 0.9), onset)
    }

    /// The summary over one detector's episodes (`None` when none was measured).
    pub fn from_episodes(episodes: &[&DetectorEpisode]) -> Option<Self> {
        let measured: Vec<&&DetectorEpisode> = episodes.iter().filter(|e| e.theta_rel_err_median.is_some()).collect();
        if measured.is_empty() {
            return None;
        }
        let med: Vec<f64> = measured.iter().filter_map(|e| e.theta_rel_err_median).collect();
        let p90: Vec<f64> = measured.iter().filter_map(|e| e.theta_rel_err_p90).collect();
        let onset: Vec<f64> = measured.iter().filter_map(|e| e.theta_at_first_estimate_deg).collect();
        Some(Self {
            median_rel_err: quantile(&med, 0.5)?,
            p90_rel_err: quantile(&p90, 0.5)?,
            theta_at_first_estimate_deg: quantile(&onset, 0.5),
            episodes: measured.len() as u64,
        })
    }
}

/// Per-detector summaries over all episodes, keyed by detector id.
pub fn summarize_by_detector(episodes: &[EpisodeOutcome]) -> BTreeMap<String, DetectorSummary> {
    let mut by_detector: BTreeMap<&str, Vec<&DetectorEpisode>> = BTreeMap::new();
    for e in episodes {
        for d in &e.detectors {
            by_detector.entry(&d.detector).or_default().push(d);
        }
    }
    let mut summaries: BTreeMap<String, DetectorSummary> = by_detector
        .into_iter()
        .map(|(k, v)| (k.to_string(), DetectorSummary::from_episodes(v)))
        .collect();
    let null_collisions = summaries.get(crate::reference::NULL).map(|s| s.collisions);
    if let Some(null) = null_collisions.filter(|&c| c > 0) {
        for s in summaries.values_mut() {
            s.collision_reduction = Some(1.0 - s.collisions as f64 / null as f64);
        }
    }
    summaries
}

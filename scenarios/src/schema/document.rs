//! The typed sections of a scenario file: `[episode]`, `[robot]`, `[[detectors]]`, `[scoring]`.

use loomlab_agents::{Course, EscapeConfig, TriggerSignal, VelocityCommand};
#[cfg(doc)]
use loomlab_detector::{Registration, Registry};
use loomlab_sim::WorldDesc;
use serde::{Deserialize, Serialize};
use toml::Table;

use crate::metrics::ScoringConfig;

fn d_duration() -> f64 {
    3.0
}
fn d_repeats() -> u32 {
    1
}

/// `[episode]`: length, seed and repetitions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EpisodeDesc {
    /// Simulated time per episode in seconds (default 3). The open-loop pass stops earlier at the
    /// first contact, a closed-loop pass at its first contact.
    #[serde(default = "d_duration")]
    pub duration_s: f64,
    /// Seed of the random ranges and of the episodes' simulator seeds (default 0).
    #[serde(default)]
    pub seed: u64,
    /// Episodes per parameter point, each with its own simulator seed (default 1).
    #[serde(default = "d_repeats")]
    pub repeats: u32,
}

impl Default for EpisodeDesc {
    fn default() -> Self {
        Self {
            duration_s: d_duration(),
            seed: 0,
            repeats: d_repeats(),
        }
    }
}

/// One change of the cruise command in `[[robot.schedule]]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CruiseChange {
    /// From this time on (s) the robot cruises with the command below.
    pub at_s: f64,
    /// Forward speed (m/s; default 0).
    #[serde(default)]
    pub forward_mps: f64,
    /// Yaw rate (rad/s, positive = left; default 0).
    #[serde(default)]
    pub yaw_rate_rps: f64,
    /// Lateral speed (m/s, positive = left; default 0).
    #[serde(default)]
    pub lateral_mps: f64,
}

/// `[robot]`: the cruise command, what the robot does when nothing threatens it (the open-loop
/// pass follows it for the whole episode; the escape controller passes it through when armed).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CruiseDesc {
    /// Forward speed (m/s; default 0: standing still).
    #[serde(default)]
    pub forward_mps: f64,
    /// Yaw rate (rad/s, positive = left; default 0).
    #[serde(default)]
    pub yaw_rate_rps: f64,
    /// Lateral speed (m/s, positive = left; default 0).
    #[serde(default)]
    pub lateral_mps: f64,
    /// Later changes of the cruise command, in increasing `at_s` (default none).
    #[serde(default)]
    pub schedule: Vec<CruiseChange>,
}

impl CruiseDesc {
    /// The cruise command in effect at time `t_s`.
    pub fn command_at(&self, t_s: f64) -> VelocityCommand {
        let mut c = VelocityCommand {
            forward_mps: self.forward_mps,
            yaw_rate_rps: self.yaw_rate_rps,
            lateral_mps: self.lateral_mps,
        };
        for s in &self.schedule {
            if s.at_s <= t_s + 1e-9 {
                c = VelocityCommand {
                    forward_mps: s.forward_mps,
                    yaw_rate_rps: s.yaw_rate_rps,
                    lateral_mps: s.lateral_mps,
                };
            }
        }
        c
    }

    /// Checks every value; with dynamic physics also that no command exceeds the drive's limits
    /// (`limits`: `world.robot`), which the physics would silently clamp it to.
    pub(super) fn validate(&self, limits: Option<&loomlab_sim::RobotDesc>) -> Result<(), (String, String)> {
        let base = [
            ("robot.forward_mps", self.forward_mps),
            ("robot.yaw_rate_rps", self.yaw_rate_rps),
            ("robot.lateral_mps", self.lateral_mps),
        ];
        for (k, v) in base {
            if !v.is_finite() {
                return Err((k.into(), format!("{v} must be finite")));
            }
        }
        let mut last = f64::NEG_INFINITY;
        for (i, s) in self.schedule.iter().enumerate() {
            for (k, v) in [
                ("at_s", s.at_s),
                ("forward_mps", s.forward_mps),
                ("yaw_rate_rps", s.yaw_rate_rps),
                ("lateral_mps", s.lateral_mps),
            ] {
                if !v.is_finite() {
                    return Err((format!("robot.schedule[{i}].{k}"), format!("{v} must be finite")));
                }
            }
            if s.at_s < 0.0 || s.at_s < last {
                return Err((
                    format!("robot.schedule[{i}].at_s"),
                    format!("{} must be >= 0 and not before the previous change", s.at_s),
                ));
            }
            last = s.at_s;
        }
        let Some(robot) = limits else { return Ok(()) };
        let commands = [(
            String::from("robot"),
            self.forward_mps,
            self.yaw_rate_rps,
            self.lateral_mps,
        )]
        .into_iter()
        .chain(self.schedule.iter().enumerate().map(|(i, s)| {
            (
                format!("robot.schedule[{i}]"),
                s.forward_mps,
                s.yaw_rate_rps,
                s.lateral_mps,
            )
        }));
        for (key, forward, yaw, lateral) in commands {
            if let Some((name, value, limit_key, limit)) = robot.exceeded_limit(forward, yaw, lateral) {
                return Err((
                    format!("{key}.{name}"),
                    format!(
                        "{value} exceeds world.robot.{limit_key} ({limit}), the drive's limit: the physics would \
                         run the robot at {limit} instead; lower it or raise world.robot.{limit_key}"
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// One `[[detectors]]` entry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DetectorDesc {
    /// Detector id: one of the registry's ([`Registry`]: `hopfield`, `soc`, `keil2004`,
    /// `cizek2019`, `fu2020`, …).
    pub id: String,
    /// Name in reports and CSV (default: the id). Lets one scenario run a detector twice, e.g.
    /// `hopfield` at two thresholds.
    #[serde(default)]
    pub label: Option<String>,
    /// Alarm threshold (default: the detector's [`Registration::default_threshold`]).
    #[serde(default)]
    pub threshold: Option<f64>,
    /// Which signal is compared with the threshold (default: the detector's
    /// [`Registration::default_trigger`], `angular_size_deg` for hopfield, `output` for the
    /// baselines; `tau` for the time-to-contact strategy, which needs θ̂).
    #[serde(default)]
    pub trigger: Option<TriggerSignal>,
    /// `trigger = "tau"`: alarm when the estimated time to contact is at most this (s; default
    /// `DecisionRule::default().tau_threshold_s`). Replaces `threshold` for τ rows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tau_threshold_s: Option<f64>,
    /// `trigger = "tau"`: the smallest θ̂ (degrees) for an alarm (default
    /// `DecisionRule::default().min_angular_size_deg`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_angular_size_deg: Option<f64>,
    /// The collision-course gate: `"off"` (default) or `"image"` (needs θ̂).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub course: Option<Course>,
    /// Persistence: an alarm needs the decision value at or above the threshold on this many
    /// consecutive frames (1–10 000; default 1: at once; `DecisionRule::persistence_frames`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub persistence_frames: Option<usize>,
    /// Persistence window: an alarm needs the decision value at or above the threshold on any
    /// `persistence_frames` of the last this many frames (`persistence_frames`–10 000; default
    /// `persistence_frames`: consecutive frames; `DecisionRule::persistence_window_frames`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub persistence_window_frames: Option<usize>,
    /// Detector parameters: keys of the detector's config type (its
    /// [`loomlab_detector::DetectorConfig`], e.g. `HopfieldConfig` except `n`, `fov_deg` and
    /// `frame_rate_hz`, which come from `world.camera`, or `SocConfig`).
    #[serde(default)]
    pub params: Option<Table>,
}

impl DetectorDesc {
    /// The entry `id = "<id>"` with every other key left out (the registry's defaults).
    pub fn of_id(id: &str) -> Self {
        Self {
            id: id.to_string(),
            label: None,
            threshold: None,
            trigger: None,
            tau_threshold_s: None,
            min_angular_size_deg: None,
            course: None,
            persistence_frames: None,
            persistence_window_frames: None,
            params: None,
        }
    }
}

/// `[scoring]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScoringDesc {
    /// Extra margin (s): a threat's alarm must come at least this long before its escape deadline
    /// to be a hit (default: `ScoringConfig::default().lead_margin_s`, 0).
    #[serde(default = "d_margin")]
    pub lead_margin_s: f64,
    /// Removed (replaced by the escape deadline); rejected with a message naming the replacement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lead_min_s: Option<f64>,
}

fn d_margin() -> f64 {
    ScoringConfig::default().lead_margin_s
}

impl Default for ScoringDesc {
    fn default() -> Self {
        Self {
            lead_margin_s: d_margin(),
            lead_min_s: None,
        }
    }
}

/// The typed form of one expanded scenario tree.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ScenarioDoc {
    #[serde(default)]
    #[allow(dead_code)] // read from the tree before typing
    pub(super) name: Option<String>,
    #[serde(default)]
    pub(super) description: String,
    #[serde(default)]
    pub(super) episode: EpisodeDesc,
    pub(super) world: WorldDesc,
    #[serde(default)]
    pub(super) robot: CruiseDesc,
    #[serde(default)]
    pub(super) detectors: Option<Vec<DetectorDesc>>,
    #[serde(default)]
    pub(super) controller: EscapeConfig,
    #[serde(default)]
    pub(super) scoring: ScoringDesc,
}

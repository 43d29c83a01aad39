//! Options of the step-by-step environment: what the agent observes, how its actions map to
//! commands, the reward and the time limit. Deserialisable (the Python bindings pass them as JSON),
//! unknown keys are errors.

use std::collections::BTreeMap;

use loomlab_agents::ActionConfig;
use serde::{Deserialize, Serialize};

use super::{EnvError, ObsMode, RewardConfig};

/// Largest frame size the environment accepts.
pub const MAX_FRAME_SIZE: u32 = 1024;

/// Largest action scale ([`ActionConfig`]'s speeds in m/s and yaw rate in rad/s) the options
/// accept: larger values are typos (a robot's drive manages a few m/s). Scales above the
/// scenario robot's limits (`world.robot.max_speed_mps`, `max_yaw_rate_rps`) are accepted and
/// clamped to them when the environment is built.
pub const MAX_ACTION_SCALE: f64 = 100.0;

/// Largest [`EnvOptions::action_repeat`].
pub const MAX_ACTION_REPEAT: u32 = 120;

/// The agent's action space.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ActionKind {
    /// `[forward, yaw_rate, lateral]` in [-1, 1], scaled by [`ActionConfig`]'s maxima to an absolute
    /// velocity command ([`loomlab_agents::ContinuousAction`]).
    #[default]
    Continuous,
    /// 0 none (cruise), 1 dodge left, 2 dodge right, 3 stop ([`loomlab_agents::DiscreteAction`]).
    Discrete,
    /// The escape controller's manoeuvres ([`MANOEUVRE_ACTIONS`]): 0 cruise, 1 sidestep left,
    /// 2 sidestep right, 3 stop, 4 reverse, 5 the planner's choice; each the command the scenario's
    /// controller gives for it ([`loomlab_agents::EscapeConfig::command`], the first row's
    /// `[controller]` keys: `dodge_speed_mps`, `reverse_speed_mps`, a differential drive's turn).
    Manoeuvre,
}

/// The actions of [`ActionKind::Manoeuvre`], in index order (Gymnasium `Discrete(6)`).
pub const MANOEUVRE_ACTIONS: [&str; 6] = ["cruise", "sidestep_left", "sidestep_right", "stop", "reverse", "plan"];

/// Which seeds an environment's resets draw (module docs of the crate, "Seed streams").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SeedStream {
    /// Training episodes: every drawn seed (the simulator's and the scenario expansion's) has its
    /// top bit clear.
    Train,
    /// Held-out evaluation episodes: every drawn seed has its top bit set, so no evaluation
    /// episode is ever a training one.
    Eval,
}

impl SeedStream {
    /// A drawn seed moved into this stream's half of the seeds.
    pub fn tag(self, seed: u64) -> u64 {
        match self {
            SeedStream::Train => seed & !(1 << 63),
            SeedStream::Eval => seed | (1 << 63),
        }
    }
}

impl ActionKind {
    /// `"continuous"` or `"discrete"`.
    pub fn as_str(self) -> &'static str {
        match self {
            ActionKind::Continuous => "continuous",
            ActionKind::Discrete => "discrete",
            ActionKind::Manoeuvre => "manoeuvre",
        }
    }
}

/// Everything about an environment that is not in the scenario file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EnvOptions {
    /// Detector ids to run and observe (`None`: the scenario's detectors). Order is kept.
    pub detectors: Option<Vec<String>>,
    /// Alarm thresholds by detector id, overriding the scenario's (θ̂ in degrees for `hopfield`, the
    /// output for the baselines; for a row with `trigger = "tau"` the urgency 1/τ in s⁻¹, i.e.
    /// `1 / tau_threshold_s`). A row's strategy (`trigger`, `tau_threshold_s`,
    /// `min_angular_size_deg`, `course`) comes from the scenario's `[[detectors]]` entry.
    pub thresholds: BTreeMap<String, f64>,
    /// Frame size n (`None`: the scenario's camera size).
    pub frame_size: Option<u32>,
    /// Whether the observation includes the egocentric frame (n × n, 8 bit).
    pub observe_frames: bool,
    /// Raw signals or normalized features ([`crate::features`]).
    pub obs_mode: ObsMode,
    /// Continuous or discrete actions.
    pub action_kind: ActionKind,
    /// Scales of the action mappings (each at most [`MAX_ACTION_SCALE`]; clamped to the scenario
    /// robot's drive limits when the environment is built: [`EscapeEnv::options`](crate::EscapeEnv::options)
    /// reports the scales in use).
    pub action: ActionConfig,
    /// Clamp continuous actions into [-1, 1] instead of rejecting them (NaN/∞ are always errors).
    pub clip_actions: bool,
    /// Reward weights.
    pub reward: RewardConfig,
    /// Truncate episodes after this many camera periods (`None`: only the scenario's duration
    /// ends them).
    pub max_episode_steps: Option<u64>,
    /// Camera periods each action is held for (default 1: one decision per frame). One
    /// [`EscapeEnv::step`](crate::EscapeEnv::step) then renders and steps the detectors on every
    /// one of these frames (the detectors see every frame) and returns the last observation and
    /// the summed reward: a decision rate below the camera rate, which shortens the credit
    /// assignment from a decision to its outcome by this factor.
    pub action_repeat: u32,
    /// Discrete actions only: a dodge or stop is held for this long in one step (s; rounded to
    /// whole camera periods, at least `action_repeat` of them; default 0: `action_repeat` periods
    /// like every action). A dodge is then one decision with one outcome, as the escape
    /// controller's manoeuvre is (`[controller] duration_s`), instead of several decisions that
    /// must all choose it: random exploration rarely holds a dodge long enough to evade.
    pub dodge_hold_s: f64,
    /// The sensor profile every episode runs under (`ideal`, `robot`: blur, noise, quantisation and
    /// the perception and actuation latencies, `loomlab_sim::SensorProfile`); `None`: the scenario
    /// file's own sensor keys.
    pub sensor: Option<String>,
    /// Suites only: keep the scenarios of these difficulty tiers (0 to 3, the files' `tier` key,
    /// as `loomlab run --tier`); `None`: every scenario.
    pub tiers: Option<Vec<u8>>,
    /// The seed stream resets draw from: `train` or `eval` (disjoint halves of the seeds: see
    /// [`SeedStream`]); `None` (the default): untagged seeds, as before streams existed (either half).
    pub seed_stream: Option<SeedStream>,
}

impl Default for EnvOptions {
    fn default() -> Self {
        Self {
            detectors: None,
            thresholds: BTreeMap::new(),
            frame_size: None,
            observe_frames: false,
            obs_mode: ObsMode::Raw,
            action_kind: ActionKind::Continuous,
            action: ActionConfig::default(),
            clip_actions: false,
            reward: RewardConfig::default(),
            max_episode_steps: None,
            action_repeat: 1,
            dodge_hold_s: 0.0,
            sensor: None,
            tiers: None,
            seed_stream: None,
        }
    }
}

impl EnvOptions {
    /// Parses options from JSON. Errors name the key path (`reward.effort_per_s`), the value
    /// found there and what is expected; unknown keys are errors. JSON has no NaN or infinity, so
    /// text holding them is rejected as a whole (the Python side names the option first).
    pub fn from_json(text: &str) -> Result<Self, EnvError> {
        let value: serde_json::Value = serde_json::from_str(text).map_err(|e| {
            EnvError::option(
                "(options)",
                "(not JSON)",
                format!(
                    "the options must be a JSON object of finite numbers, strings, booleans, lists and objects ({e})"
                ),
            )
        })?;
        serde_path_to_error::deserialize(&value).map_err(|e| {
            let shown = value_at(&value, e.path()).map_or_else(|| "(missing)".to_string(), |v| v.to_string());
            EnvError::option(e.path().to_string(), shown, e.into_inner().to_string())
        })
    }

    /// Checks every value.
    pub fn validate(&self) -> Result<(), EnvError> {
        if let Some(name) = &self.sensor {
            loomlab_sim::SensorProfile::named(name).map_err(|reason| EnvError::option("sensor", name, reason))?;
        }
        if let Some(n) = self.frame_size
            && !(loomlab_sim::MIN_FRAME_SIZE..=MAX_FRAME_SIZE).contains(&n)
        {
            return Err(EnvError::option(
                "frame_size",
                n,
                format!(
                    "must be in {}..={MAX_FRAME_SIZE} pixels (the detectors need at least {0}; 64 is fast for RL)",
                    loomlab_sim::MIN_FRAME_SIZE
                ),
            ));
        }
        if let Some(d) = &self.detectors
            && d.is_empty()
        {
            return Err(EnvError::option(
                "detectors",
                "[]",
                format!(
                    "choose at least one detector ({})",
                    loomlab_detector::detector_ids().join(", ")
                ),
            ));
        }
        for (id, t) in &self.thresholds {
            if !t.is_finite() {
                return Err(EnvError::option(format!("thresholds.{id}"), t, "must be finite"));
            }
        }
        if !(1..=MAX_ACTION_REPEAT).contains(&self.action_repeat) {
            return Err(EnvError::option(
                "action_repeat",
                self.action_repeat,
                format!(
                    "must be in 1..={MAX_ACTION_REPEAT} camera periods (1: one decision per frame; 8: 15 Hz at 120 Hz)"
                ),
            ));
        }
        if !(self.dodge_hold_s.is_finite() && (0.0..=10.0).contains(&self.dodge_hold_s)) {
            return Err(EnvError::option(
                "dodge_hold_s",
                self.dodge_hold_s,
                "must be in 0..=10 seconds (0: a dodge is held for action_repeat periods like every action; 0.6: the default escape manoeuvre)",
            ));
        }
        if let Some(tiers) = &self.tiers {
            if tiers.is_empty() {
                return Err(EnvError::option(
                    "tiers",
                    "[]",
                    "name at least one tier (0 to 3), or leave tiers out",
                ));
            }
            if let Some(t) = tiers.iter().find(|&&t| t > loomlab_scenarios::tier::MAX_TIER) {
                return Err(EnvError::option(
                    "tiers",
                    t,
                    format!("tiers run from 0 to {}", loomlab_scenarios::tier::MAX_TIER),
                ));
            }
        }
        if self.max_episode_steps == Some(0) {
            return Err(EnvError::option("max_episode_steps", 0, "must be >= 1"));
        }
        self.action.validate()?;
        for (key, v) in [
            ("action.dodge_speed_mps", self.action.dodge_speed_mps),
            ("action.max_forward_mps", self.action.max_forward_mps),
            ("action.max_yaw_rate_rps", self.action.max_yaw_rate_rps),
            ("action.max_lateral_mps", self.action.max_lateral_mps),
        ] {
            if v > MAX_ACTION_SCALE {
                return Err(EnvError::option(
                    key,
                    v,
                    format!(
                        "must be at most {MAX_ACTION_SCALE} (m/s or rad/s); scales above the robot's drive limits \
                         (world.robot.max_speed_mps, max_yaw_rate_rps) are clamped to them, so give the speed \
                         you mean, e.g. 2"
                    ),
                ));
            }
        }
        self.reward.validate()
    }
}

/// The JSON value at a deserialisation error's path (`None` where the path leads nowhere).
fn value_at<'a>(root: &'a serde_json::Value, path: &serde_path_to_error::Path) -> Option<&'a serde_json::Value> {
    use serde_path_to_error::Segment;
    path.iter().try_fold(root, |v, seg| match seg {
        Segment::Seq { index } => v.get(index),
        Segment::Map { key } | Segment::Enum { variant: key } => v.get(key),
        Segment::Unknown => None,
    })
}

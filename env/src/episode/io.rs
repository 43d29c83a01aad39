//! The environment's inputs and outputs: actions, observations, step results, episode summaries and snapshots.

use loomlab_agents::DiscreteAction;
use loomlab_scenarios::metrics::DetectorEpisode;
use serde::{Deserialize, Serialize};

use crate::RewardTerms;
// the docs link to them
#[cfg(doc)]
use super::EscapeEnv;
#[cfg(doc)]
use crate::features::ObsMode;
#[cfg(doc)]
use crate::{ActionKind, EnvOptions};

/// Number of entries of [`Observation::robot`].
pub const ROBOT_DIM: usize = 7;

/// Detector signals are clamped into ±this (observation spaces need finite bounds; no detector
/// output comes near it: the Hopfield z is at most (N+1)² ≈ 3.8·10⁵ at n = 1024).
pub const SIGNAL_LIMIT: f32 = 1e6;

/// The robot observation entries are clamped into ±this (metres, m/s, rad/s, seconds).
pub const ROBOT_LIMIT: f32 = 1e5;

/// Names of the entries of [`Observation::robot`], in order.
pub const ROBOT_FIELDS: [&str; ROBOT_DIM] = [
    "x_m",
    "y_m",
    "yaw_rad",
    "forward_mps",
    "yaw_rate_rps",
    "lateral_mps",
    "t_s",
];

/// An action of an external agent.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Action {
    /// Normalised `[forward, yaw_rate, lateral]` (see [`ActionKind::Continuous`]).
    Continuous([f32; 3]),
    /// Discrete action index (see [`ActionKind::Discrete`]).
    Discrete(i64),
}

impl Action {
    pub(super) fn kind_name(&self) -> &'static str {
        match self {
            Action::Continuous(_) => "continuous",
            Action::Discrete(_) => "discrete",
        }
    }
}

/// What the agent observes after a reset or a step.
///
/// The detectors see their first frame in the first step, exactly as in the scenario runner's
/// open-loop pass, so the observation at reset holds the frame at t = 0 but zero signals and no
/// alarm. Non-finite detector values are reported as 0 and values are clamped into
/// ±[`SIGNAL_LIMIT`] (observations must be finite numbers within finite bounds).
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// Per detector (in [`EscapeEnv::detector_labels`] order): `[output, aux…]`, names in
    /// [`EscapeEnv::signal_names`].
    pub signals: Vec<Vec<f32>>,
    /// The angular-size estimate θ̂ in degrees of the first detector that gives one (`hopfield`),
    /// 0 when none of the chosen detectors does.
    pub theta_hat_deg: f32,
    /// Per detector: whether its trigger signal is at or above its alarm threshold on this frame.
    pub alarm: Vec<bool>,
    /// The robot: [`ROBOT_FIELDS`] — pose relative to its start pose (x ahead, y left, yaw), the
    /// command applied during the last step (m/s, rad/s) and the episode time.
    pub robot: [f32; ROBOT_DIM],
    /// The egocentric frame, n·n grey levels row-major (row 0 at the top), if observed.
    pub frame: Option<Vec<u8>>,
    /// With [`EnvOptions::observe_frames`] and an event camera ([`EscapeEnv::event_camera`]): the
    /// period's ON then OFF event counts per pixel (2·n·n, each n·n row-major); zeros on the reset
    /// frame.
    pub events: Option<Vec<u16>>,
    /// The feature vector ([`crate::features`]), when [`EnvOptions::obs_mode`] is
    /// [`ObsMode::Normalized`] or [`ObsMode::Privileged`].
    pub features: Option<Vec<f32>>,
}

/// The label of the agent's own row in [`EpisodeSummary::agent`].
pub const AGENT_LABEL: &str = "agent";

/// The scored outcome of an episode (reported with its last step).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EpisodeSummary {
    /// Whether the episode had a threat (open-loop ground truth).
    pub threat: bool,
    /// Open-loop contact time of the threat (s).
    pub t_contact_s: Option<f64>,
    /// Whether the robot was touched.
    pub collision: bool,
    /// A threat that did not touch the robot.
    pub evaded: bool,
    /// Steps taken.
    pub steps: u64,
    /// Sum of the rewards.
    pub episode_return: f64,
    /// Per detector: the scoring of its alarms (hit / miss / false alarm / correct rejection).
    pub detectors: Vec<DetectorEpisode>,
    /// The agent scored as a detector row (label [`AGENT_LABEL`]): its "alarm" is the first
    /// observation on which it departed from the cruise command (the time of the observation the
    /// departing action was chosen on), classified against the same escape deadline as the
    /// detectors; `collision` is the agent's closed-loop outcome.
    pub agent: DetectorEpisode,
}

/// Ground truth and bookkeeping of one step (Gymnasium's `info`).
#[derive(Debug, Clone, PartialEq)]
pub struct StepInfo {
    /// Episode time (s).
    pub t_s: f64,
    /// Steps taken since the reset.
    pub step: u64,
    /// Whether the episode has a threat: an object that touches the robot if it keeps cruising.
    pub threat: bool,
    /// Open-loop contact time of the threat (s).
    pub t_contact_s: Option<f64>,
    /// True time to contact of the reference object under the current command (`None`: not on a
    /// collision course). The reference object is the threat, else the moving object (projectile
    /// or vehicle; any object if there is none) that comes closest in the open-loop pass, as in the
    /// scenario runner.
    pub ttc_s: Option<f64>,
    /// True angular size of the reference object (degrees).
    pub angular_size_deg: Option<f64>,
    /// Whether the robot has been touched.
    pub collision: bool,
    /// Index of the scenario episode (sweep point × draw × repeat) this episode runs.
    pub episode: usize,
    /// Whether the last command deviated from the cruise command.
    pub dodging: bool,
    /// What the scenario's escape controller would command now (threshold baseline), as a
    /// continuous action (normalised, clamped into [-1, 1]).
    pub controller_continuous: [f32; 3],
    /// The same as a discrete action.
    pub controller_discrete: DiscreteAction,
    /// The same as a manoeuvre action index ([`crate::MANOEUVRE_ACTIONS`]: 0 cruise, 1 and 2 a
    /// dodge to the left or right, 3 stop, 4 reverse; the plan's choice is one of these).
    pub controller_manoeuvre: usize,
    /// The terms of the last reward (summed over the camera periods of a repeated action).
    pub reward_terms: RewardTerms,
    /// The scored outcome, on the step that ends the episode (terminated or truncated).
    pub outcome: Option<EpisodeSummary>,
}

/// The result of [`EscapeEnv::step`] (Gymnasium's `(obs, reward, terminated, truncated, info)`).
#[derive(Debug, Clone, PartialEq)]
pub struct StepResult {
    /// The observation after the step.
    pub obs: Observation,
    /// The reward of the step ([`RewardTerms::total`]; summed over the camera periods of a
    /// repeated action, [`EnvOptions::action_repeat`]).
    pub reward: f64,
    /// The episode ended: collision, or the scenario's duration is over.
    pub terminated: bool,
    /// The episode was cut by [`EnvOptions::max_episode_steps`].
    pub truncated: bool,
    /// Ground truth and bookkeeping.
    pub info: StepInfo,
}

/// How the current episode was chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EpisodeStart {
    /// Drawn from the seed stream, whose state before the draws is given.
    Drawn {
        /// Seed-stream state before the episode's draws.
        rng_state: u64,
    },
    /// A given scenario episode and simulator seed ([`EscapeEnv::reset_to_episode`]).
    Fixed {
        /// Scenario episode index.
        index: usize,
        /// Simulator seed.
        seed: u64,
    },
}

/// The state needed to reproduce an episode exactly (pickling in Python): how it started and the
/// actions taken since.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EpisodeSnapshot {
    /// State of the seed stream now (restored after the replay).
    pub rng_state: u64,
    /// How the current episode started; `None` before the first reset.
    pub start: Option<EpisodeStart>,
    /// Actions since the start.
    pub actions: Vec<Action>,
}

//! [`EscapeEnv`]: one closed-loop episode stepped by an external agent.

use std::sync::Arc;

use loomlab_agents::{
    ContinuousAction, DiscreteAction, Ego, EscapeAgent, EscapeConfig, EscapeController, Strategy, TriggerSignal,
    VelocityCommand,
};
use loomlab_detector::{DetectorParams, Frame};
use loomlab_sim::{GpuContext, RobotState, Sim, StepOutput};
use serde::{Deserialize, Serialize};

use super::features::{FeatureSpec, Normalizer, ObsMode, PrivilegedPercept, mode_feature_specs};
use super::reward::StepFacts;
use super::{
    ActionKind, EnvError, EnvOptions, EnvScenario, EpisodeRng, RewardTerms, ScenarioEpisodes, shared_gpu_context,
};
use loomlab_scenarios::metrics::{DetectorEpisode, GroundTruth, TIME_EPS_S, TraceSample, score_detector_episode};
use loomlab_scenarios::reference::INDICATOR_THRESHOLD;
use loomlab_scenarios::schema::{DetectorSpec, EpisodeSpec};
use loomlab_scenarios::truth::{open_loop_truth, threat_deadline};

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
    fn kind_name(&self) -> &'static str {
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

/// What the environment keeps per detector (the detector itself lives in the [`EscapeAgent`]).
struct DetectorSlot {
    label: String,
    id: String,
    params: DetectorParams,
    trigger: TriggerSignal,
    threshold: f64,
    /// The row's escape-controller configuration (its decision strategy), threshold included.
    controller: EscapeConfig,
    /// The row's decision strategy, stepped on its θ̂ and the looming side (stateful rows only).
    strategy: Option<Strategy>,
    trace: Vec<TraceSample>,
}

/// The controller configuration of detector `d` at alarm threshold `threshold` (for a τ row, the
/// urgency 1/τ in s⁻¹), and its stateful strategy if it has one.
fn slot_controller(d: &DetectorSpec, base: &EscapeConfig, threshold: f64) -> (EscapeConfig, Option<Strategy>) {
    let d = DetectorSpec { threshold, ..d.clone() };
    let config = d.controller(base);
    let strategy = d.is_strategy().then(|| config.strategy());
    (config, strategy)
}

struct Running {
    sim: Sim,
    spec: EpisodeSpec,
    start_kind: EpisodeStart,
    frames: u64,
    actions: Vec<Action>,
    /// Open-loop contact time of the threat (s); `None`: no threat.
    t_contact_s: Option<f64>,
    /// Escape deadline of the threat (s); `None`: no threat, or unavoidable.
    t_deadline_s: Option<f64>,
    reference: Option<usize>,
    start: RobotState,
    last_robot: RobotState,
    steps: u64,
    collision: bool,
    done: bool,
    episode_return: f64,
    last_command: VelocityCommand,
    /// The cruise command during the last step.
    last_cruise: VelocityCommand,
    /// Whether a step of this episode earned the timely-dodge bonus.
    timely_paid: bool,
    /// The agent's departures from cruising, one sample per step at the time of the observation
    /// the action was chosen on (signal 1: departed, 0: cruised).
    agent_trace: Vec<TraceSample>,
    /// The last observation's time and reference-object truth (for the next agent sample).
    last_t_s: f64,
    last_ttc_s: Option<f64>,
    last_angular_size_deg: Option<f64>,
}

/// One closed-loop episode at a time, stepped by an external agent: the environment of the Python
/// `loomlab.EscapeEnv` (which wraps the native class of the same name, `loomlab._native.EscapeEnv`),
/// usable from Rust as it is.
///
/// The scenario is expanded once ([`loomlab_scenarios::schema`]: sweeps × random draws × repeats; scenarios with
/// a `[random]` table are re-expanded with a fresh seed at every reset). Each
/// [`reset`](Self::reset) draws one of its episodes and a simulator seed from the seed stream, runs
/// the open-loop pass in physics-only mode for the ground truth (see the module docs), and renders
/// the first frame. Each [`step`](Self::step) applies the agent's command for one camera period,
/// renders, steps the detectors and returns observation, reward, termination and ground truth; the
/// last step scores the episode with [`loomlab_scenarios::metrics`]. Same seed and actions ⇒ same results (on
/// the same GPU adapter).
pub struct EscapeEnv {
    scenario: EnvScenario,
    options: EnvOptions,
    base: ScenarioEpisodes,
    resample: bool,
    n: u32,
    ctx: Arc<GpuContext>,
    detectors: Vec<DetectorSlot>,
    signal_names: Vec<Vec<String>>,
    /// Detectors, looming side and the shadow escape controller (driven by the first detector).
    agent: EscapeAgent,
    normalizer: Normalizer,
    privileged: PrivilegedPercept,
    rng: EpisodeRng,
    running: Option<Running>,
}

impl std::fmt::Debug for EscapeEnv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EscapeEnv")
            .field("scenario", &self.base.name)
            .field("n", &self.n)
            .field("detectors", &self.detector_labels())
            .finish()
    }
}

/// The result of two consecutive periods of one [`EscapeEnv::step`]: the second's observation and
/// info, the summed reward terms.
pub(crate) fn combine_steps(r: StepResult, next: StepResult) -> StepResult {
    let terms = r.info.reward_terms.plus(&next.info.reward_terms);
    StepResult {
        reward: terms.total(),
        info: StepInfo {
            reward_terms: terms,
            ..next.info
        },
        ..next
    }
}

/// A detector value for the observation: finite, clamped into ±[`SIGNAL_LIMIT`] (non-finite: 0).
fn finite_or_zero(v: f64) -> f32 {
    if v.is_finite() {
        (v as f32).clamp(-SIGNAL_LIMIT, SIGNAL_LIMIT)
    } else {
        0.0
    }
}

fn wrap_angle(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

/// 8-bit grey level of a luminance in [0, 1] (the simulator's rounding).
fn to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

fn deviation(a: VelocityCommand, b: VelocityCommand) -> [f64; 3] {
    [
        a.forward_mps - b.forward_mps,
        a.yaw_rate_rps - b.yaw_rate_rps,
        a.lateral_mps - b.lateral_mps,
    ]
}

impl EscapeEnv {
    /// Builds the environment: expands the scenario, validates the options, builds the detectors and
    /// finds a GPU adapter (shared by every environment of the process).
    pub fn new(scenario: EnvScenario, options: EnvOptions) -> Result<Self, EnvError> {
        Self::with_context(scenario, options, shared_gpu_context()?)
    }

    /// Like [`new`](Self::new) on a given GPU context.
    pub fn with_context(scenario: EnvScenario, options: EnvOptions, ctx: Arc<GpuContext>) -> Result<Self, EnvError> {
        options.validate()?;
        let base = scenario.load(&options, 0)?;
        Self::build(scenario, base, options, ctx)
    }

    /// An environment over a fixed list of expanded episodes (e.g. a suite's, as `loomlab run`
    /// expands it, for [`reset_to_episode`](Self::reset_to_episode)); `source` names them in errors
    /// and as the scenario. [`reset`](Self::reset) draws among them (no random re-expansion). The
    /// episodes must run the same detectors at the same frame size; the options' `detectors` and
    /// `frame_size` are not applied (the episodes were expanded with them).
    pub fn for_episodes(
        source: &std::path::Path,
        episodes: ScenarioEpisodes,
        options: EnvOptions,
        ctx: Arc<GpuContext>,
    ) -> Result<Self, EnvError> {
        options.validate()?;
        episodes.check(source)?;
        Self::build(EnvScenario::from_toml(String::new(), source), episodes, options, ctx)
    }

    fn build(
        scenario: EnvScenario,
        base: ScenarioEpisodes,
        options: EnvOptions,
        ctx: Arc<GpuContext>,
    ) -> Result<Self, EnvError> {
        let first = &base.episodes[0];
        let n = first.world.camera.n;
        for key in options.thresholds.keys() {
            if !first.detectors.iter().any(|d| &d.label == key) {
                return Err(EnvError::option(
                    format!("thresholds.{key}"),
                    options.thresholds[key],
                    format!(
                        "`{key}` is not one of the chosen detectors {:?}",
                        first.detectors.iter().map(|d| d.label.as_str()).collect::<Vec<_>>()
                    ),
                ));
            }
        }
        let mut detectors = Vec::new();
        let mut built = Vec::new();
        let mut signal_names = Vec::new();
        for spec in &first.detectors {
            let mut detector = spec.build(n as usize)?;
            // learn the auxiliary signal names (fixed per detector) from one blank frame
            let probe = detector.step(&Frame::uniform(n as usize, 0.5))?;
            detector.reset();
            let mut names = vec!["output".to_string()];
            names.extend(probe.aux.iter().map(|(k, _)| (*k).to_string()));
            signal_names.push(names);
            built.push(detector);
            let threshold = options.thresholds.get(&spec.label).copied().unwrap_or(spec.threshold);
            let (controller, strategy) = slot_controller(spec, &first.controller, threshold);
            detectors.push(DetectorSlot {
                label: spec.label.clone(),
                id: spec.id.clone(),
                params: spec.params.clone(),
                trigger: spec.trigger,
                threshold,
                controller,
                strategy,
                trace: Vec::new(),
            });
        }
        let agent = EscapeAgent::new(built, detectors[0].controller.clone())?;
        Ok(Self {
            resample: scenario.has_random_ranges(),
            n,
            ctx,
            detectors,
            signal_names,
            agent,
            normalizer: Normalizer::default(),
            privileged: PrivilegedPercept::default(),
            rng: EpisodeRng::from_entropy(),
            running: None,
            scenario,
            options,
            base,
        })
    }

    /// The scenario file.
    pub fn scenario(&self) -> &EnvScenario {
        &self.scenario
    }

    /// The scenario's name.
    pub fn scenario_name(&self) -> &str {
        &self.base.name
    }

    /// The scenario's expanded episodes (with the file's seed; see [`reset_to_episode`](Self::reset_to_episode)).
    pub fn episodes(&self) -> &[EpisodeSpec] {
        &self.base.episodes
    }

    /// The options.
    pub fn options(&self) -> &EnvOptions {
        &self.options
    }

    /// Frame size n.
    pub fn frame_size(&self) -> u32 {
        self.n
    }

    /// Camera period of the current episode (s; of the scenario's first episode before a reset).
    pub fn dt(&self) -> f64 {
        let world = match &self.running {
            Some(r) => &r.spec.world,
            None => &self.base.episodes[0].world,
        };
        world.dt()
    }

    /// Steps of the current episode when it runs its full duration (of the first episode before a
    /// reset).
    pub fn duration_steps(&self) -> u64 {
        match &self.running {
            Some(r) => r.frames,
            None => self.base.episodes[0].frames() as u64,
        }
    }

    /// The chosen detectors' labels (the detector id unless the scenario gave a label), in
    /// observation order.
    pub fn detector_labels(&self) -> Vec<&str> {
        self.detectors.iter().map(|d| d.label.as_str()).collect()
    }

    /// The chosen detectors' ids, in observation order.
    pub fn detector_ids(&self) -> Vec<&str> {
        self.detectors.iter().map(|d| d.id.as_str()).collect()
    }

    /// Names of each detector's signal vector (`output` then its auxiliary signals).
    pub fn signal_names(&self) -> &[Vec<String>] {
        &self.signal_names
    }

    /// Names and declared bounds of the features of the observation mode ([`crate::features`]; the
    /// normalized mode's for the raw mode), in order.
    pub fn feature_specs(&self) -> Vec<FeatureSpec> {
        mode_feature_specs(self.options.obs_mode, &self.detector_labels())
    }

    /// The alarm thresholds of the current episode, in detector order.
    pub fn thresholds(&self) -> Vec<f64> {
        self.detectors.iter().map(|d| d.threshold).collect()
    }

    /// The adapter that renders the frames.
    pub fn adapter(&self) -> String {
        self.ctx.describe()
    }

    /// The latest frame as 8-bit grey levels (n·n; empty before the first reset).
    pub fn frame_u8(&self) -> Vec<u8> {
        self.running.as_ref().map(|r| r.sim.frame_u8()).unwrap_or_default()
    }

    /// Whether an episode is running (reset and not ended).
    pub fn is_running(&self) -> bool {
        self.running.as_ref().is_some_and(|r| !r.done)
    }

    /// The command the robot follows now when nothing threatens it.
    pub fn cruise(&self) -> VelocityCommand {
        match &self.running {
            Some(r) => r.spec.cruise.command_at(r.sim.time()),
            None => self.base.episodes[0].cruise.command_at(0.0),
        }
    }

    /// Starts a new episode drawn from the seed stream. `Some(seed)` restarts the stream
    /// (reproducible); `None` continues it (a fresh environment's stream is seeded from OS entropy).
    pub fn reset(&mut self, seed: Option<u64>) -> Result<(Observation, StepInfo), EnvError> {
        if let Some(s) = seed {
            self.rng = EpisodeRng::new(s);
        }
        let rng_state = self.rng.state();
        let sim_seed = self.rng.next_u64();
        let draw = self.rng.next_u64();
        let spec = if self.resample {
            // a fresh expansion of the random ranges (a nonzero seed mixed into the file's)
            let sc = self.scenario.load(&self.options, draw | 1)?;
            let i = (self.rng.next_u64() % sc.episodes.len() as u64) as usize;
            sc.episodes[i].clone()
        } else {
            self.base.episodes[(draw % self.base.episodes.len() as u64) as usize].clone()
        };
        self.start(spec, sim_seed, EpisodeStart::Drawn { rng_state })
    }

    /// Starts scenario episode `index` (of [`episodes`](Self::episodes)) with simulator seed `seed`
    /// (`None`: the episode's own seed, as `loomlab run` uses it). The seed stream is untouched.
    pub fn reset_to_episode(&mut self, index: usize, seed: Option<u64>) -> Result<(Observation, StepInfo), EnvError> {
        let spec = self.base.episodes.get(index).cloned().ok_or_else(|| {
            EnvError::option(
                "episode",
                index,
                format!("the scenario has {} episodes", self.base.episodes.len()),
            )
        })?;
        let seed = seed.unwrap_or(spec.seed);
        self.start(spec, seed, EpisodeStart::Fixed { index, seed })
    }

    fn start(
        &mut self,
        spec: EpisodeSpec,
        sim_seed: u64,
        start_kind: EpisodeStart,
    ) -> Result<(Observation, StepInfo), EnvError> {
        let frames = spec.frames() as u64;
        let truth = open_loop_truth(&spec, sim_seed)?;
        let sim = match self.running.take() {
            Some(mut r) => {
                r.sim.reset(&spec.world, sim_seed)?;
                r.sim
            }
            None => Sim::with_context(&spec.world, sim_seed, Arc::clone(&self.ctx))?,
        };
        let mut sim = sim;
        let escape = EscapeController::new(spec.controller.clone())?;
        let t_deadline_s = threat_deadline(&spec, sim_seed, &truth, &escape, &mut sim)?.and_then(|d| d.t_s);
        for (i, (slot, d)) in self.detectors.iter_mut().zip(&spec.detectors).enumerate() {
            if slot.params != d.params {
                self.agent.replace_detector(i, d.build(self.n as usize)?);
                slot.params = d.params.clone();
            }
            slot.trace.clear();
            slot.trigger = d.trigger;
            slot.threshold = self.options.thresholds.get(&d.label).copied().unwrap_or(d.threshold);
            (slot.controller, slot.strategy) = slot_controller(d, &spec.controller, slot.threshold);
        }
        self.agent.set_controller(self.detectors[0].controller.clone())?;
        self.agent.reset();
        let first = sim.observe()?;
        let start = first.robot;
        let cruise = spec.cruise.command_at(0.0);
        self.running = Some(Running {
            sim,
            spec,
            start_kind,
            frames,
            actions: Vec::new(),
            t_contact_s: truth.t_contact_s(),
            t_deadline_s,
            reference: truth.reference,
            start,
            last_robot: start,
            steps: 0,
            collision: false,
            done: false,
            episode_return: 0.0,
            last_command: cruise,
            last_cruise: cruise,
            timely_paid: false,
            agent_trace: Vec::new(),
            last_t_s: 0.0,
            last_ttc_s: None,
            last_angular_size_deg: None,
        });
        self.normalizer.reset(self.detectors.len());
        self.privileged.reset();
        self.process(&first, false, RewardTerms::default())
    }

    /// Applies an agent action for [`EnvOptions::action_repeat`] camera periods (a discrete dodge
    /// or stop for [`EnvOptions::dodge_hold_s`] when set; fewer when the episode ends first): the
    /// detectors see every frame, the result holds the last observation and info, the summed
    /// reward and reward terms.
    pub fn step(&mut self, action: Action) -> Result<StepResult, EnvError> {
        let command = self.command_for(action)?;
        let mut r = self.step_command(command)?;
        if let Some(run) = self.running.as_mut() {
            run.actions.push(action);
        }
        for _ in 1..self.hold_for(action) {
            if r.terminated || r.truncated {
                break;
            }
            // the discrete actions follow the cruise command of each period
            let next = self.step_command(self.command_for(action)?)?;
            r = combine_steps(r, next);
        }
        Ok(r)
    }

    /// Camera periods one [`step`](Self::step) with `action` lasts (fewer when the episode ends).
    pub(crate) fn hold_for(&self, action: Action) -> u32 {
        match action {
            Action::Discrete(i) if i != 0 && self.options.dodge_hold_s > 0.0 => {
                let dt = self.dt();
                ((self.options.dodge_hold_s / dt).round() as u32).max(self.options.action_repeat)
            }
            _ => self.options.action_repeat,
        }
    }

    /// Records `action` as the one the last [`step`](Self::step) was given (for
    /// [`snapshot`](Self::snapshot)): what the vector environment's batched step does after the
    /// first period.
    pub(crate) fn record_action(&mut self, action: Action) {
        if let Some(run) = self.running.as_mut() {
            run.actions.push(action);
        }
    }

    /// The velocity command an action maps to now (validating it).
    pub fn command_for(&self, action: Action) -> Result<VelocityCommand, EnvError> {
        let cfg = &self.options.action;
        match (self.options.action_kind, action) {
            (ActionKind::Continuous, Action::Continuous(a)) => {
                let a = ContinuousAction(a);
                Ok(if self.options.clip_actions {
                    a.to_command_clamped(cfg)?
                } else {
                    a.to_command(cfg)?
                })
            }
            (ActionKind::Discrete, Action::Discrete(i)) => {
                Ok(DiscreteAction::from_index(i)?.to_command(self.cruise(), cfg))
            }
            (kind, a) => Err(EnvError::ActionKind {
                expected: kind.as_str(),
                got: a.kind_name(),
            }),
        }
    }

    /// Applies a velocity command for one camera period (the Rust-side interface; only actions
    /// given to [`step`](Self::step) are recorded for [`snapshot`](Self::snapshot)).
    pub fn step_command(&mut self, command: VelocityCommand) -> Result<StepResult, EnvError> {
        let cruise = self.begin_command(command)?;
        let r = self.running.as_mut().expect("begin_command checked the episode");
        let out = r.sim.step(&command.to_sim())?;
        self.finish_command(command, cruise, out)
    }

    /// The simulator of the running episode (the vector environment steps them in one batch
    /// between [`Self::begin_command`] and [`Self::finish_command`]).
    pub(crate) fn sim_mut(&mut self) -> Option<&mut Sim> {
        self.running.as_mut().map(|r| &mut r.sim)
    }

    /// [`step_command`](Self::step_command) up to the simulator step: checks the command and the
    /// episode's state, records the agent sample; returns the cruise command of the period.
    pub(crate) fn begin_command(&mut self, command: VelocityCommand) -> Result<VelocityCommand, EnvError> {
        if !command.is_finite() {
            return Err(EnvError::option(
                "command",
                format!("{command:?}"),
                "velocity commands must be finite",
            ));
        }
        let r = match self.running.as_mut() {
            None => return Err(EnvError::State("step() called before reset(); call reset() first")),
            Some(r) if r.done => {
                return Err(EnvError::State(
                    "step() called after the episode ended (terminated or truncated); call reset()",
                ));
            }
            Some(r) => r,
        };
        let cruise = r.spec.cruise.command_at(r.sim.time());
        let departed = deviation(command, cruise)
            .iter()
            .any(|d| d.abs() > super::reward::DODGE_TOLERANCE);
        r.agent_trace.push(TraceSample {
            t_s: r.last_t_s,
            signal: if departed { INDICATOR_THRESHOLD } else { 0.0 },
            ttc_s: r.last_ttc_s,
            angular_size_deg: r.last_angular_size_deg,
        });
        Ok(cruise)
    }

    /// [`step_command`](Self::step_command) after the simulator step `out`: reward, termination,
    /// the detectors and the observation.
    pub(crate) fn finish_command(
        &mut self,
        command: VelocityCommand,
        cruise: VelocityCommand,
        out: StepOutput,
    ) -> Result<StepResult, EnvError> {
        let max_steps = self.options.max_episode_steps;
        let Some(r) = self.running.as_mut() else {
            return Err(EnvError::State("step() called before reset(); call reset() first"));
        };
        let dt = r.spec.world.dt();
        r.steps += 1;
        r.last_command = command;
        r.last_cruise = cruise;
        let collision = !r.collision && out.first_collision().is_some();
        r.collision |= collision;
        let (s0, c0) = r.start.yaw_rad.sin_cos();
        let progress_m = (out.robot.x_m - r.last_robot.x_m) * c0 + (out.robot.y_m - r.last_robot.y_m) * s0;
        r.last_robot = out.robot;
        let first_dodge = !r.agent_trace[..r.agent_trace.len() - 1]
            .iter()
            .any(|s| s.signal >= INDICATOR_THRESHOLD);
        let window_s = self.options.reward.timely_dodge_window_s;
        let in_window = r.t_contact_s.is_some()
            && r.t_deadline_s.is_some_and(|td| {
                let end = td - r.spec.scoring.lead_margin_s + TIME_EPS_S;
                r.last_t_s <= end && r.last_t_s >= end - window_s - 2.0 * TIME_EPS_S
            });
        let facts = StepFacts {
            dt,
            collision,
            progress_m,
            deviation: deviation(command, cruise),
            threat: r.t_contact_s.is_some(),
            first_dodge,
            in_window,
            bonus_unpaid: !r.timely_paid,
        };
        let terms = self.options.reward.terms(&facts);
        r.timely_paid |= terms.timely_dodge > 0.0;
        r.episode_return += terms.total();
        let terminated = r.collision || r.steps >= r.frames;
        let truncated = !terminated && max_steps.is_some_and(|m| r.steps >= m);
        r.done = terminated || truncated;
        let done = r.done;
        let (obs, info) = self.process(&out, done, terms)?;
        Ok(StepResult {
            obs,
            reward: terms.total(),
            terminated,
            truncated,
            info,
        })
    }

    /// Steps the detectors (not on the reset frame), the shadow controller and the bookkeeping.
    fn process(
        &mut self,
        out: &StepOutput,
        done: bool,
        terms: RewardTerms,
    ) -> Result<(Observation, StepInfo), EnvError> {
        let n = self.n as usize;
        let r = self.running.as_ref().expect("process() runs inside an episode");
        let reference = r.reference.and_then(|id| out.truth.get(id));
        let ttc_s = reference.and_then(|t| t.ttc_s).map(f64::from);
        let angular_size_deg = reference.map(|t| f64::from(t.angular_size_deg));
        let cruise_now = r.spec.cruise.command_at(out.t_s);
        // the camera's pose as the robot's odometry and inertial sensor know it (the detectors'
        // efference copy, as in the scenario runner)
        let camera_pose = r.sim.camera_pose();
        let nd = self.detectors.len();
        let mut signals = Vec::with_capacity(nd);
        let mut alarm = Vec::with_capacity(nd);
        let mut theta_hat = None;
        let mut looming_side = None;
        let (controller_continuous, controller_discrete);
        if out.frame_index == 0 {
            // the reset frame: detectors see their first frame in the first step
            for names in &self.signal_names {
                signals.push(vec![0.0; names.len()]);
                alarm.push(false);
            }
            controller_continuous = self.normalised(cruise_now);
            controller_discrete = DiscreteAction::None;
        } else {
            let frame = Frame::from_f32(n, out.frame.clone())?;
            // the robot's own motion during the last period, as the agent's controller sees it
            let last = self.agent.controller().last_command().unwrap_or(cruise_now);
            let ego = Ego {
                yaw_rate_rps: last.yaw_rate_rps,
                forward_mps: last.forward_mps,
                ..Ego::default()
            };
            let step = self.agent.step_posed(out.t_s, &frame, cruise_now, Some(&camera_pose))?;
            for (d, s) in self.detectors.iter_mut().zip(&step.signals) {
                let raw = d.trigger.value(s).unwrap_or(f64::NAN);
                // a stateful row's value is its strategy's decision value, as the agent computes it
                let value = match &mut d.strategy {
                    Some(strategy) => {
                        let percept = d.controller.percept_of(raw, step.looming_side, s.region.as_ref());
                        strategy.update(out.t_s, percept, ego).value
                    }
                    None => raw,
                };
                alarm.push(value >= d.threshold);
                d.trace.push(TraceSample {
                    t_s: out.t_s,
                    signal: value,
                    ttc_s,
                    angular_size_deg: angular_size_deg.filter(|v| v.is_finite()),
                });
                if theta_hat.is_none() {
                    theta_hat = s.angular_size_deg;
                }
                let mut v = Vec::with_capacity(1 + s.aux.len());
                v.push(finite_or_zero(s.output));
                v.extend(s.aux.iter().map(|(_, x)| finite_or_zero(*x)));
                signals.push(v);
            }
            looming_side = step.looming_side;
            controller_continuous = self.normalised(step.command);
            controller_discrete = DiscreteAction::from_command(step.command, cruise_now);
        }
        let r = self.running.as_ref().expect("process() runs inside an episode");
        let (dx, dy) = (out.robot.x_m - r.start.x_m, out.robot.y_m - r.start.y_m);
        let (s0, c0) = r.start.yaw_rad.sin_cos();
        let cmd = r.last_command;
        let robot = [
            (dx * c0 + dy * s0) as f32,
            (-dx * s0 + dy * c0) as f32,
            wrap_angle(out.robot.yaw_rad - r.start.yaw_rad) as f32,
            cmd.forward_mps as f32,
            cmd.yaw_rate_rps as f32,
            cmd.lateral_mps as f32,
            out.t_s as f32,
        ]
        .map(|v| v.clamp(-ROBOT_LIMIT, ROBOT_LIMIT));
        let dodging = deviation(cmd, r.last_cruise)
            .iter()
            .any(|d| d.abs() > super::reward::DODGE_TOLERANCE);
        let obs = Observation {
            signals,
            theta_hat_deg: theta_hat.map(finite_or_zero).unwrap_or(0.0),
            alarm,
            robot,
            frame: self
                .options
                .observe_frames
                .then(|| out.frame.iter().map(|&v| to_u8(v)).collect()),
            features: None,
        };
        let obs = match self.options.obs_mode {
            ObsMode::Raw => obs,
            ObsMode::Privileged => {
                let dt = r.spec.world.dt();
                let duration_s = r.frames as f64 * dt;
                let features = self
                    .privileged
                    .features(&out.truth, &obs, dt, duration_s, &self.options.action, cmd);
                Observation {
                    features: Some(features),
                    ..obs
                }
            }
            ObsMode::Normalized => {
                let dt = r.spec.world.dt();
                let duration_s = r.frames as f64 * dt;
                let features = self
                    .normalizer
                    .features(&obs, looming_side, dt, duration_s, &self.options.action, cmd);
                Observation {
                    features: Some(features),
                    ..obs
                }
            }
        };
        let outcome = if done {
            let truth = GroundTruth {
                threat: r.t_contact_s.is_some(),
                t_contact_s: r.t_contact_s,
                t_deadline_s: r.t_deadline_s,
                collision: r.collision,
            };
            let mut scored = Vec::with_capacity(nd);
            for d in &self.detectors {
                scored.push(score_detector_episode(
                    &d.label,
                    d.threshold,
                    &d.trace,
                    &truth,
                    &r.spec.scoring,
                )?);
            }
            let agent = score_detector_episode(
                AGENT_LABEL,
                INDICATOR_THRESHOLD,
                &r.agent_trace,
                &truth,
                &r.spec.scoring,
            )?;
            Some(EpisodeSummary {
                threat: truth.threat,
                t_contact_s: truth.t_contact_s,
                collision: r.collision,
                evaded: truth.threat && !r.collision,
                steps: r.steps,
                episode_return: r.episode_return,
                detectors: scored,
                agent,
            })
        } else {
            None
        };
        let info = StepInfo {
            t_s: out.t_s,
            step: r.steps,
            threat: r.t_contact_s.is_some(),
            t_contact_s: r.t_contact_s,
            ttc_s,
            angular_size_deg,
            collision: r.collision,
            episode: r.spec.index,
            dodging,
            controller_continuous,
            controller_discrete,
            reward_terms: terms,
            outcome,
        };
        if let Some(r) = self.running.as_mut() {
            r.last_t_s = out.t_s;
            r.last_ttc_s = ttc_s;
            r.last_angular_size_deg = angular_size_deg.filter(|v| v.is_finite());
        }
        Ok((obs, info))
    }

    /// A command as a normalised continuous action (clamped into [-1, 1]).
    fn normalised(&self, c: VelocityCommand) -> [f32; 3] {
        ContinuousAction::from_command(c, &self.options.action).0
    }

    /// The state that reproduces the current episode: see [`EpisodeSnapshot`].
    pub fn snapshot(&self) -> EpisodeSnapshot {
        EpisodeSnapshot {
            rng_state: self.rng.state(),
            start: self.running.as_ref().map(|r| r.start_kind),
            actions: self.running.as_ref().map(|r| r.actions.clone()).unwrap_or_default(),
        }
    }

    /// Restores a snapshot by replaying it (the episode's start and the recorded actions); returns
    /// the last observation and info when an episode was running.
    pub fn restore(&mut self, snapshot: &EpisodeSnapshot) -> Result<Option<(Observation, StepInfo)>, EnvError> {
        self.running = None;
        let mut last = match snapshot.start {
            None => {
                self.rng = EpisodeRng::from_state(snapshot.rng_state);
                return Ok(None);
            }
            Some(EpisodeStart::Drawn { rng_state }) => {
                self.rng = EpisodeRng::from_state(rng_state);
                self.reset(None)?
            }
            Some(EpisodeStart::Fixed { index, seed }) => self.reset_to_episode(index, Some(seed))?,
        };
        for &a in &snapshot.actions {
            let s = self.step(a)?;
            last = (s.obs, s.info);
        }
        self.rng = EpisodeRng::from_state(snapshot.rng_state);
        Ok(Some(last))
    }
}

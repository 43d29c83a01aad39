//! The running episode's state, and the resets that start one (open-loop truth, detectors, first frame).

use std::sync::Arc;

use loomlab_agents::{DodgeOffset, EscapeAgent, VelocityCommand};
use loomlab_scenarios::metrics::TraceSample;
use loomlab_scenarios::schema::EpisodeSpec;
use loomlab_sim::{RobotState, Sim};

use super::prefetch::{DrawSource, OpenLoop, Prepared, open_loop};
use super::slots::{detector_instances, slot_controller};
use super::{Action, EpisodeStart, EscapeEnv, Observation, StepInfo};
use crate::{EnvError, EpisodeRng, RewardTerms};

pub(super) struct Running {
    pub(super) sim: Sim,
    pub(super) spec: EpisodeSpec,
    pub(super) start_kind: EpisodeStart,
    pub(super) frames: u64,
    pub(super) actions: Vec<Action>,
    /// Open-loop contact time of the threat (s); `None`: no threat.
    pub(super) t_contact_s: Option<f64>,
    /// Escape deadline of the threat (s); `None`: no threat, or unavoidable.
    pub(super) t_deadline_s: Option<f64>,
    pub(super) reference: Option<usize>,
    pub(super) start: RobotState,
    pub(super) last_robot: RobotState,
    pub(super) steps: u64,
    pub(super) collision: bool,
    pub(super) done: bool,
    pub(super) episode_return: f64,
    pub(super) last_command: VelocityCommand,
    /// The cruise command during the last step.
    pub(super) last_cruise: VelocityCommand,
    /// Whether a step of this episode earned the timely-dodge bonus.
    pub(super) timely_paid: bool,
    /// The agent's departures from cruising, one sample per step at the time of the observation
    /// the action was chosen on (signal 1: departed, 0: cruised).
    pub(super) agent_trace: Vec<TraceSample>,
    /// The last observation's time and reference-object truth (for the next agent sample).
    pub(super) last_t_s: f64,
    pub(super) last_ttc_s: Option<f64>,
    pub(super) last_angular_size_deg: Option<f64>,
    /// The looming side of the last observation (image x; what the manoeuvre actions dodge away
    /// from).
    pub(super) last_looming_side: Option<f32>,
    /// The simulator seed the episode runs with.
    pub(super) sim_seed: u64,
    /// How far the agent's commands have taken the robot's body off its cruising path: the
    /// lateral speeds commanded beyond the cruise's, through the drive's acceleration limit (what
    /// the robot knows of itself; the manoeuvre actions' sidesteps hold within
    /// `max_dodge_offset_m`).
    pub(super) dodge: DodgeOffset,
}

impl EscapeEnv {
    /// Starts a new episode drawn from the seed stream. `Some(seed)` restarts the stream
    /// (reproducible); `None` continues it (a fresh environment's stream is seeded from OS entropy).
    /// Meanwhile the next drawn episode is prepared on a background thread (its open-loop truth
    /// and escape deadline, most of a reset's cost), so that the next `reset(None)` finds it ready;
    /// the results are those of computing it then.
    pub fn reset(&mut self, seed: Option<u64>) -> Result<(Observation, StepInfo), EnvError> {
        if let Some(s) = seed {
            self.rng = EpisodeRng::new(s);
        }
        let rng_state = self.rng.state();
        let Prepared { drawn, open_loop } = match self.prefetcher.take(rng_state) {
            Some(p) => p,
            None => {
                let source = DrawSource::new(self.resample, &self.scenario, &self.options, &self.base);
                let drawn = source.draw(self.rng)?;
                let open_loop = self.open_loop_inline(&drawn.spec, drawn.sim_seed)?;
                Prepared { drawn, open_loop }
            }
        };
        self.rng = drawn.rng_after;
        let first = self.start(drawn.spec, drawn.sim_seed, open_loop, EpisodeStart::Drawn { rng_state })?;
        let source = DrawSource::new(self.resample, &self.scenario, &self.options, &self.base);
        self.prefetcher.start(source, self.rng, &self.ctx, self.n);
        Ok(first)
    }

    /// The open-loop truth and deadline computed now, the views rendered on the episode's
    /// renderer (a fresh environment's first reset, or a reset the background did not prepare).
    fn open_loop_inline(&mut self, spec: &EpisodeSpec, sim_seed: u64) -> Result<OpenLoop, EnvError> {
        let (mut renderer, own) = match self.running.as_mut().and_then(|r| r.sim.take_renderer()) {
            Some(r) => (r, true),
            None => (self.prefetcher.take_renderer(&self.ctx, self.n)?, false),
        };
        let result = open_loop(spec, sim_seed, &mut renderer);
        match self.running.as_mut() {
            Some(r) if own => {
                r.sim.attach_renderer(renderer)?;
            }
            _ => self.prefetcher.keep_renderer(renderer),
        }
        result
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
        let open_loop = self.open_loop_inline(&spec, seed)?;
        self.start(spec, seed, open_loop, EpisodeStart::Fixed { index, seed })
    }

    fn start(
        &mut self,
        spec: EpisodeSpec,
        sim_seed: u64,
        (truth, deadline): OpenLoop,
        start_kind: EpisodeStart,
    ) -> Result<(Observation, StepInfo), EnvError> {
        let frames = spec.frames() as u64;
        let mut sim = match self.running.take() {
            Some(mut r) => {
                r.sim.reset(&spec.world, sim_seed)?;
                r.sim
            }
            None => Sim::with_context(&spec.world, sim_seed, Arc::clone(&self.ctx))?,
        };
        let t_deadline_s = deadline.and_then(|d| d.t_s);
        // detectors of other parameters than the last episode's (a sweep of them): built afresh
        let (instances, owners) = detector_instances(&spec.detectors);
        let same_layout = self.detectors.iter().map(|s| s.instance).eq(instances.iter().copied());
        if !same_layout {
            let built = owners
                .iter()
                .map(|&row| spec.detectors[row].build(self.n as usize))
                .collect::<Result<Vec<_>, _>>()?;
            self.agent = EscapeAgent::new(built, self.agent.controller().config().clone(), spec.facts)?;
        } else {
            for (k, &row) in owners.iter().enumerate() {
                if self.detectors[row].params != spec.detectors[row].params {
                    self.agent
                        .replace_detector(k, spec.detectors[row].build(self.n as usize)?);
                }
            }
        }
        for ((slot, d), &instance) in self.detectors.iter_mut().zip(&spec.detectors).zip(&instances) {
            slot.params = d.params.clone();
            slot.instance = instance;
            slot.trace.clear();
            slot.trigger = d.trigger;
            slot.threshold = self.options.thresholds.get(&d.label).copied().unwrap_or(d.threshold);
            (slot.controller, slot.decider) = slot_controller(d, &spec.controller, &spec.facts, slot.threshold);
        }
        self.agent
            .set_controller(self.detectors[0].controller.clone(), spec.facts)?;
        self.agent.reset();
        let mut first = sim.observe()?;
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
            last_looming_side: None,
            sim_seed,
            dodge: DodgeOffset::default(),
        });
        self.normalizer.reset(self.detectors.len());
        self.privileged.reset();
        self.process(&mut first, false, RewardTerms::default())
    }
}

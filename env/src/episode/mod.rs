//! [`EscapeEnv`]: one closed-loop episode stepped by an external agent.

mod build;
mod io;
mod observe;
mod prefetch;
mod running;
mod slots;
mod snapshot;
mod step;

use std::sync::Arc;

use loomlab_agents::{EscapeAgent, VelocityCommand};
use loomlab_scenarios::schema::EpisodeSpec;
use loomlab_sim::GpuContext;

pub use io::{
    AGENT_LABEL, Action, EpisodeSnapshot, EpisodeStart, EpisodeSummary, Observation, ROBOT_DIM, ROBOT_FIELDS,
    ROBOT_LIMIT, SIGNAL_LIMIT, StepInfo, StepResult,
};
pub(crate) use step::combine_steps;

use crate::features::{FeatureSpec, Normalizer, PrivilegedPercept, mode_feature_specs};
use crate::{EnvOptions, EnvScenario, EpisodeRng, ScenarioEpisodes};
use prefetch::Prefetcher;
use running::Running;
use slots::DetectorSlot;

/// One closed-loop episode at a time, stepped by an external agent: the environment of the Python
/// `loomlab.EscapeEnv` (which wraps the native class of the same name, `loomlab._native.EscapeEnv`),
/// usable from Rust as it is.
///
/// The scenario is expanded once ([`loomlab_scenarios::schema`]: sweeps × random draws × repeats; scenarios with
/// a `[random]` table are re-expanded with a fresh seed at every reset). Each
/// [`reset`](Self::reset) draws one of its episodes and a simulator seed from the seed stream, runs
/// the open-loop pass in physics-only mode for the ground truth and the escape deadline (for a
/// reset that continues the stream, on a background thread while the previous episode ran), and
/// renders the first frame. Each [`step`](Self::step) applies the agent's command for one camera period,
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
    /// The next drawn episode, prepared in the background ([`prefetch`]).
    prefetcher: Prefetcher,
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

impl EscapeEnv {
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

    /// Whether the episodes have an event camera (`[world.camera] kind = "events"`, or the
    /// `events` sensor profile): then the observed frames come with the period's event counts
    /// ([`Observation::events`]) and the detectors get the events.
    pub fn event_camera(&self) -> bool {
        self.base
            .episodes
            .first()
            .is_some_and(|e| !e.world.camera.kind.is_frames())
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

    /// Resets so far that found their episode prepared in the background (see [`Self::reset`]).
    pub fn prefetched_resets(&self) -> u64 {
        self.prefetcher.hits
    }

    /// Ends the environment's background work: waits for the preparation of the next episode
    /// (`episode::prefetch`: a thread rendering on the GPU) and drops the running episode. Dropping the
    /// environment does the same; call it before the process exits when the environment itself
    /// lives on (a thread rendering on lavapipe while the process exits can crash it). The
    /// environment stays usable: the next reset computes its episode inline.
    pub fn close(&mut self) {
        self.prefetcher.join();
        self.running = None;
    }

    /// Background threads of this environment that are still running (0 after
    /// [`close`](Self::close)).
    pub fn background_threads(&self) -> usize {
        self.prefetcher.alive().load(std::sync::atomic::Ordering::SeqCst)
    }

    /// The live count of this environment's background threads, which outlives the environment
    /// (tests: dropping the environment joins them).
    #[cfg(test)]
    pub(crate) fn background_thread_count(&self) -> Arc<std::sync::atomic::AtomicUsize> {
        self.prefetcher.alive()
    }

    /// The adapter that renders the frames.
    pub fn adapter(&self) -> String {
        self.ctx.describe()
    }

    /// The latest frame as 8-bit grey levels (n·n; empty before the first reset).
    pub fn frame_u8(&self) -> Vec<u8> {
        self.running.as_ref().map(|r| r.sim.frame_u8()).unwrap_or_default()
    }

    /// The simulator seed of the current episode (`None` before the first reset): drawn from the
    /// seed stream, in the stream's half of the seeds when the options name one
    /// ([`crate::SeedStream`]).
    pub fn episode_seed(&self) -> Option<u64> {
        self.running.as_ref().map(|r| r.sim_seed)
    }

    /// The expanded episode being run (`None` before the first reset): its scenario, tier and
    /// parameters.
    pub fn episode_spec(&self) -> Option<&EpisodeSpec> {
        self.running.as_ref().map(|r| &r.spec)
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
}

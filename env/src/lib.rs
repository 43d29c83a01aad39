//! A step-by-step closed-loop episode API for external agents (the engine of the Python Gymnasium
//! environment `loomlab/Escape-v0`, usable from Rust as it is).
//!
//! - [`EscapeEnv`]: one environment. `reset(seed)` → [`Observation`], `step(action)` →
//!   [`StepResult`] `{ obs, reward, terminated, truncated, info }`.
//! - [`EscapeVectorEnv`]: N environments stepped on Rust threads (rayon) with next-step auto-reset.
//! - [`EnvScenario`]: a scenario file in the suite schema ([`loomlab_scenarios::schema`]: world, cruise command,
//!   detectors with thresholds, escape controller, episode length, sweeps and random ranges);
//!   [`EnvOptions`]: what an environment adds (chosen detectors, frame size, observed frame, action
//!   kind, reward, time limit).
//!
//! # Ground truth (as the scenario runner, [`loomlab_scenarios::runner`])
//! At every reset an **open-loop pass** ([`loomlab_scenarios::truth`]) runs the episode's world in
//! physics-only mode (no rendering) with the robot following its cruise command for the episode's
//! duration: the first object that touches the robot makes the episode a **threat**, with its exact
//! contact time `t_contact_s` (parry time of impact). The *reference object* is the touching one,
//! else the moving object that came closest. For a threat the reset also finds its **escape
//! deadline** ([`loomlab_scenarios::deadline`]; the open-loop frames up to the contact are
//! rendered once more for the looming sides), which decides hit or miss when the episode is
//! scored. Per step, `info` reports the reference object's true time to
//! contact (under the robot's current command) and true angular size. Detectors see their first
//! frame in the first step (the reset observation has the t = 0 frame but zero signals), so an
//! agent that always cruises gives the detectors exactly the runner's open-loop frames and its
//! traces. The step that ends the episode scores every detector's alarms over the frames seen with
//! [`loomlab_scenarios::metrics::score_detector_episode`] (hit / miss / unavoidable / false alarm /
//! correct rejection, with the *agent's* collision as the closed-loop outcome).
//!
//! # Episodes, termination, seeds
//! One step is one camera period. An episode is **terminated** when the robot is touched (any
//! object) or when the scenario's duration is over (the encounter has played out: the task ends,
//! and the observation carries the time); it is **truncated** when [`EnvOptions::max_episode_steps`]
//! cuts it earlier. `reset(Some(seed))` restarts the environment's seed stream (SplitMix64,
//! [`EpisodeRng`]); each reset draws a simulator seed and one of the scenario's expanded episodes
//! from it (scenarios with `[random]` ranges are re-expanded with a fresh seed each time), so a
//! seed and a sequence of actions reproduce an episode exactly (same frames on the same GPU
//! adapter). `reset(None)` continues the stream. [`EscapeEnv::reset_to_episode`] starts a given
//! scenario episode with its own seed, as `loomlab run` runs it.
//!
//! # Escape controller baseline
//! The scenario's escape controller runs in shadow mode on the first chosen detector (with that
//! detector's trigger and threshold, and the looming side from the frames):
//! `info.controller_continuous` / `controller_discrete` is what it would command now. Feeding it
//! back as the action gives the threshold baseline.

mod episode;
mod error;
pub mod features;
mod options;
mod reward;
mod scenario;
mod vector;

use std::sync::{Arc, OnceLock};

use loomlab_sim::GpuContext;

pub use episode::{
    AGENT_LABEL, Action, EpisodeSnapshot, EpisodeStart, EpisodeSummary, EscapeEnv, Observation, ROBOT_DIM,
    ROBOT_FIELDS, ROBOT_LIMIT, SIGNAL_LIMIT, StepInfo, StepResult,
};
pub use error::{EnvError, ErrorKind};
pub use features::{FeatureSpec, ObsMode, feature_specs, mode_feature_specs};
pub use options::{
    ActionKind, EnvOptions, MANOEUVRE_ACTIONS, MAX_ACTION_REPEAT, MAX_ACTION_SCALE, MAX_FRAME_SIZE, SeedStream,
};
pub use reward::{DODGE_TOLERANCE, RewardConfig, RewardTerms};
pub use scenario::{EnvScenario, ScenarioEpisodes};
pub use vector::{EscapeVectorEnv, MAX_NUM_ENVS, VectorSnapshot};

/// The process-wide GPU context shared by every environment (created on first use; the error,
/// e.g. no adapter, is remembered and reported again).
pub fn shared_gpu_context() -> Result<Arc<GpuContext>, EnvError> {
    static CTX: OnceLock<Result<Arc<GpuContext>, String>> = OnceLock::new();
    match CTX.get_or_init(|| GpuContext::new().map_err(|e| e.to_string())) {
        Ok(ctx) => Ok(Arc::clone(ctx)),
        Err(e) => Err(EnvError::Sim(loomlab_sim::SimError::NoAdapter { detail: e.clone() })),
    }
}

/// A second process-wide GPU context on the same adapter, for the environments' background work
/// (preparing the next episode: `episode::prefetch`), so that its rendering does not queue ahead of
/// the environments' own frames (a device renders its submissions in order; lavapipe on one
/// thread per device). `None` when it cannot be created: the background then uses
/// [`shared_gpu_context`]. Views rendered on either are identical (same adapter and driver).
pub(crate) fn background_gpu_context() -> Option<Arc<GpuContext>> {
    static CTX: OnceLock<Option<Arc<GpuContext>>> = OnceLock::new();
    CTX.get_or_init(|| GpuContext::new().ok()).clone()
}

/// The seed stream of an environment: SplitMix64 (Steele et al. 2014), whose whole state is one
/// `u64`, so it is trivially saved and restored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EpisodeRng(u64);

impl EpisodeRng {
    /// A stream started from `seed`.
    pub fn new(seed: u64) -> Self {
        // mix the seed once so that consecutive seeds start far apart
        let mut r = EpisodeRng(seed ^ 0x6C6F_6F6D_6C61_6221);
        r.next_u64();
        r
    }

    /// A stream seeded from the operating system's randomness (via std's hash keys).
    pub fn from_entropy() -> Self {
        use std::hash::{BuildHasher, Hasher};
        let mut h = std::collections::hash_map::RandomState::new().build_hasher();
        h.write_u64(0x6C6F_6F6D);
        EpisodeRng::new(h.finish())
    }

    /// Resumes a stream from [`state`](Self::state).
    pub fn from_state(state: u64) -> Self {
        EpisodeRng(state)
    }

    /// The whole state.
    pub fn state(&self) -> u64 {
        self.0
    }

    /// The next value.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod tests_rl;

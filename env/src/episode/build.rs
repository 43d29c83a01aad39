//! Building an environment: options, scenario expansion and the detector slots.

use std::sync::Arc;

use loomlab_agents::{ActionConfig, EscapeAgent};
use loomlab_detector::Frame;
use loomlab_sim::GpuContext;

use super::EscapeEnv;
use super::slots::{DetectorSlot, detector_instances, slot_controller};
use crate::features::{Normalizer, PrivilegedPercept};
use crate::{EnvError, EnvOptions, EnvScenario, EpisodeRng, ScenarioEpisodes, shared_gpu_context};

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
        mut options: EnvOptions,
        ctx: Arc<GpuContext>,
    ) -> Result<Self, EnvError> {
        clamp_to_robot(&mut options.action, &base);
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
        let (instances, owners) = detector_instances(&first.detectors);
        let mut built = Vec::with_capacity(owners.len());
        let mut instance_names = Vec::with_capacity(owners.len());
        for &row in &owners {
            let mut detector = first.detectors[row].build(n as usize)?;
            // learn the auxiliary signal names (fixed per detector) from one blank frame
            let probe = detector.step(&Frame::uniform(n as usize, 0.5))?;
            detector.reset();
            let mut names = vec!["output".to_string()];
            names.extend(probe.aux.iter().map(|(k, _)| (*k).to_string()));
            instance_names.push(names);
            built.push(detector);
        }
        let mut detectors = Vec::new();
        let mut signal_names = Vec::new();
        for (spec, &instance) in first.detectors.iter().zip(&instances) {
            signal_names.push(instance_names[instance].clone());
            let threshold = options.thresholds.get(&spec.label).copied().unwrap_or(spec.threshold);
            let (controller, decider) = slot_controller(spec, &first.controller, &first.facts, threshold);
            detectors.push(DetectorSlot {
                label: spec.label.clone(),
                id: spec.id.clone(),
                params: spec.params.clone(),
                trigger: spec.trigger,
                threshold,
                controller,
                decider,
                trace: Vec::new(),
                instance,
            });
        }
        let agent = EscapeAgent::new(built, detectors[0].controller.clone(), first.facts)?;
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
            prefetcher: Default::default(),
            scenario,
            options,
            base,
        })
    }
}

/// Clamps the action scales to the drive limits of the episodes' robot (the smallest over the
/// episodes): a continuous ±1 commands at most `world.robot.max_speed_mps` forward and sideways
/// and `max_yaw_rate_rps` of yaw, and a discrete dodge at most `max_speed_mps` sideways. The
/// physics would clamp a faster command anyway (the default `max_forward_mps` 3 m/s drove at
/// 2 m/s while the observation said 3); clamped here, the command the observation reports is the
/// one the robot follows.
fn clamp_to_robot(action: &mut ActionConfig, base: &ScenarioEpisodes) {
    let robots = base.episodes.iter().map(|e| &e.world.robot);
    let speed = robots
        .clone()
        .map(|r| f64::from(r.max_speed_mps))
        .fold(f64::INFINITY, f64::min);
    let yaw = robots
        .map(|r| f64::from(r.max_yaw_rate_rps))
        .fold(f64::INFINITY, f64::min);
    action.max_forward_mps = action.max_forward_mps.min(speed);
    action.max_lateral_mps = action.max_lateral_mps.min(speed);
    action.dodge_speed_mps = action.dodge_speed_mps.min(speed);
    action.max_yaw_rate_rps = action.max_yaw_rate_rps.min(yaw);
}

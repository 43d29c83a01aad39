//! [`EscapeVectorEnv`]: N environments stepped in lockstep, their N views rendered in batches
//! (one submission and one readback per group: `loomlab_sim::Sim::step_submit` and
//! `step_collect`), everything else (the detectors, rewards, resets) in parallel on Rust threads,
//! a group's detectors while the device renders the next group.

use loomlab_sim::{Renderer, Sim};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::episode::combine_steps;
use super::{Action, EnvError, EnvOptions, EnvScenario, EpisodeSnapshot, EscapeEnv, Observation, StepInfo, StepResult};
use loomlab_agents::VelocityCommand;

/// The state that reproduces a vector environment exactly (pickling in Python): each
/// environment's [`EpisodeSnapshot`] and which of them reset on their next step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VectorSnapshot {
    /// Per-environment snapshots, in order.
    pub envs: Vec<EpisodeSnapshot>,
    /// Whether each environment's episode ended in the last step (so its next step resets it).
    pub autoreset: Vec<bool>,
}

/// N [`EscapeEnv`]s stepped in parallel (rayon), with Gymnasium's **next-step** auto-reset:
/// after an environment's episode ends (terminated or truncated), its next `step` ignores the action,
/// resets it (continuing its seed stream) and returns the first observation with reward 0 and
/// `terminated = truncated = false`. So the results equal those of N single environments driven
/// the same way (Gymnasium's `SyncVectorEnv` in its default mode), frames included: each camera
/// period renders the running environments' views in one batch, and a view's pixels do not
/// depend on the batch. The engine of the Python `loomlab.EscapeVectorEnv` (through the native
/// class of the same name).
#[derive(Debug)]
pub struct EscapeVectorEnv {
    envs: Vec<EscapeEnv>,
    autoreset: Vec<bool>,
    /// Renders the environments' views of one period in one batch.
    renderer: Renderer,
    batched: bool,
}

/// Most environments one [`EscapeVectorEnv`] holds. Each has its own simulator, episode state and
/// background thread: 400 took 2.1 GB and 17 s to reset on a 2-core machine, and 100 000 never
/// finished building. For more, run several vector environments in several processes (e.g. Ray
/// workers, `loomlab.rllib`).
pub const MAX_NUM_ENVS: usize = 256;

impl EscapeVectorEnv {
    /// Builds `num_envs` environments of the same scenario and options (sharing one GPU context);
    /// `num_envs` is in 1..=[`MAX_NUM_ENVS`].
    pub fn new(scenario: EnvScenario, options: EnvOptions, num_envs: usize) -> Result<Self, EnvError> {
        if !(1..=MAX_NUM_ENVS).contains(&num_envs) {
            return Err(EnvError::option(
                "num_envs",
                num_envs,
                format!(
                    "must be in 1..={MAX_NUM_ENVS}: each environment holds its own simulator and episode (400 take \
                     about 2 GB and 17 s to reset); use at most {MAX_NUM_ENVS}, and several processes (e.g. Ray \
                     workers) for more"
                ),
            ));
        }
        let ctx = super::shared_gpu_context()?;
        let envs = (0..num_envs)
            .map(|_| EscapeEnv::with_context(scenario.clone(), options.clone(), ctx.clone()))
            .collect::<Result<Vec<_>, _>>()?;
        let renderer = Renderer::with_context(ctx, envs[0].frame_size())?;
        Ok(Self {
            autoreset: vec![false; num_envs],
            envs,
            renderer,
            batched: true,
        })
    }

    /// Whether [`step`](Self::step) renders the environments' views in one batch per camera
    /// period (the default) or each environment renders its own, one submission per view (the
    /// path before batching, kept for comparison: `env/examples/vector_bench.rs`). The results are
    /// the same either way.
    pub fn set_batched(&mut self, batched: bool) {
        self.batched = batched;
    }

    /// Ends every environment's background work ([`EscapeEnv::close`]); dropping the vector
    /// environment does the same.
    pub fn close(&mut self) {
        self.envs.iter_mut().for_each(EscapeEnv::close);
    }

    /// Number of environments.
    pub fn num_envs(&self) -> usize {
        self.envs.len()
    }

    /// The environments (for their metadata: detector ids, signal names, frame size…).
    pub fn envs(&self) -> &[EscapeEnv] {
        &self.envs
    }

    /// The seeds `seed + i` of the environments, or [`EnvError::Seed`] when the last one would
    /// pass `u64::MAX` (seeds never wrap around: that would repeat environment 0's episodes).
    pub fn seeds(&self, seed: u64) -> Result<Vec<u64>, EnvError> {
        let n = self.envs.len() as u64;
        if seed.checked_add(n - 1).is_none() {
            return Err(EnvError::Seed {
                seed: seed.to_string(),
                reason: format!(
                    "environment i gets seed + i, so with {n} environments the seed must be <= {} (2^64 - {n})",
                    u64::MAX - (n - 1)
                ),
            });
        }
        Ok((0..n).map(|i| seed + i).collect())
    }

    /// Resets every environment; with `Some(seed)` environment i gets seed `seed + i` (Gymnasium's
    /// convention; [`EnvError::Seed`] if that passes `u64::MAX`), with `None` each continues its own
    /// seed stream. An environment's error names its index ([`EnvError::InEnv`]).
    pub fn reset(&mut self, seed: Option<u64>) -> Result<Vec<(Observation, StepInfo)>, EnvError> {
        let seeds = match seed {
            Some(s) => self.seeds(s)?.into_iter().map(Some).collect(),
            None => vec![None; self.envs.len()],
        };
        let out = self
            .envs
            .par_iter_mut()
            .zip(seeds)
            .enumerate()
            .map(|(i, (env, seed))| env.reset(seed).map_err(|e| e.in_env(i)))
            .collect::<Result<Vec<_>, _>>()?;
        self.autoreset.fill(false);
        Ok(out)
    }

    /// Steps every environment with its action (one per environment, validated before any
    /// environment moves, so a bad action changes nothing). An environment's error names its index
    /// ([`EnvError::InEnv`]).
    pub fn step(&mut self, actions: &[Action]) -> Result<Vec<StepResult>, EnvError> {
        if actions.len() != self.envs.len() {
            return Err(EnvError::ActionCount {
                expected: self.envs.len(),
                got: actions.len(),
            });
        }
        for (i, ((env, &a), &auto)) in self.envs.iter().zip(actions).zip(&self.autoreset).enumerate() {
            if !auto {
                env.command_for(a).map_err(|e| e.in_env(i))?;
            }
        }
        let results = if self.batched {
            self.step_batched(actions)?
        } else {
            self.envs
                .par_iter_mut()
                .zip(actions.par_iter())
                .zip(self.autoreset.par_iter())
                .enumerate()
                .map(|(i, ((env, &a), &auto))| {
                    if auto {
                        reset_result(env, i)
                    } else {
                        env.step(a).map_err(|e| e.in_env(i))
                    }
                })
                .collect::<Result<Vec<_>, EnvError>>()?
        };
        for (auto, r) in self.autoreset.iter_mut().zip(&results) {
            *auto = r.terminated || r.truncated;
        }
        Ok(results)
    }

    /// [`step`](Self::step) with the camera periods of all environments in lockstep: period p
    /// steps every environment whose step lasts more than p periods (action repeat, dodge hold)
    /// and whose episode has not ended, their views rendered in batches; the detectors and the
    /// rest of each period run in parallel, and so do the auto-resets (their environments take no
    /// period). Each environment goes through exactly the calls of [`EscapeEnv::step`].
    fn step_batched(&mut self, actions: &[Action]) -> Result<Vec<StepResult>, EnvError> {
        let n = self.envs.len();
        let mut results: Vec<Option<StepResult>> = (0..n).map(|_| None).collect();
        let holds: Vec<u32> = self.envs.iter().zip(actions).map(|(e, &a)| e.hold_for(a)).collect();
        let max_hold = holds.iter().copied().max().unwrap_or(1).max(1);
        for period in 0..max_hold {
            // who steps this period, and the commands (validated, bookkept) before anything moves
            let mut pending: Vec<Option<(VelocityCommand, VelocityCommand)>> = vec![None; n];
            for (i, env) in self.envs.iter_mut().enumerate() {
                // an environment that auto-resets this step takes no period
                let going = !self.autoreset[i]
                    && (period == 0
                        || (period < holds[i] && results[i].as_ref().is_some_and(|r| !r.terminated && !r.truncated)));
                if going {
                    let command = env.command_for(actions[i]).map_err(|e| e.in_env(i))?;
                    let cruise = env.begin_command(command).map_err(|e| e.in_env(i))?;
                    pending[i] = Some((command, cruise));
                }
            }
            let mut going: Vec<(usize, &mut EscapeEnv)> = Vec::new();
            let mut reset_envs: Vec<(usize, &mut EscapeEnv)> = Vec::new();
            for (i, env) in self.envs.iter_mut().enumerate() {
                if pending[i].is_some() {
                    going.push((i, env));
                } else if period == 0 && self.autoreset[i] {
                    reset_envs.push((i, env));
                }
            }
            if going.is_empty() && reset_envs.is_empty() {
                break;
            }
            let stepping: Vec<usize> = going.iter().map(|(i, _)| *i).collect();
            let resetting: Vec<usize> = reset_envs.iter().map(|(i, _)| *i).collect();
            let mut reset_slots: Vec<Option<Result<StepResult, EnvError>>> =
                (0..resetting.len()).map(|_| None).collect();
            let mut finished: Vec<Option<Result<StepResult, EnvError>>> = (0..stepping.len()).map(|_| None).collect();
            // In groups (`Sim::batch_group`): the device renders group g's views while this
            // thread steps group g + 1's physics, and group g's detectors run on the pool while
            // the device renders the groups after it. The auto-resets (of environments that take
            // no period) run on the pool meanwhile.
            let layers = going
                .iter_mut()
                .filter_map(|(_, env)| env.sim_mut().map(|s| s.layers_per_frame()))
                .max()
                .unwrap_or(1);
            let group = Sim::batch_group_of(stepping.len().max(1), layers, &self.renderer);
            let renderer = &mut self.renderer;
            let pending = &pending;
            rayon::in_place_scope(|scope| -> Result<(), EnvError> {
                for ((i, env), slot) in reset_envs.into_iter().zip(reset_slots.iter_mut()) {
                    scope.spawn(move |_| *slot = Some(reset_result(env, i)));
                }
                let mut submitted = Vec::with_capacity(going.len().div_ceil(group));
                for chunk in going.chunks_mut(group) {
                    let commands: Vec<loomlab_sim::Command> = chunk
                        .iter()
                        .filter_map(|(i, _)| pending[*i].map(|(c, _)| c.to_sim()))
                        .collect();
                    submitted.push(Sim::step_submit(&mut sims_of(chunk)?, &commands, renderer)?);
                }
                for ((chunk, steps), slots) in going.chunks_mut(group).zip(submitted).zip(finished.chunks_mut(group)) {
                    let outs = Sim::step_collect(&mut sims_of(chunk)?, renderer, steps)?;
                    scope.spawn(move |_| {
                        chunk
                            .par_iter_mut()
                            .zip(outs)
                            .zip(slots.par_iter_mut())
                            .for_each(|(((i, env), out), slot)| {
                                *slot = Some(match pending[*i] {
                                    Some((command, cruise)) => {
                                        env.finish_command(command, cruise, out).map_err(|e| e.in_env(*i))
                                    }
                                    None => Err(EnvError::State("an environment stepped without a command").in_env(*i)),
                                });
                            });
                    });
                }
                Ok(())
            })?;
            for (&i, reset) in resetting.iter().zip(reset_slots) {
                results[i] =
                    Some(reset.unwrap_or_else(|| Err(EnvError::State("an environment did not reset").in_env(i)))?);
            }
            for (&i, next) in stepping.iter().zip(finished) {
                let next = next.unwrap_or_else(|| Err(EnvError::State("an environment took no step").in_env(i)))?;
                results[i] = Some(match results[i].take() {
                    Some(r) if period > 0 => combine_steps(r, next),
                    _ => {
                        self.envs[i].record_action(actions[i]);
                        next
                    }
                });
            }
        }
        results
            .into_iter()
            .enumerate()
            .map(|(i, r)| r.ok_or_else(|| EnvError::State("an environment took no step").in_env(i)))
            .collect()
    }

    /// [`step`](Self::step) with **same-step** auto-reset (what Stable-Baselines3's `VecEnv` and
    /// the training loops want, in one call instead of a step and a [`reset_envs`](Self::reset_envs)):
    /// every environment whose episode ends in this step is reset at once (in parallel, each
    /// continuing its seed stream). Returns the step's results (an ended environment's holds its
    /// last observation and its outcome) and, per environment, the first observation of its new
    /// episode (`None` for those still running). No auto-reset is left pending.
    pub fn step_resetting(
        &mut self,
        actions: &[Action],
    ) -> Result<(Vec<StepResult>, Vec<Option<Observation>>), EnvError> {
        let results = self.step(actions)?;
        let fresh = self
            .envs
            .par_iter_mut()
            .zip(self.autoreset.par_iter())
            .enumerate()
            .map(|(i, (env, &ended))| {
                if ended {
                    env.reset(None).map(|(obs, _)| Some(obs)).map_err(|e| e.in_env(i))
                } else {
                    Ok(None)
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        self.autoreset.fill(false);
        Ok((results, fresh))
    }

    /// Resets the environments `indices` now (each continues its seed stream) and clears their
    /// pending next-step auto-reset: what a same-step auto-reset (Stable-Baselines3's `VecEnv`)
    /// calls for the environments whose episode just ended. Returns their `(obs, info)` in the
    /// order of `indices`.
    pub fn reset_envs(&mut self, indices: &[usize]) -> Result<Vec<(Observation, StepInfo)>, EnvError> {
        let n = self.envs.len();
        if let Some(&bad) = indices.iter().find(|&&i| i >= n) {
            return Err(EnvError::option(
                "indices",
                bad,
                format!("environment indices must be < num_envs = {n}"),
            ));
        }
        let mut out = Vec::with_capacity(indices.len());
        for &i in indices {
            out.push(self.envs[i].reset(None).map_err(|e| e.in_env(i))?);
            self.autoreset[i] = false;
        }
        Ok(out)
    }

    /// The state that reproduces every environment: see [`VectorSnapshot`].
    pub fn snapshot(&self) -> VectorSnapshot {
        VectorSnapshot {
            envs: self.envs.iter().map(EscapeEnv::snapshot).collect(),
            autoreset: self.autoreset.clone(),
        }
    }

    /// Restores a snapshot by replaying each environment's episode (in parallel); returns each
    /// environment's last observation and info (`None` for one that was never reset).
    pub fn restore(&mut self, snapshot: &VectorSnapshot) -> Result<Vec<Option<(Observation, StepInfo)>>, EnvError> {
        let n = self.envs.len();
        if snapshot.envs.len() != n || snapshot.autoreset.len() != n {
            return Err(EnvError::Scenario(format!(
                "the snapshot holds {} environments ({} autoreset flags), this vector environment {n}; \
                 restore it into a vector environment of the same size",
                snapshot.envs.len(),
                snapshot.autoreset.len()
            )));
        }
        let out = self
            .envs
            .par_iter_mut()
            .zip(snapshot.envs.par_iter())
            .enumerate()
            .map(|(i, (env, snap))| env.restore(snap).map_err(|e| e.in_env(i)))
            .collect::<Result<Vec<_>, _>>()?;
        self.autoreset.clone_from(&snapshot.autoreset);
        Ok(out)
    }
}

/// The simulators of a group of environments (all of them running).
fn sims_of<'a>(group: &'a mut [(usize, &mut EscapeEnv)]) -> Result<Vec<&'a mut Sim>, EnvError> {
    let n = group.len();
    let sims: Vec<&mut Sim> = group.iter_mut().filter_map(|(_, env)| env.sim_mut()).collect();
    if sims.len() != n {
        return Err(EnvError::State("step() called before reset(); call reset() first"));
    }
    Ok(sims)
}

/// The result of an auto-reset step: the first observation, reward 0, not done.
fn reset_result(env: &mut EscapeEnv, i: usize) -> Result<StepResult, EnvError> {
    let (obs, info) = env.reset(None).map_err(|e| e.in_env(i))?;
    Ok(StepResult {
        obs,
        reward: 0.0,
        terminated: false,
        truncated: false,
        info,
    })
}

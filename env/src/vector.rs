//! [`EscapeVectorEnv`]: N environments stepped in parallel on Rust threads.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{Action, EnvError, EnvOptions, EnvScenario, EpisodeSnapshot, EscapeEnv, Observation, StepInfo, StepResult};

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
/// the same way (Gymnasium's `SyncVectorEnv` in its default mode). The engine of the Python
/// `loomlab.EscapeVectorEnv` (through the native class of the same name).
#[derive(Debug)]
pub struct EscapeVectorEnv {
    envs: Vec<EscapeEnv>,
    autoreset: Vec<bool>,
}

impl EscapeVectorEnv {
    /// Builds `num_envs` environments of the same scenario and options (sharing one GPU context).
    pub fn new(scenario: EnvScenario, options: EnvOptions, num_envs: usize) -> Result<Self, EnvError> {
        if num_envs == 0 {
            return Err(EnvError::option("num_envs", 0, "must be >= 1"));
        }
        let ctx = super::shared_gpu_context()?;
        let envs = (0..num_envs)
            .map(|_| EscapeEnv::with_context(scenario.clone(), options.clone(), ctx.clone()))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            autoreset: vec![false; num_envs],
            envs,
        })
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
        let results = self
            .envs
            .par_iter_mut()
            .zip(actions.par_iter())
            .zip(self.autoreset.par_iter())
            .enumerate()
            .map(|(i, ((env, &a), &auto))| {
                if auto {
                    let (obs, info) = env.reset(None).map_err(|e| e.in_env(i))?;
                    Ok(StepResult {
                        obs,
                        reward: 0.0,
                        terminated: false,
                        truncated: false,
                        info,
                    })
                } else {
                    env.step(a).map_err(|e| e.in_env(i))
                }
            })
            .collect::<Result<Vec<_>, EnvError>>()?;
        for (auto, r) in self.autoreset.iter_mut().zip(&results) {
            *auto = r.terminated || r.truncated;
        }
        Ok(results)
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

//! [`EscapeVectorEnv`]: N environments stepped in parallel on Rust threads.

use rayon::prelude::*;

use super::{Action, EnvError, EnvOptions, EnvScenario, EscapeEnv, Observation, StepInfo, StepResult};

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

    /// Resets every environment; with `Some(seed)` environment i gets seed `seed + i` (Gymnasium's
    /// convention), with `None` each continues its own seed stream.
    pub fn reset(&mut self, seed: Option<u64>) -> Result<Vec<(Observation, StepInfo)>, EnvError> {
        let out = self
            .envs
            .par_iter_mut()
            .enumerate()
            .map(|(i, env)| env.reset(seed.map(|s| s.wrapping_add(i as u64))))
            .collect::<Result<Vec<_>, _>>()?;
        self.autoreset.fill(false);
        Ok(out)
    }

    /// Steps every environment with its action (one per environment, validated before any
    /// environment moves, so a bad action changes nothing).
    pub fn step(&mut self, actions: &[Action]) -> Result<Vec<StepResult>, EnvError> {
        if actions.len() != self.envs.len() {
            return Err(EnvError::ActionCount {
                expected: self.envs.len(),
                got: actions.len(),
            });
        }
        for ((env, &a), &auto) in self.envs.iter().zip(actions).zip(&self.autoreset) {
            if !auto {
                env.command_for(a)?;
            }
        }
        let results = self
            .envs
            .par_iter_mut()
            .zip(actions.par_iter())
            .zip(self.autoreset.par_iter())
            .map(|((env, &a), &auto)| {
                if auto {
                    let (obs, info) = env.reset(None)?;
                    Ok(StepResult {
                        obs,
                        reward: 0.0,
                        terminated: false,
                        truncated: false,
                        info,
                    })
                } else {
                    env.step(a)
                }
            })
            .collect::<Result<Vec<_>, EnvError>>()?;
        for (auto, r) in self.autoreset.iter_mut().zip(&results) {
            *auto = r.terminated || r.truncated;
        }
        Ok(results)
    }
}

//! Snapshots: reproducing an episode by replaying how it started and the actions since.

use super::{EpisodeSnapshot, EpisodeStart, EscapeEnv, Observation, StepInfo};
use crate::{EnvError, EpisodeRng};

impl EscapeEnv {
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

//! Fingerprints of runs: a stable hash of everything that determines a run's rows (the version,
//! every episode as built, the options), so that a resumed run or sweep can check it continues
//! the same work.

use crate::error::ScenarioError;
use crate::schema::{EpisodeSpec, Scenario};

/// Incremental 64-bit FNV-1a (stable across platforms and versions, unlike `DefaultHasher`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fingerprint(u64);

impl Default for Fingerprint {
    fn default() -> Self {
        Self::new()
    }
}

impl Fingerprint {
    /// The empty fingerprint.
    pub fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }

    /// Adds bytes.
    pub fn add(&mut self, bytes: &[u8]) {
        self.0 = bytes
            .iter()
            .fold(self.0, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3));
    }

    /// Adds one episode as built: its identity, seed, parameters, world, cruise command, length,
    /// controller and scoring (a newline, then the fields separated by `|`).
    pub fn add_episode(&mut self, ep: &EpisodeSpec) {
        let line = format!(
            "\n{}|{}|{}|{:?}|{}|{}|{}|{}|{}",
            ep.scenario,
            ep.index,
            ep.seed,
            ep.params,
            json(&ep.world),
            json(&ep.cruise),
            ep.duration_s,
            json(&ep.controller),
            ep.scoring.lead_margin_s,
        );
        self.add(line.as_bytes());
    }

    /// Adds a scenario's definition, in O(1) of its episodes: the scenario as loaded (its tree with
    /// the suite's defaults merged, its sweeps and random draws, seed, repeats, episode count and
    /// the load options, as its `Debug` text), then its first and last episode as built. Two
    /// scenarios with the same definition expand to the same episodes (the expansion is
    /// deterministic); a changed file, default, option or way of building episodes changes it.
    pub fn add_definition(&mut self, scenario: &Scenario) -> Result<(), ScenarioError> {
        self.add(format!("\n{scenario:?}").as_bytes());
        let last = scenario.len().saturating_sub(1);
        for index in [0, last] {
            let ep = scenario.episode(index)?;
            self.add_episode(&ep);
            self.add(format!("{:?}", ep.detectors).as_bytes());
        }
        Ok(())
    }

    /// The fingerprint as 16 hex digits.
    pub fn hex(&self) -> String {
        format!("{:016x}", self.0)
    }
}

/// `v` as JSON text (empty on failure).
fn json<T: serde::Serialize>(v: &T) -> String {
    serde_json::to_string(v).unwrap_or_default()
}

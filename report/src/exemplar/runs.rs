//! The runs kept while a suite runs, from which the exemplars are drawn.

use std::collections::{BTreeMap, BTreeSet};

use loomlab_scenarios::EpisodeRun;
use loomlab_scenarios::reference::is_reference;

use super::{ExemplarKind, MAX_SCENARIOS};

/// The runs of the episodes that may become exemplars, kept while a suite runs (offered in suite
/// order): per scenario its first episode and the first with each kind of outcome among those
/// offered, so at most four runs per scenario are held.
#[derive(Debug, Default)]
pub struct ExemplarRuns {
    runs: BTreeMap<(String, usize), EpisodeRun>,
    seen: BTreeMap<String, BTreeSet<ExemplarKind>>,
}

impl ExemplarRuns {
    /// Keeps `run` if it is a candidate (call in suite order).
    pub fn offer(&mut self, run: &EpisodeRun) {
        let o = &run.outcome;
        if !self.seen.contains_key(&o.scenario) && self.seen.len() >= MAX_SCENARIOS {
            return;
        }
        let seen = self.seen.entry(o.scenario.clone()).or_default();
        let mut keep = seen.insert(ExemplarKind::First);
        for kind in [ExemplarKind::Miss, ExemplarKind::FalseAlarm, ExemplarKind::Hit] {
            if o.detectors
                .iter()
                .any(|d| !is_reference(&d.detector) && Some(d.outcome) == kind.outcome())
            {
                keep |= seen.insert(kind);
            }
        }
        if keep {
            self.runs.insert((o.scenario.clone(), o.episode), run.clone());
        }
    }

    /// The kept run of an episode.
    pub fn get(&self, scenario: &str, episode: usize) -> Option<&EpisodeRun> {
        self.runs.get(&(scenario.to_string(), episode))
    }

    /// Runs kept.
    pub fn len(&self) -> usize {
        self.runs.len()
    }

    /// Whether no run is kept.
    pub fn is_empty(&self) -> bool {
        self.runs.is_empty()
    }
}

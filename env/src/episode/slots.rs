//! What the environment keeps per detector: its slot and the slot's escape controller.

#[cfg(doc)]
use loomlab_agents::EscapeAgent;
use loomlab_agents::{Decider, EscapeConfig, RobotFacts, TriggerSignal};
use loomlab_detector::DetectorParams;
use loomlab_scenarios::metrics::TraceSample;
use loomlab_scenarios::schema::DetectorSpec;

/// What the environment keeps per detector (the detector itself lives in the [`EscapeAgent`]).
pub(super) struct DetectorSlot {
    pub(super) label: String,
    pub(super) id: String,
    pub(super) params: DetectorParams,
    pub(super) trigger: TriggerSignal,
    pub(super) threshold: f64,
    /// The row's escape-controller configuration (its decision rule), threshold included.
    pub(super) controller: EscapeConfig,
    /// The row's decider, stepped on its θ̂ and the looming side (stateful rows only).
    pub(super) decider: Option<Decider>,
    pub(super) trace: Vec<TraceSample>,
    /// The detector instance the row reads (index into the agent's detectors): rows that run the
    /// same detector share one ([`detector_instances`]).
    pub(super) instance: usize,
}

/// Per row, the detector instance it reads, and the rows that build one (in instance order): rows
/// with the same detector id and parameters (e.g. `hopfield` and `hopfield_tau`, which differ only
/// in their decision rule) share one instance, as in the scenario runner's open-loop pass (a
/// detector's signals depend on nothing but its frames and efference copies). Row 0 always builds
/// instance 0 (the agent's driving detector).
pub(super) fn detector_instances(specs: &[DetectorSpec]) -> (Vec<usize>, Vec<usize>) {
    let mut owners: Vec<usize> = Vec::new();
    let instance = specs
        .iter()
        .enumerate()
        .map(|(i, d)| {
            match owners
                .iter()
                .position(|&j| specs[j].id == d.id && specs[j].params == d.params)
            {
                Some(k) => k,
                None => {
                    owners.push(i);
                    owners.len() - 1
                }
            }
        })
        .collect();
    (instance, owners)
}

/// The controller configuration of detector `d` at alarm threshold `threshold` (for a τ row, the
/// urgency 1/τ in s⁻¹), and its decider for the robot of `facts` if its rule keeps state.
pub(super) fn slot_controller(
    d: &DetectorSpec,
    base: &EscapeConfig,
    facts: &RobotFacts,
    threshold: f64,
) -> (EscapeConfig, Option<Decider>) {
    let d = DetectorSpec { threshold, ..d.clone() };
    let config = d.controller(base);
    let decider = d.is_stateful().then(|| config.decider(facts));
    (config, decider)
}

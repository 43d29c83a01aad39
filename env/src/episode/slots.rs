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

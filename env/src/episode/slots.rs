//! What the environment keeps per detector: its slot and the slot's escape controller.

#[cfg(doc)]
use loomlab_agents::EscapeAgent;
use loomlab_agents::{EscapeConfig, Strategy, TriggerSignal};
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
    /// The row's escape-controller configuration (its decision strategy), threshold included.
    pub(super) controller: EscapeConfig,
    /// The row's decision strategy, stepped on its θ̂ and the looming side (stateful rows only).
    pub(super) strategy: Option<Strategy>,
    pub(super) trace: Vec<TraceSample>,
}

/// The controller configuration of detector `d` at alarm threshold `threshold` (for a τ row, the
/// urgency 1/τ in s⁻¹), and its stateful strategy if it has one.
pub(super) fn slot_controller(
    d: &DetectorSpec,
    base: &EscapeConfig,
    threshold: f64,
) -> (EscapeConfig, Option<Strategy>) {
    let d = DetectorSpec { threshold, ..d.clone() };
    let config = d.controller(base);
    let strategy = d.is_strategy().then(|| config.strategy());
    (config, strategy)
}

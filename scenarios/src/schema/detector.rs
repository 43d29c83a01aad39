//! Detector rows: resolving `[[detectors]]` entries against a registry and a camera, and detectors files.

use std::path::Path;

use loomlab_agents::decision::MAX_PERSISTENCE_FRAMES;
use loomlab_agents::{Course, DecisionRule, EscapeConfig, TriggerSignal};
use loomlab_detector::{Detector, DetectorError, DetectorParams, Registration, Registry, Signal};
use loomlab_sim::WorldDesc;
use serde::Deserialize;
use toml::{Table, Value};

use super::CameraFacts;
use super::document::DetectorDesc;
use super::load::typed;
use crate::error::ScenarioError;

/// The trigger signal of a registry signal ([`Signal::Output`] → `output`, [`Signal::AngularSize`]
/// → `angular_size_deg`).
pub fn trigger_of(signal: Signal) -> TriggerSignal {
    match signal {
        Signal::Output => TriggerSignal::Output,
        Signal::AngularSize => TriggerSignal::AngularSizeDeg,
    }
}

/// A detector of an episode, ready to build.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectorSpec {
    /// Name in reports (the id unless the scenario gave a label).
    pub label: String,
    /// Detector id (a registry id).
    pub id: String,
    /// Which signal is compared with the threshold.
    pub trigger: TriggerSignal,
    /// Alarm threshold: an alarm is `signal >= threshold`, the signal being the decision value of
    /// the row's decider (for `trigger = "tau"` the urgency 1/τ̂, so this is `1 / tau_threshold_s`
    /// in s⁻¹).
    pub threshold: f64,
    /// `trigger = "tau"`: the smallest θ̂ for an alarm (degrees; `None`: the controller's).
    pub min_angular_size_deg: Option<f64>,
    /// The collision-course gate.
    pub course: Course,
    /// Frames the decision value must be at or above the threshold (1: none) within the last
    /// `persistence_window_frames`.
    pub persistence_frames: usize,
    /// The persistence window (frames, ≥ `persistence_frames`; equal: consecutive frames).
    pub persistence_window_frames: usize,
    /// Validated parameters (camera keys such as the Hopfield `n` and `fov_deg` already match the
    /// camera).
    pub params: DetectorParams,
}

impl DetectorSpec {
    /// Builds a fresh detector for n×n frames.
    pub fn build(&self, n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        self.params.build(n)
    }

    /// The escape controller's configuration for this detector: `base` with this row's decision
    /// rule.
    pub fn controller(&self, base: &EscapeConfig) -> EscapeConfig {
        EscapeConfig {
            decision: DecisionRule {
                trigger: self.trigger,
                threshold: self.threshold,
                tau_threshold_s: if self.trigger == TriggerSignal::Tau {
                    1.0 / self.threshold
                } else {
                    base.decision.tau_threshold_s
                },
                min_angular_size_deg: self.min_angular_size_deg.unwrap_or(base.decision.min_angular_size_deg),
                course: self.course,
                persistence_frames: self.persistence_frames,
                persistence_window_frames: Some(self.persistence_window_frames),
                ..base.decision
            },
            ..base.clone()
        }
    }

    /// Whether this row's decision rule keeps state ([`DecisionRule::is_stateful`]: τ, the course
    /// gate or persistence): its decision value is not the raw trigger signal.
    pub fn is_stateful(&self) -> bool {
        self.controller(&EscapeConfig::default()).decision.is_stateful()
    }
}

/// The camera facts of a world's camera (what detectors take from the camera).
pub fn camera_facts(world: &WorldDesc) -> CameraFacts {
    CameraFacts {
        n: world.camera.n as usize,
        fov_deg: f64::from(world.camera.fov_deg),
        frame_rate_hz: f64::from(world.camera_hz),
    }
}

/// The default camera's facts with frame side `n` (for validating detector lists that are not tied
/// to a world yet).
pub fn default_camera(n: usize) -> CameraFacts {
    CameraFacts {
        n,
        ..camera_facts(&WorldDesc::default())
    }
}

/// Validates one `[[detectors]]` entry for `camera` against the built-in registry and builds its
/// spec. Errors are `(key, reason)` with the key relative to the entry (`threshold`,
/// `params.alpha`, …).
pub fn resolve_detector(d: &DetectorDesc, camera: CameraFacts) -> Result<DetectorSpec, (String, String)> {
    resolve_detector_in(Registry::builtin(), d, camera)
}

/// [`resolve_detector`] against `registry`.
pub fn resolve_detector_in(
    registry: &Registry,
    d: &DetectorDesc,
    camera: CameraFacts,
) -> Result<DetectorSpec, (String, String)> {
    let Some(reg) = registry.find(&d.id) else {
        return Err((
            "id".into(),
            format!("unknown detector `{}`; known ids: {}", d.id, registry.ids().join(", ")),
        ));
    };
    let id = reg.id.as_str();
    let threshold = d.threshold.unwrap_or(reg.default_threshold);
    if !threshold.is_finite() {
        return Err(("threshold".into(), format!("{threshold} must be finite")));
    }
    let label = d.label.clone().unwrap_or_else(|| id.to_string());
    if label.is_empty() || label.contains([',', '"', '\n']) {
        return Err((
            "label".into(),
            "must be non-empty, without commas, quotes or newlines".into(),
        ));
    }
    if crate::reference::is_reference(&label) {
        return Err((
            "label".into(),
            format!(
                "`{label}` is reserved for a reference row ({}); choose another label",
                crate::reference::REFERENCE_LABELS.join(", ")
            ),
        ));
    }
    let trigger = d.trigger.unwrap_or_else(|| trigger_of(reg.default_trigger));
    let gives_theta = reg.gives(Signal::AngularSize);
    let with_theta = || angular_size_ids(registry).join(", ");
    // a trigger on θ̂ needs a detector that estimates it: any other detector would never alarm
    if trigger == TriggerSignal::AngularSizeDeg && !gives_theta {
        return Err((
            "trigger".into(),
            format!(
                "\"angular_size_deg\" needs a detector that estimates the angular size θ̂ ({}); \
                 `{id}` gives none, so it would never alarm: use trigger = \"output\"",
                with_theta()
            ),
        ));
    }
    let course = d.course.unwrap_or_default();
    let needs_theta = trigger == TriggerSignal::Tau || course != Course::Off;
    if needs_theta && !gives_theta {
        let key = if trigger == TriggerSignal::Tau {
            "trigger"
        } else {
            "course"
        };
        return Err((
            key.into(),
            format!(
                "`{}` needs an angular-size estimate θ̂, which `{id}` does not give (detectors with θ̂: {})",
                if trigger == TriggerSignal::Tau {
                    "trigger = \"tau\""
                } else {
                    "course = \"image\""
                },
                with_theta()
            ),
        ));
    }
    if course != Course::Off && trigger == TriggerSignal::Output {
        return Err((
            "course".into(),
            "the collision-course gate needs θ̂: use trigger = \"tau\" or \"angular_size\"".into(),
        ));
    }
    let threshold = if trigger == TriggerSignal::Tau {
        if d.threshold.is_some() {
            return Err((
                "threshold".into(),
                "with trigger = \"tau\" the alarm threshold is tau_threshold_s (seconds)".into(),
            ));
        }
        let tau = d.tau_threshold_s.unwrap_or(DecisionRule::default().tau_threshold_s);
        if !(tau.is_finite() && tau > 0.0) {
            return Err((
                "tau_threshold_s".into(),
                format!("{tau} must be a finite number of seconds > 0"),
            ));
        }
        1.0 / tau
    } else {
        for (key, given) in [
            ("tau_threshold_s", d.tau_threshold_s.is_some()),
            ("min_angular_size_deg", d.min_angular_size_deg.is_some()),
        ] {
            if given {
                return Err((key.into(), "only used with trigger = \"tau\"".into()));
            }
        }
        threshold
    };
    if let Some(m) = d.min_angular_size_deg
        && !(m.is_finite() && m >= 0.0)
    {
        return Err((
            "min_angular_size_deg".into(),
            format!("{m} must be a finite number >= 0"),
        ));
    }
    let persistence_frames = d.persistence_frames.unwrap_or(1);
    if !(1..=MAX_PERSISTENCE_FRAMES).contains(&persistence_frames) {
        return Err((
            "persistence_frames".into(),
            format!(
                "{persistence_frames} must be a whole number of frames from 1 (alarm at once) to {MAX_PERSISTENCE_FRAMES}"
            ),
        ));
    }
    let persistence_window_frames = d.persistence_window_frames.unwrap_or(persistence_frames);
    if !(persistence_frames..=MAX_PERSISTENCE_FRAMES).contains(&persistence_window_frames) {
        return Err((
            "persistence_window_frames".into(),
            format!(
                "{persistence_window_frames} must be a whole number of frames from persistence_frames ({persistence_frames}) to {MAX_PERSISTENCE_FRAMES}"
            ),
        ));
    }
    let params = reg
        .configure(d.params.as_ref(), &camera)
        .map_err(|e| (e.key, e.reason))?;
    Ok(DetectorSpec {
        label,
        id: id.to_string(),
        trigger,
        threshold,
        min_angular_size_deg: d.min_angular_size_deg,
        course,
        persistence_frames,
        persistence_window_frames,
        params,
    })
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DetectorsDoc {
    detectors: Vec<DetectorDesc>,
}

/// Parses a detectors file: TOML holding only `[[detectors]]` entries (the scenario syntax), as
/// `loomlab run --detectors-file` takes and a sweep writes for each parameter point. Every entry is
/// checked (at a 64×64, 60° camera; the real camera is checked when the suite loads).
pub fn parse_detector_entries(text: &str, path: &Path) -> Result<Vec<DetectorDesc>, ScenarioError> {
    let tree: Table = toml::from_str(text).map_err(|e| ScenarioError::Syntax {
        path: path.into(),
        message: e.to_string().trim_end().to_string(),
    })?;
    let doc: DetectorsDoc = typed(Value::Table(tree), "").map_err(|(k, r)| ScenarioError::key(path, k, r))?;
    if doc.detectors.is_empty() {
        return Err(ScenarioError::key(
            path,
            "detectors",
            "the list is empty; give at least one [[detectors]] entry",
        ));
    }
    let mut labels = Vec::new();
    for (i, d) in doc.detectors.iter().enumerate() {
        let spec = resolve_detector(d, default_camera(64))
            .map_err(|(k, r)| ScenarioError::key(path, format!("detectors[{i}].{k}"), r))?;
        if labels.contains(&spec.label) {
            return Err(ScenarioError::key(
                path,
                format!("detectors[{i}].label"),
                format!(
                    "detector `{}` is listed twice; give the entries different labels",
                    spec.label
                ),
            ));
        }
        labels.push(spec.label);
    }
    Ok(doc.detectors)
}

/// Reads a detectors file (see [`parse_detector_entries`]).
pub fn load_detector_entries(path: &Path) -> Result<Vec<DetectorDesc>, ScenarioError> {
    let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
        path: path.into(),
        source,
    })?;
    parse_detector_entries(&text, path)
}

/// The entry of detector `id` with every other key left out.
pub(super) fn bare(id: &str) -> DetectorDesc {
    DetectorDesc::of_id(id)
}

/// The ids of the detectors in `registry` that give θ̂.
pub fn angular_size_ids(registry: &Registry) -> Vec<&str> {
    registry
        .iter()
        .filter(|r| r.gives(Signal::AngularSize))
        .map(|r| r.id.as_str())
        .collect()
}

/// The registration of a built-in detector id (its default threshold and trigger, …).
pub fn registration(id: &str) -> Option<&'static Registration> {
    Registry::builtin().find(id)
}

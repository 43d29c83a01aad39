//! An episode's rows (detector or reference) and which of a tracker's alarms are about the threat.

use loomlab_agents::TriggerSignal;
use loomlab_detector::{ImageRegion, Pinhole};
use loomlab_sim::ObjectTruth;

use super::trace::{DecisionTrace, DetectorTrace};
use crate::reference::IdealKind;
use crate::schema::DetectorSpec;

/// For a detector that numbers its tracks ([`ImageRegion::track`], `tracker`): per frame, whether
/// its tracked region overlaps object `id`'s true image extent (`truth`, per frame; seen through
/// `camera`) — scoring only, which may read the ground truth. `None` for a detector
/// without tracks: its alarms are taken to be about the threat.
pub(super) fn covers_object(
    regions: &[Option<ImageRegion>],
    truth: &[Vec<ObjectTruth>],
    id: usize,
    camera: &Pinhole,
) -> Option<Vec<bool>> {
    if !regions.iter().flatten().any(|r| r.track.is_some()) {
        return None;
    }
    let angle = |v: f64| camera.angle_deg(v);
    let overlaps = |[a0, a1]: [f64; 2], [b0, b1]: [f32; 2]| a0 <= f64::from(b1) && f64::from(b0) <= a1;
    let covers = |k: usize| {
        let (Some(Some(r)), Some(o)) = (regions.get(k), truth.get(k).and_then(|t| t.iter().find(|o| o.id == id)))
        else {
            return false;
        };
        // image y is up, as elevation; image x is right, as azimuth
        o.in_view && overlaps(r.x.map(angle), o.azimuth_extent_deg) && overlaps(r.y.map(angle), o.elevation_extent_deg)
    };
    Some((0..regions.len()).map(covers).collect())
}

/// How a row's closed loop after its first alarm is run.
pub(super) enum Tail<'a> {
    /// The detector drives the escape agent on rendered frames.
    Detector(&'a DetectorSpec),
    /// An ideal observer on ground truth drives the escape agent, physics only (`ideal_*`).
    Ideal(IdealKind),
    /// One trigger, then physics only: the escape-deadline replay (`oracle`).
    Replay,
}

/// One row of an episode: a detector or a reference row, with its open-loop trigger signal.
pub(super) struct Row<'a> {
    pub(super) label: String,
    pub(super) trigger: TriggerSignal,
    pub(super) threshold: f64,
    pub(super) signal: Vec<f64>,
    /// θ̂ before the decider, for rows whose signal is a decider's value.
    pub(super) raw: Option<Vec<f64>>,
    /// The decider's τ̂ and gate per frame, for the same rows.
    pub(super) estimates: Option<(Vec<Option<f64>>, Vec<bool>)>,
    /// Per frame, whether the row's region covers the threat's true image (see `about_threat`).
    pub(super) about_mask: Option<Vec<bool>>,
    /// The detector's image regions, for a detector that localises the object.
    pub(super) regions: Option<Vec<Option<ImageRegion>>>,
    /// For a row that names the object of each alarm in a threat episode (the ideal rows; a
    /// detector that numbers its tracks, whose tracked region is matched with the threat's true
    /// image by [`covers_object`]): its signal about the threat object alone. The row is scored on
    /// it — an alarm about another object (a passing car) is not a hit — while its closed loop
    /// still starts at its first alarm about anything.
    pub(super) about_threat: Option<Vec<f64>>,
    pub(super) output: Vec<f64>,
    pub(super) tail: Tail<'a>,
}

impl Row<'_> {
    /// The row's open-loop trace.
    pub(super) fn into_trace(self) -> DetectorTrace {
        DetectorTrace {
            label: self.label,
            trigger: self.trigger,
            threshold: self.threshold,
            decision: self
                .raw
                .zip(self.estimates)
                .map(|(theta_hat_deg, (tau_s, gate_open))| DecisionTrace {
                    theta_hat_deg,
                    tau_s,
                    gate_open,
                }),
            regions: self.regions,
            about_threat: self.about_mask,
            signal: self.signal,
            output: self.output,
        }
    }
}

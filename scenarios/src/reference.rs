//! Reference rows: what a report's detectors are measured against, computed from ground truth and
//! scored by the same code as the detectors.
//!
//! - `null` never alarms: its collision rate is the threat rate, the floor every detector must
//!   beat ([`DetectorSummary::collision_reduction`](crate::metrics::DetectorSummary) is measured
//!   against it);
//! - `oracle` alarms exactly at each evadable threat's escape deadline frame and never otherwise:
//!   the ceiling (it evades every evadable threat with no false alarm);
//! - `ideal_theta` alarms when the true angular size of any approaching object (angular size
//!   growing) reaches the Hopfield trigger threshold: what a perfect θ̂ would do with the same
//!   threshold. It separates "the estimate is wrong" from "thresholding θ is too late". Its
//!   perception is perfect throughout: it dodges away from the true image side (bearing) of the
//!   object it triggers on, and its closed loop after the first alarm is simulated physics-only
//!   with ground truth as its input (re-triggers included).
//!
//! The oracle and null signals are indicators (1 at an alarm frame, 0 elsewhere, threshold
//! [`INDICATOR_THRESHOLD`]); ideal_theta's signal is in degrees. Reference rows are excluded from
//! regressions and from threshold calibration.

use loomlab_sim::ObjectTruth;

/// Label of the never-alarming reference row.
pub const NULL: &str = "null";
/// Label of the reference row that alarms at each threat's escape deadline.
pub const ORACLE: &str = "oracle";
/// Label of the reference row that thresholds the true angular size.
pub const IDEAL_THETA: &str = "ideal_theta";
/// Every reference label, in table order.
pub const REFERENCE_LABELS: [&str; 3] = [NULL, ORACLE, IDEAL_THETA];
/// Alarm threshold of the indicator signals of `null` and `oracle`.
pub const INDICATOR_THRESHOLD: f64 = 1.0;

/// Whether `label` names a reference row (reserved: detectors may not use these labels).
pub fn is_reference(label: &str) -> bool {
    REFERENCE_LABELS.contains(&label)
}

/// The ideal θ̂: the largest true angular size (degrees) of the objects whose angular size is
/// growing; 0 when none is.
pub fn ideal_theta_deg(truth: &[ObjectTruth]) -> f64 {
    ideal_percept(truth).0
}

/// The ideal θ̂ and the image side (bearing, −1 left … +1 right) of the object it comes from
/// (`None` when no object is looming).
pub fn ideal_percept(truth: &[ObjectTruth]) -> (f64, Option<f32>) {
    truth
        .iter()
        .filter(|o| o.angular_rate_deg_s > 0.0)
        .max_by(|a, b| a.angular_size_deg.total_cmp(&b.angular_size_deg))
        .map_or((0.0, None), |o| (f64::from(o.angular_size_deg), Some(o.bearing)))
}

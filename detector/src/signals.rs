//! The [`Detector`] trait shared by every looming model, and its output [`Signals`].

use crate::{DetectorError, Frame};

/// What a detector reports for one frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Signals {
    /// The model's primary output (z for Hopfield; the LGMD potential for baselines).
    pub output: f64,
    /// Estimated angular size of the looming object in degrees, for models that give one.
    pub angular_size_deg: Option<f64>,
    /// Named auxiliary signals (e.g. `("on", z_on)`), written as `<id>_<name>` CSV columns.
    pub aux: Vec<(&'static str, f64)>,
}

/// The robot's own motion during the camera period that ended with a frame: the velocity command it
/// applied (an efference copy, for detectors that discount their own motion).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EfferenceCopy {
    /// Forward speed (m/s).
    pub forward_mps: f64,
    /// Yaw rate (rad/s, positive = turning left).
    pub yaw_rate_rps: f64,
    /// Lateral speed (m/s, positive = to the left).
    pub lateral_mps: f64,
}

/// A looming detector: a causal filter from frames to [`Signals`].
///
/// Implementations keep their own state between frames; [`Detector::reset`]
/// returns them to the state before the first frame.
pub trait Detector: Send {
    /// Stable id used in the CLI, CSV columns, reports and Python (e.g. `hopfield`).
    fn id(&self) -> &'static str;
    /// Forget all history (start a new video).
    fn reset(&mut self);
    /// Process the next frame. Errors only on frames of the wrong size.
    fn step(&mut self, frame: &Frame) -> Result<Signals, DetectorError>;
    /// [`Self::step`] with the efference copy of the camera period that ended with `frame`: what
    /// the scenario runner and the escape agent call. The default ignores it.
    fn step_moving(&mut self, frame: &Frame, ego: &EfferenceCopy) -> Result<Signals, DetectorError> {
        let _ = ego;
        self.step(frame)
    }
}

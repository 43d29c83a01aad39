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
}

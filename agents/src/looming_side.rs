//! Estimating which side of the image a looming object is on, for the dodge direction.
//!
//! The estimate is the x centroid of the temporal contrast |frame(t) − frame(t−1)|: an expanding
//! object changes the pixels along its edges, so their centroid sits on the object. The result is
//! in image x, −1 (left edge) … +1 (right edge), pixel column j at x = 2(j + ½)/n − 1. Whole-field
//! motion (the robot's own movement against a textured background) spreads the contrast over the
//! image and pulls the centroid towards 0, which the controller's `side_deadband` then treats as
//! "unknown" (dodge to the default side). A frame pair with (almost) no change gives `None`.

use loomlab_detector::Frame;

/// Default minimum mean |Δ| per pixel for an estimate (below: no usable change).
pub const DEFAULT_MIN_MEAN_CHANGE: f32 = 1e-3;

/// The x centroid in [-1, 1] of |current − previous|, or `None` if the frames differ in size or
/// the mean absolute change per pixel is below `min_mean_change`.
pub fn temporal_contrast_centroid_x(previous: &Frame, current: &Frame, min_mean_change: f32) -> Option<f32> {
    let n = current.n();
    if previous.n() != n || n == 0 {
        return None;
    }
    let (mut total, mut weighted) = (0.0f64, 0.0f64);
    for (row_prev, row_cur) in previous.data().chunks_exact(n).zip(current.data().chunks_exact(n)) {
        for (j, (&a, &b)) in row_prev.iter().zip(row_cur).enumerate() {
            let d = f64::from((b - a).abs());
            total += d;
            weighted += d * ((2.0 * j as f64 + 1.0) / n as f64 - 1.0);
        }
    }
    if total / ((n * n) as f64) < f64::from(min_mean_change) || total <= 0.0 {
        return None;
    }
    Some((weighted / total).clamp(-1.0, 1.0) as f32)
}

/// Keeps the previous frame and reports [`temporal_contrast_centroid_x`] for each new one.
#[derive(Debug, Clone)]
pub struct LoomingSideEstimator {
    previous: Option<Frame>,
    min_mean_change: f32,
}

impl Default for LoomingSideEstimator {
    fn default() -> Self {
        Self::new(DEFAULT_MIN_MEAN_CHANGE)
    }
}

impl LoomingSideEstimator {
    /// An estimator that needs a mean |Δ| per pixel of at least `min_mean_change`.
    pub fn new(min_mean_change: f32) -> Self {
        Self {
            previous: None,
            min_mean_change,
        }
    }

    /// Forget the previous frame (start a new episode).
    pub fn reset(&mut self) {
        self.previous = None;
    }

    /// Take `frame` as the previous frame without estimating: for a caller that already knows
    /// this frame's estimate (it ran an identical estimator on the same frames).
    pub fn remember(&mut self, frame: &Frame) {
        match &mut self.previous {
            Some(previous) => previous.clone_from(frame),
            None => self.previous = Some(frame.clone()),
        }
    }

    /// Estimate the looming side from this frame and the previous one (`None` on the first frame).
    pub fn update(&mut self, frame: &Frame) -> Option<f32> {
        let side = self
            .previous
            .as_ref()
            .and_then(|p| temporal_contrast_centroid_x(p, frame, self.min_mean_change));
        self.remember(frame);
        side
    }
}

//! Helpers shared by the baseline models: frame history / temporal contrast
//! (docs/detectors.md, common §2) and parameter validation with uniform error messages.

use crate::compensation::CompensatedDifference;

/// The [`DetectorConfig`](crate::registry::DetectorConfig) items of a model whose `fov_deg` field
/// comes from the camera (never a param): its `CAMERA_KEYS` and `for_camera`.
macro_rules! fov_from_camera {
    () => {
        const CAMERA_KEYS: &'static [&'static str] = &["fov_deg"];

        fn for_camera(self, camera: &crate::registry::CameraFacts) -> Self {
            Self {
                fov_deg: camera.fov_deg,
                ..self
            }
        }
    };
}
use crate::{DetectorError, EfferenceCopy, Frame};

/// Result of [`PreviousFrame::begin`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FrameStep {
    /// First frame since construction/reset: it was stored, the model reports
    /// `z(0) = 0` and must not touch any other state (docs/detectors.md, common §2).
    /// Carries the side length n that this frame fixed.
    First(usize),
    /// A later frame of the fixed size n; call [`PreviousFrame::contrast_into`].
    Next(usize),
}

/// The previous frame `F_{t-1}` (as f64) and the side length fixed by the first frame.
///
/// With ego-motion compensation ([`Self::compensated`], a model's `compensate = true`) the
/// temporal contrast is taken against the previous frame warped to the current view by the
/// camera's motion in between ([`CompensatedDifference`] with a baseline of one frame; 0 where the
/// warped frame does not reach): the static world's image motion cancels. The motion is the
/// efference copy given to [`Self::set_motion`] before the frame; without one (or with `dt_s = 0`)
/// nothing is predicted to move and the contrast is the plain difference.
#[derive(Debug, Clone, Default)]
pub(crate) struct PreviousFrame {
    n: Option<usize>,
    data: Vec<f64>,
    compensation: Option<Compensation>,
}

/// The state of [`PreviousFrame`]'s ego-motion compensation.
#[derive(Debug, Clone)]
struct Compensation {
    fov_deg: f64,
    /// Built on the first frame (it fixes n).
    difference: Option<CompensatedDifference>,
    /// The efference copy of the next frame.
    ego: EfferenceCopy,
    residual: Vec<f32>,
}

impl PreviousFrame {
    /// A previous frame whose contrast is ego-motion compensated (`compensate = true`) for a camera
    /// of `fov_deg`, or the paper's plain one.
    pub(crate) fn compensated(compensate: bool, fov_deg: f64) -> Self {
        Self {
            compensation: compensate.then(|| Compensation {
                fov_deg,
                difference: None,
                ego: EfferenceCopy::default(),
                residual: Vec::new(),
            }),
            ..Self::default()
        }
    }

    /// The efference copy of the next frame (used only with compensation).
    pub(crate) fn set_motion(&mut self, ego: &EfferenceCopy) {
        if let Some(c) = &mut self.compensation {
            c.ego = *ego;
        }
    }

    /// With compensation: steps the compensated difference with `frame` and the pending efference
    /// copy, leaving `F_t − warped F_{t−1}` in the residual. Returns whether to use it: false
    /// without compensation, and when the camera's motion is not known (then the plain difference
    /// is exactly the paper's, border pixels included).
    fn compensate(&mut self, frame: &Frame) -> bool {
        let Some(c) = &mut self.compensation else {
            return false;
        };
        let n = frame.n();
        let difference = c
            .difference
            .get_or_insert_with(|| CompensatedDifference::new(n, c.fov_deg, 1));
        c.residual.resize(n * n, 0.0);
        difference.step(frame.data(), &c.ego, &mut c.residual);
        let known = c.ego.knows_motion();
        c.ego = EfferenceCopy::default();
        known
    }

    /// Checks the frame size. On the first frame stores the frame and returns
    /// [`FrameStep::First`]; afterwards returns [`FrameStep::Next`] without storing
    /// anything (the caller then computes the contrast with [`Self::contrast_into`]).
    pub(crate) fn begin(&mut self, frame: &Frame) -> Result<FrameStep, DetectorError> {
        let got = frame.n();
        match self.n {
            None => {
                self.n = Some(got);
                self.data.clear();
                self.data.extend(frame.data().iter().map(|&v| f64::from(v)));
                self.compensate(frame);
                Ok(FrameStep::First(got))
            }
            Some(expected) if expected != got => Err(DetectorError::FrameSize { expected, got }),
            Some(n) => Ok(FrameStep::Next(n)),
        }
    }

    /// Writes `out = scale·(F_t − F_{t−1})` and stores `F_t` as the new previous frame.
    /// Returns `Σ|out|`. `out` must have n·n entries.
    pub(crate) fn contrast_into(&mut self, frame: &Frame, scale: f64, out: &mut [f64]) -> f64 {
        if self.compensate(frame) {
            return self.compensated_contrast(frame, scale, out);
        }
        let mut sum_abs = 0.0;
        for ((o, prev), &f) in out.iter_mut().zip(self.data.iter_mut()).zip(frame.data()) {
            let f = f64::from(f);
            let p = scale * (f - *prev);
            *prev = f;
            *o = p;
            sum_abs += p.abs();
        }
        sum_abs
    }

    /// As [`Self::contrast_into`] without the sum (for models that do not need it).
    pub(crate) fn contrast_only(&mut self, frame: &Frame, scale: f64, out: &mut [f64]) {
        if self.compensate(frame) {
            self.compensated_contrast(frame, scale, out);
            return;
        }
        for ((o, prev), &f) in out.iter_mut().zip(self.data.iter_mut()).zip(frame.data()) {
            let f = f64::from(f);
            *o = scale * (f - *prev);
            *prev = f;
        }
    }

    /// `out = scale·residual` of the compensated difference just stepped, storing `F_t`; `Σ|out|`.
    fn compensated_contrast(&mut self, frame: &Frame, scale: f64, out: &mut [f64]) -> f64 {
        let residual = self.compensation.as_ref().map_or(&[][..], |c| &c.residual[..]);
        let mut sum_abs = 0.0;
        for (((o, prev), &f), &r) in out.iter_mut().zip(self.data.iter_mut()).zip(frame.data()).zip(residual) {
            *prev = f64::from(f);
            *o = scale * f64::from(r);
            sum_abs += o.abs();
        }
        sum_abs
    }

    /// Forgets the previous frame and the fixed size (keeps the allocation).
    pub(crate) fn reset(&mut self) {
        self.n = None;
        if let Some(c) = &mut self.compensation {
            c.difference = None;
            c.ego = EfferenceCopy::default();
        }
    }
}

/// Sets `buf` to `len` zeros, reusing its allocation.
pub(crate) fn zeroed(buf: &mut Vec<f64>, len: usize) {
    buf.clear();
    buf.resize(len, 0.0);
}

/// Valid range of a real-valued parameter.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Range {
    /// `[lo, hi]`.
    Closed(f64, f64),
    /// `[lo, hi)`.
    ClosedOpen(f64, f64),
    /// `> 0`.
    Positive,
    /// `>= 0`.
    NonNegative,
    /// any finite value.
    Finite,
}

impl Range {
    fn contains(self, v: f64) -> bool {
        if !v.is_finite() {
            return false;
        }
        match self {
            Range::Closed(lo, hi) => (lo..=hi).contains(&v),
            Range::ClosedOpen(lo, hi) => (lo..hi).contains(&v),
            Range::Positive => v > 0.0,
            Range::NonNegative => v >= 0.0,
            Range::Finite => true,
        }
    }

    fn describe(self) -> String {
        match self {
            Range::Closed(lo, hi) => format!("a number in [{lo}, {hi}]"),
            Range::ClosedOpen(lo, hi) => format!("a number in [{lo}, {hi})"),
            Range::Positive => "a finite number > 0".into(),
            Range::NonNegative => "a finite number >= 0".into(),
            Range::Finite => "a finite number".into(),
        }
    }
}

/// Checks one real parameter. `name` is the dotted config key (`keil2004.kappa`),
/// `meaning` says what it does, `default` is the spec value shown as a hint.
pub(crate) fn check(
    name: &'static str,
    value: f64,
    range: Range,
    default: f64,
    meaning: &str,
) -> Result<(), DetectorError> {
    if range.contains(value) {
        Ok(())
    } else {
        Err(DetectorError::InvalidParameter {
            name,
            value: format!("{value}"),
            reason: format!("{meaning}; it must be {} (spec default {default})", range.describe()),
        })
    }
}

/// Checks every entry of a 3-vector parameter (centre, nearest, diagonal).
pub(crate) fn check3(
    name: &'static str,
    value: [f64; 3],
    range: Range,
    default: [f64; 3],
    meaning: &str,
) -> Result<(), DetectorError> {
    const POS: [&str; 3] = ["centre", "nearest", "diagonal"];
    for (k, &v) in value.iter().enumerate() {
        if !range.contains(v) {
            return Err(DetectorError::InvalidParameter {
                name,
                value: format!("{value:?}"),
                reason: format!(
                    "{meaning}; entry {k} ({}) = {v} but every entry must be {} (spec default {default:?}, \
                     order: centre, nearest, diagonal)",
                    POS[k],
                    range.describe()
                ),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_frame_fixes_size_and_reset_forgets_it() {
        let mut prev = PreviousFrame::default();
        assert_eq!(prev.begin(&Frame::uniform(4, 0.25)).unwrap(), FrameStep::First(4));
        let err = prev.begin(&Frame::uniform(5, 0.25)).unwrap_err();
        assert!(matches!(err, DetectorError::FrameSize { expected: 4, got: 5 }));
        let f = Frame::uniform(4, 0.75);
        assert_eq!(prev.begin(&f).unwrap(), FrameStep::Next(4));
        let mut out = vec![0.0; 16];
        let s = prev.contrast_into(&f, 2.0, &mut out);
        assert!(out.iter().all(|&p| p == 1.0));
        assert_eq!(s, 16.0);
        prev.reset();
        assert_eq!(prev.begin(&Frame::uniform(5, 0.0)).unwrap(), FrameStep::First(5));
    }

    #[test]
    fn check_reports_name_value_and_range() {
        assert!(check("m.x", 0.5, Range::ClosedOpen(0.0, 1.0), 0.7, "memory").is_ok());
        let e = check("m.x", 1.0, Range::ClosedOpen(0.0, 1.0), 0.7, "memory").unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("m.x") && msg.contains("[0, 1)") && msg.contains("0.7"),
            "{msg}"
        );
        assert!(check("m.x", f64::NAN, Range::Finite, 0.0, "x").is_err());
        let e = check3("m.k", [1.0, -1.0, 2.0], Range::NonNegative, [1.0; 3], "k").unwrap_err();
        assert!(e.to_string().contains("nearest"), "{e}");
    }
}

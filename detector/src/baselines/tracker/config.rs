//! The tracker's parameters ([`TrackerConfig`]): defaults, validation and registry building.

use serde::Deserialize;

use super::Tracker;
use crate::baselines::common::{Range, check};
use crate::registry::DetectorConfig;
use crate::{Detector, DetectorError};

/// Parameters of [`Tracker`].
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackerConfig {
    /// Full field of view of the camera (degrees): from `world.camera`, never a param. Default 60.
    pub fov_deg: f64,
    /// How many frames back the compensated difference compares with (frames, ≥ 1). Default 8
    /// (67 ms at 120 Hz): a far object's edge moves a fraction of a pixel per frame.
    pub baseline_frames: usize,
    /// Residual above which a pixel counts as changed (luminance, in (0, 1)). Default 0.06.
    pub threshold: f64,
    /// Prediction error allowed at edges, as pixels times the local gradient (pixels, ≥ 0).
    /// Default 0.5.
    pub edge_tolerance_px: f64,
    /// Changed pixels at most this far apart (Chebyshev, pixels, 1–8) belong to one region.
    /// Default 2.
    pub link_px: usize,
    /// Fewest changed pixels of a region of the compensated difference (a moving camera; pixels,
    /// ≥ 1). Default 4: the prediction's errors at the static texture's edges come in small specks.
    pub min_pixels: usize,
    /// Fewest changed pixels of a region against a standing camera's background model (pixels,
    /// ≥ 1). Default 2: the model has no prediction error, and a far object that grows by a
    /// fraction of a pixel changes its edge pixels one or two at a time.
    pub standing_min_pixels: usize,
    /// Frames a track survives without a region (frames). Default 6.
    pub hold_frames: usize,
    /// The track's validation gate (ratio, > 1): once the track holds 8
    /// measurements, a region whose box is larger or smaller than its predicted size by more than
    /// this factor (give or take 2 pixels) is not measured: a merge with another region
    /// or a split, not the object's growth (module docs, step 3). Default 1.3 (the decision
    /// strategies' jump ratio): at 120 Hz an object grows by 30 % in a frame only at a time to
    /// contact below 0.03 s.
    pub size_gate_ratio: f64,
    /// Frames a new track must last before it is reported (frames, ≥ 1): a box of a few pixels
    /// that appears and vanishes again is noise, and a decision strategy fitting the first frames
    /// of a track would read its jitter as motion. Default 30 (0.25 s at 120 Hz).
    pub confirm_frames: usize,
    /// Memory of the fit of the track's measurements (frames, ≥ 1): a measurement `j` frames old
    /// weighs `exp(−j/fit_frames)` in the least-squares lines through the object's inverse size and
    /// its centre in units of its size, which change linearly in time for an object moving at a
    /// constant velocity (module docs, step 4). Default 45 (0.375 s at 120 Hz).
    pub fit_frames: usize,
    /// Time constant of the background model of a standing camera (frames, ≥ 1): the background
    /// follows the frames by `1/background_frames` of their difference per frame outside the
    /// tracked object's box (and 8 times slower inside it). Default
    /// 60 (0.5 s at 120 Hz): a far object that grows by a pixel in half a second still differs
    /// from it, and a change the scene keeps (a light switched on) fades within about a second.
    pub background_frames: usize,
    /// Whether a moving camera measures the tracked object by its appearance in the frame when it
    /// stands out from its surround (module docs, step 3). Default true; false measures the
    /// compensated difference's regions only.
    pub appearance: bool,
    /// Whether a region on a collision course takes the track over from an object that will pass
    /// beside the camera (module docs, step 3). Default true; false keeps a track until it ends.
    pub take_over: bool,
}

impl Default for TrackerConfig {
    fn default() -> Self {
        Self {
            fov_deg: 60.0,
            baseline_frames: 8,
            threshold: 0.06,
            edge_tolerance_px: 0.5,
            link_px: 2,
            min_pixels: 4,
            standing_min_pixels: 2,
            hold_frames: 6,
            size_gate_ratio: 1.3,
            confirm_frames: 30,
            fit_frames: 45,
            background_frames: 60,
            appearance: true,
            take_over: true,
        }
    }
}

impl TrackerConfig {
    /// Checks every value (the error names the parameter, its range and its default).
    pub fn validate(&self) -> Result<(), DetectorError> {
        check("tracker.fov_deg", self.fov_deg, Range::Closed(0.5, 170.0), 60.0, "the camera's field of view")?;
        check(
            "tracker.threshold",
            self.threshold,
            Range::Closed(1e-6, 1.0),
            0.06,
            "the residual above which a pixel counts as changed",
        )?;
        check(
            "tracker.size_gate_ratio",
            self.size_gate_ratio,
            Range::Closed(1.01, 100.0),
            1.3,
            "the track's validation gate (ratio of box sizes)",
        )?;
        check(
            "tracker.edge_tolerance_px",
            self.edge_tolerance_px,
            Range::Closed(0.0, 10.0),
            0.5,
            "the prediction error allowed at edges (pixels)",
        )?;
        for (name, value, lo, hi, default) in [
            ("tracker.baseline_frames", self.baseline_frames, 1, 120, 8),
            ("tracker.link_px", self.link_px, 1, 8, 2),
            ("tracker.min_pixels", self.min_pixels, 1, 10_000, 4),
            ("tracker.standing_min_pixels", self.standing_min_pixels, 1, 10_000, 2),
            ("tracker.hold_frames", self.hold_frames, 0, 1_000, 6),
            ("tracker.confirm_frames", self.confirm_frames, 1, 1_000, 30),
            ("tracker.fit_frames", self.fit_frames, 1, 1_000, 45),
            ("tracker.background_frames", self.background_frames, 1, 100_000, 60),
        ] {
            if !(lo..=hi).contains(&value) {
                return Err(DetectorError::InvalidParameter {
                    name,
                    value: value.to_string(),
                    reason: format!("it must be an integer in {lo}..={hi} (default {default})"),
                });
            }
        }
        Ok(())
    }
}

impl DetectorConfig for TrackerConfig {
    fov_from_camera!();

    fn validate(&self) -> Result<(), DetectorError> {
        TrackerConfig::validate(self)
    }

    fn build(&self, _n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        Ok(Box::new(Tracker::new(*self)?))
    }
}

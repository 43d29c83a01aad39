//! SOC — the spatial sum of absolute temporal contrast (detector id `soc`).
//!
//! Keil 2025, caption of Fig. `FigApproachCurves`: `SOC(t) = Σ_ij |F_ij(t) − F_ij(t−1)|`.
//! It is the common input of the three "SOC-based" baselines and tracks the angular
//! velocity of an approaching object when there is no background motion.
//! Frame 0 has no previous frame and reports 0 (docs/detectors.md, common §2).

use serde::Deserialize;

use super::common::{FrameStep, PreviousFrame, Range, check, zeroed};
use crate::registry::{DetectorConfig, Registration, Signal};
use crate::{Detector, DetectorError, EfferenceCopy, Frame, Signals};

/// How the absolute temporal contrast is pooled over the frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SocPooling {
    /// `Σ_ij |P_ij|` — Keil's definition (grows with the frame size, N = n² pixels).
    #[default]
    Sum,
    /// `Σ_ij |P_ij| / n²` — frame-size independent, in [0, 1].
    Mean,
}

/// Parameters of [`Soc`].
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SocConfig {
    /// Sum (Keil's definition, default) or mean over the frame.
    pub pooling: SocPooling,
    /// Take the temporal contrast against the previous frame warped to the current view by the
    /// robot's own motion (its efference copy; `crate::compensation`) instead of the plain previous
    /// frame, so that the static world's image motion cancels. Default false: the paper's model.
    pub compensate: bool,
    /// Full field of view of the camera (degrees), for `compensate`: from `world.camera`, never a
    /// param. Default 60.
    pub fov_deg: f64,
}

impl Default for SocConfig {
    fn default() -> Self {
        Self {
            pooling: SocPooling::Sum,
            compensate: false,
            fov_deg: 60.0,
        }
    }
}

impl SocConfig {
    /// Checks the field of view (the error names it, its range and its default).
    pub fn validate(&self) -> Result<(), DetectorError> {
        check("soc.fov_deg", self.fov_deg, Range::Closed(0.5, 170.0), 60.0, "the camera's field of view")?;
        Ok(())
    }
}

/// Sum of absolute temporal contrast (see the module docs).
///
/// `output` is the pooled contrast per [`SocConfig::pooling`]; `aux` holds
/// `mean` (= Σ|P|/n², whatever the pooling).
#[derive(Debug, Clone)]
pub struct Soc {
    config: SocConfig,
    prev: PreviousFrame,
    contrast: Vec<f64>,
}

impl Soc {
    /// Builds the model after validating `config`. The first frame fixes n.
    pub fn new(config: SocConfig) -> Result<Self, DetectorError> {
        config.validate()?;
        Ok(Self {
            config,
            prev: PreviousFrame::compensated(config.compensate, config.fov_deg),
            contrast: Vec::new(),
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &SocConfig {
        &self.config
    }

    fn signals(output: f64, mean: f64) -> Signals {
        Signals {
            output,
            angular_size_deg: None,
            aux: vec![("mean", mean)],
            region: None,
            objects: Vec::new(),
        }
    }
}

impl Detector for Soc {
    fn id(&self) -> &'static str {
        "soc"
    }

    fn snapshot(&self) -> Option<Box<dyn Detector>> {
        Some(Box::new(self.clone()))
    }

    fn reset(&mut self) {
        self.prev.reset();
    }

    fn step_moving(&mut self, frame: &Frame, ego: &EfferenceCopy) -> Result<Signals, DetectorError> {
        self.prev.set_motion(ego);
        self.step(frame)
    }

    fn step(&mut self, frame: &Frame) -> Result<Signals, DetectorError> {
        let n = match self.prev.begin(frame)? {
            FrameStep::First(n) => {
                zeroed(&mut self.contrast, n * n);
                return Ok(Self::signals(0.0, 0.0));
            }
            FrameStep::Next(n) => n,
        };
        let sum = self.prev.contrast_into(frame, 1.0, &mut self.contrast);
        let mean = sum / (n * n) as f64;
        let output = match self.config.pooling {
            SocPooling::Sum => sum,
            SocPooling::Mean => mean,
        };
        Ok(Self::signals(output, mean))
    }
}

impl DetectorConfig for SocConfig {
    fov_from_camera!();

    fn validate(&self) -> Result<(), DetectorError> {
        SocConfig::validate(self)
    }

    fn build(&self, _n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        Ok(Box::new(Soc::new(*self)?))
    }
}

/// `soc` in the registry. The default threshold (output units) is calibrated on held-out draws
/// of the default suite (`loomlab run --seed 7 --calibrate 0.1`: the smallest threshold, rounded up
/// to three significant digits, with at most 10 % false alarms over its non-threat episodes; see
/// `scenarios/README.md`).
pub(crate) fn registration() -> Registration {
    Registration::of::<SocConfig>(
        "soc",
        "Sum of absolute temporal contrast (Keil 2025, Fig. FigApproachCurves)",
        &[Signal::Output],
        Signal::Output,
        270.0,
    )
}

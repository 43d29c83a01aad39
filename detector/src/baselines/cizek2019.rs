//! "CizFai19" — Čížek & Faigl (2019) LGMD1 with Keil's adaptive thresholds, detector id `cizek2019`.
//!
//! Keil 2025 implemented Čížek & Faigl's Eqs. 7–11 (photoreceptor … summation layer),
//! dropped their fixed threshold (their Eq. 12) and added two adaptive thresholds
//! (Keil 2025 Eqs. `EqCizekFaigl19a–c`, exact; docs/detectors.md#cizek2019). Čížek & Faigl's own text
//! could not be read, so **the presynaptic chain is the standard LGMD1 P→E→I→S form**
//! (Yue & Rind 2006; kernel from Fu's `LGMDSingle.cs`), docs/detectors.md, cizek2019 §1–§2. **Unverified:**
//! the value of `W_I` (0.6 assumed), signed vs absolute P/S (signed by default;
//! [`Cizek2019Config::absolute_summation`] gives the other reading), border handling
//! (clamp-to-edge).
//!
//! Per frame t ≥ 1 (docs/detectors.md, cizek2019 §2):
//! 1. photoreceptors `P_t = F_t − F_{t−1}` (Č&F Eq. 7), excitation `E_t = P_t`;
//! 2. lateral inhibition `I_t = w_I ⋆ P_{t−1}` (3×3, centre 0, nearest 1/4, diagonal 1/8,
//!    clamp-to-edge; `P_0 := 0`);
//! 3. summation `S_t = E_t − W_I·I_t` (Č&F Eq. 11);
//! 4. cell threshold `T_s = LP[mean|P_t|, α_s]` (Eq. `EqCizekFaigl19a`); `S ← 0` where `S ≤ 2·T_s`;
//! 5. membrane potential `ẑ = mean|S|`;
//! 6. output gate `T_l = LP[ẑ, α_l]` (Eq. `EqCizekFaigl19c`); `z = ẑ` if `ẑ > 0.95·T_l`, else 0
//!    (Eq. `EqCizekFaigl19b`).
//!
//! Both lowpasses update first, then compare (docs/detectors.md, common §3). Frame 0 only stores the
//! frame and reports 0 (common §2).

use serde::Deserialize;

use super::common::{FrameStep, PreviousFrame, Range, check, zeroed};
use super::lowpass::LowPass;
use super::stencil::{SymKernel, corr3_rows};
use crate::registry::{DetectorConfig, Registration, Signal};
use crate::{Detector, DetectorError, EfferenceCopy, Frame, Signals};

/// The 3×3 lateral-inhibition kernel `w_I` (docs/detectors.md, cizek2019 §2; sum 1.5, centre 0).
const INHIBITION_KERNEL: SymKernel = SymKernel {
    centre: 0.0,
    near: 0.25,
    diag: 0.125,
};

/// Parameters of [`Cizek2019`]. Defaults: docs/detectors.md, cizek2019 §3.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Cizek2019Config {
    /// `W_I`: weight of the lateral inhibition in `S = E − W_I·I`, ≥ 0. Default 0.6
    /// (assumed: Fu's Yue & Rind implementation; Čížek & Faigl's value unknown).
    pub w_i: f64,
    /// `α_s`: memory of the cell-threshold lowpass `T_s`, in [0, 1). Keil 2025: 0.75.
    pub alpha_s: f64,
    /// Summation cells with `S ≤ threshold_factor·T_s` are zeroed, ≥ 0. Keil 2025: 2.
    pub threshold_factor: f64,
    /// `α_l`: memory of the output-gate lowpass `T_l`, in [0, 1). Keil 2025: 0.75.
    pub alpha_l: f64,
    /// The output passes only if `ẑ > gate_factor·T_l`, ≥ 0. Keil 2025: 0.95.
    pub gate_factor: f64,
    /// `false` (default): signed S, the literal reading (thresholding also deletes every
    /// negative S). `true`: `S ← |S|` before thresholding (symmetric dark/light responses),
    /// docs/detectors.md, cizek2019 §6.
    pub absolute_summation: bool,
    /// Take the temporal contrast against the previous frame warped to the current view by the
    /// robot's own motion (its efference copy; `crate::compensation`) instead of the plain previous
    /// frame, so that the static world's image motion cancels. Default false: the paper's model.
    pub compensate: bool,
    /// Full field of view of the camera (degrees), for `compensate`: from `world.camera`, never a
    /// param. Default 60.
    pub fov_deg: f64,
}

impl Default for Cizek2019Config {
    fn default() -> Self {
        Self {
            w_i: 0.6,
            alpha_s: 0.75,
            threshold_factor: 2.0,
            alpha_l: 0.75,
            gate_factor: 0.95,
            absolute_summation: false,
            compensate: false,
            fov_deg: 60.0,
        }
    }
}

impl Cizek2019Config {
    /// Checks every parameter against its valid range.
    pub fn validate(&self) -> Result<(), DetectorError> {
        check("cizek2019.fov_deg", self.fov_deg, Range::Closed(0.5, 170.0), 60.0, "the camera's field of view")?;
        let d = Self::default();
        check(
            "cizek2019.w_i",
            self.w_i,
            Range::NonNegative,
            d.w_i,
            "weight of the lateral inhibition",
        )?;
        check(
            "cizek2019.alpha_s",
            self.alpha_s,
            Range::ClosedOpen(0.0, 1.0),
            d.alpha_s,
            "memory of the cell-threshold lowpass T_s",
        )?;
        check(
            "cizek2019.threshold_factor",
            self.threshold_factor,
            Range::NonNegative,
            d.threshold_factor,
            "summation cells S <= threshold_factor·T_s are zeroed",
        )?;
        check(
            "cizek2019.alpha_l",
            self.alpha_l,
            Range::ClosedOpen(0.0, 1.0),
            d.alpha_l,
            "memory of the output-gate lowpass T_l",
        )?;
        check(
            "cizek2019.gate_factor",
            self.gate_factor,
            Range::NonNegative,
            d.gate_factor,
            "the output passes only if z_hat > gate_factor·T_l",
        )
    }
}

/// "CizFai19" looming model, see the module docs.
///
/// `output` = z; `aux` = `z_hat` (membrane potential before the gate), `t_s` (cell
/// threshold `T_s`), `t_l` (output-gate threshold `T_l`).
#[derive(Debug, Clone)]
pub struct Cizek2019 {
    config: Cizek2019Config,
    prev: PreviousFrame,
    /// `P_t` of this frame.
    contrast: Vec<f64>,
    /// `P_{t−1}` (0 before the second frame).
    prev_contrast: Vec<f64>,
    /// One row of the inhibition `I_t`.
    row: Vec<f64>,
    cell_threshold: LowPass,
    gate_threshold: LowPass,
}

impl Cizek2019 {
    /// Builds the model after validating `config`. The first frame fixes n.
    pub fn new(config: Cizek2019Config) -> Result<Self, DetectorError> {
        config.validate()?;
        Ok(Self {
            config,
            prev: PreviousFrame::compensated(config.compensate, config.fov_deg),
            contrast: Vec::new(),
            prev_contrast: Vec::new(),
            row: Vec::new(),
            cell_threshold: LowPass::new(config.alpha_s),
            gate_threshold: LowPass::new(config.alpha_l),
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &Cizek2019Config {
        &self.config
    }

    fn signals(z: f64, z_hat: f64, t_s: f64, t_l: f64) -> Signals {
        Signals {
            output: z,
            angular_size_deg: None,
            aux: vec![("z_hat", z_hat), ("t_s", t_s), ("t_l", t_l)],
            region: None,
            objects: Vec::new(),
        }
    }
}

impl Detector for Cizek2019 {
    fn id(&self) -> &'static str {
        "cizek2019"
    }

    fn snapshot(&self) -> Option<Box<dyn Detector>> {
        Some(Box::new(self.clone()))
    }

    fn reset(&mut self) {
        self.prev.reset();
        self.cell_threshold.reset();
        self.gate_threshold.reset();
    }

    fn step_moving(&mut self, frame: &Frame, ego: &EfferenceCopy) -> Result<Signals, DetectorError> {
        self.prev.set_motion(ego);
        self.step(frame)
    }

    fn step(&mut self, frame: &Frame) -> Result<Signals, DetectorError> {
        let n = match self.prev.begin(frame)? {
            FrameStep::First(n) => {
                zeroed(&mut self.contrast, n * n);
                zeroed(&mut self.prev_contrast, n * n);
                zeroed(&mut self.row, n);
                return Ok(Self::signals(0.0, 0.0, 0.0, 0.0));
            }
            FrameStep::Next(n) => n,
        };
        let count = (n * n) as f64;
        // 1. photoreceptors P_t and the cell threshold T_s (Eq. EqCizekFaigl19a).
        let sum_abs = self.prev.contrast_into(frame, 1.0, &mut self.contrast);
        let t_s = self.cell_threshold.update(sum_abs / count);
        let cut = self.config.threshold_factor * t_s;
        let (w_i, absolute) = (self.config.w_i, self.config.absolute_summation);
        // 2.–5. inhibition from P_{t−1}, summation, thresholding and pooling in one pass.
        let contrast = &self.contrast;
        let mut sum_s = 0.0;
        corr3_rows(
            n,
            INHIBITION_KERNEL,
            &self.prev_contrast,
            &mut self.row,
            |start, inhibition| {
                for (&p, &inh) in contrast[start..start + n].iter().zip(inhibition) {
                    let mut s = p - w_i * inh;
                    if absolute {
                        s = s.abs();
                    }
                    if s > cut {
                        sum_s += s.abs();
                    }
                }
            },
        );
        std::mem::swap(&mut self.contrast, &mut self.prev_contrast);
        let z_hat = sum_s / count;
        // 6. adaptive output gate (Eqs. EqCizekFaigl19b, EqCizekFaigl19c).
        let t_l = self.gate_threshold.update(z_hat);
        let z = if z_hat > self.config.gate_factor * t_l {
            z_hat
        } else {
            0.0
        };
        Ok(Self::signals(z, z_hat, t_s, t_l))
    }
}

impl DetectorConfig for Cizek2019Config {
    fov_from_camera!();

    fn validate(&self) -> Result<(), DetectorError> {
        Cizek2019Config::validate(self)
    }

    fn build(&self, _n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        Ok(Box::new(Cizek2019::new(*self)?))
    }
}

/// `cizek2019` in the registry. The default threshold (output units) is calibrated on held-out draws
/// of the default suite (`loomlab run --seed 7 --calibrate 0.1`: the smallest threshold, rounded up
/// to three significant digits, with at most 10 % false alarms over its non-threat episodes; see
/// `scenarios/README.md`).
pub(crate) fn registration() -> Registration {
    Registration::of::<Cizek2019Config>(
        "cizek2019",
        "LGMD of Čížek & Faigl 2019 with Keil's adaptive thresholds",
        &[Signal::Output],
        Signal::Output,
        0.0172,
    )
}

//! "Advanced" — Keil, Roca-Moreno & Rodríguez-Vázquez (2004), detector id `keil2004`.
//!
//! **Front end RECONSTRUCTED.** The 2004 model equations could not be retrieved; this is
//! reconstruction R-A of docs/detectors.md, keil2004 §2, built from what Keil 2025 says about the model
//! (ON/OFF temporal-contrast channels, self-limiting diffusion layers whose persistent
//! inhibition curtails the excitation that feeds them, half-wave rectified channel
//! activities that can be exactly zero). Only the output stage is exact: Keil 2025
//! Eq. `EqSigmaPi` with ε = 0.001, α = 0.5 (docs/detectors.md, common §6). Label results as
//! "Advanced (reconstructed)".
//!
//! Per frame t ≥ 1 (docs/detectors.md, keil2004 §2), for each channel c ∈ {on, off}:
//! 1. excitation `e_on = [P_t]^+`, `e_off = [−P_t]^+` with `P_t = F_t − F_{t−1}`;
//! 2. curtailed excitation `x_c = [e_c − V_c(t−1)]^+`;
//! 3. lateral spread: `U ← x_c`, then `K` Jacobi steps `U ← U + κ·Δ₅U` (5-point Laplacian,
//!    clamp-to-edge = zero-flux borders);
//! 4. persistent inhibition `V_c(t) = a_V·V_c(t−1) + b·U`;
//! 5. channel activity `z_c = mean_ij x_c` (mean pooling, docs/detectors.md, keil2004 §6);
//!
//! and the output `z = LP[z_on·z_off + ε(z_on + z_off), α]` (Eq. `EqSigmaPi`).
//! Frame 0 only stores the frame and reports 0 (docs/detectors.md, common §2).

use serde::Deserialize;

use super::common::{FrameStep, PreviousFrame, Range, check, zeroed};
use super::lowpass::LowPass;
use super::stencil::diffuse_step;
use crate::registry::{DetectorConfig, Registration, Signal};
use crate::{Detector, DetectorError, EfferenceCopy, Frame, Signals};

/// Parameters of [`Keil2004`]. Defaults: docs/detectors.md, keil2004 §3.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Keil2004Config {
    /// `a_V`: per-frame persistence of the inhibition (diffusion) layer, in [0, 1).
    /// Reconstruction default 0.7 (≈ 2.8-frame time constant).
    pub a_v: f64,
    /// `b`: gain of new inhibition, ≥ 0. Reconstruction default 1.0.
    pub b: f64,
    /// `κ`: diffusion step, in [0, 0.25] (explicit-Euler stability). Reconstruction default 0.2.
    pub kappa: f64,
    /// `K`: diffusion iterations per frame, 0…1000. Reconstruction default 10.
    pub iterations: usize,
    /// `ε` of Eq. `EqSigmaPi` (single-polarity fallback), ≥ 0. Exact (Keil 2025): 0.001.
    pub epsilon: f64,
    /// `α`: memory of the output lowpass, in [0, 1). Exact (Keil 2025): 0.5.
    pub alpha: f64,
    /// Take the temporal contrast against the previous frame warped to the current view by the
    /// robot's own motion (its efference copy; `crate::compensation`) instead of the plain previous
    /// frame, so that the static world's image motion cancels. Default false: the paper's model.
    pub compensate: bool,
    /// Full field of view of the camera (degrees), for `compensate`: from `world.camera`, never a
    /// param. Default 60.
    pub fov_deg: f64,
}

impl Default for Keil2004Config {
    fn default() -> Self {
        Self {
            a_v: 0.7,
            b: 1.0,
            kappa: 0.2,
            iterations: 10,
            epsilon: 0.001,
            alpha: 0.5,
            compensate: false,
            fov_deg: 60.0,
        }
    }
}

/// Largest accepted number of diffusion iterations per frame.
pub const KEIL2004_MAX_ITERATIONS: usize = 1000;

impl Keil2004Config {
    /// Checks every parameter against its valid range.
    pub fn validate(&self) -> Result<(), DetectorError> {
        check("keil2004.fov_deg", self.fov_deg, Range::Closed(0.5, 170.0), 60.0, "the camera's field of view")?;
        let d = Self::default();
        check(
            "keil2004.a_v",
            self.a_v,
            Range::ClosedOpen(0.0, 1.0),
            d.a_v,
            "per-frame persistence of the inhibition layer",
        )?;
        check("keil2004.b", self.b, Range::NonNegative, d.b, "gain of new inhibition")?;
        check(
            "keil2004.kappa",
            self.kappa,
            Range::Closed(0.0, 0.25),
            d.kappa,
            "diffusion step (the explicit scheme is unstable above 0.25)",
        )?;
        if self.iterations > KEIL2004_MAX_ITERATIONS {
            return Err(DetectorError::InvalidParameter {
                name: "keil2004.iterations",
                value: self.iterations.to_string(),
                reason: format!(
                    "diffusion iterations per frame; it must be an integer in [0, {KEIL2004_MAX_ITERATIONS}] \
                     (spec default {})",
                    d.iterations
                ),
            });
        }
        check(
            "keil2004.epsilon",
            self.epsilon,
            Range::NonNegative,
            d.epsilon,
            "weight of the single-polarity term of Eq. EqSigmaPi",
        )?;
        check(
            "keil2004.alpha",
            self.alpha,
            Range::ClosedOpen(0.0, 1.0),
            d.alpha,
            "memory of the output lowpass",
        )
    }
}

/// Per-channel state: the inhibition (diffusion) layer `V_c`.
#[derive(Debug, Clone, Default)]
struct Channel {
    inhibition: Vec<f64>,
}

/// "Advanced" looming model (reconstruction R-A), see the module docs.
///
/// `output` = z; `aux` = `z_on`, `z_off` (the channel activities before combination).
#[derive(Debug, Clone)]
pub struct Keil2004 {
    config: Keil2004Config,
    prev: PreviousFrame,
    contrast: Vec<f64>,
    /// Curtailed excitation `x_c`, then the diffusion buffer `U`.
    spread: Vec<f64>,
    /// Second buffer for the Jacobi iteration.
    scratch: Vec<f64>,
    on: Channel,
    off: Channel,
    output: LowPass,
}

impl Keil2004 {
    /// Builds the model after validating `config`. The first frame fixes n.
    pub fn new(config: Keil2004Config) -> Result<Self, DetectorError> {
        config.validate()?;
        Ok(Self {
            config,
            prev: PreviousFrame::compensated(config.compensate, config.fov_deg),
            contrast: Vec::new(),
            spread: Vec::new(),
            scratch: Vec::new(),
            on: Channel::default(),
            off: Channel::default(),
            output: LowPass::new(config.alpha),
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &Keil2004Config {
        &self.config
    }

    fn signals(z: f64, z_on: f64, z_off: f64) -> Signals {
        Signals {
            output: z,
            angular_size_deg: None,
            aux: vec![("z_on", z_on), ("z_off", z_off)],
            region: None,
            objects: Vec::new(),
        }
    }

    /// Steps 1–5 of the module docs for one channel; `sign` = +1 (ON) or −1 (OFF).
    fn channel_step(&mut self, n: usize, sign: f64, off_channel: bool) -> f64 {
        let Self {
            config,
            contrast,
            spread,
            scratch,
            on,
            off,
            ..
        } = self;
        let channel = if off_channel { off } else { on };
        // 1.–2. curtailed excitation x = [[sign·P]^+ − V]^+, and its mean.
        let mut sum = 0.0;
        for ((x, &p), &v) in spread.iter_mut().zip(contrast.iter()).zip(&channel.inhibition) {
            let e = (sign * p).max(0.0);
            let xc = (e - v).max(0.0);
            *x = xc;
            sum += xc;
        }
        // 3. lateral spread by K Jacobi diffusion steps (ping-pong between the two buffers).
        for _ in 0..config.iterations {
            diffuse_step(n, config.kappa, spread, scratch);
            std::mem::swap(spread, scratch);
        }
        // 4. persistent inhibition.
        let (a_v, b) = (config.a_v, config.b);
        for (v, &u) in channel.inhibition.iter_mut().zip(spread.iter()) {
            *v = a_v * *v + b * u;
        }
        // 5. mean pooling.
        sum / (n * n) as f64
    }
}

impl Detector for Keil2004 {
    fn id(&self) -> &'static str {
        "keil2004"
    }

    fn snapshot(&self) -> Option<Box<dyn Detector>> {
        Some(Box::new(self.clone()))
    }

    fn reset(&mut self) {
        self.prev.reset();
        self.output.reset();
    }

    fn step_moving(&mut self, frame: &Frame, ego: &EfferenceCopy) -> Result<Signals, DetectorError> {
        self.prev.set_motion(ego);
        self.step(frame)
    }

    fn step(&mut self, frame: &Frame) -> Result<Signals, DetectorError> {
        let n = match self.prev.begin(frame)? {
            FrameStep::First(n) => {
                let len = n * n;
                for buf in [
                    &mut self.contrast,
                    &mut self.spread,
                    &mut self.scratch,
                    &mut self.on.inhibition,
                    &mut self.off.inhibition,
                ] {
                    zeroed(buf, len);
                }
                return Ok(Self::signals(0.0, 0.0, 0.0));
            }
            FrameStep::Next(n) => n,
        };
        self.prev.contrast_only(frame, 1.0, &mut self.contrast);
        let z_on = self.channel_step(n, 1.0, false);
        let z_off = self.channel_step(n, -1.0, true);
        let z = self.output.update(z_on * z_off + self.config.epsilon * (z_on + z_off));
        Ok(Self::signals(z, z_on, z_off))
    }
}

impl DetectorConfig for Keil2004Config {
    fov_from_camera!();

    fn validate(&self) -> Result<(), DetectorError> {
        Keil2004Config::validate(self)
    }

    fn build(&self, _n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        Ok(Box::new(Keil2004::new(*self)?))
    }
}

/// `keil2004` in the registry. The default threshold (output units) is calibrated on held-out draws
/// of the default suite (`loomlab run --seed 7 --calibrate 0.1`: the smallest threshold, rounded up
/// to three significant digits, with at most 10 % false alarms over its non-threat episodes; see
/// `scenarios/README.md`).
pub(crate) fn registration() -> Registration {
    Registration::of::<Keil2004Config>(
        "keil2004",
        "\"Advanced\" LGMD model of Keil, Roca-Moreno & Rodríguez-Vázquez 2004",
        &[Signal::Output],
        Signal::Output,
        0.000095,
    )
}

//! "FuHuPe20" — LGMD2 of Fu, Hu, Peng, Rind & Yue (2020), two instances combined as in
//! Keil 2025; detector id `fu2020`.
//!
//! One LGMD2 instance follows the authors' reference code (`fuqinbing/LGMD2-open-source`,
//! `lgmd2OpenSource.cs`, the supplement of the T-Cyb paper), layer by layer as restated in
//! docs/detectors.md, fu2020 §2; every constant is from that code (fu2020 §3). The paper text itself was
//! not read, so minor paper/code differences cannot be excluded (fu2020 §1).
//!
//! Keil's wrapper (Keil 2025 subsection "FuHuPe20"; docs/detectors.md, fu2020 §2):
//! * temporal contrast in 8-bit units `P_t = 255·(F_t − F_{t−1})` (float, not rounded);
//! * instance OFF (the original, dark-selective LGMD2) is fed `+P_t`, its spike count is
//!   `z_off`; instance ON, an independent copy, is fed `−P_t`, its spike count is `z_on`;
//! * output `z = LP[z_on·z_off + ε(z_on + z_off), α]` (Eq. `EqSigmaPi`), ε = 0.05, α = 0.75;
//! * the model frame rate is fixed at 120 Hz whatever the video's rate.
//!
//! One instance per frame (input `P`, docs/detectors.md, fu2020 §2): photoreceptor mediation
//! `pm = LP(mean|P|)` → adaptive inhibition biases `W_i,on = max(pm/T_pm, 1)`,
//! `W_i,off = max(pm/T_pm, 0.5)`; ON/OFF half-wave rectifiers with residual term
//! (`ON = 1[P ≥ c]·P + d·ON_prev`, `OFF = 1[P < c]·|P| + d·OFF_prev`, the asymmetry of the code
//! kept); spatiotemporal 3×3 lateral inhibition mixing current and previous ON/OFF with
//! position-dependent delays; summation `S = S_on + S_off + S_on·S_off` of the rectified
//! `ON − W_i,on·I_on`, `OFF − W_i,off·I_off`; grouping `G = S·C_e/ω` with `C_e` the 3×3 mean of
//! `S` and `ω = Δ_C + max|C_e|/C_w`, kept where `C_de·G ≥ T_de`; membrane potential
//! `mp = ΣG`, `smp = 1/(1 + exp(−mp/(N·C_sig)))`; spike-frequency adaptation; spikes
//! `⌊exp(C_spi·(sfa − T_sp))⌋` (Keil's "equation 27"). The onset artefact of the code
//! (`smp_prev` starts at 0, so motion in the first frames can spike) is kept on purpose
//! (docs/detectors.md, fu2020 §6). Frame 0 only stores the frame and reports 0 (common §2).

use serde::Deserialize;

use super::common::{FrameStep, PreviousFrame, Range, check, check3, zeroed};
use super::lowpass::LowPass;
use super::stencil::{SymKernel, corr3_classes_rows, corr3_rows, max_abs};
use crate::registry::{DetectorConfig, Registration, Signal};
use crate::simd::simd_dispatch;
use crate::{Detector, DetectorError, EfferenceCopy, Frame, Signals};

/// Parameters of [`Fu2020`]. Defaults: docs/detectors.md, fu2020 §3 (all from `lgmd2OpenSource.cs`,
/// ε and α from Keil 2025). Triples are ordered (centre, nearest, diagonal).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Fu2020Config {
    /// Model frame rate in Hz (fixed by Keil at 120 whatever the video's rate).
    pub fps_model: f64,
    /// `true`: frame interval `⌊1000/fps_model⌋` ms, the integer division of the C# code
    /// (8 ms at 120 Hz); `false` (default, recommended in docs/detectors.md, fu2020 §6): `1000/fps_model`.
    pub integer_frame_interval: bool,
    /// ON-pathway inhibition delays τ_on (centre, nearest, diagonal), ms: 15, 30, 45.
    pub tau_on: [f64; 3],
    /// OFF-pathway inhibition delays τ_off (centre, nearest, diagonal), ms: 60, 120, 180.
    pub tau_off: [f64; 3],
    /// Photoreceptor-mediation lowpass time constant τ_PM, ms: 90.
    pub tau_pm: f64,
    /// Spike-frequency-adaptation highpass time constant τ_sfa, ms: 800.
    pub tau_sfa: f64,
    /// `T_pm`: divisor turning `pm` into the inhibition biases: 8.
    pub t_pm: f64,
    /// Floor of the adaptive ON inhibition bias `W_i,on`: 1.0.
    pub w_i_on_base: f64,
    /// Floor of the adaptive OFF inhibition bias `W_i,off`: 0.5.
    pub w_i_off_base: f64,
    /// Clip point `c` of the ON/OFF rectifiers (P units): 0.1.
    pub clip_point: f64,
    /// Residual (DC) proportion `d` of the previous ON/OFF value, in [0, 1): 0.1.
    pub dc: f64,
    /// Weight of the local ON excitation in the summation layer: 1.
    pub w_on: f64,
    /// Weight of the local OFF excitation in the summation layer: 1.
    pub w_off: f64,
    /// Weight of the ON·OFF interaction term in the summation layer: 1.
    pub w_onoff: f64,
    /// ON inhibition kernel (centre, nearest, diagonal): 2, 0.5, 0.25.
    pub kernel_on: [f64; 3],
    /// OFF inhibition kernel (centre, nearest, diagonal): 1, 0.25, 0.125.
    pub kernel_off: [f64; 3],
    /// `C_w`: grouping scale divisor: 4.
    pub c_w: f64,
    /// `Δ_C`: small constant of the grouping scale ω (> 0, keeps ω > 0): 0.01.
    pub delta_c: f64,
    /// `C_de`: grouping decay coefficient: 0.5.
    pub c_de: f64,
    /// `T_de`: grouping threshold (a cell is kept if `C_de·G ≥ T_de`): 15.
    pub t_de: f64,
    /// `C_sig`: sigmoid coefficient: 1.
    pub c_sig: f64,
    /// `T_sfa`: SFA threshold: 0.003.
    pub t_sfa: f64,
    /// `C_spi`: spike-mapping scale: 4.
    pub c_spi: f64,
    /// `T_sp`: spiking threshold: 0.78.
    pub t_sp: f64,
    /// `N_ts`: spikes in a run that raise the (optional) collision flag: 8.
    pub n_ts: u32,
    /// Scale of the temporal contrast fed to the instances (Keil: 255, 8-bit units).
    pub contrast_scale: f64,
    /// `ε` of Eq. `EqSigmaPi`: 0.05 (Keil 2025).
    pub epsilon: f64,
    /// `α`: memory of the output lowpass, in [0, 1): 0.75 (Keil 2025).
    pub alpha: f64,
    /// Take the temporal contrast against the previous frame warped to the current view by the
    /// robot's own motion (its efference copy; `crate::compensation`) instead of the plain previous
    /// frame, so that the static world's image motion cancels. Default false: the paper's model.
    pub compensate: bool,
    /// Full field of view of the camera (degrees), for `compensate`: from `world.camera`, never a
    /// param. Default 60.
    pub fov_deg: f64,
}

impl Default for Fu2020Config {
    fn default() -> Self {
        Self {
            fps_model: 120.0,
            integer_frame_interval: false,
            tau_on: [15.0, 30.0, 45.0],
            tau_off: [60.0, 120.0, 180.0],
            tau_pm: 90.0,
            tau_sfa: 800.0,
            t_pm: 8.0,
            w_i_on_base: 1.0,
            w_i_off_base: 0.5,
            clip_point: 0.1,
            dc: 0.1,
            w_on: 1.0,
            w_off: 1.0,
            w_onoff: 1.0,
            kernel_on: [2.0, 0.5, 0.25],
            kernel_off: [1.0, 0.25, 0.125],
            c_w: 4.0,
            delta_c: 0.01,
            c_de: 0.5,
            t_de: 15.0,
            c_sig: 1.0,
            t_sfa: 0.003,
            c_spi: 4.0,
            t_sp: 0.78,
            n_ts: 8,
            contrast_scale: 255.0,
            epsilon: 0.05,
            alpha: 0.75,
            compensate: false,
            fov_deg: 60.0,
        }
    }
}

/// Per-frame coefficients derived from the time constants (docs/detectors.md, common §5):
/// lowpass gain `a(τ) = Δt/(Δt + τ)`, highpass factor `h(τ) = τ/(τ + Δt)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fu2020Coefficients {
    /// Frame interval Δt in ms.
    pub frame_interval_ms: f64,
    /// `a(τ_on)` for centre, nearest, diagonal (0.357143, 0.217391, 0.156250 at 120 Hz).
    pub a_on: [f64; 3],
    /// `a(τ_off)` for centre, nearest, diagonal (0.121951, 0.064935, 0.044248 at 120 Hz).
    pub a_off: [f64; 3],
    /// `a(τ_PM)` (0.084746 at 120 Hz).
    pub a_pm: f64,
    /// `h(τ_sfa)` (0.989691 at 120 Hz).
    pub h_sfa: f64,
}

impl Fu2020Config {
    /// Checks every parameter against its valid range.
    pub fn validate(&self) -> Result<(), DetectorError> {
        check("fu2020.fov_deg", self.fov_deg, Range::Closed(0.5, 170.0), 60.0, "the camera's field of view")?;
        let d = Self::default();
        check(
            "fu2020.fps_model",
            self.fps_model,
            Range::Positive,
            d.fps_model,
            "model frame rate in Hz",
        )?;
        if self.integer_frame_interval && self.fps_model > 1000.0 {
            return Err(DetectorError::InvalidParameter {
                name: "fu2020.fps_model",
                value: format!("{}", self.fps_model),
                reason: "with integer_frame_interval = true the frame interval ⌊1000/fps_model⌋ ms would be 0; \
                         use fps_model <= 1000 or integer_frame_interval = false"
                    .into(),
            });
        }
        let tau = "time constants in ms";
        check3("fu2020.tau_on", self.tau_on, Range::NonNegative, d.tau_on, tau)?;
        check3("fu2020.tau_off", self.tau_off, Range::NonNegative, d.tau_off, tau)?;
        check("fu2020.tau_pm", self.tau_pm, Range::NonNegative, d.tau_pm, tau)?;
        check("fu2020.tau_sfa", self.tau_sfa, Range::NonNegative, d.tau_sfa, tau)?;
        check(
            "fu2020.t_pm",
            self.t_pm,
            Range::Positive,
            d.t_pm,
            "divisor of the photoreceptor mediation",
        )?;
        check(
            "fu2020.w_i_on_base",
            self.w_i_on_base,
            Range::NonNegative,
            d.w_i_on_base,
            "ON inhibition floor",
        )?;
        check(
            "fu2020.w_i_off_base",
            self.w_i_off_base,
            Range::NonNegative,
            d.w_i_off_base,
            "OFF inhibition floor",
        )?;
        check(
            "fu2020.clip_point",
            self.clip_point,
            Range::Finite,
            d.clip_point,
            "ON/OFF clip point",
        )?;
        check(
            "fu2020.dc",
            self.dc,
            Range::ClosedOpen(0.0, 1.0),
            d.dc,
            "residual proportion of ON/OFF",
        )?;
        check("fu2020.w_on", self.w_on, Range::NonNegative, d.w_on, "summation weight")?;
        check(
            "fu2020.w_off",
            self.w_off,
            Range::NonNegative,
            d.w_off,
            "summation weight",
        )?;
        check(
            "fu2020.w_onoff",
            self.w_onoff,
            Range::NonNegative,
            d.w_onoff,
            "summation weight",
        )?;
        check3(
            "fu2020.kernel_on",
            self.kernel_on,
            Range::NonNegative,
            d.kernel_on,
            "ON inhibition kernel",
        )?;
        check3(
            "fu2020.kernel_off",
            self.kernel_off,
            Range::NonNegative,
            d.kernel_off,
            "OFF inhibition kernel",
        )?;
        check("fu2020.c_w", self.c_w, Range::Positive, d.c_w, "grouping scale divisor")?;
        check(
            "fu2020.delta_c",
            self.delta_c,
            Range::Positive,
            d.delta_c,
            "grouping scale offset (keeps ω > 0)",
        )?;
        check(
            "fu2020.c_de",
            self.c_de,
            Range::Finite,
            d.c_de,
            "grouping decay coefficient",
        )?;
        check("fu2020.t_de", self.t_de, Range::Finite, d.t_de, "grouping threshold")?;
        check(
            "fu2020.c_sig",
            self.c_sig,
            Range::Positive,
            d.c_sig,
            "sigmoid coefficient",
        )?;
        check("fu2020.t_sfa", self.t_sfa, Range::Finite, d.t_sfa, "SFA threshold")?;
        check(
            "fu2020.c_spi",
            self.c_spi,
            Range::Closed(0.0, 50.0),
            d.c_spi,
            "spike-mapping scale",
        )?;
        check("fu2020.t_sp", self.t_sp, Range::Finite, d.t_sp, "spiking threshold")?;
        if self.n_ts == 0 {
            return Err(DetectorError::InvalidParameter {
                name: "fu2020.n_ts",
                value: "0".into(),
                reason: format!(
                    "spikes that raise the collision flag; it must be an integer >= 1 (spec default {})",
                    d.n_ts
                ),
            });
        }
        check(
            "fu2020.contrast_scale",
            self.contrast_scale,
            Range::Positive,
            d.contrast_scale,
            "scale of the temporal contrast (255 = 8-bit units)",
        )?;
        check(
            "fu2020.epsilon",
            self.epsilon,
            Range::NonNegative,
            d.epsilon,
            "weight of the single-polarity term",
        )?;
        check(
            "fu2020.alpha",
            self.alpha,
            Range::ClosedOpen(0.0, 1.0),
            d.alpha,
            "memory of the output lowpass",
        )
    }

    /// The per-frame coefficients for this configuration (docs/detectors.md, common §5 and fu2020 §3).
    pub fn coefficients(&self) -> Fu2020Coefficients {
        let dt = if self.integer_frame_interval {
            (1000.0 / self.fps_model).floor()
        } else {
            1000.0 / self.fps_model
        };
        let a = |tau: f64| dt / (dt + tau);
        Fu2020Coefficients {
            frame_interval_ms: dt,
            a_on: self.tau_on.map(a),
            a_off: self.tau_off.map(a),
            a_pm: a(self.tau_pm),
            h_sfa: self.tau_sfa / (self.tau_sfa + dt),
        }
    }
}

/// What one LGMD2 instance reports for a frame.
#[derive(Debug, Clone, Copy, Default)]
struct InstanceOutput {
    spikes: f64,
    sfa: f64,
    collision: bool,
}

/// State of one LGMD2 instance (docs/detectors.md, fu2020 §2).
#[derive(Debug, Clone, Default)]
struct Lgmd2 {
    on: Vec<f64>,
    off: Vec<f64>,
    on_prev: Vec<f64>,
    off_prev: Vec<f64>,
    pm: f64,
    smp: f64,
    sfa: f64,
    spike_run: u64,
}

/// Work buffers shared by the two instances (used one after the other).
#[derive(Debug, Clone, Default)]
struct Scratch {
    /// Current/previous ON (or OFF) blended per position class (centre, nearest, diagonal).
    blend: [Vec<f64>; 3],
    /// `S_on`, then the summation layer `S`.
    summation: Vec<f64>,
    /// `C_e`, the 3×3 mean of `S`.
    excitation: Vec<f64>,
    /// One row of a correlation result.
    row: Vec<f64>,
}

/// The constants one instance needs per frame.
#[derive(Debug, Clone, Copy)]
struct Constants {
    cfg: Fu2020Config,
    co: Fu2020Coefficients,
    kernel_on: SymKernel,
    kernel_off: SymKernel,
}

fn sym(k: [f64; 3]) -> SymKernel {
    SymKernel {
        centre: k[0],
        near: k[1],
        diag: k[2],
    }
}

/// `B_k = a_k·cur + (1 − a_k)·prev` for the three position classes.
fn blend(cur: &[f64], prev: &[f64], a: [f64; 3], out: &mut [Vec<f64>; 3]) {
    for (k, o) in out.iter_mut().enumerate() {
        let (ak, bk) = (a[k], 1.0 - a[k]);
        for ((o, &c), &p) in o.iter_mut().zip(cur).zip(prev) {
            *o = ak * c + bk * p;
        }
    }
}

/// Summation-cell rectifier of the reference code: `exc − inh·w`, 0 if ≤ 0.
#[inline(always)]
fn s_cell(exc: f64, inh: f64, w: f64) -> f64 {
    let t = exc - inh * w;
    if t <= 0.0 { 0.0 } else { t }
}

impl Lgmd2 {
    fn allocate(&mut self, len: usize) {
        for b in [&mut self.on, &mut self.off, &mut self.on_prev, &mut self.off_prev] {
            zeroed(b, len);
        }
        self.pm = 0.0;
        self.smp = 0.0;
        self.sfa = 0.0;
        self.spike_run = 0;
    }

}

/// "FuHuPe20" looming model: two LGMD2 instances combined by Eq. `EqSigmaPi`, see the
/// module docs.
///
/// `output` = z (0 ≤ z ≤ 4.2 with the defaults; Keil divides by 2 for plots);
/// `aux` = `z_on`, `z_off` (spike counts of the ON and OFF instances, in {0, 1, 2} with the
/// defaults), `sfa_on`, `sfa_off` (their SFA outputs) and `collision` (1 if either
/// instance's spike run reached `N_ts`, the optional collision flag Keil does not use).
#[derive(Debug, Clone)]
pub struct Fu2020 {
    constants: Constants,
    prev: PreviousFrame,
    contrast: Vec<f64>,
    /// Instance fed with `−P` (light-object, "ON").
    on: Lgmd2,
    /// Instance fed with `+P` (the original dark-object-selective LGMD2, "OFF").
    off: Lgmd2,
    scratch: Scratch,
    output: LowPass,
}

impl Fu2020 {
    /// Builds the model after validating `config`. The first frame fixes n.
    pub fn new(config: Fu2020Config) -> Result<Self, DetectorError> {
        config.validate()?;
        Ok(Self {
            constants: Constants {
                cfg: config,
                co: config.coefficients(),
                kernel_on: sym(config.kernel_on),
                kernel_off: sym(config.kernel_off),
            },
            prev: PreviousFrame::compensated(config.compensate, config.fov_deg),
            contrast: Vec::new(),
            on: Lgmd2::default(),
            off: Lgmd2::default(),
            scratch: Scratch::default(),
            output: LowPass::new(config.alpha),
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &Fu2020Config {
        &self.constants.cfg
    }

    /// The per-frame coefficients in use.
    pub fn coefficients(&self) -> &Fu2020Coefficients {
        &self.constants.co
    }

    fn signals(z: f64, on: InstanceOutput, off: InstanceOutput) -> Signals {
        Signals {
            output: z,
            angular_size_deg: None,
            aux: vec![
                ("z_on", on.spikes),
                ("z_off", off.spikes),
                ("sfa_on", on.sfa),
                ("sfa_off", off.sfa),
                ("collision", f64::from(u8::from(on.collision || off.collision))),
            ],
            region: None,
            objects: Vec::new(),
        }
    }
}

simd_dispatch! {
    /// One frame of docs/detectors.md, fu2020 §2, for the LGMD2 `lgmd` with input `sign·p`
    /// (with AVX-512 or AVX2 where the CPU has it, `crate::simd`).
    fn lgmd2_step(
        lgmd: &mut Lgmd2,
        p: &[f64],
        sign: f64,
        mean_abs_p: f64,
        n: usize,
        k: &Constants,
        s: &mut Scratch,
    ) -> InstanceOutput {
        let (cfg, co) = (&k.cfg, &k.co);
        // 1. photoreceptor mediation and adaptive inhibition biases.
        let pm = co.a_pm * mean_abs_p + (1.0 - co.a_pm) * lgmd.pm;
        let w_i_on = (pm / cfg.t_pm).max(cfg.w_i_on_base);
        let w_i_off = (pm / cfg.t_pm).max(cfg.w_i_off_base);
        // 2. ON/OFF half-wave rectifiers with residual term (asymmetric clip, as in the code).
        let (clip, dc) = (cfg.clip_point, cfg.dc);
        let rect = lgmd
            .on
            .iter_mut()
            .zip(lgmd.off.iter_mut())
            .zip(lgmd.on_prev.iter().zip(&lgmd.off_prev));
        for (((on, off), (&on_p, &off_p)), &pv) in rect.zip(p) {
            let q = sign * pv;
            *on = if q >= clip { q + dc * on_p } else { dc * on_p };
            *off = if q < clip { q.abs() + dc * off_p } else { dc * off_p };
        }
        // 3.–4. spatiotemporal lateral inhibition and local summation cells.
        blend(&lgmd.on, &lgmd.on_prev, co.a_on, &mut s.blend);
        {
            let (on, summation) = (&lgmd.on, &mut s.summation);
            let [bc, bn, bd] = &s.blend;
            corr3_classes_rows(n, k.kernel_on, bc, bn, bd, &mut s.row, |start, inh| {
                let rows = summation[start..start + n].iter_mut().zip(&on[start..start + n]);
                for ((s_on, &exc), &inh) in rows.zip(inh) {
                    *s_on = s_cell(exc, inh, w_i_on);
                }
            });
        }
        blend(&lgmd.off, &lgmd.off_prev, co.a_off, &mut s.blend);
        {
            let (off, summation) = (&lgmd.off, &mut s.summation);
            let [bc, bn, bd] = &s.blend;
            let (w_on, w_off, w_onoff) = (cfg.w_on, cfg.w_off, cfg.w_onoff);
            corr3_classes_rows(n, k.kernel_off, bc, bn, bd, &mut s.row, |start, inh| {
                let rows = summation[start..start + n].iter_mut().zip(&off[start..start + n]);
                for ((sum, &exc), &inh) in rows.zip(inh) {
                    let s_on = *sum;
                    let s_off = s_cell(exc, inh, w_i_off);
                    *sum = w_on * s_on + w_off * s_off + w_onoff * s_on * s_off;
                }
            });
        }
        // 5. grouping layer: C_e, ω, G, threshold; 6. membrane potential.
        let mut max_ce = 0.0f64;
        {
            let excitation = &mut s.excitation;
            let ninth = 1.0 / 9.0;
            let box3 = SymKernel {
                centre: ninth,
                near: ninth,
                diag: ninth,
            };
            corr3_rows(n, box3, &s.summation, &mut s.row, |start, ce| {
                excitation[start..start + n].copy_from_slice(ce);
                max_ce = max_abs(ce, max_ce);
            });
        }
        let omega = cfg.delta_c + max_ce / cfg.c_w;
        let mut mp = 0.0;
        for (&sv, &ce) in s.summation.iter().zip(&s.excitation) {
            let g = sv * ce / omega;
            if g * cfg.c_de >= cfg.t_de {
                mp += g;
            }
        }
        let smp = 1.0 / (1.0 + (-mp / ((n * n) as f64 * cfg.c_sig)).exp());
        // 7. spike-frequency adaptation.
        let diff = smp - lgmd.smp;
        let sfa = if diff <= cfg.t_sfa {
            co.h_sfa * (lgmd.sfa + diff)
        } else {
            co.h_sfa * smp
        };
        let sfa = sfa.max(0.5);
        // 8. spikes; 9. optional collision flag.
        let spikes = (cfg.c_spi * (sfa - cfg.t_sp)).exp().floor();
        if spikes == 0.0 {
            lgmd.spike_run = 0;
        } else {
            lgmd.spike_run = lgmd.spike_run.saturating_add(spikes as u64);
        }
        // 10. keep the state.
        std::mem::swap(&mut lgmd.on, &mut lgmd.on_prev);
        std::mem::swap(&mut lgmd.off, &mut lgmd.off_prev);
        lgmd.pm = pm;
        lgmd.smp = smp;
        lgmd.sfa = sfa;
        InstanceOutput {
            spikes,
            sfa,
            collision: lgmd.spike_run >= u64::from(cfg.n_ts),
        }
    }
}

impl Detector for Fu2020 {
    fn id(&self) -> &'static str {
        "fu2020"
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
                zeroed(&mut self.contrast, len);
                self.on.allocate(len);
                self.off.allocate(len);
                for b in self.scratch.blend.iter_mut() {
                    zeroed(b, len);
                }
                zeroed(&mut self.scratch.summation, len);
                zeroed(&mut self.scratch.excitation, len);
                zeroed(&mut self.scratch.row, n);
                let zero = InstanceOutput::default();
                return Ok(Self::signals(0.0, zero, zero));
            }
            FrameStep::Next(n) => n,
        };
        let k = &self.constants;
        let sum_abs = self.prev.contrast_into(frame, k.cfg.contrast_scale, &mut self.contrast);
        let mean_abs = sum_abs / (n * n) as f64;
        let off = lgmd2_step(&mut self.off, &self.contrast, 1.0, mean_abs, n, k, &mut self.scratch);
        let on = lgmd2_step(&mut self.on, &self.contrast, -1.0, mean_abs, n, k, &mut self.scratch);
        let (z_on, z_off) = (on.spikes, off.spikes);
        let z = self.output.update(z_on * z_off + k.cfg.epsilon * (z_on + z_off));
        Ok(Self::signals(z, on, off))
    }
}

impl DetectorConfig for Fu2020Config {
    fov_from_camera!();

    fn validate(&self) -> Result<(), DetectorError> {
        Fu2020Config::validate(self)
    }

    fn build(&self, _n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        Ok(Box::new(Fu2020::new(*self)?))
    }
}

/// `fu2020` in the registry. The default threshold (output units) is calibrated on held-out draws
/// of the default suite (`loomlab run --seed 7 --calibrate 0.1`: the smallest threshold, rounded up
/// to three significant digits, with at most 10 % false alarms over its non-threat episodes; see
/// `scenarios/README.md`).
pub(crate) fn registration() -> Registration {
    Registration::of::<Fu2020Config>(
        "fu2020",
        "LGMD2 of Fu et al. 2020, ON/OFF instances combined",
        &[Signal::Output],
        Signal::Output,
        2.47,
    )
}

//! Keil's modern-Hopfield looming detector (paper §2.2), with an optional temporal high-pass
//! front end and a second angular-size readout for cluttered scenes.
//!
//! Per frame t:
//! 1. **Frame processing** ([`processing`]): F(t) = R_oi ⊙ [F̃(t) ∗ S_odd] (eq. 3–4), then the
//!    query ξ(t) = zero-mean unit vector of F(t) (§2.2.2) — or, with the adapted front end,
//!    of F(t) minus its per-pixel running mean (see [`processing`]).
//! 2. **Pattern memory** ([`templates`]): ON = [ξ(t−delay), x_1, …, x_N] and
//!    OFF = [ξ(t−delay), −x_1, …, −x_N], with x_i the zero-mean unit vectors of the Laplacians
//!    of N = 1 + ⌊3n/5⌋ striped disks of diameters s·n, s = 0.1, 0.1 + 3/(2n), … (eq. 7):
//!    N + 1 = 2 + ⌊3n/5⌋ columns each.
//! 3. **Retrieval** (eq. 5–6), independently for ON and OFF: ξ(0) = ξ(t),
//!    p(τ) = softmax(β·Xᵀξ(τ)), ξ(τ+1) = X·p(τ), until ‖ξ(τ+1) − ξ(τ)‖ ≤ `tolerance` or
//!    `max_iterations` updates were made.
//! 4. **Activity** (eq. 8–11): ẑ = c·p with c = [1, …, N+1], low-passed per channel with α,
//!    and z = z_on·z_off.
//!
//! # Decisions where the paper is loose
//! - **eq. 6** writes OFFᵀ·ξ_on; read as a typo: the OFF channel iterates its own state ξ_off.
//! - **Softmax** is computed stably (the maximum is subtracted before exponentiating); no
//!   "fail-safe" variant is needed for β = 500.
//! - **Start-up**: while fewer than `delay` frames were seen (t < delay + 1 in the paper's
//!   1-based time) the delayed column is the current query (paper footnote), which then
//!   matches itself perfectly: ẑ = 1.
//! - **Which p gives the activity**: the iteration computes p(τ) from ξ(τ), then ξ(τ+1) =
//!   X·p(τ), then tests the stop rule; the activity uses p(τ) of the last update made (the
//!   distribution that produced the final state ξ(τ+1)). With β = 500 the first update
//!   usually lands on one pattern and the second confirms it, so this p is one-hot on the
//!   winner. `iterations_on/off` count the updates made (1 ..= `max_iterations`).
//! - **Winner**: argmax of that p (first index on ties), as a memory column index: 0 = the
//!   delayed frame, i ≥ 1 = template i (scale s_i).
//! - **Low-pass** (eq. 10): out(t+1) = α·out(t) + (1 − α)·in(t) is applied after frame t and
//!   reported for frame t (no extra frame of latency). The state starts at 1, the floor
//!   (identical to starting from the first ẑ, which is always 1 by the start-up rule), so
//!   z_on, z_off ∈ [1, N+1] and z ∈ [1, (N+1)²] on every frame. (The paper writes
//!   c = [1, …, N] and z_on, z_off ∈ [1, N], counting the memory's columns as N; with N
//!   templates plus the delayed column the top index is N + 1.) ẑ is clamped to [1, N+1],
//!   which only absorbs rounding (Σp = 1 ± 1e-16).
//! - **Blank frames**: if the processed frame has (near) zero centred norm
//!   (≤ [`processing::MIN_QUERY_NORM`]: a blank or constant frame, or edges only outside the
//!   mask) there is nothing to normalise. Such a frame is "no evidence": both channels report
//!   the delayed column as retrieved (p = e_1, ẑ = 1, winner 0, 0 iterations), the low-pass
//!   states z_on, z_off are *held* (no evidence, no change: an object that fills the whole view
//!   in the last frames of an approach keeps its high activity instead of dropping to the floor;
//!   a detector that has seen only blank frames stays at the floor), and the frame is *not*
//!   stored as a delayed memory column: the delayed column is the query of the `delay`-th
//!   latest frame with evidence (or the current query while fewer were seen, as at start-up).
//!   Storing it (as a zero column) would make the delayed column lose to every template
//!   `delay` frames later, a spurious response to a single dropped frame. Never NaN. With the
//!   adapted front end a high-pass with no structure (a static scene) is no evidence in the
//!   same way, and a blank camera frame is skipped before the high-pass.
//! - **Frame border** of the S_odd convolution: replicate (configurable), see [`processing`].
//!
//! # Angular-size readouts
//! The activity is a (soft) template index, and template i is a disk of diameter s_i·n
//! pixels, i.e. of visual angle θ = 2·atan(s_i·tan(fov/2)) for a pinhole camera with
//! f = (n/2)/tan(fov/2).
//!
//! - **Paper** (`readout = "paper"`, default, [`angular_size_deg`]): the geometric mean of the
//!   ON and OFF activities, a = √z ∈ [1, N+1], read as a continuous column index; the template
//!   index is i = a − 1 ∈ [0, N] and its scale s = s_1 + (i − 1)·Δs for i ≥ 1, s = s_1·i for
//!   i < 1 (linear down to 0 at the floor a = 1). It inherits the low-pass (α = 0.85: a lag of
//!   about five frames) and, while only one channel responds (the other stays at 1), reads the
//!   size of a much smaller template than the one retrieved.
//! - **Winner** (`readout = "winner"`, [`winner_scale`]): each frame with evidence, each
//!   channel's winning column gives a scale — s_w for template w, 0 when the delayed frame wins
//!   (the channel does not respond) — and the larger of the two is taken; that scale is
//!   low-passed with `readout_alpha` (0 = none; frames without evidence hold it) and turned
//!   into θ̂ = 2·atan(s·tan(fov/2)). It follows the retrieved template without the lag of z
//!   and reads 0 while neither channel responds; its smallest non-zero value is the smallest
//!   template's angle (with the paper's schedule 2·atan(0.1·tan(fov/2)), 6.6° at 60°).
//!
//! - **Template** (`readout = "template"`, [`best_template`]): each frame, the template whose
//!   cosine with the query is the largest in magnitude (the delayed column left out: the first
//!   retrieval step's winner in a memory of the templates alone), when that cosine is at least
//!   `min_template_cosine`; its scale is low-passed with `readout_alpha` over consecutive frames
//!   that read one, and θ̂ is 0 on a frame that does not. Meant for a query centred on an object
//!   ([`attention`]), whose delayed column holds the same object a few frames earlier and would
//!   win most frames.
//!
//! z (the detector's `output`) is the same for every readout.

//! # Template phase and centre (why the defaults)
//! Measured with the stimulus renderer (n = 64, 128, 256; the paper's approach: 0.5 m disk,
//! 50 km/h, 10 m → 0.1 m, 120 frames/s, 60° field of view), see
//! `detector/tests/hopfield_stimuli.rs`:
//! - **Stripe phase** ([`TemplateConfig::phase`], stimulus `object.phase`): a striped disk
//!   (horizontal grating, 2 cycles per disk, uniform gray background) whose stripe edge runs
//!   through its centre (phase 0) gives z = 1 on every frame of the approach: that edge stays
//!   put while the disk grows, so the delayed frame keeps winning. With phase 0.25 (the centre
//!   in the middle of a bright stripe, every edge moves) the response rises steeply in the
//!   final approach (z ≈ 4000–6000 at n = 256). Default 0.25 for templates and stimuli.
//! - **Template centre** ([`TemplateConfig::offset_px`]): the query is an odd (Sobel) edge
//!   response, the template an even (Laplacian) one. Across one edge they are orthogonal when
//!   the edges coincide and correlate when the template edge is offset by about a pixel, so a
//!   template exactly concentric with a mirror-symmetric disk is orthogonal to its query:
//!   with offset 0 a white disk gives z = 1 for the whole approach. Offsets of 0.5, 1, 1.5 and
//!   2 px all give the rising response (winning templates within a few indices of the
//!   disk's true size); the default 0.5 centres the template on pixel row n/2, the usual
//!   integer-grid convention, half a pixel below the geometric centre used by the stimuli.

pub mod attention;
pub mod config;
pub mod fast;
pub mod processing;
pub mod reference;
pub mod templates;

pub use config::{
    Attention, FrameBorder, FrontEnd, HopfieldConfig, Implementation, MaskConfig, Readout, ScaleSchedule,
    TemplateConfig, TemplateKind,
};
pub use fast::FastHopfield;
pub use reference::ReferenceHopfield;
pub use templates::TemplateBank;

use crate::registry::{CameraFacts, DetectorConfig, Registration, Signal};
use crate::{Detector, DetectorError, EfferenceCopy, Frame, Signals};

/// Raw (un-filtered) retrieval result of one frame, from either implementation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Retrieval {
    /// ẑ_on = c·p_on ∈ [1, N+1] (eq. 8).
    pub z_hat_on: f64,
    /// ẑ_off = c·p_off ∈ [1, N+1].
    pub z_hat_off: f64,
    /// argmax of p_on as a memory column (0 = delayed frame, i = template i).
    pub winner_on: usize,
    /// argmax of p_off as a memory column.
    pub winner_off: usize,
    /// Number of updates (eq. 5) made by the ON channel (0 for a blank frame).
    pub iterations_on: usize,
    /// Number of updates made by the OFF channel.
    pub iterations_off: usize,
}

impl Retrieval {
    fn from_channels(p_on: &[f64], p_off: &[f64], iterations_on: usize, iterations_off: usize) -> Self {
        Self {
            z_hat_on: activity(p_on),
            z_hat_off: activity(p_off),
            winner_on: argmax(p_on),
            winner_off: argmax(p_off),
            iterations_on,
            iterations_off,
        }
    }
}

/// ẑ = Σ_k (k+1)·p_k (eq. 8), clamped to [1, N+1]; a non-finite value (impossible for finite
/// inputs) reads as the floor.
fn activity(p: &[f64]) -> f64 {
    let z: f64 = p.iter().enumerate().map(|(k, pk)| (k + 1) as f64 * pk).sum();
    if z.is_finite() {
        z.clamp(1.0, p.len() as f64)
    } else {
        1.0
    }
}

fn argmax(p: &[f64]) -> usize {
    let mut best = 0;
    for (k, &v) in p.iter().enumerate() {
        if v > p[best] {
            best = k;
        }
    }
    best
}

/// Numerically stable softmax in place (subtracts the maximum first). A vector containing
/// NaN becomes e_1 (the delayed column): never reached with finite inputs.
pub(crate) fn softmax_in_place(v: &mut [f64]) {
    let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() || v.iter().any(|x| x.is_nan()) {
        v.fill(0.0);
        v[0] = 1.0;
        return;
    }
    let mut sum = 0.0;
    for x in v.iter_mut() {
        *x = (*x - max).exp();
        sum += *x;
    }
    let inv = 1.0 / sum;
    v.iter_mut().for_each(|x| *x *= inv);
}

/// Angular size θ̂ in degrees read from the activity z (see the module docs): a = √z,
/// i = a − 1, s = s_start + (i − 1)·Δs (i ≥ 1) or s_start·i (i < 1), θ̂ = 2·atan(s·tan(fov/2)).
pub fn angular_size_deg(z: f64, cfg: &HopfieldConfig) -> f64 {
    let a = if z.is_finite() { z.max(1.0).sqrt() } else { 1.0 };
    let i = a - 1.0;
    let t = &cfg.template;
    let start = t.scale_start_for(cfg.n);
    let s = if i >= 1.0 {
        start + (i - 1.0) * t.scale_step_for(cfg.n)
    } else {
        start * i
    };
    scale_to_deg(s, cfg)
}

/// Visual angle in degrees of a disk of scale s (diameter s·n pixels) seen through the
/// camera: 2·atan(s·tan(fov/2)).
pub fn scale_to_deg(s: f64, cfg: &HopfieldConfig) -> f64 {
    2.0 * crate::Pinhole::new(cfg.fov_deg).angle_deg(s)
}

/// The winner readout's scale for one frame: the larger of the ON and OFF winners' template
/// scales, a winner of 0 (the delayed frame) counting as scale 0.
pub fn winner_scale(winner_on: usize, winner_off: usize, cfg: &HopfieldConfig) -> f64 {
    let scale = |w: usize| if w == 0 { 0.0 } else { cfg.template.scale(cfg.n, w) };
    scale(winner_on).max(scale(winner_off))
}

/// The template readout's template for one frame: the 1-based index and the cosine magnitude
/// of the template whose cosine with the query is the largest in magnitude (the first on ties),
/// when that magnitude is at least `min_cosine`.
pub fn best_template(cosines: &[f64], min_cosine: f64) -> Option<(usize, f64)> {
    let mut best: Option<(usize, f64)> = None;
    for (i, c) in cosines.iter().enumerate() {
        if c.abs() >= min_cosine && best.is_none_or(|(_, b)| c.abs() > b) {
            best = Some((i + 1, c.abs()));
        }
    }
    best
}

/// Everything the Hopfield detector reports for one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HopfieldSignals {
    /// Low-passed ON activity z_on ∈ [1, N+1] (eq. 11).
    pub z_on: f64,
    /// Low-passed OFF activity z_off ∈ [1, N+1].
    pub z_off: f64,
    /// z = z_on·z_off ∈ [1, (N+1)²] (eq. 12), the detector output.
    pub z: f64,
    /// Raw ON activity ẑ_on of this frame (eq. 8).
    pub z_hat_on: f64,
    /// Raw OFF activity ẑ_off of this frame.
    pub z_hat_off: f64,
    /// Winning ON memory column (0 = delayed frame, i ≥ 1 = template i).
    pub winner_on: usize,
    /// Winning OFF memory column.
    pub winner_off: usize,
    /// Angular size θ̂ in degrees from the configured readout: from √z
    /// ([`angular_size_deg`]), from the winning templates ([`winner_scale`]) or from the
    /// best-matching template ([`best_template`]).
    pub angular_size_deg: f64,
    /// Updates made by the ON channel this frame.
    pub iterations_on: usize,
    /// Updates made by the OFF channel this frame.
    pub iterations_off: usize,
}

#[derive(Debug, Clone)]
enum Engine {
    Reference(Box<ReferenceHopfield>),
    Fast(Box<FastHopfield>),
}

/// The modern-Hopfield looming detector (id `hopfield`).
///
/// ```
/// use loomlab_detector::{Frame, hopfield::{Hopfield, HopfieldConfig}};
/// let mut det = Hopfield::new(HopfieldConfig::for_size(32)).unwrap();
/// let s = det.step_hopfield(&Frame::uniform(32, 0.5)).unwrap();
/// assert_eq!((s.z_on, s.z_off, s.z), (1.0, 1.0, 1.0)); // no edges: the floor
/// ```
#[derive(Debug, Clone)]
pub struct Hopfield {
    config: HopfieldConfig,
    engine: Engine,
    /// The compensated front end's high-pass (`None` for the other front ends).
    ego_high_pass: Option<processing::EgoHighPass>,
    z_on: f64,
    z_off: f64,
    /// The winner or template readout's (low-passed) scale.
    readout_scale: f64,
    /// The attention's tracker (`attention = "tracker"`; `None` for the whole frame).
    attention: Option<attention::TrackerAttention>,
}

impl Hopfield {
    /// Validates `config` and builds the pattern memories.
    pub fn new(config: HopfieldConfig) -> Result<Self, DetectorError> {
        config.validate()?;
        let engine = match config.implementation {
            Implementation::Reference => Engine::Reference(Box::new(ReferenceHopfield::new(&config)?)),
            Implementation::Fast => Engine::Fast(Box::new(FastHopfield::new(&config)?)),
        };
        let ego_high_pass = (config.front_end == FrontEnd::Compensated)
            .then(|| processing::EgoHighPass::new(config.n, config.fov_deg, config.adaptation_weight()));
        let attention = match config.attention {
            Attention::None => None,
            Attention::Tracker => {
                // what the query image holds outside the frame: no edge in a camera frame, no
                // change in the compensated front end's high-pass
                let outside = match config.front_end {
                    FrontEnd::Compensated => attention::Outside::Zero,
                    FrontEnd::Paper | FrontEnd::Adapted => attention::Outside::Replicate,
                };
                Some(attention::TrackerAttention::new(config.n, config.fov_deg, outside)?)
            }
        };
        Ok(Self {
            config,
            engine,
            ego_high_pass,
            z_on: 1.0,
            z_off: 1.0,
            readout_scale: 0.0,
            attention,
        })
    }

    /// The configuration it was built with.
    pub fn config(&self) -> &HopfieldConfig {
        &self.config
    }

    /// Number of templates N.
    pub fn template_count(&self) -> usize {
        self.config.template_count()
    }

    /// Columns per pattern memory, N + 1.
    pub fn memory_columns(&self) -> usize {
        self.config.memory_columns()
    }

    /// The reference engine, if this detector runs it.
    pub fn reference(&self) -> Option<&ReferenceHopfield> {
        match &self.engine {
            Engine::Reference(r) => Some(r),
            Engine::Fast(_) => None,
        }
    }

    /// The fast engine, if this detector runs it.
    pub fn fast(&self) -> Option<&FastHopfield> {
        match &self.engine {
            Engine::Fast(f) => Some(f),
            Engine::Reference(_) => None,
        }
    }

    /// Processes the next frame and returns all signals (the compensated front end without an
    /// efference copy: no motion known).
    pub fn step_hopfield(&mut self, frame: &Frame) -> Result<HopfieldSignals, DetectorError> {
        self.step_hopfield_moving(frame, &EfferenceCopy::default())
    }

    /// [`Self::step_hopfield`] with the efference copy of the camera period that ended with
    /// `frame` (only the compensated front end reads it).
    pub fn step_hopfield_moving(
        &mut self,
        frame: &Frame,
        ego: &EfferenceCopy,
    ) -> Result<HopfieldSignals, DetectorError> {
        if frame.n() != self.config.n {
            return Err(DetectorError::FrameSize {
                expected: self.config.n,
                got: frame.n(),
            });
        }
        if let Some(attention) = &mut self.attention {
            let track = |r: Option<crate::ImageRegion>| r.and_then(|r| r.track);
            let before = track(attention.region());
            if track(attention.follow(frame, ego)?) != before {
                // another object: its size is not the last one's
                self.readout_scale = 0.0;
            }
        }
        let input = match &mut self.ego_high_pass {
            Some(hp) => hp.high_pass(frame.data(), ego),
            None => frame.data(),
        };
        let input = match &mut self.attention {
            Some(attention) => attention.centre(input),
            None => input,
        };
        let r = match &mut self.engine {
            Engine::Reference(e) => e.retrieve(input),
            Engine::Fast(e) => e.retrieve(input),
        };
        let alpha = self.config.alpha;
        let top = self.memory_columns() as f64;
        // A blank frame (0 iterations) carries no evidence: the low-pass state is held.
        if r.iterations_on > 0 {
            self.z_on = (alpha * self.z_on + (1.0 - alpha) * r.z_hat_on).clamp(1.0, top);
            self.z_off = (alpha * self.z_off + (1.0 - alpha) * r.z_hat_off).clamp(1.0, top);
            if self.config.readout == Readout::Winner {
                self.readout_scale = self.low_passed_scale(winner_scale(r.winner_on, r.winner_off, &self.config));
            }
        }
        if self.config.readout == Readout::Template {
            let best = match &self.engine {
                Engine::Reference(e) => best_template(&e.last_template_cosines(), self.config.min_template_cosine),
                Engine::Fast(e) => best_template(e.last_template_cosines(), self.config.min_template_cosine),
            };
            self.readout_scale = match best {
                // afresh after a frame that read no size
                Some((i, _)) if self.readout_scale > 0.0 => {
                    self.low_passed_scale(self.config.template.scale(self.config.n, i))
                }
                Some((i, _)) => self.config.template.scale(self.config.n, i),
                None => 0.0,
            };
        }
        let z = self.z_on * self.z_off;
        let angular_size_deg = match self.config.readout {
            Readout::Paper => angular_size_deg(z, &self.config),
            Readout::Winner | Readout::Template => scale_to_deg(self.readout_scale, &self.config),
        };
        Ok(HopfieldSignals {
            z_on: self.z_on,
            z_off: self.z_off,
            z,
            z_hat_on: r.z_hat_on,
            z_hat_off: r.z_hat_off,
            winner_on: r.winner_on,
            winner_off: r.winner_off,
            angular_size_deg,
            iterations_on: r.iterations_on,
            iterations_off: r.iterations_off,
        })
    }

    /// The winner or template readout's scale after this frame's `scale`: a·old + (1 − a)·scale
    /// with a = `readout_alpha` (0: the frame's own scale).
    fn low_passed_scale(&self, scale: f64) -> f64 {
        let a = self.config.readout_alpha;
        a * self.readout_scale + (1.0 - a) * scale
    }

    /// With attention, the attended object's image region for the collision-course gate: the
    /// tracker's centroid and track number, and a box θ̂ wide and high centred on the centroid
    /// (the Hopfield memory's size, not the tracker's box); `None` without attention, an object or
    /// a size.
    fn attended_region(&self, theta_deg: f64) -> Option<crate::ImageRegion> {
        let region = self.attention.as_ref()?.region()?;
        if theta_deg <= 0.0 {
            return None;
        }
        let half = crate::Pinhole::new(self.config.fov_deg).image_coord(0.5 * theta_deg);
        let [x, y] = region.centroid;
        Some(crate::ImageRegion {
            x: [x - half, x + half],
            y: [y - half, y + half],
            ..region
        })
    }
}

impl Detector for Hopfield {
    fn id(&self) -> &'static str {
        "hopfield"
    }

    fn snapshot(&self) -> Option<Box<dyn Detector>> {
        Some(Box::new(self.clone()))
    }

    fn reset(&mut self) {
        self.z_on = 1.0;
        self.z_off = 1.0;
        self.readout_scale = 0.0;
        if let Some(attention) = &mut self.attention {
            attention.reset();
        }
        if let Some(hp) = &mut self.ego_high_pass {
            hp.reset();
        }
        match &mut self.engine {
            Engine::Reference(e) => e.reset(),
            Engine::Fast(e) => e.reset(),
        }
    }

    fn step(&mut self, frame: &Frame) -> Result<Signals, DetectorError> {
        self.step_moving(frame, &EfferenceCopy::default())
    }

    fn step_moving(&mut self, frame: &Frame, ego: &EfferenceCopy) -> Result<Signals, DetectorError> {
        let s = self.step_hopfield_moving(frame, ego)?;
        Ok(Signals {
            output: s.z,
            angular_size_deg: Some(s.angular_size_deg),
            aux: vec![("on", s.z_on), ("off", s.z_off)],
            region: self.attended_region(s.angular_size_deg),
            objects: Vec::new(),
        })
    }
}

impl DetectorConfig for HopfieldConfig {
    const CAMERA_KEYS: &'static [&'static str] = &config::CAMERA_KEYS;

    fn for_camera(self, camera: &CameraFacts) -> Self {
        Self {
            n: camera.n,
            fov_deg: camera.fov_deg,
            frame_rate_hz: camera.frame_rate_hz,
            ..self
        }
    }

    fn validate(&self) -> Result<(), DetectorError> {
        HopfieldConfig::validate(self)
    }

    fn build(&self, n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        Ok(Box::new(Hopfield::new(HopfieldConfig { n, ..*self })?))
    }
}

/// `hopfield` in the registry: triggered by θ̂ at the locust's escape angle of 10° (paper
/// discussion). The calibration of the baselines' thresholds allows any θ̂ > 0 here (θ̂ jumps from
/// 0 to well above 10° within a frame or two when the detector responds), so 10° is kept: it gives
/// the same rates on that calibration run.
pub(crate) fn registration() -> Registration {
    Registration::of::<HopfieldConfig>(
        "hopfield",
        "Keil's modern-Hopfield looming detector (Keil 2025, paper §2.2)",
        &[Signal::Output, Signal::AngularSize],
        Signal::AngularSize,
        10.0,
    )
}

#[cfg(test)]
mod tests;

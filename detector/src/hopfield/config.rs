//! Parameters of the modern-Hopfield looming detector ([`HopfieldConfig`]), with the paper's
//! values (Keil, §2.2) as defaults.
//!
//! In a TOML file (e.g. a `[hopfield]` table) every key is optional and unknown keys are errors:
//!
//! ```toml
//! n = 256                 # frame side length the pattern memory is built for
//! beta = 500.0            # inverse temperature β (eq. 5)
//! delay = 5               # the first memory column is the query of `delay` frames ago
//! alpha = 0.85            # low-pass memory coefficient α (eq. 10)
//! tolerance = 0.01        # stop when ‖ξ(τ+1) − ξ(τ)‖ ≤ tolerance (≥ 1e-6) …
//! max_iterations = 5      # … or after this many updates (eq. 5)
//! fov_deg = 60.0          # camera field of view, for the angular-size readout only
//! frame_rate_hz = 120.0   # camera frame rate, for the adapted front end only
//! implementation = "fast" # or "reference" (literal dense matrices, slow)
//! frame_border = "replicate" # or "zero": padding of the 3×3 S_odd convolution
//! front_end = "paper"     # or "adapted": temporal high-pass before retrieval
//! adaptation_tau_s = 0.1  # adapted front end: time constant of the running mean (seconds)
//! readout = "paper"       # angular size from √z; or "winner": from the winning template;
//!                         # or "template": from the best-matching template alone
//! readout_alpha = 0.0     # winner and template readouts: low-pass coefficient (0 = none)
//! min_template_cosine = 0.05 # template readout: smallest cosine that reads a size
//! attention = "none"      # or "tracker": the query centred on the object `tracker` follows
//! mask = { radius_frac = 0.9, blur_sigma_px = 20.0 }   # or mask = "none" / mask = false
//! # mask = { radius_frac = 0.9, blur_sigma_frac = 0.078 } # blur proportional to n
//!
//! [template]
//! kind = "striped_disk"   # or "uniform_disk"
//! cycles = 2.0            # stripes: square-wave cycles per disk diameter
//! phase = 0.25            # stripes: phase in cycles (0.25: disk centre in a bright stripe)
//! offset_px = 0.5         # template centre this many pixels below the frame centre
//! schedule = "paper"      # or "footnote": 7-pixel first disk, 1-pixel steps
//! scale_start = 0.1       # first disk diameter, fraction of n
//! # scale_start_px = 7.0  # … or in pixels (instead of scale_start)
//! # scale_step = 0.005859375  # default 3/(2n) ("paper") or 1/n ("footnote")
//! scale_end = 1.0         # last diameter ≤ scale_end·n
//! ```
//!
//! # Front ends
//! - `front_end = "paper"` (default): the query is the processed camera frame, exactly as in
//!   the paper.
//! - `front_end = "adapted"`: the processed frame first passes a first-order temporal
//!   high-pass: a per-pixel running mean M is subtracted, G(t) = F(t) − M(t−1), and updated,
//!   M(t) = M(t−1) + w·G(t), with the per-frame weight w = 1 − exp(−1/(τ·f)) for the time
//!   constant τ = `adaptation_tau_s` (seconds, default 0.1) and the frame rate
//!   f = `frame_rate_hz` (default 120, the simulator's camera default), so the filter has
//!   the same time constant at any frame rate. Static structure (ground texture, backdrops)
//!   fades from the query within about τ, and what moves or grows stays. M starts from the
//!   first frame, and for two time constants after it (`warm_up_frames`: 24 frames at
//!   τ = 0.1 s and 120 Hz) the query is withheld (no evidence, nothing stored in the delayed
//!   memory) while M follows the frames: until then G holds a shorter history of the image's
//!   changes than later, and a delayed query from that period retrieved a template as soon as
//!   a later query met it (a θ̂ of tens of degrees at 0.06 s that no object caused). See
//!   [`super::processing`] for blank frames.
//! - `front_end = "compensated"`: the adapted high-pass, taken on the camera image after the
//!   static world's image motion is removed. The per-pixel running mean M̃ of the camera
//!   images is, every frame, first warped to the current view by the camera's motion since the
//!   previous frame (the efference copy handed to [`crate::Detector::step_moving`]:
//!   rotation exactly, translation through the ground-plane homography below the horizon,
//!   points at infinity elsewhere — [`crate::compensation`]), then G̃ = F̃ − warp(M̃) and
//!   M̃ ← warp(M̃) + w·G̃ (the same w). Pixels whose warped mean falls outside the view restart
//!   from the current image (G̃ = 0 there). The paper's edge filter, mask, memory and retrieval
//!   then run on G̃ unchanged, in both implementations (which therefore agree as on the paper
//!   front end). Without an efference copy (`step`, or an unknown motion) the mean is not
//!   warped: the adapted high-pass on the camera image. A uniform camera frame (dropped) is
//!   skipped (no evidence; M̃ unchanged). The same warm-up as the adapted front end's.
//!
//! # Angular-size readouts
//! - `readout = "paper"` (default): θ̂ from √(z_on·z_off) read as a template index.
//! - `readout = "winner"`: θ̂ from the template that wins the retrieval this frame, per
//!   channel, optionally low-passed with `readout_alpha` (see [`super`]).
//! - `readout = "template"`: θ̂ from the template whose cosine with this frame's query is the
//!   largest in magnitude — the first retrieval step's winner in a memory of the templates alone,
//!   without the delayed column — when that cosine is at least `min_template_cosine`, low-passed
//!   with `readout_alpha` over consecutive frames that read a size; 0 otherwise (see [`super`]).
//!   Once the query is centred on an object (`attention = "tracker"`), the delayed column holds
//!   the same object a few frames earlier and wins most frames: its winner says "no change", not
//!   the object's size.
//!
//! # Attention
//! - `attention = "none"` (default): the query is the whole frame, as in the paper, whose
//!   templates are discs centred on the image.
//! - `attention = "tracker"` (with the paper or the compensated front end; the adapted one's
//!   high-pass would run on the centred view, which moves with the object): the detector runs
//!   the `tracker` reference detector (its defaults, the camera's field of view) on the same
//!   frames and efference copies, and shifts the front end's output by whole pixels so that the
//!   pixel holding the tracked object's centroid lands on the templates' centre before the edge
//!   filter; while the tracker reports no object the query is empty (no evidence). What the
//!   Hopfield memory reads is then the size of the object the tracker localises; its θ̂ comes
//!   with that object's image position (a box θ̂ wide and high around the centroid, and the
//!   tracker's track number) for the collision-course gate (see [`super::attention`]).
//!
//! Every key keeps its own default: `front_end = "adapted"` alone keeps the paper readout,
//! which with the adapted front end reads too small (median error 28–35 % on the cluttered
//! approach) while only one channel responds, and lags by the low-pass; give
//! `readout = "winner"` with it.
//! [`HopfieldConfig::adapted`] / [`HopfieldConfig::adapted_for_size`] give the adapted front
//! end with the winner readout (`readout_alpha = 0.5`), the settings measured on the
//! cluttered approach of `detector/tests/hopfield_clutter.rs` (onset at θ ≈ 8° (n = 128) and
//! 12° (n = 64), median |θ̂ − θ|/θ of 4 % and 12 % over 10°–60°, where the paper front end
//! never leaves rest). On dynamic-noise backgrounds (a new noise image every frame) the winner
//! readout overestimates: each frame some template wins on the noise, and the larger of ON
//! and OFF is taken.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Deserializer, Serialize};

use crate::DetectorError;

/// Which implementation of the (identical) equations runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Implementation {
    /// Literal dense d×(N+1) pattern matrices, exactly the paper's equations, f64. Slow
    /// (tens of frames per second at n = 256) and memory hungry (2·d·(N+1) f64), kept as the
    /// executable specification the fast path is tested against.
    Reference,
    /// The same numbers (to ~1e-12) via exact identities: one shared sparse product for ON and
    /// OFF, iteration in pattern space with the Gram matrix, run-length templates.
    #[default]
    Fast,
}

impl Implementation {
    /// The name used in config files and on the command line (`reference` / `fast`).
    pub fn as_str(self) -> &'static str {
        match self {
            Implementation::Reference => "reference",
            Implementation::Fast => "fast",
        }
    }
}

impl fmt::Display for Implementation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Implementation {
    type Err = DetectorError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "reference" => Ok(Implementation::Reference),
            "fast" => Ok(Implementation::Fast),
            other => Err(DetectorError::InvalidParameter {
                name: "implementation",
                value: other.to_string(),
                reason: "expected `reference` or `fast`".into(),
            }),
        }
    }
}

/// Padding of the frame for the 3×3 S_odd convolution (the paper does not say).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FrameBorder {
    /// Pixels outside the frame repeat the nearest border pixel: the frame border is not an
    /// edge, so a uniform frame gives a zero (degenerate) query. Default.
    #[default]
    Replicate,
    /// Pixels outside the frame are black (MATLAB `conv2(…, 'same')`): the frame border of a
    /// bright image becomes a static horizontal edge at the top and bottom rows.
    Zero,
}

/// The region-of-interest mask R_oi (paper §2.2.1): a white disk of radius
/// `radius_frac·n/2` centred in the frame, blurred with a Gaussian of standard deviation
/// `blur_sigma_px` pixels, or `blur_sigma_frac·n` pixels when that is given.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct MaskConfig {
    /// Disk radius as a fraction of n/2 (paper: 0.9, chosen from 0.5, 0.75, 0.9).
    pub radius_frac: f64,
    /// Standard deviation of the Gaussian blur in pixels (paper: 20; 0 = sharp disk). An
    /// absolute width: at n = 256 it softens the disk edge, at n ≤ 64 it blurs the whole disk
    /// (use `blur_sigma_frac` to scale it with n).
    pub blur_sigma_px: f64,
    /// Standard deviation of the blur as a fraction of n, replacing `blur_sigma_px` (which
    /// must then keep its default). `0.078125` = 20/256: the paper's blur at n = 256, scaled to
    /// any n. Default: not set (absolute `blur_sigma_px`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub blur_sigma_frac: Option<f64>,
}

/// The paper's mask blur in pixels.
pub const PAPER_BLUR_SIGMA_PX: f64 = 20.0;

impl Default for MaskConfig {
    fn default() -> Self {
        Self {
            radius_frac: 0.9,
            blur_sigma_px: PAPER_BLUR_SIGMA_PX,
            blur_sigma_frac: None,
        }
    }
}

impl MaskConfig {
    /// The blur's standard deviation in pixels for frames of side n.
    pub fn blur_sigma_for(&self, n: usize) -> f64 {
        match self.blur_sigma_frac {
            Some(frac) => frac * n as f64,
            None => self.blur_sigma_px,
        }
    }
}

/// The gray-level template image P̃(s) drawn at every scale (paper Fig. "Pattern Memory").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TemplateKind {
    /// A disk (luminance 1) on black with a horizontal square-wave grating: luminance 1 where
    /// frac(cycles·b + phase) < ½, else 0, with b the upward vertical coordinate from the
    /// disk centre in disk diameters (the convention of the stimulus `grating` texture).
    /// The paper's default template.
    #[default]
    StripedDisk,
    /// A uniform white disk (luminance 1) on black.
    UniformDisk,
}

/// Which template sizes the pattern memory holds (paper §2.2.3 and its footnote).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ScaleSchedule {
    /// Disk diameters s·n with s = `scale_start` (0.1), increasing by Δs = 3/(2n) up to
    /// `scale_end` (1): N = 1 + ⌊3n/5⌋ templates. The paper's main schedule. Default.
    #[default]
    Paper,
    /// The alternative the paper reports as equally good for most videos: a first disk of
    /// seven pixels (s = 7/n) and steps of one pixel (Δs = 1/n), N = 1 + ⌊(scale_end·n − 7)⌋
    /// templates (n − 6 with scale_end = 1). Small objects get templates of their own size at
    /// any n, at the price of about 5/3 as many columns. `scale_start_px` and `scale_step`
    /// override the seven pixels and the one-pixel step; `scale_start` must stay unset.
    Footnote,
}

/// First disk diameter of the footnote schedule, in pixels.
pub const FOOTNOTE_START_PX: f64 = 7.0;

/// The smallest template disk diameter accepted, in pixels: a narrower disk covers at most a
/// single pixel row, whose Laplacian is a point blob rather than the outline of a disk.
pub const MIN_TEMPLATE_DIAMETER_PX: f64 = 2.0;

/// Default of [`TemplateConfig::scale_start`] (the paper's 0.1).
pub const PAPER_SCALE_START: f64 = 0.1;

/// Template images and their scale schedule (paper §2.2.3).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct TemplateConfig {
    /// Image drawn at each scale. Default: striped disk.
    pub kind: TemplateKind,
    /// Square-wave cycles per disk diameter of the striped disk (paper: 2).
    pub cycles: f64,
    /// Stripe phase in cycles (see [`TemplateKind::StripedDisk`]). Default 0.25: the disk
    /// centre lies in the middle of a bright stripe, the same as the stimulus default, so no
    /// stripe edge sits still at the centre while a disk grows (with 0 one does, and the
    /// delayed frame keeps winning: z stays at 1).
    pub phase: f64,
    /// Vertical position of every template disk's centre, in pixels below the frame's
    /// geometric centre (n/2 in continuous coordinates whose pixel centres are at k + ½).
    ///
    /// Default 0.5: the template is centred on the centre of pixel row n/2 (0-based), the
    /// usual integer-grid convention (`cy = n // 2`), half a pixel below the geometric centre
    /// where the stimulus objects are centred. Why not 0: the query is an *odd* (Sobel) edge
    /// response and the template an *even* (Laplacian) one. Across one edge the Sobel response
    /// is a symmetric bump and the Laplacian an antisymmetric doublet, so their dot product
    /// vanishes when the edges coincide and is largest when the template edge is about a pixel
    /// off. A disk mirror-symmetric about the frame centre and a template symmetric about the
    /// same centre are therefore exactly orthogonal (measured: z stays at 1 for the whole
    /// approach of a white disk); any half-pixel or pixel shift makes the edges of a matching
    /// disk add up (0.5, 1, 1.5 and 2 px give the same rise within a frame or two; 0.5 keeps
    /// retrieving the largest template one frame longer when the disk overfills the frame).
    pub offset_px: f64,
    /// Sizes of the templates: the paper's schedule or its footnote's. Default paper.
    pub schedule: ScaleSchedule,
    /// Scale s of the first (smallest) template: disk diameter s·n pixels (paper: 0.1). Only
    /// with the paper schedule and without `scale_start_px`.
    pub scale_start: f64,
    /// Diameter of the first template in pixels, instead of the fraction `scale_start`
    /// (≥ 2 pixels; the footnote schedule's default is 7). Default: not set.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scale_start_px: Option<f64>,
    /// Scale increment Δs; `None` = the schedule's: 3/(2n) (paper) or 1/n (footnote).
    pub scale_step: Option<f64>,
    /// Largest scale: N = 1 + ⌊(scale_end − s_1)/Δs⌋ templates (paper: 1, giving
    /// N = 1 + ⌊3n/5⌋).
    pub scale_end: f64,
}

impl Default for TemplateConfig {
    fn default() -> Self {
        Self {
            kind: TemplateKind::StripedDisk,
            cycles: 2.0,
            phase: 0.25,
            offset_px: 0.5,
            schedule: ScaleSchedule::Paper,
            scale_start: PAPER_SCALE_START,
            scale_start_px: None,
            scale_step: None,
            scale_end: 1.0,
        }
    }
}

impl TemplateConfig {
    /// Scale s_1 of the first template for frames of side n: `scale_start_px`/n if given,
    /// else 7/n (footnote) or `scale_start` (paper).
    pub fn scale_start_for(&self, n: usize) -> f64 {
        match (self.scale_start_px, self.schedule) {
            (Some(px), _) => px / n as f64,
            (None, ScaleSchedule::Footnote) => FOOTNOTE_START_PX / n as f64,
            (None, ScaleSchedule::Paper) => self.scale_start,
        }
    }

    /// Δs for frames of side n: `scale_step`, or the schedule's 3/(2n) (paper) or 1/n
    /// (footnote).
    pub fn scale_step_for(&self, n: usize) -> f64 {
        self.scale_step.unwrap_or(match self.schedule {
            ScaleSchedule::Paper => 3.0 / (2.0 * n as f64),
            ScaleSchedule::Footnote => 1.0 / n as f64,
        })
    }

    /// Number N of templates for frames of side n (paper: 1 + ⌊3n/5⌋).
    pub fn template_count(&self, n: usize) -> usize {
        let steps = (self.scale_end - self.scale_start_for(n)) / self.scale_step_for(n);
        // The epsilon makes exact multiples (n divisible by 5 with the paper's schedule) count.
        // `as usize` saturates (a huge or infinite count is then rejected by `validate`, which
        // checks it against MAX_TEMPLATES); NaN counts as 0.
        ((steps + 1e-9).floor().max(0.0) as usize).saturating_add(1)
    }

    /// Scale s_i of template i (1-based, as in the paper): s_1 + (i − 1)·Δs.
    pub fn scale(&self, n: usize, i: usize) -> f64 {
        self.scale_start_for(n) + (i as f64 - 1.0) * self.scale_step_for(n)
    }
}

/// Largest template count accepted (guards against absurd schedules eating memory).
pub const MAX_TEMPLATES: usize = 4096;

/// Largest memory the reference implementation may allocate for its two dense pattern
/// memories (2·n²·(N+1) f64), in bytes: 8 GiB.
pub const MAX_REFERENCE_BYTES: f64 = 8.0 * 1024.0 * 1024.0 * 1024.0;

/// Smallest accepted convergence `tolerance`. The fast implementation never forms ξ(τ): it
/// evaluates ‖ξ(τ+1) − ξ(τ)‖² in pattern space as a difference of dot products of order 1,
/// whose rounding error (≈ 1e-15) is ≈ 3e-8 in the distance. Below 1e-6 its stop decision,
/// and with it the iteration count, would be decided by rounding and could differ from the
/// reference implementation's.
pub const MIN_TOLERANCE: f64 = 1e-6;

/// How the camera frame becomes the query (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FrontEnd {
    /// The processed frame itself, as in the paper. Default.
    #[default]
    Paper,
    /// The processed frame minus its per-pixel running mean (temporal high-pass with time
    /// constant `adaptation_tau_s`): static clutter fades out of the query.
    Adapted,
    /// The adapted high-pass with the robot's own motion removed first: the running mean of the
    /// camera images is warped by the static world's predicted image motion (from the efference
    /// copy) before it is subtracted (see the module docs).
    Compensated,
}

/// How θ̂ (`angular_size_deg`) is read out (see [`super`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Readout {
    /// From the low-passed activity: √(z_on·z_off) read as a template index. Default.
    #[default]
    Paper,
    /// From the template that wins this frame's retrieval (per channel; the larger of ON and
    /// OFF), optionally low-passed with `readout_alpha`.
    Winner,
    /// From the template that matches this frame's query best (the delayed column left out),
    /// when its cosine is at least `min_template_cosine`, optionally low-passed with
    /// `readout_alpha`.
    Template,
}

/// Keys of [`HopfieldConfig`] that describe the camera rather than the detector: the frame side
/// `n`, the field of view `fov_deg` and the frame rate `frame_rate_hz`. Wherever the detector runs
/// on frames from a camera, a stimulus or a video, these come from that source, and files of
/// detector parameters (scenario `[[detectors]] params`, `loomlab detect --hopfield-config`) reject
/// them.
pub const CAMERA_KEYS: [&str; 3] = ["n", "fov_deg", "frame_rate_hz"];

/// All parameters of the Hopfield detector. `Default` = the paper's values for 256×256 frames.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct HopfieldConfig {
    /// Frame side length n the pattern memory is built for (d = n² pixels). Default 256.
    pub n: usize,
    /// Inverse temperature β of the softmax (paper: 500).
    pub beta: f64,
    /// Delay (frames) of the dynamic first memory column ξ(t − delay) (paper: 5).
    pub delay: usize,
    /// Low-pass memory coefficient α of eq. 10 (paper: 0.85).
    pub alpha: f64,
    /// Convergence tolerance on ‖ξ(τ+1) − ξ(τ)‖₂ (paper: 0.01; at least [`MIN_TOLERANCE`]).
    pub tolerance: f64,
    /// Maximum number of updates ξ ← X·softmax(β Xᵀξ) per frame and channel (paper: 5).
    pub max_iterations: usize,
    /// Region-of-interest mask; `None` = no mask (in TOML: `mask = "none"` or `mask = false`).
    #[serde(deserialize_with = "deserialize_mask", serialize_with = "serialize_mask")]
    pub mask: Option<MaskConfig>,
    /// Padding of the S_odd convolution. Default replicate.
    pub frame_border: FrameBorder,
    /// Template image and scale schedule.
    pub template: TemplateConfig,
    /// Horizontal = vertical field of view of the camera in degrees, used only to turn the
    /// winning template size into an angular size (default 60). Owned by the camera.
    pub fov_deg: f64,
    /// Camera frame rate in frames per second, used only by the adapted front end to turn
    /// `adaptation_tau_s` into a per-frame weight (default 120, the simulator's and the
    /// stimuli's default). Owned by the camera, like `fov_deg`.
    pub frame_rate_hz: f64,
    /// Which implementation runs (default fast).
    pub implementation: Implementation,
    /// Query front end: the paper's processed frame, or its temporal high-pass. Default paper.
    pub front_end: FrontEnd,
    /// Time constant τ of the adapted front end's running mean, in seconds (default 0.1:
    /// weight 0.28 per frame at 30 frames/s, 0.08 at 120). Ignored by the paper front end.
    ///
    /// Why 0.1 s: when an object expands over static clutter, the clutter it has just covered
    /// is still in the running mean and shows up in G as a negative copy of the clutter's
    /// edges, for about τ. With τ = 0.3 s (weight 0.1 per frame at 30 frames/s) that residue
    /// outweighs the object's rim once the object grows fast, and the delayed frame wins
    /// again (measured on `detector/tests/hopfield_clutter.rs`: activity only between θ ≈ 9°
    /// and 15°); with 0.1–0.15 s the templates keep winning up to the end of the approach;
    /// much shorter (≤ 0.05 s) approaches frame differencing and responds to single-frame
    /// jitter of small objects.
    pub adaptation_tau_s: f64,
    /// Angular-size readout. Default paper.
    pub readout: Readout,
    /// Low-pass coefficient of the winner and template readouts, in [0, 1): θ̂ scale ←
    /// a·old + (1 − a)·new each frame with evidence (the template readout: each frame that reads
    /// a size, starting afresh after one that does not and with each new tracked object); 0
    /// (default) = the raw per-frame winner or template. Ignored by the paper readout.
    pub readout_alpha: f64,
    /// Template readout: the smallest cosine (in magnitude) between the query and its
    /// best-matching template that reads as a size, in (0, 1] (default 0.05: measured on the
    /// default suite's frames, 0.1–0.3 for the best template on an object, at most about 0.01 on
    /// the residual noise of the compensated front end). Ignored by the other readouts.
    pub min_template_cosine: f64,
    /// Where the query looks: the whole frame (default `none`) or the object that the `tracker`
    /// detector follows (`tracker`).
    pub attention: Attention,
}

/// Where the query looks (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Attention {
    /// The whole frame, as in the paper. Default.
    #[default]
    None,
    /// Centred on the object that the `tracker` detector follows in the same frames.
    Tracker,
}

impl Default for HopfieldConfig {
    fn default() -> Self {
        Self {
            n: 256,
            beta: 500.0,
            delay: 5,
            alpha: 0.85,
            tolerance: 0.01,
            max_iterations: 5,
            mask: Some(MaskConfig::default()),
            frame_border: FrameBorder::Replicate,
            template: TemplateConfig::default(),
            fov_deg: 60.0,
            frame_rate_hz: 120.0,
            implementation: Implementation::Fast,
            front_end: FrontEnd::Paper,
            adaptation_tau_s: 0.1,
            readout: Readout::Paper,
            readout_alpha: 0.0,
            min_template_cosine: DEFAULT_MIN_TEMPLATE_COSINE,
            attention: Attention::None,
        }
    }
}

/// Default of [`HopfieldConfig::min_template_cosine`].
pub const DEFAULT_MIN_TEMPLATE_COSINE: f64 = 0.05;

fn invalid(name: &'static str, value: impl fmt::Display, reason: impl Into<String>) -> DetectorError {
    DetectorError::InvalidParameter {
        name,
        value: value.to_string(),
        reason: reason.into(),
    }
}

impl HopfieldConfig {
    /// The paper's parameters for frames of side `n`.
    pub fn for_size(n: usize) -> Self {
        Self { n, ..Self::default() }
    }

    /// The settings for cluttered scenes at n = 256 (see [`HopfieldConfig::adapted_for_size`]).
    pub fn adapted() -> Self {
        Self::adapted_for_size(256)
    }

    /// The paper's parameters for frames of side `n`, except the front end and readout:
    /// `front_end = "adapted"` (τ = 0.1 s), `readout = "winner"` with `readout_alpha = 0.5`.
    /// Set `frame_rate_hz` and `fov_deg` to the camera's.
    pub fn adapted_for_size(n: usize) -> Self {
        Self {
            n,
            front_end: FrontEnd::Adapted,
            readout: Readout::Winner,
            readout_alpha: ADAPTED_READOUT_ALPHA,
            ..Self::default()
        }
    }

    /// Same parameters, other implementation.
    pub fn with_implementation(self, implementation: Implementation) -> Self {
        Self { implementation, ..self }
    }

    /// Parses a TOML table (all keys optional, unknown keys rejected) and validates it.
    pub fn from_toml_str(text: &str) -> Result<Self, DetectorError> {
        let cfg: Self = toml::from_str(text).map_err(|e| DetectorError::InvalidParameter {
            name: "hopfield",
            value: "<toml>".into(),
            reason: e.to_string(),
        })?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Number N of templates (paper: 1 + ⌊3n/5⌋).
    pub fn template_count(&self) -> usize {
        self.template.template_count(self.n)
    }

    /// Number of columns of each pattern memory: N + 1 (the delayed query plus N templates;
    /// 2 + ⌊3n/5⌋ with the paper's schedule).
    pub fn memory_columns(&self) -> usize {
        self.template_count() + 1
    }

    /// Per-frame update weight of the adapted front end's running mean:
    /// w = 1 − exp(−1/(τ·f)) with τ = `adaptation_tau_s`, f = `frame_rate_hz`.
    pub fn adaptation_weight(&self) -> f64 {
        -(-1.0 / (self.adaptation_tau_s * self.frame_rate_hz)).exp_m1()
    }

    /// Checks every parameter; the error names the key, the value and the valid range.
    pub fn validate(&self) -> Result<(), DetectorError> {
        let n = self.n;
        if !(16..=4096).contains(&n) {
            return Err(invalid("n", n, "frame side must be in 16..=4096 pixels"));
        }
        if !(self.beta.is_finite() && self.beta > 0.0) {
            return Err(invalid(
                "beta",
                self.beta,
                "inverse temperature must be a positive finite number (paper: 500)",
            ));
        }
        if self.delay == 0 || self.delay > 1000 {
            return Err(invalid(
                "delay",
                self.delay,
                "delay must be 1..=1000 frames (0 would store the query itself: it always wins; paper: 5)",
            ));
        }
        if !(self.alpha.is_finite() && (0.0..1.0).contains(&self.alpha)) {
            return Err(invalid(
                "alpha",
                self.alpha,
                "low-pass memory must be in [0, 1) (paper: 0.85)",
            ));
        }
        if !(self.tolerance.is_finite() && self.tolerance >= MIN_TOLERANCE) {
            return Err(invalid(
                "tolerance",
                self.tolerance,
                format!(
                    "must be a finite number ≥ {MIN_TOLERANCE:e} (paper: 0.01): the fast implementation measures \
                     ‖ξ(τ+1) − ξ(τ)‖ in pattern space, where rounding leaves ≈ 3e-8 of noise, so smaller \
                     tolerances (and 0) would stop or not stop by chance"
                ),
            ));
        }
        if self.max_iterations == 0 || self.max_iterations > 1000 {
            return Err(invalid(
                "max_iterations",
                self.max_iterations,
                "must be 1..=1000 (paper: 5)",
            ));
        }
        if let Some(m) = &self.mask {
            if !(m.radius_frac.is_finite() && m.radius_frac > 0.0) {
                return Err(invalid(
                    "mask.radius_frac",
                    m.radius_frac,
                    "mask radius must be a positive fraction of n/2 (paper: 0.9); use mask = \"none\" for no mask",
                ));
            }
            if !(m.blur_sigma_px.is_finite() && m.blur_sigma_px >= 0.0 && m.blur_sigma_px <= 1000.0) {
                return Err(invalid(
                    "mask.blur_sigma_px",
                    m.blur_sigma_px,
                    "blur must be in [0, 1000] pixels (paper: 20)",
                ));
            }
            if let Some(frac) = m.blur_sigma_frac {
                if !(frac.is_finite() && (0.0..=1.0).contains(&frac)) {
                    return Err(invalid(
                        "mask.blur_sigma_frac",
                        frac,
                        "blur must be in [0, 1] times n (0.078125 = the paper's 20 px at n = 256)",
                    ));
                }
                if m.blur_sigma_px != PAPER_BLUR_SIGMA_PX {
                    return Err(invalid(
                        "mask.blur_sigma_frac",
                        frac,
                        format!(
                            "give the blur either in pixels (blur_sigma_px = {}) or as a fraction of n \
                             (blur_sigma_frac), not both",
                            m.blur_sigma_px
                        ),
                    ));
                }
            }
        }
        self.validate_template()?;
        if !(self.fov_deg.is_finite() && self.fov_deg > 0.0 && self.fov_deg < 180.0) {
            return Err(invalid(
                "fov_deg",
                self.fov_deg,
                "field of view must be in (0, 180) degrees",
            ));
        }
        if !(self.frame_rate_hz.is_finite() && self.frame_rate_hz > 0.0 && self.frame_rate_hz <= 100_000.0) {
            return Err(invalid(
                "frame_rate_hz",
                self.frame_rate_hz,
                "camera frame rate must be in (0, 100000] frames per second (default 120)",
            ));
        }
        if !(self.adaptation_tau_s.is_finite() && self.adaptation_tau_s > 0.0 && self.adaptation_tau_s <= 3600.0) {
            return Err(invalid(
                "adaptation_tau_s",
                self.adaptation_tau_s,
                "time constant of the adapted front end must be in (0, 3600] seconds (default 0.1)",
            ));
        }
        if !(self.readout_alpha.is_finite() && (0.0..1.0).contains(&self.readout_alpha)) {
            return Err(invalid(
                "readout_alpha",
                self.readout_alpha,
                "low-pass of the winner and template readouts must be in [0, 1) (0 = unfiltered)",
            ));
        }
        if self.attention == Attention::Tracker && self.front_end == FrontEnd::Adapted {
            return Err(invalid(
                "attention",
                "tracker",
                "the adapted front end's high-pass would run on the centred view, which moves with \
                 the object; use front_end = \"compensated\" (its high-pass runs before the query is \
                 centred) or \"paper\" with attention = \"tracker\"",
            ));
        }
        if !(self.min_template_cosine.is_finite() && self.min_template_cosine > 0.0 && self.min_template_cosine <= 1.0)
        {
            return Err(invalid(
                "min_template_cosine",
                self.min_template_cosine,
                "the template readout's smallest cosine must be in (0, 1] (default 0.05)",
            ));
        }
        if self.implementation == Implementation::Reference {
            let bytes = 2.0 * (n * n) as f64 * self.memory_columns() as f64 * 8.0;
            if bytes > MAX_REFERENCE_BYTES {
                return Err(invalid(
                    "implementation",
                    "reference",
                    format!(
                        "the dense pattern memories would take {:.1} GiB (2·n²·(N+1) f64 with n = {n}, N = {}), \
                         more than {} GiB; use implementation = \"fast\" or fewer templates",
                        bytes / 1024f64.powi(3),
                        self.template_count(),
                        MAX_REFERENCE_BYTES / 1024f64.powi(3)
                    ),
                ));
            }
        }
        Ok(())
    }

    fn validate_template(&self) -> Result<(), DetectorError> {
        let n = self.n;
        let t = &self.template;
        if !(t.cycles.is_finite() && t.cycles > 0.0 && t.cycles <= n as f64) {
            return Err(invalid(
                "template.cycles",
                t.cycles,
                "must be in (0, n] cycles per disk (paper: 2)",
            ));
        }
        if !t.phase.is_finite() {
            return Err(invalid(
                "template.phase",
                t.phase,
                "must be a finite number of cycles (default 0.25)",
            ));
        }
        if !(t.offset_px.is_finite() && t.offset_px.abs() <= n as f64 / 4.0) {
            return Err(invalid(
                "template.offset_px",
                t.offset_px,
                "must be finite and within ±n/4 pixels (default 0.5)",
            ));
        }
        let start_changed = t.scale_start != PAPER_SCALE_START;
        if let Some(px) = t.scale_start_px {
            if start_changed {
                return Err(invalid(
                    "template.scale_start_px",
                    px,
                    format!(
                        "give the first template size either as a fraction of n (scale_start = {}) or in \
                         pixels (scale_start_px), not both",
                        t.scale_start
                    ),
                ));
            }
            if !(px.is_finite() && px >= MIN_TEMPLATE_DIAMETER_PX && px <= n as f64) {
                return Err(invalid(
                    "template.scale_start_px",
                    px,
                    format!("the first disk must be 2..=n = {n} pixels wide (a narrower one has no disk outline)"),
                ));
            }
        } else if t.schedule == ScaleSchedule::Footnote && start_changed {
            return Err(invalid(
                "template.scale_start",
                t.scale_start,
                "the footnote schedule starts at 7 pixels; set template.scale_start_px to change that \
                 (scale_start belongs to the paper schedule)",
            ));
        }
        let start = t.scale_start_for(n);
        if !(start.is_finite() && start * n as f64 >= MIN_TEMPLATE_DIAMETER_PX) {
            if t.schedule == ScaleSchedule::Paper && t.scale_start_px.is_none() && !start_changed {
                // The paper's default schedule at a small n: say why n is too small.
                return Err(invalid(
                    "n",
                    n,
                    format!(
                        "too small for the paper's template schedule: its smallest template disk is \
                         scale_start·n = 0.1·{n} = {:.1} pixels wide, and a disk narrower than 2 pixels is at \
                         most one pixel row, with no disk outline to match, so the paper's schedule needs \
                         n ≥ {} (loomlab_detector::MIN_FRAME_SIZE); for smaller frames (down to 16) set template.schedule = \"footnote\" \
                         (7-pixel first disk) or template.scale_start_px (e.g. 4)",
                        start * n as f64,
                        crate::MIN_FRAME_SIZE
                    ),
                ));
            }
            return Err(invalid(
                "template.scale_start",
                t.scale_start,
                format!(
                    "the smallest disk must be at least 2 pixels wide: scale_start ≥ 2/n = {} \
                     (or give scale_start_px ≥ 2)",
                    2.0 / n as f64
                ),
            ));
        }
        if let Some(step) = t.scale_step
            && !(step.is_finite() && step > 0.0)
        {
            return Err(invalid(
                "template.scale_step",
                step,
                "must be a positive number (default 3/(2n) for the paper schedule, 1/n for the footnote's)",
            ));
        }
        if !(t.scale_end.is_finite() && t.scale_end >= start && t.scale_end <= 4.0) {
            return Err(invalid(
                "template.scale_end",
                t.scale_end,
                format!("must be in [first scale = {start}, 4] (paper: 1)"),
            ));
        }
        let count = self.template_count();
        if count > MAX_TEMPLATES {
            return Err(invalid(
                "template.scale_step",
                t.scale_step_for(n),
                format!("gives {count} templates, more than {MAX_TEMPLATES}; use a larger step"),
            ));
        }
        Ok(())
    }
}

/// `readout_alpha` of [`HopfieldConfig::adapted`].
pub const ADAPTED_READOUT_ALPHA: f64 = 0.5;

/// `mask` in TOML: a table, or `"none"` / `false` for no mask (`true` = the paper's mask).
#[derive(Deserialize)]
#[serde(untagged)]
enum MaskSetting {
    Flag(bool),
    Word(String),
    Table(MaskConfig),
}

fn deserialize_mask<'de, D: Deserializer<'de>>(d: D) -> Result<Option<MaskConfig>, D::Error> {
    match MaskSetting::deserialize(d)? {
        MaskSetting::Flag(false) => Ok(None),
        MaskSetting::Flag(true) => Ok(Some(MaskConfig::default())),
        MaskSetting::Word(w) if w == "none" => Ok(None),
        MaskSetting::Word(w) if w == "paper" || w == "default" => Ok(Some(MaskConfig::default())),
        MaskSetting::Word(w) => Err(serde::de::Error::custom(format!(
            "mask = \"{w}\": expected \"none\", \"paper\", true/false or a table {{ radius_frac, blur_sigma_px or blur_sigma_frac }}"
        ))),
        MaskSetting::Table(m) => Ok(Some(m)),
    }
}

fn serialize_mask<S: serde::Serializer>(mask: &Option<MaskConfig>, s: S) -> Result<S::Ok, S::Error> {
    match mask {
        None => s.serialize_str("none"),
        Some(m) => m.serialize(s),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_paper_values() {
        let c = HopfieldConfig::default();
        assert_eq!((c.n, c.delay, c.max_iterations), (256, 5, 5));
        assert_eq!((c.beta, c.alpha, c.tolerance, c.fov_deg), (500.0, 0.85, 0.01, 60.0));
        assert_eq!(
            c.mask,
            Some(MaskConfig {
                radius_frac: 0.9,
                blur_sigma_px: 20.0,
                ..Default::default()
            })
        );
        assert_eq!(c.implementation, Implementation::Fast);
        assert_eq!(c.template.kind, TemplateKind::StripedDisk);
        assert_eq!(c.template_count(), 154); // the paper's N at n = 256
        c.validate().unwrap();
    }

    #[test]
    fn template_count_is_one_plus_floor_three_n_over_five() {
        for n in [16, 20, 25, 32, 50, 64, 100, 128, 200, 250, 256, 300, 512] {
            let c = HopfieldConfig::for_size(n);
            assert_eq!(c.template_count(), 1 + 3 * n / 5, "n = {n}");
            assert_eq!(c.memory_columns(), 2 + 3 * n / 5, "n = {n}");
        }
    }

    #[test]
    fn toml_keys_masks_and_unknown_keys() {
        let c = HopfieldConfig::from_toml_str("n = 64\nmask = \"none\"\nimplementation = \"reference\"").unwrap();
        assert_eq!((c.n, c.mask, c.implementation), (64, None, Implementation::Reference));
        let c = HopfieldConfig::from_toml_str("mask = false").unwrap();
        assert_eq!(c.mask, None);
        let c =
            HopfieldConfig::from_toml_str("mask = { radius_frac = 0.5 }\n[template]\nkind = \"uniform_disk\"").unwrap();
        assert_eq!(
            c.mask,
            Some(MaskConfig {
                radius_frac: 0.5,
                blur_sigma_px: 20.0,
                ..Default::default()
            })
        );
        assert_eq!(c.template.kind, TemplateKind::UniformDisk);
        assert!(
            HopfieldConfig::from_toml_str("betta = 3")
                .unwrap_err()
                .to_string()
                .contains("betta")
        );
        assert!(HopfieldConfig::from_toml_str("mask = \"round\"").is_err());
        assert!(HopfieldConfig::from_toml_str("[template]\nsize = 3").is_err());
    }

    #[test]
    fn invalid_values_name_the_key() {
        let bad = [
            (
                "n",
                HopfieldConfig {
                    n: 4,
                    ..Default::default()
                },
            ),
            (
                "beta",
                HopfieldConfig {
                    beta: f64::NAN,
                    ..Default::default()
                },
            ),
            (
                "delay",
                HopfieldConfig {
                    delay: 0,
                    ..Default::default()
                },
            ),
            (
                "alpha",
                HopfieldConfig {
                    alpha: 1.0,
                    ..Default::default()
                },
            ),
            (
                "tolerance",
                HopfieldConfig {
                    tolerance: -1.0,
                    ..Default::default()
                },
            ),
            (
                "max_iterations",
                HopfieldConfig {
                    max_iterations: 0,
                    ..Default::default()
                },
            ),
            (
                "mask.radius_frac",
                HopfieldConfig {
                    mask: Some(MaskConfig {
                        radius_frac: 0.0,
                        blur_sigma_px: 1.0,
                        ..Default::default()
                    }),
                    ..Default::default()
                },
            ),
            (
                "mask.blur_sigma_px",
                HopfieldConfig {
                    mask: Some(MaskConfig {
                        radius_frac: 0.9,
                        blur_sigma_px: -1.0,
                        ..Default::default()
                    }),
                    ..Default::default()
                },
            ),
            (
                "template.scale_start",
                HopfieldConfig {
                    template: TemplateConfig {
                        scale_start: 0.001,
                        ..Default::default()
                    },
                    ..Default::default()
                },
            ),
            (
                "template.scale_step",
                HopfieldConfig {
                    template: TemplateConfig {
                        scale_step: Some(0.0),
                        ..Default::default()
                    },
                    ..Default::default()
                },
            ),
            (
                "template.scale_step",
                HopfieldConfig {
                    template: TemplateConfig {
                        scale_step: Some(1e-6),
                        ..Default::default()
                    },
                    ..Default::default()
                },
            ),
            (
                "template.cycles",
                HopfieldConfig {
                    template: TemplateConfig {
                        cycles: 0.0,
                        ..Default::default()
                    },
                    ..Default::default()
                },
            ),
            (
                "fov_deg",
                HopfieldConfig {
                    fov_deg: 180.0,
                    ..Default::default()
                },
            ),
        ];
        for (key, cfg) in bad {
            match cfg.validate() {
                Err(DetectorError::InvalidParameter { name, .. }) => assert_eq!(name, key),
                other => panic!("{key}: expected InvalidParameter, got {other:?}"),
            }
        }
        assert_eq!("fast".parse::<Implementation>().unwrap(), Implementation::Fast);
        assert!("slow".parse::<Implementation>().is_err());
    }

    #[test]
    fn attention_and_the_template_readout_parse() {
        let c = HopfieldConfig::default();
        assert_eq!(
            (c.attention, c.min_template_cosine),
            (Attention::None, DEFAULT_MIN_TEMPLATE_COSINE)
        );
        let c = HopfieldConfig::from_toml_str(
            "attention = \"tracker\"\nreadout = \"template\"\nmin_template_cosine = 0.1\nreadout_alpha = 0.5\n",
        )
        .unwrap();
        assert_eq!(
            (c.attention, c.readout, c.min_template_cosine, c.readout_alpha),
            (Attention::Tracker, Readout::Template, 0.1, 0.5)
        );
        let e = HopfieldConfig::from_toml_str("attention = \"gaze\"\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("attention") && e.contains("tracker"), "{e}");
    }

    #[test]
    fn new_keys_parse_with_paper_defaults() {
        let c = HopfieldConfig::default();
        assert_eq!(
            (
                c.front_end,
                c.readout,
                c.readout_alpha,
                c.frame_rate_hz,
                c.adaptation_tau_s
            ),
            (FrontEnd::Paper, Readout::Paper, 0.0, 120.0, 0.1)
        );
        assert_eq!(
            (c.template.schedule, c.template.scale_start_px),
            (ScaleSchedule::Paper, None)
        );
        assert_eq!(c.mask.unwrap().blur_sigma_frac, None);
        let c = HopfieldConfig::from_toml_str(
            "n = 128\nfront_end = \"adapted\"\nadaptation_tau_s = 0.2\nframe_rate_hz = 30\n\
             readout = \"winner\"\nreadout_alpha = 0.5\nmask = { blur_sigma_frac = 0.078125 }\n\
             [template]\nschedule = \"footnote\"\nscale_start_px = 9.0\n",
        )
        .unwrap();
        assert_eq!(
            (
                c.front_end,
                c.readout,
                c.readout_alpha,
                c.frame_rate_hz,
                c.adaptation_tau_s
            ),
            (FrontEnd::Adapted, Readout::Winner, 0.5, 30.0, 0.2)
        );
        assert_eq!(c.mask.unwrap().blur_sigma_for(128), 10.0);
        assert_eq!(c.template.schedule, ScaleSchedule::Footnote);
        assert_eq!(c.template.scale_start_for(128), 9.0 / 128.0);
        assert_eq!(c.template_count(), 1 + 128 - 9);
        assert!(HopfieldConfig::from_toml_str("front_end = \"lowpass\"").is_err());
        assert!(HopfieldConfig::from_toml_str("readout = \"max\"").is_err());
        assert!(HopfieldConfig::from_toml_str("[template]\nschedule = \"other\"").is_err());
        // Round trip through TOML.
        for c in [HopfieldConfig::default(), HopfieldConfig::adapted(), c] {
            let text = toml::to_string(&c).unwrap();
            assert_eq!(HopfieldConfig::from_toml_str(&text).unwrap(), c, "{text}");
        }
        let a = HopfieldConfig::adapted_for_size(64);
        assert_eq!((a.n, a.front_end, a.readout), (64, FrontEnd::Adapted, Readout::Winner));
        assert_eq!(
            HopfieldConfig {
                front_end: FrontEnd::Paper,
                readout: Readout::Paper,
                readout_alpha: 0.0,
                ..a
            },
            HopfieldConfig::for_size(64)
        );
    }

    #[test]
    fn footnote_schedule_starts_at_seven_pixels_in_one_pixel_steps() {
        for n in [16, 20, 64, 128, 256, 4096] {
            let t = TemplateConfig {
                schedule: ScaleSchedule::Footnote,
                ..Default::default()
            };
            assert_eq!(t.template_count(n), n - 6, "n = {n}");
            assert!((t.scale(n, 1) * n as f64 - 7.0).abs() < 1e-9);
            assert!((t.scale(n, 5) * n as f64 - 11.0).abs() < 1e-9);
            let c = HopfieldConfig {
                n,
                template: t,
                ..Default::default()
            };
            c.validate().unwrap();
            assert!(c.template_count() <= MAX_TEMPLATES);
        }
        // Pixels instead of a fraction, with the paper's step.
        let t = TemplateConfig {
            scale_start_px: Some(25.6),
            ..Default::default()
        };
        assert_eq!(t.template_count(256), TemplateConfig::default().template_count(256));
    }

    #[test]
    fn small_frames_explain_the_minimum() {
        for n in 16..20 {
            match HopfieldConfig::for_size(n).validate() {
                Err(DetectorError::InvalidParameter { name, reason, .. }) => {
                    assert_eq!(name, "n");
                    assert!(reason.contains("n ≥ 20") && reason.contains("2 pixels"), "{reason}");
                    assert!(
                        reason.contains("scale_start_px") && reason.contains("footnote"),
                        "{reason}"
                    );
                }
                other => panic!("n = {n}: {other:?}"),
            }
            // The way out the message offers works.
            for template in [
                TemplateConfig {
                    schedule: ScaleSchedule::Footnote,
                    ..Default::default()
                },
                TemplateConfig {
                    scale_start_px: Some(4.0),
                    ..Default::default()
                },
            ] {
                let c = HopfieldConfig {
                    template,
                    ..HopfieldConfig::for_size(n)
                };
                c.validate().unwrap();
                crate::hopfield::Hopfield::new(c).unwrap();
            }
        }
        HopfieldConfig::for_size(20).validate().unwrap();
        let e = HopfieldConfig::for_size(15).validate().unwrap_err().to_string();
        assert!(e.contains("16..=4096"), "{e}");
    }

    #[test]
    fn new_invalid_values_name_the_key() {
        let d = HopfieldConfig::default();
        let bad = [
            ("tolerance", HopfieldConfig { tolerance: 0.0, ..d }),
            ("tolerance", HopfieldConfig { tolerance: 1e-7, ..d }),
            (
                "frame_rate_hz",
                HopfieldConfig {
                    frame_rate_hz: 0.0,
                    ..d
                },
            ),
            (
                "frame_rate_hz",
                HopfieldConfig {
                    frame_rate_hz: f64::INFINITY,
                    ..d
                },
            ),
            (
                "adaptation_tau_s",
                HopfieldConfig {
                    adaptation_tau_s: 0.0,
                    ..d
                },
            ),
            (
                "adaptation_tau_s",
                HopfieldConfig {
                    adaptation_tau_s: f64::NAN,
                    ..d
                },
            ),
            (
                "readout_alpha",
                HopfieldConfig {
                    readout_alpha: 1.0,
                    ..d
                },
            ),
            (
                "readout_alpha",
                HopfieldConfig {
                    readout_alpha: -0.1,
                    ..d
                },
            ),
            (
                "attention",
                HopfieldConfig {
                    attention: Attention::Tracker,
                    front_end: FrontEnd::Adapted,
                    ..d
                },
            ),
            (
                "min_template_cosine",
                HopfieldConfig {
                    min_template_cosine: 0.0,
                    ..d
                },
            ),
            (
                "min_template_cosine",
                HopfieldConfig {
                    min_template_cosine: 1.5,
                    ..d
                },
            ),
            (
                "min_template_cosine",
                HopfieldConfig {
                    min_template_cosine: f64::NAN,
                    ..d
                },
            ),
            (
                "mask.blur_sigma_frac",
                HopfieldConfig {
                    mask: Some(MaskConfig {
                        blur_sigma_frac: Some(2.0),
                        ..Default::default()
                    }),
                    ..d
                },
            ),
            (
                "mask.blur_sigma_frac",
                HopfieldConfig {
                    mask: Some(MaskConfig {
                        blur_sigma_px: 5.0,
                        blur_sigma_frac: Some(0.05),
                        ..Default::default()
                    }),
                    ..d
                },
            ),
            (
                "template.scale_start_px",
                HopfieldConfig {
                    template: TemplateConfig {
                        scale_start_px: Some(1.5),
                        ..Default::default()
                    },
                    ..d
                },
            ),
            (
                "template.scale_start_px",
                HopfieldConfig {
                    template: TemplateConfig {
                        scale_start_px: Some(7.0),
                        scale_start: 0.2,
                        ..Default::default()
                    },
                    ..d
                },
            ),
            (
                "template.scale_start",
                HopfieldConfig {
                    template: TemplateConfig {
                        schedule: ScaleSchedule::Footnote,
                        scale_start: 0.2,
                        ..Default::default()
                    },
                    ..d
                },
            ),
            (
                "implementation",
                HopfieldConfig {
                    n: 2048,
                    implementation: Implementation::Reference,
                    ..d
                },
            ),
        ];
        for (key, cfg) in bad {
            match cfg.validate() {
                Err(e @ DetectorError::InvalidParameter { name, .. }) => {
                    assert_eq!(name, key, "{e}");
                    assert!(e.to_string().contains(key), "{e}");
                }
                other => panic!("{key}: expected InvalidParameter, got {other:?}"),
            }
        }
        let e = HopfieldConfig { tolerance: 1e-9, ..d }
            .validate()
            .unwrap_err()
            .to_string();
        assert!(e.contains("1e-6") && e.contains("pattern space"), "{e}");
        HopfieldConfig {
            tolerance: MIN_TOLERANCE,
            ..d
        }
        .validate()
        .unwrap();
    }
}

//! The paper's artificial approach videos (paper §3.1–3.2; file format: docs/design.md §4), rendered analytically
//! on the CPU together with the true angular size of the object in every frame.
//!
//! A stimulus TOML file ([`StimulusSpec`]) describes an object (disk or square, textured)
//! approaching the camera at constant speed over a background (uniform, drifting or rotating
//! sine grating, static or dynamic noise), optionally behind an occluding foreground grating
//! and with random pixel dropout. `stimuli/` at the repository root holds the paper's
//! examples and a README documenting every key.
//!
//! ```
//! use loomlab_detector::stimulus::StimulusSpec;
//! let spec = StimulusSpec::from_toml_str("[stimulus]\nsize = 64\n", std::path::Path::new("<inline>")).unwrap();
//! assert_eq!(spec.frame_count(), 86); // 10 m → 0.1 m at 50 km/h, 120 frames/s
//! let f = spec.render_frame(85);
//! assert!((f.theta_true_deg - 2.0 * (0.25f64 / f.distance_m).atan().to_degrees()).abs() < 1e-12);
//! ```
//!
//! # Geometry
//! - Frame k is at t = k/fps, the object at distance d = `start_distance_m` − v·t with
//!   v = `speed_kmh`/3.6; frames are produced while d ≥ `end_distance_m`
//!   ([`StimulusSpec::frame_count`]: 86 for the paper's approach).
//! - True angular size θ = 2·atan((diameter/2)/d); for a square `diameter_m` is the side.
//! - Pinhole camera with focal length f = (n/2)/tan(fov/2) pixels; the object's image radius
//!   (half-side) is r = f·tan(θ/2) = f·(diameter/2)/d, so its pixel size matches θ exactly
//!   (for an object on the optical axis).
//! - The object's image centre is the frame centre shifted by `focus_x·n/2` to the right and
//!   `focus_y·n/2` up: the focus of expansion of paper Fig. 8 (`focus_x = 1`: right edge).
//!   The object is drawn as a frontal disk/square of radius r around that point.
//!
//! # Rendering
//! Background, then the object alpha-blended with `opacity` × its anti-aliased area coverage
//! (see `render.rs`), then the foreground bars (pixels under a bar are set to the foreground
//! luminance), then dropout (each pixel set to 0 with probability `dropout`, independently per
//! pixel and frame). Textures are defined in object-centred coordinates and scale with the
//! object (see `textures.rs` for the exact formulas), backgrounds in frame coordinates (see
//! `background.rs`). Orientation 0 means horizontal stripes everywhere; angles are
//! counter-clockwise.
//!
//! # Why the default stripe phase is 0.25
//! A grating texture is `bright` where frac(cycles·b' + phase) < ½, with b' the (rotated)
//! vertical object coordinate in diameters. With `phase = 0` a stripe edge runs through the
//! object's centre; that edge stays put while the disk grows (every other edge moves
//! outwards), so an edge-based detector sees a static structure at the centre and the delayed
//! frame keeps matching (docs/detectors.md, hopfield §2: z stays at 1 for such a disk).
//! `phase = 0.25` puts the centre in the middle of a bright stripe: every edge moves as the
//! object grows, like the paper's Fig. 3 insets (two bright and two dark stripes on a disk of
//! 2 cycles, symmetric about the centre). The same phase convention applies to checker, circular and starburst.
//!
//! # Randomness
//! Everything random (the object's noise texture, noise backgrounds, dropout) comes from
//! ChaCha8 generators seeded from (`stimulus.seed`, element, frame number), so rendering is
//! deterministic, frame `t` is the same whether rendered alone or in sequence, and a
//! different seed gives different noise.
//!
//! Noise distributions: the object's `noise` texture is a static grid of `noise_cells`² cells
//! fixed to the object, each uniform in [dark, bright) (`noise = "uniform"`, default) or either
//! dark or bright (`noise = "binary"`); a noise background is per-pixel uniform U[0, 1) (or
//! binary 0/1) white noise. Contrast matters (docs/design.md §4, paper Fig. 7b): a uniform-[0, 1] patch
//! over uniform-[0, 1] dynamic noise leaves the sum of temporal contrast flat (the patch pixels
//! differ from frame to frame no more than the noise they cover), whereas a binary patch makes
//! it rise.

mod background;
mod noise;
pub mod paper;
mod render;
pub mod spec;
mod textures;

pub use spec::{
    BackgroundKind, BackgroundSection, CorruptionSection, ForegroundSection, NoiseDistribution, ObjectSection, Shape,
    StimulusSection, StimulusSpec, Texture,
};

use crate::Frame;

/// One rendered frame with its ground truth.
#[derive(Debug, Clone, PartialEq)]
pub struct StimulusFrame {
    /// The n×n image, luminance in [0, 1].
    pub frame: Frame,
    /// Time of the frame in seconds (frame number / fps).
    pub t_s: f64,
    /// True angular size of the object in degrees, 2·atan((diameter/2)/distance).
    pub theta_true_deg: f64,
    /// Distance of the object from the camera in metres.
    pub distance_m: f64,
}

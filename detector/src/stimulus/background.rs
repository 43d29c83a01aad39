//! Backgrounds and the occluding foreground grating, evaluated per frame.
//!
//! Image coordinates of pixel (row i, column j): its centre at `x = j + ½ − n/2` (right),
//! `y = n/2 − i − ½` (up). A grating of orientation φ (counter-clockwise from horizontal
//! stripes) varies along `u = −x·sin φ + y·cos φ`, so for φ = 0 the stripes are horizontal
//! and `u` points up.
//!
//! - `grating`: `L·(1 + C·sin(2π·k·u/n − 2π·k_t·t/fps))` with `L` = `luminance`, `C` =
//!   `contrast`, `k` = `cycles` per image, `k_t` = `drift_hz`, `t` the frame number: the paper's
//!   phase `2π·t·k_t·Δt`. The waves travel towards +u, i.e. from the bottom to the top for
//!   φ = 0 (paper Fig. 4). Values are clamped to [0, 1].
//! - `rotating_grating`: the same with φ(t) = `orientation_deg` + t·`rotation_deg_per_frame`.
//!   The sine is anchored at the frame centre, so after 180° the grating is phase-reversed
//!   (paper Fig. 5b).
//! - `noise`: independent per-pixel values in [0, 1] (`noise`: uniform U[0, 1) or binary),
//!   redrawn every frame when `dynamic`, otherwise one image for the whole episode.
//! - foreground: a square wave along the same `u`: a pixel is covered by a bar where
//!   frac(k·u/n − k_t·t/fps) < `duty`; covered pixels are set to the foreground `luminance`.
//!
//! Per-pixel trigonometry is avoided: sin(A_j + B_i) = sin A_j·cos B_i + cos A_j·sin B_i with
//! the column and row terms tabulated once per frame.

use std::f64::consts::TAU;

use super::noise::{self, Stream};
use super::spec::{BackgroundKind, BackgroundSection, ForegroundSection};

/// Pixel-centre coordinates (x right, y up) of column/row `k` in an n-pixel frame.
#[inline]
fn centred(k: usize, n: usize) -> f64 {
    k as f64 + 0.5 - 0.5 * n as f64
}

/// The background of one frame.
#[derive(Debug, Clone)]
pub(crate) enum Background {
    /// Constant luminance.
    Uniform(f32),
    /// A (drifting, possibly rotated) sine grating, tabulated by column and row.
    Grating {
        mean: f64,
        amplitude: f64,
        sin_col: Vec<f64>,
        cos_col: Vec<f64>,
        sin_row: Vec<f64>,
        cos_row: Vec<f64>,
    },
    /// A full noise image.
    Noise(Vec<f32>),
}

impl Background {
    /// The background of frame `t`.
    pub(crate) fn new(bg: &BackgroundSection, n: usize, fps: f64, seed: u64, t: usize) -> Self {
        match bg.kind {
            BackgroundKind::Uniform => Self::Uniform(bg.luminance as f32),
            BackgroundKind::Grating | BackgroundKind::RotatingGrating => {
                let orientation = if bg.kind == BackgroundKind::RotatingGrating {
                    bg.orientation_deg + t as f64 * bg.rotation_deg_per_frame
                } else {
                    bg.orientation_deg
                };
                let (sin_o, cos_o) = orientation.to_radians().sin_cos();
                let k = TAU * bg.cycles / n as f64;
                let drift = TAU * bg.drift_hz * t as f64 / fps;
                let (sin_col, cos_col) = (0..n).map(|j| (-k * centred(j, n) * sin_o).sin_cos()).unzip();
                // Row i has y = −centred(i): rows count downwards, y upwards.
                let (sin_row, cos_row) = (0..n).map(|i| (-k * centred(i, n) * cos_o - drift).sin_cos()).unzip();
                Self::Grating {
                    mean: bg.luminance,
                    amplitude: bg.luminance * bg.contrast,
                    sin_col,
                    cos_col,
                    sin_row,
                    cos_row,
                }
            }
            BackgroundKind::Noise => {
                let mut img = vec![0.0f32; n * n];
                let frame = if bg.dynamic { t as u64 } else { 0 };
                noise::fill(
                    &mut noise::rng(seed, Stream::BackgroundNoise, frame),
                    bg.noise,
                    &mut img,
                );
                Self::Noise(img)
            }
        }
    }

    /// Writes row `i` of the background into `out` (length n).
    pub(crate) fn fill_row(&self, i: usize, out: &mut [f32]) {
        let n = out.len();
        match self {
            Self::Uniform(v) => out.fill(*v),
            Self::Grating {
                mean,
                amplitude,
                sin_col,
                cos_col,
                sin_row,
                cos_row,
            } => {
                let (sb, cb) = (sin_row[i], cos_row[i]);
                for (o, (sa, ca)) in out.iter_mut().zip(sin_col.iter().zip(cos_col)) {
                    *o = (mean + amplitude * (sa * cb + ca * sb)).clamp(0.0, 1.0) as f32;
                }
            }
            Self::Noise(img) => out.copy_from_slice(&img[i * n..(i + 1) * n]),
        }
    }
}

/// The occluding foreground grating of one frame.
#[derive(Debug, Clone)]
pub(crate) struct Foreground {
    luminance: f32,
    duty: f64,
    /// Cycles per pixel along x and y (u·k/n split into x and y parts).
    kx: f64,
    ky: f64,
    offset: f64,
    n: usize,
}

impl Foreground {
    /// The foreground of frame `t`.
    pub(crate) fn new(fg: &ForegroundSection, n: usize, fps: f64, t: usize) -> Self {
        let (sin_o, cos_o) = fg.orientation_deg.to_radians().sin_cos();
        let k = fg.cycles / n as f64;
        Self {
            luminance: fg.luminance as f32,
            duty: fg.duty,
            kx: -k * sin_o,
            ky: k * cos_o,
            offset: -fg.drift_hz * t as f64 / fps,
            n,
        }
    }

    /// Covers the bar pixels of row `i` in `out` (length n).
    pub(crate) fn apply_row(&self, i: usize, out: &mut [f32]) {
        let row = -self.ky * centred(i, self.n) + self.offset;
        for (j, o) in out.iter_mut().enumerate() {
            let s = self.kx * centred(j, self.n) + row;
            if s - s.floor() < self.duty {
                *o = self.luminance;
            }
        }
    }
}

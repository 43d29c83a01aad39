//! Composition of one stimulus frame.
//!
//! Order, per pixel: background → object (alpha `opacity` times the pixel's area coverage)
//! → foreground bars → dropout. The object's outline is anti-aliased by its exact area
//! coverage: for a square the product of the x and y overlaps, for a disk the exact chord
//! overlap in x integrated over 16 sub-rows in y (pixels farther than ½√2 px from the circle
//! are fully in or out and skip this). So the rendered area equals π·r² (or 4h²) to well
//! under a pixel and the growth is smooth at sub-pixel sizes.

use rand::Rng;

use super::StimulusFrame;
use super::background::{Background, Foreground};
use super::noise::{self, Stream};
use super::spec::{Shape, StimulusSpec};
use super::textures::ObjectTexture;
use crate::Frame;

/// Sub-rows used to integrate the disk's coverage of an edge pixel.
const SUB_ROWS: usize = 16;
/// Largest image radius handled (pixels); larger objects cover any sane frame.
const MAX_RADIUS_PX: f64 = 1e7;

/// Fraction of the pixel column interval [j, j+1] inside [lo, hi].
#[inline]
fn overlap(j: f64, lo: f64, hi: f64) -> f64 {
    ((j + 1.0).min(hi) - j.max(lo)).clamp(0.0, 1.0)
}

/// Area coverage of pixel (row i, column j) by a disk of radius r centred at (cx, cy)
/// (x right, y down, pixel (i, j) spans [j, j+1]×[i, i+1]).
fn disk_coverage(i: usize, j: usize, cx: f64, cy: f64, r: f64) -> f64 {
    let dx = j as f64 + 0.5 - cx;
    let dy = i as f64 + 0.5 - cy;
    let rho2 = dx * dx + dy * dy;
    const HALF_DIAG: f64 = std::f64::consts::FRAC_1_SQRT_2;
    if r > HALF_DIAG && rho2 <= (r - HALF_DIAG) * (r - HALF_DIAG) {
        return 1.0;
    }
    if rho2 >= (r + HALF_DIAG) * (r + HALF_DIAG) {
        return 0.0;
    }
    let mut sum = 0.0;
    for s in 0..SUB_ROWS {
        let y = i as f64 + (s as f64 + 0.5) / SUB_ROWS as f64 - cy;
        let h2 = r * r - y * y;
        if h2 > 0.0 {
            let w = h2.sqrt();
            sum += overlap(j as f64, cx - w, cx + w);
        }
    }
    sum / SUB_ROWS as f64
}

impl StimulusSpec {
    /// Renders frame `t` (t = 0 is the first frame, at distance `start_distance_m`).
    ///
    /// Frames are independent of each other (random elements are seeded from
    /// (`seed`, `t`)), so any frame can be rendered alone. Frames past
    /// [`StimulusSpec::frame_count`] continue the approach; once the distance reaches zero
    /// the object fills the frame. The spec should be valid ([`StimulusSpec::validate`];
    /// parsing does it): out-of-range values give unspecified images but never panic.
    pub fn render_frame(&self, t: usize) -> StimulusFrame {
        let n = self.stimulus.size.max(1);
        let fps = self.stimulus.fps;
        let seed = self.stimulus.seed;
        let o = &self.object;

        let background = Background::new(&self.background, n, fps, seed, t);
        let foreground = self.foreground.as_ref().map(|f| Foreground::new(f, n, fps, t));
        let texture = ObjectTexture::new(o, seed);

        let r = self.object_radius_px(t);
        let r = if r.is_finite() {
            r.clamp(0.0, MAX_RADIUS_PX)
        } else {
            MAX_RADIUS_PX
        };
        let (cx, cy) = self.object_center_px();
        let alpha = o.opacity.clamp(0.0, 1.0);
        let inv_diameter = if r > 0.0 { 0.5 / r } else { 0.0 };
        let uniform_value = texture.value(0.0, 0.0);

        // Rows and columns the object can touch.
        let span = |c: f64| -> (usize, usize) {
            let lo = (c - r - 1.0).floor().max(0.0).min(n as f64) as usize;
            let hi = (c + r + 1.0).ceil().max(0.0).min(n as f64) as usize;
            (lo, hi)
        };
        let (row_lo, row_hi) = span(cy);
        let (col_lo, col_hi) = span(cx);

        let mut data = vec![0.0f32; n * n];
        for (i, row) in data.chunks_mut(n).enumerate() {
            background.fill_row(i, row);
            if alpha > 0.0 && r > 0.0 && (row_lo..row_hi).contains(&i) {
                let b = (cy - (i as f64 + 0.5)) * inv_diameter;
                let y_cov = match o.shape {
                    Shape::Square => overlap(i as f64, cy - r, cy + r),
                    Shape::Disk => 1.0,
                };
                for (j, px) in row.iter_mut().enumerate().take(col_hi).skip(col_lo) {
                    let cov = match o.shape {
                        Shape::Disk => disk_coverage(i, j, cx, cy, r),
                        Shape::Square => y_cov * overlap(j as f64, cx - r, cx + r),
                    };
                    if cov <= 0.0 {
                        continue;
                    }
                    let value = if texture.is_uniform() {
                        uniform_value
                    } else {
                        texture.value((j as f64 + 0.5 - cx) * inv_diameter, b)
                    };
                    let w = alpha * cov;
                    *px = ((1.0 - w) * *px as f64 + w * value) as f32;
                }
            }
            if let Some(fg) = &foreground {
                fg.apply_row(i, row);
            }
        }

        let dropout = self.corruption.as_ref().map_or(0.0, |c| c.dropout);
        if dropout > 0.0 {
            let mut rng = noise::rng(seed, Stream::Dropout, t as u64);
            for v in &mut data {
                if rng.random::<f64>() < dropout {
                    *v = 0.0;
                }
            }
        }

        StimulusFrame {
            frame: Frame::from_f32(n, data).expect("n ≥ 1 and n·n values"),
            t_s: self.time_s(t),
            theta_true_deg: self.theta_true_deg(t),
            distance_m: self.distance_m(t),
        }
    }

    /// Renders all [`StimulusSpec::frame_count`] frames.
    pub fn render(&self) -> Vec<StimulusFrame> {
        self.frames().collect()
    }

    /// Lazily renders the frames 0..[`StimulusSpec::frame_count`] one at a time.
    pub fn frames(&self) -> impl ExactSizeIterator<Item = StimulusFrame> + '_ {
        (0..self.frame_count()).map(move |t| self.render_frame(t))
    }
}

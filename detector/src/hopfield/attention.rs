//! Attention (`attention = "tracker"`, see [`super::config`]): the query centred on the object
//! that the `tracker` reference detector follows.
//!
//! The paper's templates are discs centred on the image, so the memory reads the size of an
//! object only while its image is (nearly) concentric with them: a small ball a few pixels off
//! centre is not retrieved at all. Attention supplies the missing "where": the tracker runs on
//! the same camera frames and efference copies, and the front end's output (the camera frame,
//! or its high-pass) is shifted by whole pixels so that the pixel holding the tracked object's
//! centroid becomes the template centre's pixel (row and column n/2); what the shift brings in
//! from outside the frame repeats the frame's border pixels (no edge where the frame ends). While the tracker reports no object the
//! query is all zero: no evidence. The size still comes from the Hopfield memory alone; the
//! tracker's box size is not used.

use crate::baselines::{Tracker, TrackerConfig};
use crate::{Detector, DetectorError, EfferenceCopy, Frame, ImageRegion};

/// The tracker that localises the object, and the shifted query image.
#[derive(Debug, Clone)]
pub struct TrackerAttention {
    tracker: Tracker,
    n: usize,
    /// The object the tracker reported for the last frame.
    region: Option<ImageRegion>,
    /// The front end's output shifted onto the object (n·n).
    centred: Vec<f32>,
}

impl TrackerAttention {
    /// For n×n frames of a camera of `fov_deg` (the tracker at its defaults).
    pub fn new(n: usize, fov_deg: f64) -> Result<Self, DetectorError> {
        Ok(Self {
            tracker: Tracker::new(TrackerConfig {
                fov_deg,
                ..TrackerConfig::default()
            })?,
            n,
            region: None,
            centred: vec![0.0; n * n],
        })
    }

    /// Forgets the tracked object.
    pub fn reset(&mut self) {
        self.tracker.reset();
        self.region = None;
    }

    /// Runs the tracker on the camera frame; the object it reports (if any) is the one the next
    /// [`Self::centre`] centres.
    pub fn follow(&mut self, frame: &Frame, ego: &EfferenceCopy) -> Result<Option<ImageRegion>, DetectorError> {
        self.region = self.tracker.step_moving(frame, ego)?.region;
        Ok(self.region)
    }

    /// The object of the last [`Self::follow`].
    pub fn region(&self) -> Option<ImageRegion> {
        self.region
    }

    /// `image` (n·n, the front end's output for the frame of the last [`Self::follow`]) shifted
    /// so the object's centroid pixel lands on pixel (n/2, n/2); all zero without an object.
    pub fn centre(&mut self, image: &[f32]) -> &[f32] {
        match self.region {
            Some(region) => {
                let (row, col) = centroid_pixel(region.centroid, self.n);
                let half = (self.n / 2) as isize;
                shift_into(
                    image,
                    self.n,
                    row as isize - half,
                    col as isize - half,
                    &mut self.centred,
                );
            }
            None => self.centred.fill(0.0),
        }
        &self.centred
    }
}

/// The pixel (row, column) of an n×n frame that holds the normalised image point `[x, y]`
/// ([`ImageRegion`]'s coordinates: x from the left border −1 to the right +1, y from the bottom
/// −1 to the top +1), clamped into the frame.
pub fn centroid_pixel([x, y]: [f64; 2], n: usize) -> (usize, usize) {
    let index = |v: f64| ((v * 0.5 * n as f64).floor().max(0.0) as usize).min(n - 1);
    (index(1.0 - y), index(x + 1.0))
}

/// `out[r][c] = image[r + dr][c + dc]` (n×n, row-major), the nearest pixel of the frame where
/// that falls outside it (replicated borders: no edge where the frame ends).
pub fn shift_into(image: &[f32], n: usize, dr: isize, dc: isize, out: &mut [f32]) {
    let source = |i: usize, d: isize| (i as isize + d).clamp(0, n as isize - 1) as usize;
    for (r, row) in out.chunks_exact_mut(n).enumerate() {
        let from = &image[source(r, dr) * n..][..n];
        for (c, o) in row.iter_mut().enumerate() {
            *o = from[source(c, dc)];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_centroid_pixel_inverts_the_region_coordinates() {
        let n = 8;
        for row in 0..n {
            for col in 0..n {
                // the centre of pixel (row, col) in normalised coordinates
                let x = 2.0 * (col as f64 + 0.5) / n as f64 - 1.0;
                let y = 1.0 - 2.0 * (row as f64 + 0.5) / n as f64;
                assert_eq!(centroid_pixel([x, y], n), (row, col));
            }
        }
        // outside the frame: clamped
        assert_eq!(centroid_pixel([-3.0, 3.0], n), (0, 0));
        assert_eq!(centroid_pixel([1.0, -1.0], n), (n - 1, n - 1));
    }

    #[test]
    fn a_shift_moves_every_pixel_and_replicates_the_border() {
        let n = 5;
        let image: Vec<f32> = (0..n * n).map(|k| k as f32 + 1.0).collect();
        for dr in -6..=6isize {
            for dc in -6..=6isize {
                let mut out = vec![-1.0; n * n];
                shift_into(&image, n, dr, dc, &mut out);
                for r in 0..n as isize {
                    for c in 0..n as isize {
                        let clamp = |v: isize| v.clamp(0, n as isize - 1);
                        let (sr, sc) = (clamp(r + dr), clamp(c + dc));
                        let want = image[(sr * n as isize + sc) as usize];
                        assert_eq!(
                            out[(r * n as isize + c) as usize],
                            want,
                            "shift ({dr}, {dc}) at ({r}, {c})"
                        );
                    }
                }
            }
        }
    }
}

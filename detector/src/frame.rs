//! The n×n grayscale [`Frame`] that every detector consumes.

use crate::DetectorError;

/// How a non-square image becomes a square frame (paper §2.2.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NonSquare {
    /// Embed symmetrically in an n = max(rows, cols) square of luminance 0.5.
    #[default]
    Embed,
    /// Crop symmetrically to an n = min(rows, cols) square.
    Crop,
}

/// An n×n grayscale image, row-major, luminance in [0, 1].
///
/// Constructors clamp values into [0, 1] and read non-finite values (NaN, ±inf)
/// as black (0.0), the same as a dropped-out pixel; [`Frame::invalid_pixels`]
/// tells how many were replaced so callers can warn about broken input.
#[derive(Debug, PartialEq)]
pub struct Frame {
    n: usize,
    data: Vec<f32>,
    invalid: usize,
}

impl Clone for Frame {
    fn clone(&self) -> Self {
        Self {
            n: self.n,
            data: self.data.clone(),
            invalid: self.invalid,
        }
    }

    /// Reuses this frame's pixel buffer (a caller that keeps the previous frame copies one per
    /// step without allocating).
    fn clone_from(&mut self, source: &Self) {
        self.n = source.n;
        self.data.clone_from(&source.data);
        self.invalid = source.invalid;
    }
}

impl Frame {
    /// A frame of uniform luminance.
    pub fn uniform(n: usize, luminance: f32) -> Self {
        Self::from_f32(n, vec![luminance; n * n]).expect("uniform frame has n*n pixels")
    }

    /// Wraps row-major luminance values (length n·n).
    pub fn from_f32(n: usize, mut data: Vec<f32>) -> Result<Self, DetectorError> {
        if n == 0 {
            return Err(DetectorError::InvalidImage(
                "frame size is 0; frames need at least 1×1 pixels".into(),
            ));
        }
        if data.len() != n * n {
            return Err(DetectorError::InvalidImage(format!(
                "{} values given for a {n}×{n} frame (expected {})",
                data.len(),
                n * n
            )));
        }
        let mut invalid = 0;
        for v in &mut data {
            if v.is_finite() {
                *v = v.clamp(0.0, 1.0);
            } else {
                *v = 0.0;
                invalid += 1;
            }
        }
        Ok(Self { n, data, invalid })
    }

    /// Converts a rows×cols image of arbitrary values to a square frame, embedding
    /// or cropping per `mode`. `pixels` is row-major with length rows·cols.
    pub fn from_rect_f32(rows: usize, cols: usize, pixels: &[f32], mode: NonSquare) -> Result<Self, DetectorError> {
        if rows == 0 || cols == 0 {
            return Err(DetectorError::InvalidImage(format!(
                "image is {cols}×{rows} pixels; it must not be empty"
            )));
        }
        if pixels.len() != rows * cols {
            return Err(DetectorError::InvalidImage(format!(
                "{} pixels given for a {cols}×{rows} image (expected {})",
                pixels.len(),
                rows * cols
            )));
        }
        if rows == cols {
            return Self::from_f32(rows, pixels.to_vec());
        }
        let n = match mode {
            NonSquare::Embed => rows.max(cols),
            NonSquare::Crop => rows.min(cols),
        };
        let mut data = vec![0.5f32; n * n];
        // Offsets of the source inside the square (embed) or of the square inside the source (crop).
        let (r_off, c_off) = ((n as isize - rows as isize) / 2, (n as isize - cols as isize) / 2);
        for i in 0..n {
            let si = i as isize - r_off;
            if si < 0 || si >= rows as isize {
                continue;
            }
            for j in 0..n {
                let sj = j as isize - c_off;
                if sj < 0 || sj >= cols as isize {
                    continue;
                }
                data[i * n + j] = pixels[si as usize * cols + sj as usize];
            }
        }
        Self::from_f32(n, data)
    }

    /// Converts an 8-bit grayscale image (row-major, rows×cols) to a frame.
    pub fn from_luma8(rows: usize, cols: usize, pixels: &[u8], mode: NonSquare) -> Result<Self, DetectorError> {
        let f: Vec<f32> = pixels.iter().map(|&p| p as f32 / 255.0).collect();
        Self::from_rect_f32(rows, cols, &f, mode)
    }

    /// Side length n.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Row-major luminance values, length n·n.
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// Luminance at row `i`, column `j`.
    pub fn get(&self, i: usize, j: usize) -> f32 {
        self.data[i * self.n + j]
    }

    /// Number of non-finite input values that were replaced by 0.
    pub fn invalid_pixels(&self) -> usize {
        self.invalid
    }

    /// The frame as 8-bit luminance (for PNG output).
    pub fn to_luma8(&self) -> Vec<u8> {
        self.data.iter().map(|&v| (v * 255.0).round() as u8).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embed_and_crop_non_square() {
        // 2 rows × 4 cols of ones.
        let px = vec![1.0f32; 8];
        let e = Frame::from_rect_f32(2, 4, &px, NonSquare::Embed).unwrap();
        assert_eq!(e.n(), 4);
        assert_eq!(e.get(0, 0), 0.5);
        assert_eq!(e.get(1, 0), 1.0);
        assert_eq!(e.get(2, 3), 1.0);
        assert_eq!(e.get(3, 3), 0.5);
        let c = Frame::from_rect_f32(2, 4, &px, NonSquare::Crop).unwrap();
        assert_eq!(c.n(), 2);
        assert!(c.data().iter().all(|&v| v == 1.0));
    }

    #[test]
    fn nan_and_out_of_range_are_sanitised() {
        let f = Frame::from_f32(2, vec![f32::NAN, 2.0, -1.0, 0.25]).unwrap();
        assert_eq!(f.data(), &[0.0, 1.0, 0.0, 0.25]);
        assert_eq!(f.invalid_pixels(), 1);
    }

    #[test]
    fn wrong_length_and_empty_are_errors() {
        assert!(Frame::from_f32(3, vec![0.0; 8]).is_err());
        assert!(Frame::from_f32(0, vec![]).is_err());
        assert!(Frame::from_rect_f32(0, 4, &[], NonSquare::Embed).is_err());
    }
}

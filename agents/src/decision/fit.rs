//! The least-squares fits of the τ estimator and the course gate: a line (through
//! [`loomlab_detector::LineFit`], the workspace's one least-squares helper) and a parabola.

use loomlab_detector::LineFit;

use super::MIN_SAMPLES;

/// Least-squares fit of `y` against `x`: `(slope, mean x, mean y)` (None with fewer than
/// [`super::MIN_SAMPLES`] points or no spread).
pub(super) fn slope(points: impl Iterator<Item = (f64, f64)>) -> Option<(f64, f64, f64)> {
    let pts: Vec<(f64, f64)> = points.collect();
    if pts.len() < MIN_SAMPLES {
        return None;
    }
    let fit = LineFit::of(&pts)?;
    (fit.sxx > 0.0).then(|| (fit.slope(), fit.mean_x, fit.mean_y))
}

/// A least-squares parabola `y = a + b·u + c·u²` in `u = x − mean_x`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Parabola {
    mean_x: f64,
    a: f64,
    b: f64,
    /// Quadratic coefficient (half the curvature).
    pub(super) c: f64,
}

impl Parabola {
    /// The parabola's value at `x`.
    pub(super) fn at(&self, x: f64) -> f64 {
        let u = x - self.mean_x;
        self.a + self.b * u + self.c * u * u
    }
}

/// Least-squares fit of a parabola (None with fewer than [`super::MIN_SAMPLES`] + 1 points or a
/// degenerate spread).
pub(super) fn parabola(points: impl Iterator<Item = (f64, f64)>) -> Option<Parabola> {
    let pts: Vec<(f64, f64)> = points.collect();
    if pts.len() < MIN_SAMPLES + 1 {
        return None;
    }
    let n = pts.len() as f64;
    let mean_x = pts.iter().map(|p| p.0).sum::<f64>() / n;
    // moments of the centred x
    let (mut s2, mut s3, mut s4, mut sy, mut sxy, mut sx2y) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for &(x, y) in &pts {
        let u = x - mean_x;
        s2 += u * u;
        s3 += u * u * u;
        s4 += u * u * u * u;
        sy += y;
        sxy += u * y;
        sx2y += u * u * y;
    }
    // normal equations with Σu = 0: [n 0 s2; 0 s2 s3; s2 s3 s4]·[a b c] = [sy sxy sx2y] (Cramer)
    let det = n * (s2 * s4 - s3 * s3) - s2 * s2 * s2;
    if det.abs() < 1e-300 {
        return None;
    }
    Some(Parabola {
        mean_x,
        a: (sy * (s2 * s4 - s3 * s3) + s2 * (sxy * s3 - s2 * sx2y)) / det,
        b: (n * (sxy * s4 - s3 * sx2y) + sy * s3 * s2 - s2 * s2 * sxy) / det,
        c: (n * (s2 * sx2y - s3 * sxy) - sy * s2 * s2) / det,
    })
}

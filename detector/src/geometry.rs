//! Basic geometry shared by every crate of the workspace: the pinhole camera's image ↔ angle
//! mapping ([`Pinhole`]) and the least-squares line ([`LineFit`]).
//!
//! This is the one place where these formulas are written: the detectors, the escape agent's
//! decision, the scenario runner's scoring and the l/|v| analysis call them (the order of every
//! floating-point operation is part of the contract: results are bit-identical to the copies they
//! replaced).

/// A pinhole camera with a square image of full field of view `fov_deg` across it: image
/// coordinate `v` ∈ [−1, 1] (x from the left to the right border, y from the bottom to the top
/// border) lies at the angle `a` from the optical axis with `v = tan(a) / tan(fov/2)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pinhole {
    /// The full field of view across the image (degrees).
    fov_deg: f64,
    /// tan(fov/2): the image coordinate 1 (the border) lies at this tangent.
    tan_half_fov: f64,
}

impl Pinhole {
    /// The camera of full field of view `fov_deg` (degrees, in (0, 180)).
    pub fn new(fov_deg: f64) -> Self {
        Self {
            fov_deg,
            tan_half_fov: (fov_deg / 2.0).to_radians().tan(),
        }
    }

    /// The full field of view across the image (degrees), as given to [`Self::new`].
    pub fn fov_deg(&self) -> f64 {
        self.fov_deg
    }

    /// tan(fov/2) (dimensionless): the tangent of the angle at the image border.
    pub fn tan_half_fov(&self) -> f64 {
        self.tan_half_fov
    }

    /// The angle from the optical axis (radians) of image coordinate `v` ∈ [−1, 1].
    pub fn angle_rad(&self, v: f64) -> f64 {
        (v * self.tan_half_fov).atan()
    }

    /// The angle from the optical axis (degrees) of image coordinate `v` ∈ [−1, 1].
    pub fn angle_deg(&self, v: f64) -> f64 {
        self.angle_rad(v).to_degrees()
    }

    /// The image coordinate of a direction at `angle_deg` (degrees) from the optical axis.
    pub fn image_coord(&self, angle_deg: f64) -> f64 {
        angle_deg.to_radians().tan() / self.tan_half_fov
    }

    /// Focal length (pixels) of n×n frames.
    pub fn focal_px(&self, n: usize) -> f64 {
        n as f64 / 2.0 / self.tan_half_fov
    }
}

/// Least-squares line through points `(x, y)`: the sums it rests on, in one pass order shared by
/// every caller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineFit {
    /// Number of points.
    pub n: usize,
    /// Mean of x.
    pub mean_x: f64,
    /// Mean of y.
    pub mean_y: f64,
    /// Σ (x − mean x)².
    pub sxx: f64,
    /// Σ (x − mean x)·(y − mean y).
    pub sxy: f64,
    /// Σ (y − mean y)².
    pub syy: f64,
}

impl LineFit {
    /// The sums of `points` (`None` without any point).
    pub fn of(points: &[(f64, f64)]) -> Option<Self> {
        if points.is_empty() {
            return None;
        }
        let n = points.len() as f64;
        let mean_x = points.iter().map(|p| p.0).sum::<f64>() / n;
        let mean_y = points.iter().map(|p| p.1).sum::<f64>() / n;
        let sxx: f64 = points.iter().map(|p| (p.0 - mean_x).powi(2)).sum();
        let sxy: f64 = points.iter().map(|p| (p.0 - mean_x) * (p.1 - mean_y)).sum();
        let syy: f64 = points.iter().map(|p| (p.1 - mean_y).powi(2)).sum();
        Some(Self {
            n: points.len(),
            mean_x,
            mean_y,
            sxx,
            sxy,
            syy,
        })
    }

    /// The slope dy/dx (`sxy / sxx`; not finite when x has no spread).
    pub fn slope(&self) -> f64 {
        self.sxy / self.sxx
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pinhole_maps_the_border_to_half_the_field_of_view_and_back() {
        let p = Pinhole::new(60.0);
        assert!((p.angle_deg(1.0) - 30.0).abs() < 1e-12);
        assert!((p.angle_deg(-1.0) + 30.0).abs() < 1e-12);
        assert!((p.image_coord(30.0) - 1.0).abs() < 1e-12);
        assert!((p.image_coord(p.angle_deg(0.3)) - 0.3).abs() < 1e-12);
        assert!((p.focal_px(64) - 32.0 / 30f64.to_radians().tan()).abs() < 1e-12);
    }

    #[test]
    fn a_line_fit_recovers_slope_and_means() {
        let f = LineFit::of(&[(0.0, 1.0), (1.0, 3.0), (2.0, 5.0)]).unwrap();
        assert_eq!((f.n, f.mean_x, f.mean_y), (3, 1.0, 3.0));
        assert_eq!(f.slope(), 2.0);
        assert_eq!(f.syy, 8.0);
        assert!(LineFit::of(&[]).is_none());
    }
}

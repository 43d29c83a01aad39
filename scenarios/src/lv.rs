//! The l/|v| analysis, the classic test of looming detectors (Gabbiani, Krapp & Laurent 1999).
//!
//! An object of half-size `l` approaching the eye at constant speed `v` subtends
//! θ(t) = 2·atan(l / (|v|·t)) at time `t` before it reaches the eye. A detector that fires when
//! θ reaches a fixed threshold θ_th, after a fixed delay δ, fires at time to collision
//!
//! ```text
//! t_alarm = (l/|v|) / tan(θ_th / 2) − δ
//! ```
//!
//! a straight line in `l/|v|`. For every threat approaching head-on at constant speed the runner
//! records `l/|v|` ([`DetectorEpisode::l_over_v_s`]) and, at each detector's alarm, the time until
//! the object's centre would reach the camera at its current closing speed
//! ([`DetectorEpisode::eye_ttc_at_alarm_s`]). A least-squares line through these points gives the
//! detector's implied threshold angle θ_th = 2·atan(1/slope) and delay δ = −intercept, with R².
//! A detector that really thresholds the angular size has R² near 1; the `ideal_theta` reference
//! row recovers its own threshold (a built-in check of the analysis).
//!
//! Which threats qualify (decided by the runner from ground truth from 0.5 s to 0.05 s before
//! contact): the reference object's half-size `l` = d·sin(θ/2) (d the distance to its centre)
//! varies by less than 5 % (a sphere-like object), its closing speed by less than 5 %, and its
//! bearing stays within 15° of the optical axis. An alarm earlier than 0.5 s before contact
//! counts only if these conditions hold from the alarm on (the approach before the window may be
//! a throw's arc or a turning vehicle, where θ does not follow the formula).

use loomlab_detector::LineFit;
use serde::{Deserialize, Serialize};

use crate::metrics::DetectorEpisode;

/// Fewest points for a fit.
pub const MIN_FIT_EPISODES: usize = 3;

/// A straight-line fit of alarm time to collision against `l/|v|` (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LvFit {
    /// Slope (dimensionless: seconds of alarm time per second of `l/|v|`).
    pub slope: f64,
    /// Intercept (s).
    pub intercept_s: f64,
    /// Implied threshold angle 2·atan(1/slope) in degrees (`None` when the slope is not positive).
    pub theta_th_deg: Option<f64>,
    /// Implied delay δ = −intercept (s; positive: the alarm comes later than the threshold
    /// crossing).
    pub delay_s: f64,
    /// Coefficient of determination of the line.
    pub r2: f64,
    /// Number of episodes (alarms on qualifying threats) in the fit.
    pub episodes: u64,
}

impl LvFit {
    /// Fits the points `(l/|v|, eye TTC at alarm)`; `None` with fewer than
    /// [`MIN_FIT_EPISODES`] points or no spread in `l/|v|`.
    pub fn fit(points: &[(f64, f64)]) -> Option<Self> {
        let pts: Vec<(f64, f64)> = points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .collect();
        if pts.len() < MIN_FIT_EPISODES {
            return None;
        }
        let LineFit {
            mean_x: mx,
            mean_y: my,
            sxx,
            sxy,
            syy,
            ..
        } = LineFit::of(&pts)?;
        if sxx <= 1e-12 * (1.0 + mx * mx) {
            return None;
        }
        let slope = sxy / sxx;
        let intercept_s = my - slope * mx;
        let r2 = if syy > 0.0 { (sxy * sxy) / (sxx * syy) } else { 1.0 };
        Some(Self {
            slope,
            intercept_s,
            theta_th_deg: (slope > 0.0).then(|| 2.0 * (1.0 / slope).atan().to_degrees()),
            delay_s: -intercept_s,
            r2,
            episodes: pts.len() as u64,
        })
    }

    /// The fit over one detector's episodes (those with both values).
    pub fn from_episodes(episodes: &[&DetectorEpisode]) -> Option<Self> {
        let points: Vec<(f64, f64)> = episodes
            .iter()
            .filter_map(|e| Some((e.l_over_v_s?, e.eye_ttc_at_alarm_s?)))
            .collect();
        Self::fit(&points)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_known_threshold_and_delay() {
        let th = 12f64.to_radians();
        let delay = 0.03;
        let pts: Vec<(f64, f64)> = [0.01, 0.03, 0.05, 0.08, 0.12]
            .iter()
            .map(|&x| (x, x / (th / 2.0).tan() - delay))
            .collect();
        let f = LvFit::fit(&pts).unwrap();
        assert!((f.theta_th_deg.unwrap() - 12.0).abs() < 1e-9, "{f:?}");
        assert!((f.delay_s - delay).abs() < 1e-12, "{f:?}");
        assert!((f.r2 - 1.0).abs() < 1e-12);
        assert_eq!(f.episodes, 5);
    }

    #[test]
    fn too_few_points_or_no_spread_gives_none() {
        assert!(LvFit::fit(&[(0.1, 1.0), (0.2, 2.0)]).is_none());
        assert!(LvFit::fit(&[(0.1, 1.0), (0.1, 2.0), (0.1, 3.0)]).is_none());
        assert!(LvFit::fit(&[(0.1, 1.0), (f64::NAN, 2.0), (0.3, 3.0)]).is_none());
    }

    #[test]
    fn a_falling_line_has_no_threshold_angle() {
        let f = LvFit::fit(&[(0.1, 1.0), (0.2, 0.5), (0.3, 0.1)]).unwrap();
        assert!(f.theta_th_deg.is_none() && f.slope < 0.0);
    }
}

//! Stage 1, the τ estimator (module docs, "`trigger = "tau"`"): the time to contact τ̂ of the
//! object's surface from the slope of ln θ over the τ window, compensated for the window's lag.

use super::fit::slope;
use super::window::SampleWindow;

/// τ̂ (s) at `t_s` from the window's samples of the last `window_s` seconds whose θ is at least
/// `min_theta_rad` (`None` with fewer than [`super::MIN_SAMPLES`] of them or a θ that does not grow).
pub(super) fn estimate(window: &SampleWindow, t_s: f64, window_s: f64, min_theta_rad: f64) -> Option<f64> {
    slope(
        window
            .since(t_s - window_s - 1e-9)
            .filter(|s| s.has_theta())
            .filter(|s| s.theta_rad >= min_theta_rad)
            .map(|s| (s.t, s.theta_rad.ln())),
    )
    .filter(|&(b, _, _)| b > 0.0)
    .map(|(b, t_mean, ln_theta_mean)| surface_factor(ln_theta_mean.exp()) / b - (t_s - t_mean))
}

/// `κ(θ)`: the time to contact of the surface of a sphere seen at angular size θ (radians) is
/// `κ(θ) · θ/θ̇` (`sin(θ/2) = R/d` gives `d/v = 2·tan(θ/2)/θ̇` and the surface is `R` nearer:
/// `κ = 2·tan(θ/2)·(1 − sin(θ/2))/θ`; κ → 1 for small θ).
pub fn surface_factor(theta_rad: f64) -> f64 {
    let half = (theta_rad / 2.0).clamp(1e-9, 1.5);
    2.0 * half.tan() * (1.0 - half.sin()) / theta_rad.max(2e-9)
}
